"""`mocapkit edit` end to end (click's runner) on the procedural humanoid."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mocapkit import datasets
from mocapkit.cli import main
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.edit import change_speed, drop_joints, in_place, mirror, trim_frames
from mocapkit.io import read_motion, write_motion
from mocapkit.provenance import read_provenance


def run(*args: str) -> tuple[int, str, str]:
    res = CliRunner().invoke(main, list(args))
    return res.exit_code, res.stdout, res.stderr


@pytest.fixture(scope="module")
def walk(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("edit")
    return write_motion(datasets.procedural_motion("walk", 3.0, seed=0).motion, d / "walk.bvh")


def test_edit_runs_every_edit_in_order_and_writes_provenance(walk, tmp_path) -> None:
    out = tmp_path / "e.bvh"
    code, stdout, stderr = run(
        "edit", str(walk), str(out), "--speed", "1.25", "--rename", "Hips=pelvis",
        "--drop-joints", ".*Toe.*", "--in-place", "--mirror", "--trim", "0.5s:2.5s", "--json",
    )  # fmt: skip
    assert code == 0, stderr
    rep = json.loads(stdout)
    assert [s["edit"] for s in rep["steps"]] == ["trim", "mirror", "in-place", "drop", "speed",
                                                 "rename"]  # fmt: skip
    assert rep["steps"][0]["frames"] == [15, 75]
    assert rep["order"] == [s["edit"] for s in rep["steps"]]
    # only the edits asked for are listed (all six were, whatever ran)
    code, stdout, _ = run("edit", str(walk), str(tmp_path / "t.bvh"), "--trim", "0:30", "--json")
    assert code == 0 and json.loads(stdout)["order"] == ["trim"]
    src = read_motion(walk)
    expected = change_speed(drop_joints(in_place(mirror(trim_frames(src, 15, 75)).motion),
                                        ".*Toe.*"), 1.25)  # fmt: skip
    got = read_motion(out)
    assert got.num_frames == expected.num_frames == 48 == rep["output"]["frames"]
    assert got.skeleton.names[0] == "pelvis" and not any("Toe" in n for n in got.skeleton.names)
    assert got.frame_time == src.frame_time
    np.testing.assert_allclose(forward_kinematics(got)[0], forward_kinematics(expected)[0],
                               atol=1e-4)  # fmt: skip
    plan = read_provenance(tmp_path / "e.bvh.provenance.json")
    assert plan.tool == "edit" and plan.inputs == [str(walk)] and plan.frames == 48
    assert plan.parameters["trim"] == "0.5s:2.5s" and plan.parameters["trim_frames"] == [15, 75]
    assert plan.parameters["mirror"] and plan.parameters["speed"] == 1.25
    seg = plan.segments[0]
    assert (seg.output_start, seg.output_stop, seg.kind) == (0, 48, "generated")
    assert (seg.source_start, seg.source_stop) == (15, 75)


def test_frames_and_seconds_give_the_same_edit(walk, tmp_path) -> None:
    outs = []
    for spec in ("15:75", "0.5s:2.5s", "15:2.5s"):
        out = tmp_path / f"t{len(outs)}.bvh"
        code, stdout, stderr = run("edit", str(walk), str(out), "--trim", spec)
        assert code == 0, stderr
        assert f"wrote {out} (60 frames" in stdout
        outs.append(read_motion(out))
    assert outs[0].allclose(outs[1], 1e-12, 1e-12) and outs[0].allclose(outs[2], 1e-12, 1e-12)
    code, _, _ = run("edit", str(walk), str(tmp_path / "open.bvh"), "--trim", "60:")
    assert code == 0 and read_motion(tmp_path / "open.bvh").num_frames == 30


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--trim", "5:2"), "--trim '5:2': reversed range"),
        (("--trim", "0:9999"), "past the end"),
        (("--trim", "1.5"), "--trim: expected A:B"),
        (("--rename", "Nope=x"), "no joint named 'Nope'"),
        (("--rename", "Hips"), "--rename 'Hips': expected OLD=NEW"),
        (("--rename", "Hips=Spine"), "two joints would be called 'Spine'"),
        (("--drop-joints", ".*"), "cannot be dropped"),
        (("--drop-joints", "Nothing"), "no joint matches"),
        (("--drop-joints", "("), "bad regular expression"),
        (("--rename", "Spine=x", "--drop-joints", "Spine"), "is dropped"),
        (("--in-place", "--extract-root"), "at most one of"),
        (("--speed", "0"), "--speed"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_no_output(walk, tmp_path, args, words) -> None:
    out = tmp_path / "bad.bvh"
    code, stdout, stderr = run("edit", str(walk), str(out), *args)
    assert code == 2, (stdout, stderr)
    assert words in stderr and len(stderr.strip().splitlines()) == 1, stderr
    assert "Traceback" not in stderr
    assert list(tmp_path.iterdir()) == []  # neither the motion nor its sidecar


def test_outputs_are_checked_before_reading(walk, tmp_path) -> None:
    code, _, stderr = run("edit", str(walk), str(walk), "--mirror")
    assert code == 2 and "refusing to overwrite the input" in stderr
    code, _, stderr = run("edit", str(walk), str(tmp_path / "x.json"))
    assert code == 2 and "cannot write this file type" in stderr
    code, _, stderr = run("edit", str(tmp_path / "nope.bvh"), str(tmp_path / "x.bvh"))
    assert code == 2 and "no such file" in stderr
    code, stdout, _ = run("edit", "--help")
    assert code == 0 and "Examples:" in stdout and "1.5s:4.0s" in stdout


def test_extract_root_then_rename_the_new_root(walk, tmp_path) -> None:
    out = tmp_path / "r.npz"
    code, stdout, stderr = run(
        "edit", str(walk), str(out), "--extract-root", "--rename", "Root=root_motion", "--json"
    )
    assert code == 0, stderr
    m = read_motion(out)
    assert m.skeleton.names[0] == "root_motion" and m.skeleton.names[1] == "Hips"
    rep = json.loads(stdout)
    assert rep["steps"][0] == {"edit": "extract", "root": "Root", "added_joint": True}
