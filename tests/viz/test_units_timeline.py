"""Each motion at its own scale, and the timeline: labels that never overlap, no empty strip,
an MDM strip with a title, joint names and a time axis (headless Chromium, see test_browser.py).
"""

from __future__ import annotations

import dataclasses
import os
import re
from pathlib import Path

import numpy as np
import pytest
from testsupport import require_chromium

from mocapkit import datasets
from mocapkit.core.motion import Motion
from mocapkit.io import read_motion, write_motion
from mocapkit.provenance import Provenance, Segment, TransitionTaken
from mocapkit.viz import ViewMotion, page_data, write_page
from mocapkit.viz.browser import Browser
from mocapkit.viz.viewer import view_files

from .helpers import random_motion

READY = "window.mocapkitViewer && window.mocapkitViewer.ready"
SHOTS = os.environ.get("MOCAPKIT_VIEW_SHOTS")


@pytest.fixture(scope="module")
def browser():
    require_chromium()
    with Browser(width=1280, height=900) as b:
        yield b


def _open(b: Browser, page: Path) -> None:
    b.errors.clear()
    b.open(page, ready=READY)
    assert b.errors == [] and b.eval("window.__mkErrors") == []


def _scaled(m: Motion, factor: float, stated: float | None = None) -> Motion:
    """``m`` in a unit ``factor`` times smaller (lengths times ``factor``); ``stated``: the
    metres per unit the file states (as an ASF does), else none."""
    sk = dataclasses.replace(m.skeleton.scaled(factor), metres_per_unit=stated)
    return Motion(sk, m.rotations, m.root_positions * factor, m.frame_time)


# ------------------------------------------------------------------------- units per motion
def test_each_motion_is_drawn_in_metres_by_its_own_unit():
    walk = datasets.procedural_motion("walk", seconds=1.0, seed=0).motion  # metres
    cm = _scaled(walk, 100.0)
    asf = _scaled(walk, 1 / 0.05, stated=0.05)  # a unit of 5 cm, stated by the file
    for order in ([walk, cm, asf], [cm, asf, walk], [asf, walk, cm]):
        d = page_data([ViewMotion(m, f"m{i}.bvh") for i, m in enumerate(order)])
        by_mpu = {r["metresPerUnit"]: r for r in d["motions"]}
        assert set(by_mpu) == {1.0, 0.01, 0.05}
        assert by_mpu[0.01]["units"] == "cm" and by_mpu[0.01]["unitsSource"] == "guessed"
        assert by_mpu[0.05]["unitsSource"] == "file" and by_mpu[0.05]["units"] == "file"
        for r in d["motions"]:
            assert 1.4 < r["stature"] < 2.0, r["name"]
            assert r["up"] == "Y"
        statures = [r["stature"] for r in d["motions"]]
        assert max(statures) - min(statures) < 1e-3  # one body, three units
        # what the motions share is said once; what differs is None at the top
        assert d["up"] == "Y" and d["units"] is None and d["metresPerUnit"] is None
    # --units applies to every motion
    d = page_data([ViewMotion(cm, "a.bvh"), ViewMotion(cm, "b.bvh")], units="cm")
    assert [r["unitsSource"] for r in d["motions"]] == ["given", "given"]
    assert d["units"] == "cm" and d["unitsSource"] == "given" and d["metresPerUnit"] == 0.01


def _side_panel_heights(b: Browser) -> dict[str, float]:
    rows = b.eval("[...document.querySelectorAll('#info div')].map(d => d.textContent)")
    out = {}
    for t in rows:
        m = re.match(r"(.+?): ([0-9.]+) m tall", t)
        if m:
            out[m.group(1)] = float(m.group(2))
    return out


def _screen_height(b: Browser, mi: int, n: int) -> float:
    ys = [b.eval(f"mocapkitViewer.screenPoint({j}, {mi}).y") for j in range(n)]
    return max(ys) - min(ys)


@pytest.mark.shared
def test_glb_bvh_and_amc_mix_at_one_scale(browser, shared_path, tmp_path):
    """A .glb (metres), a Bandai BVH (cm, guessed) and a CMU AMC (the ASF's unit), in every
    order: each side-panel height 1.4-2.0 m and the skeletons about the same size on screen."""
    b = browser
    bvh = shared_path("bandai2/data") / "dataset-2_walk-turn-left_active_001.bvh"
    amc = shared_path("cmu-asfamc/03") / "03_03.amc"
    glb = tmp_path / "walk.glb"
    write_motion(read_motion(bvh), glb)
    cut = tmp_path / "cut.bvh"
    write_motion(read_motion(bvh)[10:100], cut)
    for k, files in enumerate([[glb, cut, amc], [cut, amc, glb], [amc, glb, cut]]):
        page = view_files(files, tmp_path / f"mix{k}.html")
        _open(b, page)
        heights = _side_panel_heights(b)
        assert set(heights) == {"walk.glb", "cut.bvh", "03_03.amc"}
        for name, h in heights.items():
            assert 1.4 <= h <= 2.0, (files, name, h)
        info = b.eval("document.getElementById('info').textContent")
        assert "units m (from the file)" in info and "units cm (guessed from the height)" in info
        assert "m (from the file)" in info.split("03_03.amc")[1]
        # overlaid (not side by side): the figures stand in one place, at one scale
        if b.eval("document.getElementById('side').checked"):
            b.eval("document.getElementById('side').click()")
        b.sleep(0.2)
        sizes = [
            _screen_height(b, i, int(b.eval(f"mocapkitViewer.data.motions[{i}].numJoints")))
            for i in range(3)
        ]
        assert max(sizes) < 1.6 * min(sizes), (files, sizes)
        assert min(sizes) > 80, sizes  # ... and big enough to see (the stage is ~500 px high)
        if SHOTS and k == 0:
            Path(SHOTS).mkdir(parents=True, exist_ok=True)
            (Path(SHOTS) / "units_mix.png").write_bytes(b.screenshot())


# ------------------------------------------------------------------------- timeline
def _dense_graph_page(tmp_path: Path, n_trans: int = 80) -> tuple[Path, int]:
    clip = random_motion(600, 3)
    rng = np.random.default_rng(0)
    frames = np.sort(rng.choice(np.arange(5, 590), n_trans, replace=False))
    trans = [
        TransitionTaken(int(f), "clip.bvh", int(f), "clip.bvh", int(f) + 3, float(c))
        for f, c in zip(frames, rng.uniform(0, 2000, n_trans), strict=True)
    ]
    plan = Provenance(
        "graph synth", "synth.bvh", 30.0, 600, ["clip.bvh"], {},
        [Segment(0, 600, "clip", "clip.bvh", 0, 600)], trans,
    )  # fmt: skip
    page = write_page(
        tmp_path / "dense.html",
        [ViewMotion(clip, "synth.bvh", provenance=plan)],
        stitch={"takeoff": 300, "k": 4, "generated_frames": [301, 305], "frames": 600},
    )
    return page, n_trans


def _overlaps(a: dict, b: dict) -> bool:
    return (
        a["x"] < b["x"] + b["width"]
        and b["x"] < a["x"] + a["width"]
        and a["y"] < b["y"] + b["height"]
        and b["y"] < a["y"] + a["height"]
    )


def test_dense_transition_labels_never_overlap(browser, tmp_path):
    b = browser
    page, n = _dense_graph_page(tmp_path)
    _open(b, page)
    for width in (1280, 700):  # and after a resize
        metrics = {"width": width, "height": 900, "deviceScaleFactor": 1, "mobile": False}
        b.call("Emulation.setDeviceMetricsOverride", metrics)
        b.eval("window.dispatchEvent(new Event('resize'))")
        b.sleep(0.2)
        got = b.eval("mocapkitViewer.timelineLabels()")
        labels = got["labels"]
        assert labels, "no label at all"
        assert len(labels) + got["hidden"] == n + 2  # the costs, take-off and landing
        texts = [lab["text"] for lab in labels]
        assert "take-off" in texts and "landing" in texts  # placed first
        for i, p in enumerate(labels):
            for q in labels[i + 1 :]:
                assert not _overlaps(p, q), (p, q)
        r = b.eval("document.getElementById('timeline').getBoundingClientRect().toJSON()")
        for lab in labels:
            assert r["left"] <= lab["x"] and lab["x"] + lab["width"] <= r["right"] + 0.5
            assert r["top"] <= lab["y"] and lab["y"] + lab["height"] <= r["bottom"]
        if got["hidden"]:
            assert "left out" in b.eval("document.getElementById('tl-note').textContent")
    # every transition's details are on hover, labelled or not
    t = b.eval("mocapkitViewer.data.graph.transitions[7]")
    p = b.eval(f"mocapkitViewer.timelinePoint({t['frame']})")
    b.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": p["x"], "y": p["y"]})
    hover = b.eval("document.getElementById('hover-info').textContent")
    assert f"transition at frame {t['frame']}" in hover and f"cost {t['cost']:.3f}" in hover
    if SHOTS:
        (Path(SHOTS) / "dense_labels.png").write_bytes(b.screenshot())
    b.call("Emulation.clearDeviceMetricsOverride", {})


def test_no_overlay_no_timeline_strip(browser, tmp_path):
    b = browser
    page = write_page(tmp_path / "plain.html", [ViewMotion(random_motion(60), "a.bvh")])
    _open(b, page)
    assert b.eval("mocapkitViewer.timelineShown()") is False
    assert b.eval("document.getElementById('timeline-wrap').getBoundingClientRect().height") == 0
    assert b.eval("document.getElementById('tl-cap').hidden") is True
    # the player still works without it
    b.eval("mocapkitViewer.seek(20)")
    assert b.eval("mocapkitViewer.frame") == 20
    assert b.errors == [] and b.eval("window.__mkErrors") == []


def test_mdm_strip_has_a_title_joint_names_and_a_time_axis(browser, tmp_path):
    b = browser
    walk = datasets.procedural_motion("walk", seconds=4.0, seed=0).motion
    mdm = np.full((walk.num_frames, walk.num_joints), 0.05, np.float32)
    page = write_page(
        tmp_path / "mdm.html",
        [ViewMotion(walk, "take.bvh")],
        clean_report={"input": "take.bvh", "segments": []},
        mdm=mdm,
    )
    _open(b, page)
    assert b.eval("mocapkitViewer.timelineShown()") is True
    assert b.eval("document.getElementById('tl-cap').hidden") is False
    title = b.eval("document.getElementById('tl-cap').textContent")
    assert "MDM of take.bvh" in title and "joint" in title
    lay = b.eval("mocapkitViewer.timelineLayout()")
    assert lay["names"] is True and lay["gutter"] > 20  # joint names in a left gutter
    assert lay["ticks"] >= 3 and lay["axis"] > 0  # a time axis in seconds under the rows
    # the rows still map to the right frames and joints past the gutter
    j = list(walk.skeleton.names).index("LeftForeArm")
    p = b.eval(f"mocapkitViewer.timelinePoint(60, {j})")
    b.click(p["x"], p["y"])
    assert b.eval("mocapkitViewer.frame") == pytest.approx(60, abs=1)
    assert "LeftForeArm" in b.eval("document.getElementById('info-sel').textContent")
    if SHOTS:
        (Path(SHOTS) / "mdm_strip.png").write_bytes(b.screenshot())
