"""The viewer page without a browser: self-contained, data faithful, CLI and demo step."""

from __future__ import annotations

import base64
import json
import re

import numpy as np
import pytest
from click.testing import CliRunner

from mocapkit import datasets
from mocapkit.cli import main
from mocapkit.cli.view_commands import view_demo_step
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.core.motion import concatenate
from mocapkit.io import write_motion
from mocapkit.provenance import Provenance, Segment, TransitionTaken
from mocapkit.viz import ViewMotion, build_page, page_data
from mocapkit.viz.viewer import graph_overlay, to_y_up, view_files

from .helpers import random_motion


def page_json(html: str) -> dict:
    m = re.search(r'<script type="application/json" id="mocapkit-data">(.*?)</script>', html, re.S)
    assert m
    return json.loads(m.group(1).replace("<\\/", "</"))


def decode_positions(rec: dict) -> np.ndarray:
    q = np.frombuffer(base64.b64decode(rec["pos"]), dtype="<u2").astype(np.float64)
    q = q.reshape(rec["frames"], len(rec["names"]), 3)
    return np.asarray(rec["lo"]) + q * np.asarray(rec["step"])


def test_page_is_self_contained_and_faithful():
    m = random_motion(50)
    html = build_page(page_data([ViewMotion(m, "a.bvh")], up="Y", units="cm"))
    # offline: no external scripts, styles or fetches
    assert not re.search(r"<script[^>]+src=|<link[^>]+href=|@import", html)
    assert "Three.js Authors" in html and "OrbitControls" in html
    assert html.count("</script") == 5  # the template's own: nothing inlined closes one
    d = page_json(html)
    rec = d["motions"][0]
    assert rec["names"][: m.num_joints] == list(m.skeleton.names)
    assert len(rec["parents"]) == len(rec["names"])
    pos = decode_positions(rec)[:, : m.num_joints]
    fk, _ = forward_kinematics(m)
    np.testing.assert_allclose(pos, fk * 0.01, atol=1e-4)  # cm -> m, quantised
    assert d["up"] == "Y" and d["units"] == "cm" and d["clean"] is None


@pytest.mark.parametrize("up", ["Y", "-Y", "Z", "-Z", "X", "-X"])
def test_to_y_up_is_a_rotation_taking_up_to_y(up):
    axis = {"X": 0, "Y": 1, "Z": 2}[up[-1]]
    v = np.zeros(3)
    v[axis] = -1.0 if up.startswith("-") else 1.0
    np.testing.assert_allclose(to_y_up(v, up), [0, 1, 0])
    basis = to_y_up(np.eye(3), up)
    assert np.isclose(np.linalg.det(basis), 1.0)


def test_overlays_are_attached_to_the_right_motion():
    a, b = random_motion(40, 1), random_motion(40, 2)
    mdm = np.zeros((40, a.num_joints), np.float32)
    mdm[10:15, 3] = 1.0
    report = {"input": "dir/b.bvh", "segments": [{"joint": "Head", "start": 10, "end": 14}]}
    d = page_data([ViewMotion(a, "a.bvh"), ViewMotion(b, "b.bvh")], clean_report=report, mdm=mdm)
    c = d["clean"]
    assert c["motion"] == 1 and c["segments"][0]["joint"] == 3
    q = np.frombuffer(base64.b64decode(c["mdm"]), np.uint8).reshape(40, a.num_joints)
    assert q[12, 3] == 255 and q[5, 3] == 0
    with pytest.raises(ValueError, match="joints"):
        page_data([ViewMotion(a, "a.bvh")], mdm=np.zeros((40, 3)))
    # a report of another take (a CMU report on a Bandai take) is refused, not drawn
    other = {"input": "01_02.amc", "frames": 4346, "joints": ["root", "rthumb"], "segments": []}
    with pytest.raises(ValueError, match=r"names 2 joints, a.bvh has .*not in it: root, rthumb"):
        page_data([ViewMotion(a, "a.bvh")], clean_report=other)
    other["joints"] = list(a.skeleton.names)
    with pytest.raises(ValueError, match=r"covers 4346 frames, a\.bvh has 40"):
        page_data([ViewMotion(a, "a.bvh")], clean_report=other)
    st = page_data(
        [ViewMotion(a, "a.bvh")],
        stitch={
            "takeoff": 9,
            "k": 4,
            "generated_frames": [10, 14],
            "landing_output_frame": 14,
            "lscore_by_k": [3.0, 2.0, 1.0, 1.5, 2.5],
            "frames": 40,
        },
    )["stitch"]
    assert st["generated"] == [10, 14] and st["lscoreByK"][2] == 1.0


def test_graph_overlay_reads_the_synth_plan(tmp_path):
    clip = random_motion(120, 5)
    synth = concatenate([clip[0:50], clip[80:120]])
    plan = Provenance(
        "graph synth", "synth.bvh", 30.0, 90, ["lib/clip.bvh"], {},
        [Segment(0, 50, "clip", "lib/clip.bvh", 0, 50),
         Segment(50, 55, "transition", "lib/clip.bvh", 80, 85),
         Segment(55, 90, "clip", "lib/clip.bvh", 85, 120)],
        [TransitionTaken(50, "lib/clip.bvh", 50, "lib/clip.bvh", 80, 0.25)],
    )  # fmt: skip
    graph = {"transitions": [{}, {}, {}]}
    ov = graph_overlay([ViewMotion(clip, "clip.bvh"), ViewMotion(synth, "s.bvh", provenance=plan)],
                       graph)  # fmt: skip
    assert ov["motion"] == 1 and ov["numTransitions"] == 3
    (t,) = ov["transitions"]
    assert (t["frame"], t["end"], t["src_frame"], t["dst_frame"]) == (50, 55, 50, 80)
    assert t["cost"] == 0.25 and t["src_name"] == "clip.bvh"
    # view finds the plan beside the file by itself
    out = write_motion(synth, tmp_path / "s.bvh")
    plan.write(out)
    d = page_json(view_files([out], tmp_path / "v.html").read_text())
    assert d["graph"]["transitions"][0]["frame"] == 50


def test_view_marks_a_stitch_from_its_sidecar(tmp_path):
    """`mocapkit view OUT.bvh` of a stitch marked nothing unless the stitch JSON was given too;
    the sidecar holds the take-off, the generated frames and the data file's landing."""
    from mocapkit.stitch.library import stitch_library

    paths = []
    for n, kind in enumerate(("walk", "run")):
        m = datasets.procedural_motion(kind, seconds=2.0, seed=40 + n).motion
        paths.append(write_motion(m, tmp_path / f"{kind}.bvh"))
    q = datasets.procedural_motion("walk", seconds=2.0, seed=7).motion
    res = stitch_library(q, "30", paths)
    out = write_motion(res.motion, tmp_path / "st.bvh")
    res.provenance(str(out)).write(out)
    d = page_json(view_files([out], tmp_path / "v.html").read_text())
    st = d["stitch"]
    assert st["generated"] == [res.generated.start, res.generated.stop]
    assert st["landing"] == res.landing_index and st["takeoff"] == res.takeoff
    # the data frame playing as it is at the landing (past a cut's eased frames, k = 0)
    assert st["landingData"] == res.to_json()["data_frame_at_landing_output"]
    assert st["k"] == res.k


def test_view_cli_writes_a_page_and_reports_bad_input(tmp_path):
    walk = datasets.procedural_motion("walk", seconds=1.0, seed=0).motion
    bvh = write_motion(walk, tmp_path / "walk.bvh")
    mdm = tmp_path / "mdm.npy"
    np.save(mdm, np.zeros((walk.num_frames, walk.num_joints), np.float32))
    rep = tmp_path / "rep.json"
    rep.write_text(json.dumps({"segments": [], "repaired_cells": 0}))
    r = CliRunner().invoke(
        main,
        [
            "view",
            str(bvh),
            str(bvh),
            "--mdm",
            str(mdm),
            "--clean-report",
            str(rep),
            "--out",
            str(tmp_path / "v.html"),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "wrote" in r.output
    d = page_json((tmp_path / "v.html").read_text())
    assert len(d["motions"]) == 2 and d["clean"]["frames"] == walk.num_frames
    assert d["units"] == "m" and d["up"] == "Y"  # the procedural humanoid is in metres
    r = CliRunner().invoke(main, ["view", str(tmp_path / "missing.bvh")])
    assert r.exit_code == 2 and "error" in r.output
    np.save(mdm, np.zeros((walk.num_frames, 3), np.float32))
    r = CliRunner().invoke(main, ["view", str(bvh), "--mdm", str(mdm)])
    assert r.exit_code == 2 and "joints" in r.output


def test_demo_step_writes_pages_for_what_exists(tmp_path, capsys):
    walk = datasets.procedural_motion("walk", seconds=1.0, seed=0).motion
    write_motion(walk, tmp_path / "humanoid_walk.bvh")
    write_motion(walk, tmp_path / "stitch_walk_idle.bvh")  # stitch JSON missing
    view_demo_step(tmp_path)
    out = capsys.readouterr().out
    assert (tmp_path / "view_humanoid_walk.html").exists()
    assert (tmp_path / "view_stitch.html").exists() and "without stitch" in out
    assert not (tmp_path / "view_cleaning.html").exists() and "skipped view_cleaning" in out
    assert str(tmp_path / "view_humanoid_walk.html") in out


def test_z_up_motion_is_turned_upright():
    from mocapkit.core.rotations import quat_apply, quat_mul

    walk = datasets.procedural_motion("walk", seconds=1.0, seed=0).motion
    rx = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0])  # +90 deg about X: Y -> Z
    rot = walk.rotations.copy()
    rot[:, 0] = quat_mul(rx, rot[:, 0])
    zup = type(walk)(walk.skeleton, rot, quat_apply(rx, walk.root_positions), walk.frame_time)
    d = page_data([ViewMotion(zup, "zup.bvh")])
    assert d["up"] == "Z"
    rec = d["motions"][0]
    pos = decode_positions(rec)
    names = rec["names"]
    head, foot = names.index("Head"), names.index("LeftFoot")
    assert (pos[:, head, 1] - pos[:, foot, 1]).min() > 1.0  # metres, head above the foot
