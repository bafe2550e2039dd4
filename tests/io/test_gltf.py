"""glTF 2.0 export and reader (mocapkit.io.gltf), and ``convert``'s folder mode."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

import mocapkit as mk
from mocapkit import datasets
from mocapkit.cli import main
from mocapkit.convert import convert_many
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton
from mocapkit.io import MocapFileError, read_motion, write_motion
from mocapkit.io.gltf import gltf_space, read_gltf, up_rotation, write_gltf

SIX = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
ROT = {
    "ZXY": ("Zrotation", "Xrotation", "Yrotation"),
    "XYZ": ("Xrotation", "Yrotation", "Zrotation"),
}


def _fk_metres_y_up(m: Motion, up: str, mpu: float) -> np.ndarray:
    return mpu * mk.forward_kinematics(m)[0] @ up_rotation(up).T


def random_motion(seed: int, J: int, F: int, moving: bool) -> Motion:
    """A random tree (cm-like lengths), random rotations, End Sites on some leaves and, with
    ``moving``, animated positions on some non-root joints."""
    rng = np.random.default_rng(seed)
    parents = np.array([-1] + [int(rng.integers(0, j)) for j in range(1, J)])
    offsets = rng.normal(0, 20, (J, 3))
    six = moving & (rng.random(J) < 0.5)
    six[0] = True
    channels = tuple(SIX if six[j] else ROT["ZXY" if j % 2 else "XYZ"] for j in range(J))
    leaves = [j for j in range(J) if j not in parents]
    ep = [j for j in leaves if rng.random() < 0.6]
    sk = Skeleton(
        tuple(f"j{j}:{'x' * j}" for j in range(J)),
        parents,
        offsets,
        channels,
        ep,
        rng.normal(0, 10, (len(ep), 3)),
        tuple("" if k % 2 else f"tip{k}" for k in range(len(ep))),
    )
    q = rot.quat_normalize(rng.normal(size=(F, J, 4)))
    root = rng.normal(0, 100, (F, 3))
    trans = None
    if moving and six[1:].any():
        trans = np.broadcast_to(offsets, (F, J, 3)) + rng.normal(0, 5, (F, J, 3)) * six[:, None]
    return Motion(sk, q, root, 1 / 30 + rng.random() * 1e-3, trans)


@settings(max_examples=30, derandomize=True, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    J=st.integers(1, 9),
    F=st.integers(0, 5),
    moving=st.booleans(),
    up=st.sampled_from(["Y", "-Y", "Z", "-Z", "X", "-X"]),
    mpu=st.sampled_from([0.01, 0.0254, 1.0, 0.001]),
    ext=st.sampled_from([".glb", ".gltf"]),
)
def test_roundtrip_gives_the_same_fk_in_metres_y_up(
    tmp_path_factory, seed, J, F, moving, up, mpu, ext
) -> None:
    m = random_motion(seed, J, F, moving)
    path = write_gltf(m, tmp_path_factory.mktemp("rt") / f"take{ext}", up=up, metres_per_unit=mpu)
    back = read_gltf(path)
    assert back.num_frames == F and back.frame_time == m.frame_time
    assert back.skeleton.names == m.skeleton.names
    assert back.skeleton.channels == m.skeleton.channels
    assert back.skeleton.end_site_names == m.skeleton.end_site_names
    assert back.skeleton.metres_per_unit == 1.0
    np.testing.assert_array_equal(back.skeleton.parents, m.skeleton.parents)
    want = _fk_metres_y_up(m, up, mpu)
    got, _ = mk.forward_kinematics(back)
    # float32 in the file: relative 1e-6 of the largest coordinate
    scale = max(1.0, float(np.abs(want).max(initial=0)))
    np.testing.assert_allclose(got, want, atol=2e-6 * scale)
    es = mk.core.kinematics.end_site_positions
    if F:
        np.testing.assert_allclose(
            es(back.skeleton, got, mk.forward_kinematics(back)[1]),
            es(m.skeleton, *mk.forward_kinematics(m)) * mpu @ up_rotation(up).T,
            atol=2e-6 * scale,
        )


@pytest.mark.parametrize("up", ["Y", "-Y", "Z", "-Z", "X", "-X"])
def test_up_rotation_is_proper_and_lifts_up_to_y(up: str) -> None:
    R = up_rotation(up)
    axis = {"X": 0, "Y": 1, "Z": 2}[up[-1]]
    v = np.zeros(3)
    v[axis] = -1.0 if up.startswith("-") else 1.0
    np.testing.assert_allclose(R @ v, [0, 1, 0])
    np.testing.assert_allclose(R @ R.T, np.eye(3))
    assert np.linalg.det(R) == pytest.approx(1.0)


def _doc(path: Path) -> tuple[pygltflib.GLTF2, bytes]:
    g = pygltflib.GLTF2.load(str(path))
    return g, g.binary_blob()


def _acc(g: pygltflib.GLTF2, blob: bytes, i: int) -> np.ndarray:
    a = g.accessors[i]
    v = g.bufferViews[a.bufferView]
    n = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[a.type]
    dt = {5126: "<f4", 5123: "<u2", 5125: "<u4"}[a.componentType]
    return np.frombuffer(blob, dt, a.count * n, v.byteOffset + (a.byteOffset or 0)).reshape(
        a.count, n
    )


def test_glb_structure_skin_animation_and_mesh(tmp_path: Path) -> None:
    """What a consumer relies on: the skin's inverse bind matrices undo the rest pose, every
    joint has a rotation sampler at the frame times, the root and (Bandai-style) moving joints
    translation samplers, and the mesh is weighted wholly to existing joints."""
    m = random_motion(3, 7, 4, moving=True)
    path = write_gltf(m, tmp_path / "t.glb", up="Z", metres_per_unit=0.01)
    g, blob = _doc(path)
    J, E = m.num_joints, len(m.skeleton.end_site_parents)
    skin = g.skins[0]
    assert skin.joints == list(range(J + E))
    ibm = _acc(g, blob, skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
    rest = gltf_space(m, "Z", 0.01)[0].skeleton.rest_positions()
    np.testing.assert_allclose(ibm[:J, :3, 3], -rest, atol=1e-6)
    anim = g.animations[0]
    targets = {(c.target.node, c.target.path) for c in anim.channels}
    assert {(j, "rotation") for j in range(J)} <= targets
    moving = {j for j in range(J) if m.skeleton.has_position[j]}
    assert {j for j, p in targets if p == "translation"} == moving | {0}
    times = _acc(g, blob, anim.samplers[0].input)[:, 0]
    np.testing.assert_allclose(times, np.arange(4) * m.frame_time, rtol=1e-6)
    prim = g.meshes[0].primitives[0]
    joints = _acc(g, blob, prim.attributes.JOINTS_0)
    weights = _acc(g, blob, prim.attributes.WEIGHTS_0)
    assert joints[:, 0].max() < J + E and set(joints[:, 0]) >= set(range(J))
    np.testing.assert_allclose(weights.sum(1), 1.0)
    pos = g.accessors[prim.attributes.POSITION]
    assert pos.min is not None and pos.max is not None  # required by the spec
    assert g.extras["mocapkit"]["source_up"] == "Z"


def test_gltf_json_is_one_self_contained_file(tmp_path: Path) -> None:
    m = random_motion(5, 4, 3, moving=False)
    path = write_gltf(m, tmp_path / "t.gltf", up="Y", metres_per_unit=1.0)
    doc = json.loads(path.read_text())
    assert doc["buffers"][0]["uri"].startswith("data:application/octet-stream;base64,")
    assert list(tmp_path.iterdir()) == [path]  # no .bin beside it
    assert read_gltf(path).allclose(gltf_space(m, "Y", 1.0)[0], rot_atol=1e-6, pos_atol=1e-5)


def test_write_motion_dispatches_and_uses_the_body_model(tmp_path: Path) -> None:
    """``write_motion`` picks glTF by the extension; up axis and unit come from the body model
    (the procedural humanoid: centimetres, Y up -> its height in metres in glTF)."""
    synth = datasets.procedural_motion("walk", seconds=1.0, seed=2).motion
    path = write_motion(synth, tmp_path / "walk.glb")
    back = read_motion(path)
    body = mk.body.body_of(synth)
    pos, _ = mk.forward_kinematics(back)
    np.testing.assert_allclose(
        pos, _fk_metres_y_up(synth, body.up, body.metres_per_unit), atol=1e-5
    )
    assert 1.2 < np.ptp(pos[..., 1]) < 2.2  # a person's height in metres, along +Y


def test_reads_a_foreign_rig_without_mocapkit_metadata(tmp_path: Path) -> None:
    """Another exporter's file (no ``extras``, a rest rotation on a joint, an Armature parent
    node, keys at other times): FK of what is read matches glTF's own node transforms."""
    m = random_motion(11, 5, 6, moving=False)
    path = write_gltf(m, tmp_path / "t.glb", up="Y", metres_per_unit=1.0)
    g, _ = _doc(path)
    g.extras = None
    q_rest = rot.quat_normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    g.nodes[2].rotation = [*q_rest[1:], q_rest[0]]  # joint 2 is not animated any more
    g.animations[0].channels = [
        c for c in g.animations[0].channels if (c.target.node, c.target.path) != (2, "rotation")
    ]
    arm = pygltflib.Node(name="Armature", children=[0], translation=[1.0, 2.0, 3.0])
    g.nodes.append(arm)
    g.scenes[0].nodes = [len(g.nodes) - 1, *g.scenes[0].nodes[1:]]
    g.save(str(tmp_path / "foreign.glb"))
    back = read_gltf(tmp_path / "foreign.glb")
    want = m.rotations.copy()
    want[:, 2] = q_rest
    ref = Motion(m.skeleton, want, m.root_positions, m.frame_time)
    pos, _ = mk.forward_kinematics(back)
    J = m.num_joints  # without mocapkit's metadata the End Sites are joints too (after them)
    assert back.skeleton.names[:J] == m.skeleton.names
    assert back.num_joints == J + len(m.skeleton.end_site_parents)
    np.testing.assert_allclose(
        pos[:, :J], mk.forward_kinematics(ref)[0] + [1.0, 2.0, 3.0], atol=1e-5
    )
    assert back.num_frames == 6
    assert back.frame_time == pytest.approx(m.frame_time, rel=1e-6)


@pytest.mark.parametrize(
    ("content", "expect"),
    [
        (b"", "not a readable glTF JSON file"),
        (b"glTF\x02\x00\x00\x00\xff\xff\x00\x00", "not a readable GLB file"),
        (b'{"asset": {"version": "2.0"}}', "no skin"),
        (b"\xff\xfe garbage", "not a readable glTF JSON file"),
    ],
)
def test_bad_files_are_one_line_errors(tmp_path: Path, content: bytes, expect: str) -> None:
    bad = tmp_path / "bad.glb"
    bad.write_bytes(content)
    with pytest.raises(MocapFileError, match=expect) as err:
        read_motion(bad)
    assert str(bad) in str(err.value) and "\n" not in str(err.value)
    res = CliRunner().invoke(main, ["convert", str(bad), str(tmp_path / "x.bvh")])
    assert res.exit_code == 2
    assert res.stderr.strip().startswith(f"mocapkit: error: {bad}")
    assert "Traceback" not in res.stderr and not (tmp_path / "x.bvh").exists()


def test_truncated_glb_is_an_error(tmp_path: Path) -> None:
    m = random_motion(1, 3, 2, moving=False)
    data = write_gltf(m, tmp_path / "t.glb", up="Y", metres_per_unit=1.0).read_bytes()
    cut = tmp_path / "cut.glb"
    cut.write_bytes(data[: len(data) // 2])
    assert struct.unpack("<I", data[8:12])[0] == len(data)
    with pytest.raises(MocapFileError, match=r"cut\.glb"):
        read_gltf(cut)


# ------------------------------------------------------------------------ convert, folders
@pytest.fixture
def library(tmp_path: Path) -> Path:
    lib = tmp_path / "lib"
    for i, kind in enumerate(("walk", "run")):
        synth = datasets.procedural_motion(kind, seconds=0.5, seed=i).motion
        write_motion(synth, lib / f"{kind}.bvh")
    (lib / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    (lib / "notes.txt").write_text("not a motion")
    return lib


def run(*args: str):
    res = CliRunner().invoke(main, list(args))
    return res.exit_code, res.stdout, res.stderr


def test_convert_glb_single_file(library: Path, tmp_path: Path) -> None:
    code, out, err = run("convert", str(library / "walk.bvh"), str(tmp_path / "walk.glb"))
    assert code == 0, err
    assert "wrote" in out
    src = read_motion(library / "walk.bvh")
    back = read_motion(tmp_path / "walk.glb")
    body = mk.body.body_of(src)
    np.testing.assert_allclose(
        mk.forward_kinematics(back)[0],
        _fk_metres_y_up(src, body.up, body.metres_per_unit),
        atol=1e-5,
    )


@pytest.mark.parametrize("to", ["glb", "bvh", "npz"])
def test_convert_folder_reports_every_input_and_goes_past_a_bad_one(
    library: Path, tmp_path: Path, to: str
) -> None:
    out_dir = tmp_path / "out"
    code, out, err = run("convert", str(library), "--out-dir", str(out_dir), "--to", to)
    assert code == 2
    written = sorted(p.name for p in out_dir.iterdir() if not p.name.startswith("."))
    assert written == [f"run.{to}", f"walk.{to}"]  # beside the resume manifest
    assert out.count("wrote") == 2
    errors = [line for line in err.splitlines() if line.startswith("mocapkit: error:")]
    assert len(errors) == 1 and str(library / "broken.bvh") in errors[0]
    assert "Traceback" not in err
    assert "converted 2 of 3 inputs" in out
    for name in ("run", "walk"):
        a, b = read_motion(library / f"{name}.bvh"), read_motion(out_dir / f"{name}.{to}")
        assert a.num_frames == b.num_frames


def test_convert_folder_never_writes_over_an_input(library: Path) -> None:
    before = {p.name: p.read_bytes() for p in library.iterdir()}
    code, _, err = run("convert", str(library), "--out-dir", str(library), "--to", "bvh")
    assert code == 2
    assert err.count("refusing to overwrite the input file") == 3
    assert {p.name: p.read_bytes() for p in library.iterdir()} == before


def test_convert_many_same_stem_twice_is_an_error_for_the_second(
    library: Path, tmp_path: Path
) -> None:
    write_motion(read_motion(library / "walk.bvh"), tmp_path / "walk.npz")
    res = convert_many([library / "walk.bvh", tmp_path / "walk.npz"], tmp_path / "o", "glb")
    assert [i.ok for i in res.items] == [True, False]
    assert "already written from" in res.items[1].error
    assert res.to_json()["converted"] == 1


def test_convert_many_stems_differing_only_by_case_are_one_output(
    library: Path, tmp_path: Path
) -> None:
    """``Walk.npz`` and ``walk.npz`` are one file on macOS and Windows: the second input of a
    folder whose stems differ only by case is refused and says why (on Linux the two were
    written side by side, and the folder lost one when copied to a Mac)."""
    write_motion(read_motion(library / "walk.bvh"), tmp_path / "Walk.npz")
    res = convert_many([library / "walk.bvh", tmp_path / "Walk.npz"], tmp_path / "o", "glb")
    assert [i.ok for i in res.items] == [True, False]
    assert "differ only by case" in res.items[1].error
    assert sorted(p.name for p in (tmp_path / "o").glob("*.glb")) == ["walk.glb"]


def test_convert_folder_mode_needs_both_options(library: Path, tmp_path: Path) -> None:
    code, _, err = run("convert", str(library), "--to", "glb")
    assert code == 2 and "needs both --out-dir and --to" in err
    code, _, err = run("convert", str(library), str(tmp_path / "x.glb"))
    assert code == 2 and "is a folder" in err and "--out-dir" in err


def test_convert_help_shows_folder_and_gltf_examples() -> None:
    code, out, _ = run("convert", "--help")
    assert code == 0
    assert "--out-dir lib_glb/ --to glb" in out and "take.glb" in out
