"""The viewer page in real headless Chromium (DevTools protocol, see mocapkit.viz.browser).

Skips when no Chromium is found, unless MOCAPKIT_REQUIRE_BROWSER=1 (CI), where it fails.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest
from testsupport import require_chromium

from mocapkit import datasets
from mocapkit.clean import inject
from mocapkit.core.motion import concatenate
from mocapkit.io import write_motion
from mocapkit.viz import ViewMotion, write_page
from mocapkit.viz.browser import Browser, decode_png

from .helpers import random_motion

READY = "window.mocapkitViewer && window.mocapkitViewer.ready"
SHOTS = os.environ.get("MOCAPKIT_VIEW_SHOTS")  # keep the screenshots here, if set


@pytest.fixture(scope="module")
def browser():
    require_chromium()
    with Browser(width=1200, height=860) as b:
        yield b


@pytest.fixture(scope="module")
def cleaning_page(tmp_path_factory):
    """Procedural walk with a known injected error on LeftForeArm, the clean walk beside it and
    an MDM that is 1 on the injected cells (0.05 elsewhere)."""
    tmp = tmp_path_factory.mktemp("viewpages")
    walk = datasets.procedural_motion("walk", seconds=4.0, seed=0).motion
    j = list(walk.skeleton.names).index("LeftForeArm")
    inj = inject(walk, "offset", j, np.random.default_rng(1), start=40)
    frames = np.flatnonzero(inj.frames)
    mdm = np.full((walk.num_frames, walk.num_joints), 0.05, np.float32)
    mdm[frames, j] = 1.0
    report = {
        "input": "corrupted.bvh",
        "segments": [
            {"joint": "LeftForeArm", "start": int(frames[0]), "end": int(frames[-1]), "peak": 1}
        ],
    }
    page = write_page(
        tmp / "cleaning.html",
        [ViewMotion(inj.motion, "corrupted.bvh"), ViewMotion(walk, "cleaned.bvh")],
        clean_report=report,
        mdm=mdm,
    )
    return {"page": page, "joint": j, "frames": frames, "n": walk.num_frames}


def _open(b: Browser, page: Path) -> None:
    b.errors.clear()
    b.open(page, ready=READY)


def _assert_no_errors(b: Browser) -> None:
    assert b.errors == []
    assert b.eval("window.__mkErrors") == []


def _readout_frame(b: Browser) -> int:
    return int(b.eval("document.getElementById('readout').getAttribute('data-frame')"))


def _eventually(check, seconds: float = 10.0, step: float = 0.2) -> bool:
    import time

    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if check():
            return True
        time.sleep(step)
    return bool(check())


def test_loads_and_plays(browser, cleaning_page):
    b = browser
    _open(b, cleaning_page["page"])
    _assert_no_errors(b)
    assert b.eval("document.getElementById('readout').textContent").startswith("frame 0 / ")
    assert b.eval("mocapkitViewer.three.renderer.getContext().isContextLost()") is False
    b.eval("document.getElementById('play').click()")
    # poll rather than sleep a fixed time: a loaded CI machine may render slowly
    assert _eventually(lambda: _readout_frame(b) > 3), "the readout did not advance while playing"
    f = _readout_frame(b)
    assert _eventually(lambda: _readout_frame(b) > f)
    b.eval("document.getElementById('play').click()")  # pause
    f = _readout_frame(b)
    b.sleep(0.3)
    assert _readout_frame(b) == f
    # two motions start overlaid; the checkbox puts them side by side
    assert b.eval("mocapkitViewer.groupX(0) === mocapkitViewer.groupX(1)")
    b.eval("document.getElementById('side').click()")
    assert b.eval("mocapkitViewer.groupX(1) - mocapkitViewer.groupX(0)") > 0.3
    _assert_no_errors(b)


def test_scrubbing_and_timeline_click_jump_to_the_frame(browser, cleaning_page):
    b = browser
    _open(b, cleaning_page["page"])
    b.eval(
        "(() => { const s = document.getElementById('scrubber'); s.value = '57';"
        " s.dispatchEvent(new Event('input')); })()"
    )
    assert _readout_frame(b) == 57
    assert b.eval("document.getElementById('readout').textContent").startswith("frame 57 / ")
    assert b.eval("mocapkitViewer.frame") == 57
    # a click on the heat map jumps to that frame and selects that joint
    j = cleaning_page["joint"]
    p = b.eval(f"mocapkitViewer.timelinePoint(90, {j})")
    b.click(p["x"], p["y"])
    assert abs(_readout_frame(b) - 90) <= 1
    assert "LeftForeArm" in b.eval("document.getElementById('info-sel').textContent")
    _assert_no_errors(b)


def test_joint_colours_follow_the_mdm(browser, cleaning_page):
    b = browser
    _open(b, cleaning_page["page"])
    j, frames = cleaning_page["joint"], cleaning_page["frames"]
    bad = int(frames[len(frames) // 2])
    good = int(frames[-1]) + 20
    b.eval(f"mocapkitViewer.seek({bad})")
    r, g, bl = b.eval(f"mocapkitViewer.jointColor(0, {j})")
    assert r > 0.9 and g < 0.3 and bl < 0.3, "an MDM of 1 should be drawn red"
    r, g, bl = b.eval("mocapkitViewer.jointColor(0, 0)")
    assert bl > 0.8 and r < 0.4, "a clean joint should be drawn blue"
    # the second motion (not the analysed one) keeps its own colour
    assert b.eval(f"mocapkitViewer.jointColor(1, {j})") == pytest.approx(
        [1.0, 138 / 255, 101 / 255], abs=0.02
    )
    b.eval(f"mocapkitViewer.seek({good})")
    r, g, bl = b.eval(f"mocapkitViewer.jointColor(0, {j})")
    assert bl > 0.8 and r < 0.4, "after the error the joint should be blue again"


def _count_colour(img: np.ndarray, rgb, tol: float = 40.0) -> int:
    d = np.abs(img[..., :3].astype(np.int32) - np.asarray(rgb)).max(axis=-1)
    return int((d <= tol).sum())


def test_screenshot_shows_a_skeleton(browser, cleaning_page):
    b = browser
    _open(b, cleaning_page["page"])
    frames = cleaning_page["frames"]
    b.eval(f"mocapkitViewer.seek({int(frames[len(frames) // 2])})")  # inside the error
    b.sleep(0.3)
    rect = b.eval(
        "(() => { const r = document.getElementById('stage').getBoundingClientRect();"
        " return {x: r.left, y: r.top, width: r.width, height: r.height}; })()"
    )
    png = b.screenshot(rect)
    img = decode_png(png)
    # the stage's box may sit at a fractional pixel (401.5 high): the capture is whole pixels
    assert abs(img.shape[0] - rect["height"]) <= 1 and abs(img.shape[1] - rect["width"]) <= 1
    light = _count_colour(img, (0x4F, 0xC3, 0xF7))  # the first motion's bones (drawn on top)
    orange = _count_colour(img, (255, 138, 101))  # the second motion's, where they differ
    blue = _count_colour(img, (48, 97, 255), 60)  # the first motion's joints (MDM 0.05)
    b.eval(
        "mocapkitViewer.three.scene.children.forEach(o => { if (o.type === 'Group') "
        "o.visible = false; })"
    )
    b.sleep(0.3)
    empty = decode_png(b.screenshot(rect))
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        (Path(SHOTS) / "cleaning_stage.png").write_bytes(png)
        (Path(SHOTS) / "full_page.png").write_bytes(b.screenshot())
    assert light > 150, f"only {light} pixels of the first skeleton's colour"
    assert orange > 10, f"only {orange} pixels of the second skeleton's colour"
    assert blue > 100, f"only {blue} MDM-coloured joint pixels"
    assert _count_colour(empty, (255, 138, 101)) + _count_colour(empty, (48, 97, 255), 60) < 20
    background = _count_colour(empty, (0x1D, 0x1F, 0x27), 4)
    assert background > 0.5 * empty.shape[0] * empty.shape[1]


def test_stitch_and_graph_overlays(browser, tmp_path):
    b = browser
    clip = random_motion(120, 5)
    synth = concatenate([clip[0:50], clip[80:120]])
    write_motion(clip, tmp_path / "clip.bvh")
    from mocapkit.provenance import Provenance, Segment, TransitionTaken

    plan = Provenance(
        "graph synth", "synth.bvh", 30.0, 90, ["clip.bvh"], {},
        [Segment(0, 50, "clip", "clip.bvh", 0, 50),
         Segment(50, 55, "transition", "clip.bvh", 80, 85),
         Segment(55, 90, "clip", "clip.bvh", 85, 120)],
        [TransitionTaken(50, "clip.bvh", 50, "clip.bvh", 80, 0.25)],
    )  # fmt: skip
    stitch = {
        "takeoff": 20,
        "k": 5,
        "generated_frames": [21, 26],
        "landing_output_frame": 26,
        "lscore_by_k": [5.0, 3.0, 2.0, 1.5, 1.2, 1.0, 1.4],
        "frames": 90,
        "lscore": 1.0,
    }
    page = write_page(
        tmp_path / "overlays.html",
        [ViewMotion(synth, "synth.bvh", provenance=plan)],
        stitch=stitch,
    )
    _open(b, page)
    _assert_no_errors(b)
    assert b.eval("document.getElementById('lk-wrap').hidden") is False
    items = b.eval("[...document.querySelectorAll('#transitions div')].map(d => d.textContent)")
    assert len(items) == 1 and "frame 50" in items[0] and "cost 0.250" in items[0]
    p = b.eval("mocapkitViewer.timelinePoint(50)")
    b.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": p["x"], "y": p["y"]})
    hover = b.eval("document.getElementById('hover-info').textContent")
    assert "clip.bvh @50" in hover and "cost 0.250" in hover
    b.eval("document.querySelector('#transitions div').click()")
    assert _readout_frame(b) == 50
    b.eval("mocapkitViewer.seek(23)")
    assert b.eval("mocapkitViewer.boneColor(0)") == pytest.approx([1.0, 0xEB / 255, 0x3B / 255])
    b.eval("mocapkitViewer.seek(30)")
    assert b.eval("mocapkitViewer.boneColor(0)") != pytest.approx([1.0, 0xEB / 255, 0x3B / 255])
    text = b.eval("document.getElementById('info').textContent")
    assert "injected frames 21\u201325 (k = 5, drawn yellow)" in text
    _assert_no_errors(b)
    # a cut (k = 0) has no injected frame: its yellow frames are the landing eased in (they
    # read "injected frames 134-146 (k = 0)")
    cut = {**stitch, "k": 0, "generated_frames": [21, 29], "landing_output_frame": 29}
    page = write_page(tmp_path / "cut.html", [ViewMotion(synth, "synth.bvh")], stitch=cut)
    _open(b, page)
    text = b.eval("document.getElementById('info').textContent")
    assert "eased frames 21\u201328 (a cut, k = 0, drawn yellow)" in text
    _assert_no_errors(b)


def test_bench_script_runs_small(browser, capsys):
    """bench/bench_viewer.py on a small motion (the real run: 10,000 frames x 60 joints)."""
    from testsupport import load_bench

    mod = load_bench("bench_viewer")
    assert mod.main(["--frames", "300", "--joints", "20", "--seconds", "0.5"]) == 0
    out = capsys.readouterr().out
    assert "playback:" in out and "fps" in out


def test_an_inbetweened_take_opens_a_second_before_its_gap(browser, tmp_path):
    """Newcomer report: the page of a filled take opened at frame 0, not at the gap. It opens a
    second before the filled frames (frame 30 for a gap from 60 at 30 fps), the readout too."""
    from mocapkit.stitch.inbetween import DEFAULT_CONFIG, inbetween

    walk = datasets.procedural_motion("walk", 5.0, seed=11).motion
    lib = [datasets.procedural_motion(k, 6.0, seed=s).motion for k, s in (("idle", 1), ("run", 2))]
    out = tmp_path / "filled.bvh"
    # (the library's alone: the walk's own gait carried on keeps its feet off the floor)
    config = dataclasses.replace(DEFAULT_CONFIG, gait_share=0.0)
    res = inbetween(walk, (60, 90), lib, up="Y", output=str(out), clip_name="walk.bvh",
                    config=config)  # fmt: skip
    write_motion(res.motion, out)
    page = write_page(
        tmp_path / "filled.html", [ViewMotion(res.motion, str(out), provenance=res.provenance(out))]
    )
    b = browser
    _open(b, page)
    assert b.eval("mocapkitViewer.frame") == 60 - round(walk.fps)
    assert _readout_frame(b) == 60 - round(walk.fps)
    # the segments' shares summed by take, as the command reports them (weighing_takes)
    from mocapkit.provenance import weighing_takes

    weighing, nothing = weighing_takes(res.blended_from)
    name, share = weighing[0]
    text = b.eval("document.body.innerText")
    assert f"of {len(weighing) + nothing} take(s), by take: {name} " in text
    assert f"{name} {round(100 * share)}%" in text
    assert (f", {nothing} more take(s) at 0%" in text) == (nothing > 0)
    # the walk repeats one cycle and the library holds no walk: its own frames beside the gap
    # weigh most, and the page says they are the take's own
    main = max(res.blended_from, key=lambda x: x["weight"])
    assert main["source"] == "walk.bvh"
    assert "largest share: walk.bvh (the take's own frames) frames" in text
    assert f"(weight {round(100 * main['weight'])}%)" in text
    # the command's feet warning, measured on the frames written (a walk filled from an idle
    # and a run: a toe below the floor), and none where the feet are measured clean
    assert res.feet_warning and f"warning: {res.feet_warning}" in text
    _assert_no_errors(b)
    clean = dataclasses.replace(res, feet={**res.feet, "floor_depth_m": 0.0,
                                           "foot_skate_m_s": 0.0})  # fmt: skip
    assert not clean.feet_warning
    shown = ViewMotion(res.motion, str(out), provenance=clean.provenance(out))
    page = write_page(tmp_path / "clean.html", [shown])
    _open(b, page)
    assert "below the floor" not in b.eval("document.body.innerText")
    _assert_no_errors(b)


def test_a_standing_takes_gap_filled_by_one_segment_says_why(browser, tmp_path):
    """An idle take's sways combined out of step would keep half their motion: one segment
    fills it, and the page says why, with the share the command gives."""
    from mocapkit.stitch.inbetween import inbetween

    idle = datasets.procedural_motion("idle", 5.0, seed=3).motion
    lib = [datasets.procedural_motion("idle", 6.0, seed=s).motion for s in (4, 5, 6)]
    out = tmp_path / "idle.bvh"
    res = inbetween(idle, (60, 90), lib, up="Y", output=str(out), clip_name="idle.bvh",
                    method="library")  # fmt: skip
    assert len(res.blended_from) == 1 and res.motion_kept < 0.7
    write_motion(res.motion, out)
    shown = ViewMotion(res.motion, str(out), provenance=res.provenance(out))
    b = browser
    _open(b, write_page(tmp_path / "idle.html", [shown]))
    text = b.eval("document.body.innerText")
    assert f"alone (combined, the best segments would keep {res.motion_kept:.0%}" in text
    _assert_no_errors(b)


def test_a_walks_gap_says_what_share_its_own_gait_gave(browser, tmp_path):
    """A walk filled from other walks: the page gives the share of the fill's pose that carries
    on the walk's own gait, and the fitted half cycle, as the command does."""
    from mocapkit.stitch.inbetween import inbetween

    walk = datasets.procedural_motion("walk", 5.0, seed=11).motion
    lib = [datasets.procedural_motion("walk", 6.0, seed=s).motion for s in (1, 2)]
    out = tmp_path / "walk.bvh"
    res = inbetween(walk, (60, 90), lib, up="Y", output=str(out), clip_name="walk.bvh",
                    method="library")  # fmt: skip
    assert res.gait_share > 0
    write_motion(res.motion, out)
    shown = ViewMotion(res.motion, str(out), provenance=res.provenance(out))
    b = browser
    _open(b, write_page(tmp_path / "walk.html", [shown]))
    text = b.eval("document.body.innerText")
    pct = round(100 * res.gait_share)
    said = f"{pct}%" if res.gait_share >= 0.005 else "under 1%"
    assert f"{said} of its pose carries on the clip's own gait" in text
    assert f"fitted: {res.gait_half_period_s:.2f} s" in text
    _assert_no_errors(b)


def test_a_gap_given_to_the_kalman_transition_for_an_unlike_library_says_why(browser, tmp_path):
    """A short gap whose library holds nothing like the motion around it (a standing take for
    a walk) is filled by the Kalman transition: the page gives the fit's misses as the reason,
    and shows no warning that the fill may not look like the clip's (it is not the
    library's)."""
    from dataclasses import replace

    from mocapkit.stitch.inbetween import DEFAULT_CONFIG, inbetween

    walk = datasets.procedural_motion("walk", 5.0, seed=11).motion
    idle = [datasets.procedural_motion("idle", 6.0, seed=3).motion]
    out = tmp_path / "filled.bvh"
    config = replace(DEFAULT_CONFIG, own_frames=False)  # the walk's own steps would match
    res = inbetween(walk, (60, 64), idle, up="Y", output=str(out), clip_name="walk.bvh",
                    config=config)  # fmt: skip
    assert res.unlike and res.method == "kalman"
    write_motion(res.motion, out)
    page = write_page(
        tmp_path / "filled.html", [ViewMotion(res.motion, str(out), provenance=res.provenance(out))]
    )
    b = browser
    _open(b, page)
    text = b.eval("document.body.innerText")
    why = "by the Kalman transition (the library holds nothing like the motion around the gap: "
    assert why in " ".join(text.split()), text
    assert "may not look like" not in text
    _assert_no_errors(b)
