"""Stitching onto a library in shards (mocapkit.stitch.library) finds what one search over all
the clips finds, whatever the shard size; unreadable files are left out and named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocapkit import datasets
from mocapkit.io import write_motion
from mocapkit.stitch import stitch
from mocapkit.stitch.library import plan_shards, stitch_library

KINDS = ("walk", "run", "idle", "wave", "walk", "run", "walk")


@pytest.fixture(scope="module")
def lib(tmp_path_factory) -> tuple[list[Path], list]:
    root = tmp_path_factory.mktemp("stitchlib")
    paths, motions = [], []
    for n, kind in enumerate(KINDS):
        m = datasets.procedural_motion(kind, seconds=2.0, seed=40 + n).motion
        p = root / f"{n:02d}_{kind}.bvh"
        write_motion(m, p)
        paths.append(p)
    from mocapkit.io import read_motion

    motions = [read_motion(p) for p in paths]  # as the shards read them
    return paths, motions


@pytest.mark.parametrize("shard_files", [1, 2, 3, 100])
@pytest.mark.parametrize(("takeoff", "landing"), [("20:45", None), ("30", 12)])
def test_shards_find_what_one_search_finds(lib, shard_files, takeoff, landing):
    paths, motions = lib
    q = datasets.procedural_motion("walk", seconds=2.0, seed=7).motion
    ref = stitch(q, takeoff, motions, landing, data_names=[str(p) for p in paths])
    got = stitch_library(q, takeoff, paths, landing, shard_files=shard_files)
    assert got.transition.as_dict() == ref.transition.as_dict()
    np.testing.assert_array_equal(got.motion.rotations, ref.motion.rotations)
    np.testing.assert_array_equal(got.motion.root_positions, ref.motion.root_positions)
    assert got.data_names == tuple(str(p) for p in paths) and got.skipped == ()


def test_unreadable_files_are_left_out_and_named(lib, tmp_path):
    paths, motions = lib
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n")
    q = datasets.procedural_motion("walk", seconds=2.0, seed=7).motion
    got = stitch_library(q, "20:45", [bad, *paths], shard_files=2)
    ref = stitch(q, "20:45", motions)
    assert got.transition.clip == ref.transition.clip + 1  # indexes the given paths
    assert got.transition.lscore == ref.transition.lscore
    assert [p for p, _ in got.skipped] == [str(bad)] and str(bad) in got.skipped[0][1]
    assert got.to_json()["skipped"][0]["path"] == str(bad)
    with pytest.raises(ValueError, match=r"no data clip could be used: .*bad\.bvh"):
        stitch_library(q, "20:45", [bad])


def test_shards_are_fixed_runs_of_files():
    shards = plan_shards([f"f{i}" for i in range(70)], 32)
    assert [(s.index, s.first, len(s.paths)) for s in shards] == [(0, 0, 32), (1, 32, 32),
                                                                  (2, 64, 6)]  # fmt: skip
    with pytest.raises(ValueError, match="shard_files must be >= 1"):
        plan_shards(["a"], 0)


def test_a_library_at_another_rate_is_named_in_its_own_frames(lib, tmp_path):
    """Newcomer report: with library files at 60 fps and a 30 fps query, the landing and the
    provenance's source frames were frames of the file resampled to 30 fps (96 for the file's
    192), and --landing 192 was taken as 6.4 s into the clip."""
    from mocapkit.features import resample
    from mocapkit.io import read_motion

    paths, _ = lib
    fast = []
    for p in paths[:3]:
        f = tmp_path / f"{p.stem}_60.bvh"
        write_motion(resample(read_motion(p), 60), f)
        fast.append(f)
    q = datasets.procedural_motion("walk", seconds=2.0, seed=7).motion
    same = stitch_library(q, "30", paths[:3])  # the same clips at the query's rate
    got = stitch_library(q, "30", fast)
    assert got.data_fps == 60 and same.data_fps is None
    assert got.transition.clip == same.transition.clip
    js = got.to_json()
    assert js["landing"] == 2 * same.to_json()["landing"] and js["data_fps"] == 60
    prov = got.provenance("out.bvh")
    tail = prov.segments[-1]
    assert tail.source_start == 2 * same.provenance("out.bvh").segments[-1].source_start
    assert prov.transitions[0].target_frame == js["landing"]
    # the reported landing frame, given back, lands on the same pose
    again = stitch_library(q, "30", fast, js["landing"])
    assert again.to_json()["landing"] == js["landing"]
    assert again.transition.landing == got.transition.landing
    # a time lands at that time in every file
    at = stitch_library(q, "30", fast, "0.4s")
    assert at.to_json()["landing"] == 24 and at.transition.landing == 12
    # a rate that is no multiple: a frame of the file between frames of the search is moved to
    # the nearest one, with a warning; no reported frame lies past the file (review)
    odd = []
    for p in paths[:3]:
        f = tmp_path / f"{p.stem}_45.bvh"
        write_motion(resample(read_motion(p), 45), f)
        odd.append(f)
    with pytest.warns(UserWarning, match="landing frame 10 of .* landed on its frame 11"):
        moved = stitch_library(q, "30", odd, 10)
    assert moved.to_json()["landing"] == 11
    for res, files in ((got, fast), (moved, odd)):
        seg = res.provenance("out.bvh").segments[-1]
        n = read_motion(files[res.transition.clip]).num_frames
        assert 0 <= seg.source_start < seg.source_stop <= n
    # stitch() on motions in memory names their own frames too, as stitch_library does with
    # files (review: the two entry points disagreed)
    mem = [read_motion(f) for f in fast]
    direct = stitch(q, "30", mem, js["landing"], data_names=[str(f) for f in fast])
    assert direct.to_json()["landing"] == js["landing"] and direct.data_fps == 60
    assert direct.transition.landing == got.transition.landing
    assert direct.provenance("o.bvh").segments[-1].source_stop <= mem[0].num_frames
    with pytest.raises(ValueError, match="several frame rates"):
        stitch(q, "30", [mem[0], read_motion(paths[0])], 24)
