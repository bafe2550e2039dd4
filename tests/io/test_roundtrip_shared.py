"""Read -> write -> read of every real file in the shared corpus and in bandai1.

Pass criterion (from the foundation issue): local rotations equal to 1e-6 rad (geodesic, so
hemisphere-aligned), root and joint translations to 1e-6 units, frame time exact, skeleton
(names, hierarchy, channel layout, offsets, End Sites) unchanged.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from mocapkit.core import rotations as rot
from mocapkit.io.bvh import parse_bvh, read_bvh, write_bvh
from mocapkit.io.errors import BVHError, RepairWarning

# Files of the corpus that real tools wrote with a recoverable defect: strict reading must refuse
# them with a BVHError naming the line; lenient reading repairs them with a RepairWarning.
NEEDS_LENIENT = {
    "assimp__assimp__Boxing_Toes.bvh": "'Frames: 3069' but 3070 rows",
    "mochi-neko__mdm2bvh__results.bvh": "NaN or infinite",
}


def _roundtrip_problems(path: Path, tmp: Path) -> list[str]:
    name = path.name
    if name in NEEDS_LENIENT:
        with pytest.raises(BVHError, match=NEEDS_LENIENT[name]):
            read_bvh(path)
        with pytest.warns(RepairWarning):
            m = read_bvh(path, lenient=True)
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RepairWarning)
            m = read_bvh(path)
    out = write_bvh(m, tmp / name)
    back = read_bvh(out)
    problems = []
    if back.frame_time != m.frame_time:
        problems.append(f"frame time {m.frame_time!r} -> {back.frame_time!r}")
    if not back.skeleton.allclose(m.skeleton, atol=1e-9):
        problems.append("skeleton changed")
    if back.num_frames != m.num_frames:
        problems.append(f"{m.num_frames} frames -> {back.num_frames}")
    elif m.num_frames:
        ang = float(rot.quat_angle(m.rotations, back.rotations).max())
        dpos = float(np.abs(m.local_translations() - back.local_translations()).max())
        if ang > 1e-6:
            problems.append(f"rotation error {ang:.2e} rad")
        if dpos > 1e-6:
            problems.append(f"translation error {dpos:.2e}")
    return [f"{name}: {p}" for p in problems]


@pytest.mark.parametrize("dataset", ["bvh-corpus", "bandai1/data"])
def test_every_shared_file_round_trips(dataset: str, shared_path, tmp_path) -> None:
    folder = shared_path(dataset)
    files = sorted(folder.glob("*.bvh"))
    assert files, f"no BVH files in {folder}"
    problems: list[str] = []
    for f in files:
        problems += _roundtrip_problems(f, tmp_path)
    assert not problems, "\n".join(problems)
    # nothing left beside the outputs (atomic writes clean up their temp files)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f.name for f in files)


def test_invalid_corpus_files_get_clear_errors(shared_path) -> None:
    expected = {
        "Woosub-Won__BVHViewer__Coda02(Woman).bvh": (
            327,
            "frame 189 has 65 values; the hierarchy declares 66 channels",
        ),
        "ESJIAN__TRAM_DATA_TO_BVH__temp.bvh": (None, "blank line inside the motion data"),
        "kjangsy__DHNKinect__kinect.bvh": (None, "expected 'MOTION'"),
        "tomcatmew__simple_bvh_nn__test.bvh": (1, "expected 'HIERARCHY'"),
    }
    folder = shared_path("bvh-corpus/invalid")
    assert sorted(p.name for p in folder.glob("*.bvh")) == sorted(expected)
    for name, (line, text) in expected.items():
        with pytest.raises(BVHError) as err:
            read_bvh(folder / name)
        msg = str(err.value)
        assert msg.startswith(str(folder / name)), msg
        assert text in msg, msg
        if line is not None:
            assert err.value.line == line, msg
    # the truncated rows of Coda02 are not at the end: lenient mode must refuse them too
    with pytest.raises(BVHError, match="65 values"):
        read_bvh(folder / "Woosub-Won__BVHViewer__Coda02(Woman).bvh", lenient=True)


def test_reader_never_modifies_its_input(shared_path) -> None:
    f = shared_path("bvh-corpus") / "VictorS-67__pybvh__rotation_first_root.bvh"
    before = f.read_bytes()
    m = read_bvh(f)
    assert parse_bvh(before).allclose(m)
    assert f.read_bytes() == before
