"""Cross-check mocapkit's BVH reader and forward kinematics against independent implementations.

Peers (test-only dependencies, never imported by the library):

* ``upc-pymotion`` (``pymotion.io.bvh.BVH`` + ``pymotion.ops.skeleton_np.fk_quat``): float64, the
  main FK reference. Its quaternion ``normalize`` divides by ``|q| + 1e-8``, which shortens every
  quaternion by 1e-8 and so leaves an error floor of about 1e-7 of the height on deep chains
  (measured: at most 2.3e-7 on the corpus); the 1e-6 tolerance sits well above it.
* ``bvh`` (bvh-python) for the raw text values, with a small FK written here on top of scipy
  (``Rotation.from_euler`` + rotation matrices): float64, used as the FK reference for the files
  pymotion cannot read, and for the parser check (channel values and local rotations).
* ``bvhio`` (``readAsHierarchy`` + ``Joint.loadPose`` + ``PositionWorld``): a third, structurally
  different implementation, but it stores offsets, channel values and quaternions as PyGLM
  *float32*, so its own rounding reaches a few 1e-6 of the height on long chains (measured: up to
  3.6e-6 on ``RyosukeHori__LoadBVH__test.bvh``). It is checked at a float32 tolerance, on a subset
  of files and frames because it is slow (it builds a Python object per joint and frame).

Global joint positions must agree with the float64 reference to 1e-6 of the character's height on
every frame of every top-level file of ``bvh-corpus`` and of every ``bandai1`` take; End Site
positions too, where the peer gives them. Height = the smaller of the rest-pose extent and the
extent of the first posed frame (the Bandai takes hang the body far from a ground ``joint_Root``,
which inflates the rest-pose extent; taking the smaller one keeps the tolerance strict).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from testsupport import shared_subpath

from mocapkit.core.kinematics import end_site_positions, forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.io.bvh import read_bvh
from mocapkit.io.errors import RepairWarning

bvhio = pytest.importorskip("bvhio")
bvh_python = pytest.importorskip("bvh")
pymotion_bvh = pytest.importorskip("pymotion.io.bvh")
pymotion_skeleton = pytest.importorskip("pymotion.ops.skeleton_np")
pymotion_quat = pytest.importorskip("pymotion.rotations.quat_np")

pytestmark = pytest.mark.shared

CORPUS = "bvh-corpus"
BANDAI = "bandai1/data"
MISSING = "<data set missing>"

REL_TOL = 1e-6  # float64 references, relative to the height
REL_TOL_F32 = 1e-5  # bvhio (PyGLM float32), relative to the height
QUAT_TOL = 1e-12  # local rotations from the same Euler values, two float64 routes

# Files mocapkit reads only with lenient=True (MANIFEST.md), which must say so with a warning.
LENIENT = {
    "assimp__assimp__Boxing_Toes.bvh": "declares 3069 frames but has 3070 rows",
    "mochi-neko__mdm2bvh__results.bvh": "contains nan values (filled from neighbouring frames)",
}
# Files holding NaN: there the peers give NaN for the affected joints and their descendants
# (mocapkit fills the gaps), so only the peer's finite entries are compared.
HAS_NAN = {"mochi-neko__mdm2bvh__results.bvh"}

# Files upc-pymotion 0.3.4 cannot read (its loader is a line-keyword scanner). For these the float64
# FK reference is bvh-python + the scipy FK below; bvhio checks them too (see BVHIO_FILES).
NOT_PYMOTION = {
    "Firepal__godot_vr_mocap__test.bvh": "root has CHANNELS 0: raises 'Unknown number of channels'",
    "MathRobotics__mBVH__test.bvh": "the blank line after the last row is read as a 4th frame "
    "of a 3-frame array (IndexError)",
    "VictorS-67__pybvh__rotation_first_root.bvh": "the root lists rotations before positions; "
    "pymotion assumes positions first (KeyError 'Zrotation')",
    "assimp__assimp__Boxing_Toes.bvh": "3070 rows for 'Frames: 3069'; pymotion sizes its arrays "
    "from Frames: (IndexError)",
}

# bvhio subset: the files pymotion cannot read, the bvhio project's own example, a few varied
# layouts (CRLF, 6 channels on every joint, mixed rotation orders, no final newline) and two
# Bandai takes. Frames are subsampled to at most BVHIO_FRAMES.
BVHIO_FILES = [
    *((CORPUS, n) for n in sorted(NOT_PYMOTION)),
    (CORPUS, "Wasserwecken__bvhio__example.bvh"),
    (CORPUS, "20tab__bvh-python__test_mocapbank.bvh"),
    (CORPUS, "emretanirgan__BVH_Viewer__Matt_Happy2.bvh"),
    (CORPUS, "VictorS-67__pybvh__bvh_test1.bvh"),
    (CORPUS, "facebookresearch__fairmotion__sinusoidal.bvh"),
    (CORPUS, "mochi-neko__mdm2bvh__results.bvh"),
    (BANDAI, "dataset-1_bow_active_001.bvh"),
    (BANDAI, "dataset-1_walk_musical_001.bvh"),
]
BVHIO_FRAMES = 40

# Parser check (raw values -> local rotations and translations) against bvh-python's text values.
PARSER_FILES = [
    (CORPUS, "VictorS-67__pybvh__rotation_first_root.bvh"),  # rotations before positions
    (CORPUS, "Firepal__godot_vr_mocap__test.bvh"),  # CHANNELS 0 root, 6-channel children
    (CORPUS, "MathRobotics__mBVH__test.bvh"),  # blank line at the end
    (CORPUS, "Wasserwecken__bvhio__example.bvh"),  # blank lines in HIERARCHY, TAB separators
    (CORPUS, "20tab__bvh-python__test_mocapbank.bvh"),  # CRLF, TAB after Frames:
    (CORPUS, "VictorS-67__pybvh__bvh_test1.bvh"),  # 4 rotation orders, XZY root
    (CORPUS, "VictorS-67__pybvh__bvh_test3.bvh"),  # CRLF, no final newline
    (CORPUS, "Zju-George__video2bvh_hmr__result.bvh"),  # mixed XYZ/YXZ, 6-channel joints
    (CORPUS, "Woosub-Won__BVHViewer__Coda03(Woman).bvh"),  # e-017 exponents, named End Sites
    (CORPUS, "mochi-neko__mdm2bvh__results.bvh"),  # nan values
    (BANDAI, "dataset-1_bow_active_001.bvh"),  # 6 channels everywhere, exponents in OFFSETs
]


# --------------------------------------------------------------------------- data discovery


def _collection_dir(subpath: str) -> Path:
    """Where the data set is expected, for listing files at collection time (fixtures are not
    available when parametrizing); each test then asks the ``shared_path`` fixture."""
    return shared_subpath(subpath)


def _bvh_files(subpath: str) -> list[str]:
    """Top-level ``*.bvh`` names of a data set, or ``[MISSING]`` so that the test still runs once
    and reports the missing data set (an empty parameter list would be a silent skip)."""
    names = sorted(p.name for p in _collection_dir(subpath).glob("*.bvh"))
    return names or [MISSING]


def _locate(shared_path, subpath: str, name: str) -> Path:
    folder = shared_path(subpath)  # skips / fails when the data set is absent
    if name == MISSING:
        pytest.fail(f"{folder} holds no .bvh files")
    path = folder / name
    assert path.is_file(), f"{path} is missing (the listing at collection found it elsewhere)"
    return path


def _read_mocapkit(path: Path) -> Motion:
    if path.name in LENIENT:
        with pytest.warns(RepairWarning):
            return read_bvh(path, lenient=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RepairWarning)
        return read_bvh(path)


# --------------------------------------------------------------------------- peers


class PeerFK(NamedTuple):
    peer: str
    names: list[str]
    parents: np.ndarray  # (J,) with -1 for the root
    positions: np.ndarray  # (F', J, 3) global joint positions
    end_sites: np.ndarray | None  # (F', E, 3) global End Site positions, in file order
    end_site_parents: np.ndarray | None  # (E,)
    frames: np.ndarray  # (F',) mocapkit frame index of each peer frame


def _pymotion_fk(path: Path) -> PeerFK:
    b = pymotion_bvh.BVH()
    b.load(str(path))
    rots, local_pos, parents, _offsets, es_offsets, es_parents = b.get_data()
    # local_pos holds every joint's local translation (OFFSET or position channels).
    pos, grot = pymotion_skeleton.fk_quat(rots, local_pos[:, 0], local_pos, parents)
    parents = np.asarray(parents).copy()
    parents[0] = -1  # pymotion: the root is its own parent
    ends = es_par = None
    if len(es_parents):
        es_par = np.asarray(es_parents, dtype=np.int64)
        off = np.broadcast_to(np.asarray(es_offsets, dtype=np.float64), (len(pos), len(es_par), 3))
        ends = pos[:, es_par] + pymotion_quat.mul_vec(grot[:, es_par], off)
    return PeerFK(
        "upc-pymotion",
        [str(n) for n in b.data["names"]],
        parents,
        pos,
        ends,
        es_par,
        np.arange(len(pos)),
    )


class RawBVH(NamedTuple):
    """bvh-python's reading of a file, as float64 arrays."""

    names: list[str]
    parents: np.ndarray
    offsets: np.ndarray  # (J, 3)
    channels: list[list[str]]
    values: np.ndarray  # (F, C)
    end_site_parents: np.ndarray  # (E,)
    end_site_offsets: np.ndarray  # (E, 3)


def _bvh_python_raw(path: Path) -> RawBVH:
    # Decoded bytes, so that bvh-python's own line splitting sees the line endings as written.
    b = bvh_python.Bvh(path.read_bytes().decode("utf-8"))
    joints = b.get_joints()  # depth-first, file order
    index = {id(j): i for i, j in enumerate(joints)}
    parents = np.array([index.get(id(j.parent), -1) for j in joints], dtype=np.int64)
    offsets = np.array([[float(x) for x in j["OFFSET"][:3]] for j in joints])
    channels = [list(j["CHANNELS"][1:]) for j in joints]
    ncols = sum(len(c) for c in channels)
    rows = [r for r in b.frames if r != [""]]
    values = np.array(rows, dtype=np.float64).reshape(len(rows), ncols)
    es_par, es_off = [], []
    for i, j in enumerate(joints):
        for end in j.filter("End"):
            es_par.append(i)
            es_off.append([float(x) for x in end["OFFSET"][:3]])
    es_offsets = np.array(es_off, dtype=np.float64).reshape(-1, 3)
    return RawBVH(
        [j.name for j in joints],
        parents,
        offsets,
        channels,
        values,
        np.array(es_par, dtype=np.int64),
        es_offsets,
    )


def _raw_local(raw: RawBVH) -> tuple[list[Rotation | None], np.ndarray]:
    """Per joint: scipy local rotations over the frames (None without rotation channels) and the
    local translations (F, J, 3). Rows holding NaN give NaN rotations (identity placeholders are
    never substituted)."""
    F, J = len(raw.values), len(raw.names)
    trans = np.broadcast_to(raw.offsets, (F, J, 3)).copy()
    rots: list[Rotation | None] = []
    col = 0
    for j, ch in enumerate(raw.channels):
        cols = {c.lower(): col + k for k, c in enumerate(ch)}
        col += len(ch)
        rot = [c for c in ch if c.lower().endswith("rotation")]
        if rot:
            order = "".join(c[0].upper() for c in rot)  # uppercase: intrinsic, as BVH
            angles = raw.values[:, [cols[c.lower()] for c in rot]]
            rots.append(Rotation.from_euler(order, angles, degrees=True))
        else:
            rots.append(None)
        if "xposition" in cols:
            trans[:, j] = raw.values[:, [cols["xposition"], cols["yposition"], cols["zposition"]]]
    return rots, trans


def _scipy_fk(path: Path) -> PeerFK:
    """bvh-python's values through a plain matrix FK (scipy Euler -> matrices), float64."""
    raw = _bvh_python_raw(path)
    rots, trans = _raw_local(raw)
    F, J = trans.shape[:2]
    R = np.empty((F, J, 3, 3))
    P = np.empty((F, J, 3))
    for j, p in enumerate(raw.parents):
        local = rots[j].as_matrix() if rots[j] is not None else np.eye(3)
        if p < 0:
            R[:, j] = local
            P[:, j] = trans[:, j]
        else:
            R[:, j] = R[:, p] @ local
            P[:, j] = P[:, p] + np.einsum("fab,fb->fa", R[:, p], trans[:, j])
    ends = es_par = None
    if len(raw.end_site_parents):
        es_par = raw.end_site_parents
        ends = P[:, es_par] + np.einsum("feab,eb->fea", R[:, es_par], raw.end_site_offsets)
    return PeerFK("bvh-python+scipy", raw.names, raw.parents, P, ends, es_par, np.arange(F))


def _bvhio_fk(path: Path, num_frames: int) -> PeerFK:
    root = bvhio.readAsHierarchy(str(path))
    joints = [j for j, _, _ in root.layout()]
    parents = {id(j): i for i, j in enumerate(joints)}
    par = np.array([parents.get(id(j.Parent), -1) if j.Parent else -1 for j in joints])
    # bvhio keeps 'Frames:' rows (Boxing_Toes: 3069 of 3070); sample frames evenly, ends included.
    count = min(num_frames, root.getKeyframeRange()[1] + 1)
    frames = np.unique(np.linspace(0, count - 1, min(count, BVHIO_FRAMES)).round().astype(int))
    pos = np.empty((len(frames), len(joints), 3))
    for k, f in enumerate(frames):
        root.loadPose(int(f))
        for i, j in enumerate(joints):
            pos[k, i] = tuple(j.PositionWorld)
    # bvhio turns End Sites into bone directions of the rest pose; it gives no End Site positions.
    return PeerFK("bvhio", [j.Name for j in joints], par, pos, None, None, frames)


# --------------------------------------------------------------------------- comparison


def _height(motion: Motion, positions: np.ndarray) -> float:
    """The smaller of the rest-pose extent and the first posed frame's extent (module docstring)."""
    rest = motion.skeleton.height()  # 1.0 for a degenerate rest pose
    posed = float(np.ptp(positions[0], axis=0).max()) if len(positions) else 0.0
    return min(rest, posed) if posed > 0 else rest


def _assert_positions(
    label: str,
    what: str,
    names: list[str],
    mine: np.ndarray,
    theirs: np.ndarray,
    frames: np.ndarray,
    height: float,
    rel_tol: float,
    allow_nan: bool,
) -> None:
    finite = np.all(np.isfinite(theirs), axis=-1)
    if not allow_nan:
        assert finite.all(), f"{label}: the peer gives non-finite {what}"
    assert finite.mean() > 0.5, f"{label}: the peer gives too few finite {what} to compare"
    dist = np.linalg.norm(mine - theirs, axis=-1)
    dist[~finite] = 0.0
    f, j = np.unravel_index(np.argmax(dist), dist.shape)
    worst = float(dist[f, j])
    assert worst <= rel_tol * height, (
        f"{label}: {what} differ by {worst:.3g} units = {worst / height:.2e} of the height "
        f"{height:.4g} at frame {int(frames[f])}, {names[j]!r} (tolerance {rel_tol:.0e} of the "
        "height)"
    )


def _stable_by_parent(parents: np.ndarray) -> np.ndarray:
    return np.argsort(parents, kind="stable")


def _check_fk(label: str, motion: Motion, peer: PeerFK, rel_tol: float, allow_nan: bool) -> None:
    sk = motion.skeleton
    assert peer.names == list(sk.names), f"{label}: {peer.peer} names the joints differently"
    assert np.array_equal(peer.parents, sk.parents), f"{label}: hierarchy differs ({peer.peer})"
    pos, rot = forward_kinematics(motion)
    height = _height(motion, pos)
    assert peer.frames[-1] < motion.num_frames
    tag = f"{label} vs {peer.peer}"
    _assert_positions(
        tag,
        "joint positions",
        list(sk.names),
        pos[peer.frames],
        peer.positions,
        peer.frames,
        height,
        rel_tol,
        allow_nan,
    )
    if peer.end_sites is None:
        return
    assert len(peer.end_site_parents) == len(sk.end_site_parents), f"{tag}: End Site count"
    # Both list End Sites in file order; a stable sort by parent makes the match independent of
    # where an End Site sits among its parent's child joints.
    mine_order = _stable_by_parent(sk.end_site_parents)
    peer_order = _stable_by_parent(peer.end_site_parents)
    assert np.array_equal(sk.end_site_parents[mine_order], peer.end_site_parents[peer_order])
    ends = end_site_positions(sk, pos, rot)[peer.frames][:, mine_order]
    es_names = [f"End Site of {sk.names[p]}" for p in sk.end_site_parents[mine_order]]
    _assert_positions(
        tag,
        "End Site positions",
        es_names,
        ends,
        peer.end_sites[:, peer_order],
        peer.frames,
        height,
        rel_tol,
        allow_nan,
    )


def _fk_case(shared_path, subpath: str, name: str) -> None:
    path = _locate(shared_path, subpath, name)
    motion = _read_mocapkit(path)
    peer = _scipy_fk(path) if name in NOT_PYMOTION else _pymotion_fk(path)
    assert len(peer.frames) == motion.num_frames, (
        f"{name}: {peer.peer} reads {len(peer.frames)} frames, mocapkit {motion.num_frames}"
    )
    _check_fk(name, motion, peer, REL_TOL, allow_nan=name in HAS_NAN)


# --------------------------------------------------------------------------- tests


@pytest.mark.parametrize("name", _bvh_files(CORPUS))
def test_fk_matches_peer_corpus(shared_path, name: str) -> None:
    """Every top-level corpus file: all frames, all joints and End Sites, 1e-6 of the height."""
    _fk_case(shared_path, CORPUS, name)


@pytest.mark.parametrize("name", _bvh_files(BANDAI))
def test_fk_matches_peer_bandai(shared_path, name: str) -> None:
    """Every Bandai take: all frames, all joints and End Sites, 1e-6 of the height."""
    _fk_case(shared_path, BANDAI, name)


@pytest.mark.parametrize(("subpath", "name"), BVHIO_FILES, ids=[n for _, n in BVHIO_FILES])
def test_fk_matches_bvhio(shared_path, subpath: str, name: str) -> None:
    """Second opinion from bvhio (float32 inside, so a float32 tolerance), on sampled frames."""
    path = _locate(shared_path, subpath, name)
    motion = _read_mocapkit(path)
    peer = _bvhio_fk(path, motion.num_frames)
    _check_fk(name, motion, peer, REL_TOL_F32, allow_nan=name in HAS_NAN)


@pytest.mark.parametrize(("subpath", "name"), PARSER_FILES, ids=[n for _, n in PARSER_FILES])
def test_parser_matches_bvh_python(shared_path, subpath: str, name: str) -> None:
    """Hierarchy, offsets and channel values as bvh-python reads them: translations bit for bit,
    local rotations equal to scipy's quaternions of the same Euler values (hemisphere aligned)."""
    path = _locate(shared_path, subpath, name)
    motion = _read_mocapkit(path)
    sk = motion.skeleton
    raw = _bvh_python_raw(path)
    assert raw.names == list(sk.names)
    assert np.array_equal(raw.parents, sk.parents)
    assert [[c.lower() for c in ch] for ch in raw.channels] == [
        [c.lower() for c in ch] for ch in sk.channels
    ]
    assert np.array_equal(raw.offsets, sk.offsets)
    order = _stable_by_parent(sk.end_site_parents)
    raw_order = _stable_by_parent(raw.end_site_parents)
    assert np.array_equal(raw.end_site_parents[raw_order], sk.end_site_parents[order])
    assert np.array_equal(raw.end_site_offsets[raw_order], sk.end_site_offsets[order])

    rows = len(raw.values)
    expected = motion.num_frames
    if not path.read_bytes().rstrip(b" \t").endswith(b"\n"):
        expected -= 1  # bvh-python 0.3 flushes a line only on '\n'/'\r': it drops such a last row
    assert rows == expected, f"{name}: bvh-python read {rows} rows, expected {expected}"

    rots, trans = _raw_local(raw)
    finite_rows = np.all(np.isfinite(raw.values), axis=1)
    mine_t = motion.local_translations()[:rows]
    assert np.array_equal(mine_t[finite_rows], trans[finite_rows]), (
        f"{name}: translations are not bit-identical to float() of the text"
    )
    for j, r in enumerate(rots):
        mine_q = motion.rotations[:rows, j]
        if r is None:
            assert np.array_equal(mine_q, np.broadcast_to([1.0, 0, 0, 0], mine_q.shape))
            continue
        ref = r.as_quat()[:, [3, 0, 1, 2]]  # scipy xyzw -> wxyz
        ok = np.all(np.isfinite(ref), axis=1)
        ref, got = ref[ok], mine_q[ok]
        ref *= np.where(np.sum(ref * got, axis=1) < 0, -1.0, 1.0)[:, None]
        err = np.abs(got - ref).max(initial=0.0)
        assert err <= QUAT_TOL, f"{name}: local rotation of {sk.names[j]!r} differs by {err:.2e}"
