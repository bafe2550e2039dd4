"""The viewer on real rigs, in headless Chromium at 1280 x 900 (see tests/viz/test_browser.py).

A Bandai take (a ground root fixed at the origin, the body walking ~7 m through it), a CMU
ASF/AMC take (units from the ASF) and a Z-up BVH: the camera frames and follows the pelvis, the
character fills a sensible part of the stage at its true scale, its bones are solid, and the
ground root is a floor marker, not a bone from the origin to the hips.

Set MOCAPKIT_VIEW_SHOTS to a folder to keep the screenshots.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from testsupport import require_chromium

from mocapkit.body import body_of
from mocapkit.io import read_motion, write_motion
from mocapkit.viz.browser import Browser, decode_png
from mocapkit.viz.viewer import view_files

READY = "window.mocapkitViewer && window.mocapkitViewer.ready"
SHOTS = os.environ.get("MOCAPKIT_VIEW_SHOTS")

RIGS = {
    "bandai": ("bandai1/data", "dataset-1_walk_active_001.bvh"),
    "cmu": ("cmu-asfamc/01", "01_01.amc"),
    "zup": ("bvh-corpus", "VictorS-67__pybvh__bvh_test1.bvh"),
}

pytestmark = pytest.mark.shared


@pytest.fixture(scope="module")
def browser():
    require_chromium()
    with Browser(width=1280, height=900) as b:
        yield b


def _open_rig(b: Browser, shared_path, tmp_path: Path, rig: str) -> dict:
    folder, name = RIGS[rig]
    src = shared_path(folder) / name
    page = view_files([src], tmp_path / f"{rig}.html")
    body = body_of(read_motion(src))
    b.errors.clear()
    b.open(page, ready=READY)
    return {"src": src, "body": body, "n": b.eval("mocapkitViewer.nFrames")}


def _assert_no_errors(b: Browser) -> None:
    assert b.errors == []
    assert b.eval("window.__mkErrors") == []


def _body_joints(b: Browser) -> list[int]:
    """Every drawn joint (End Sites included), the ground root left out."""
    return b.eval(
        "(() => { const m = mocapkitViewer.data.motions[0], g = m.groundRoot;"
        " return m.names.map((_, j) => j).filter(j => j !== g); })()"
    )


def _check_framing(b: Browser, pelvis: int, frame: int) -> dict:
    """Seek ``frame``; the projected pelvis is near the stage centre, the whole body is inside
    the stage and its projected height is a sensible fraction of the stage's."""
    b.eval(f"mocapkitViewer.seek({frame})")
    r = b.eval("mocapkitViewer.stageRect()")
    cx, cy = r["x"] + r["width"] / 2, r["y"] + r["height"] / 2
    p = b.eval(f"mocapkitViewer.screenPoint({pelvis})")
    assert abs(p["x"] - cx) < 0.1 * r["width"], f"frame {frame}: pelvis x {p} vs centre {cx}"
    assert abs(p["y"] - cy) < 0.15 * r["height"], f"frame {frame}: pelvis y {p} vs centre {cy}"
    pts = b.eval(f"{_body_joints(b)}.map(j => mocapkitViewer.screenPoint(j))")
    xs = np.array([q["x"] for q in pts])
    ys = np.array([q["y"] for q in pts])
    assert xs.min() > r["x"] and xs.max() < r["x"] + r["width"], f"frame {frame}: off-stage"
    assert ys.min() > r["y"] and ys.max() < r["y"] + r["height"], f"frame {frame}: off-stage"
    frac = (ys.max() - ys.min()) / r["height"]
    assert 0.25 < frac < 0.9, f"frame {frame}: the character is {frac:.2f} of the stage height"
    return {"rect": r, "pelvis": p, "frac": frac}


def _frames(n: int) -> list[int]:
    return [0, n // 3, (2 * n) // 3, n - 1]


def _shot(b: Browser, rect: dict, name: str) -> np.ndarray:
    b.sleep(0.2)
    png = b.screenshot(rect)
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        (Path(SHOTS) / f"{name}.png").write_bytes(png)
    return decode_png(png)


def _solid_pixels(img: np.ndarray, rgb=(0x4F, 0xC3, 0xF7), tol: float = 70.0) -> int:
    """Pixels near the motion's colour (its lit and shaded sides)."""
    d = np.abs(img[..., :3].astype(np.int32) - np.asarray(rgb)).max(axis=-1)
    return int((d <= tol).sum())


@pytest.mark.parametrize("rig", sorted(RIGS))
def test_camera_frames_and_follows_the_character(browser, shared_path, tmp_path, rig):
    b = browser
    info = _open_rig(b, shared_path, tmp_path, rig)
    _assert_no_errors(b)
    pelvis = b.eval("mocapkitViewer.data.motions[0].pelvis")
    assert pelvis == info["body"].pelvis
    for f in _frames(info["n"]):
        res = _check_framing(b, pelvis, f)
    # solid bones: many pixels of the motion's colour (thin lines gave a few hundred)
    img = _shot(b, res["rect"], f"real_rig_{rig}")
    solid = _solid_pixels(img)
    assert solid > 2500
    # upright: the head is drawn above the pelvis
    head = info["body"].head
    assert head is not None
    assert (
        b.eval(f"mocapkitViewer.screenPoint({head}).y")
        < res["pelvis"]["y"] - 0.1 * res["rect"]["height"]
    )
    _assert_no_errors(b)


def test_bandai_ground_root_is_a_floor_marker(browser, shared_path, tmp_path):
    b = browser
    info = _open_rig(b, shared_path, tmp_path, "bandai")
    gr = b.eval("mocapkitViewer.data.motions[0].groundRoot")
    assert gr == info["body"].ground_root == 0
    bones = b.eval("mocapkitViewer.bones(0)")
    assert bones and all(gr not in pair for pair in bones), "a bone is drawn from the ground root"
    parents = b.eval("mocapkitViewer.data.motions[0].parents")
    children = [j for j, p in enumerate(parents) if p == gr]
    assert children  # the hips: their bone to the root is the one left out
    n = info["n"]
    for f in (0, n - 1):
        b.eval(f"mocapkitViewer.seek({f})")
        mk = b.eval("mocapkitViewer.groundMarker(0)")
        assert mk is not None and mk["visible"]
        # at the root (fixed at the origin), on the floor, with a finite heading
        assert abs(mk["x"]) < 0.01 and abs(mk["z"]) < 0.01 and abs(mk["y"]) < 0.02
        assert np.isfinite(mk["heading"])
    # the body walks metres through the root; the camera went with it
    b.eval("mocapkitViewer.seek(0)")
    t0 = b.eval("mocapkitViewer.three.camera.position.toArray()")
    b.eval(f"mocapkitViewer.seek({n - 1})")
    t1 = b.eval("mocapkitViewer.three.camera.position.toArray()")
    assert np.linalg.norm(np.subtract(t1, t0)[[0, 2]]) > 4.0
    _assert_no_errors(b)


def test_follow_during_playback_keeps_the_user_orbit(browser, shared_path, tmp_path):
    b = browser
    _open_rig(b, shared_path, tmp_path, "bandai")
    pelvis = b.eval("mocapkitViewer.data.motions[0].pelvis")
    r = b.eval("mocapkitViewer.stageRect()")
    before = b.eval("mocapkitViewer.three.camera.position.toArray()")
    # orbit: drag on the stage
    x, y = r["x"] + r["width"] / 2, r["y"] + r["height"] / 2
    b.call("Input.dispatchMouseEvent", {"type": "mousePressed", "x": x, "y": y,
                                        "button": "left", "clickCount": 1})  # fmt: skip
    for k in range(1, 11):
        b.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": x + 20 * k, "y": y,
                                            "button": "left", "buttons": 1})  # fmt: skip
    b.call("Input.dispatchMouseEvent", {"type": "mouseReleased", "x": x + 200, "y": y,
                                        "button": "left", "clickCount": 1})  # fmt: skip
    b.sleep(0.2)
    after = b.eval("mocapkitViewer.three.camera.position.toArray()")
    assert np.linalg.norm(np.subtract(after, before)) > 0.2, "the drag did not orbit the camera"
    view = np.subtract(after, b.eval("mocapkitViewer.three.controls.target.toArray()"))
    b.eval("mocapkitViewer.play()")
    b.sleep(1.5)
    b.eval("mocapkitViewer.pause()")
    assert b.eval("mocapkitViewer.frame") > 10
    # the camera moved with the body (the walk is ~1.3 m/s), keeping the orbited view direction,
    # and the pelvis is still near the centre
    cam = b.eval("mocapkitViewer.three.camera.position.toArray()")
    assert np.linalg.norm(np.subtract(cam, after)) > 0.5
    now = np.subtract(cam, b.eval("mocapkitViewer.three.controls.target.toArray()"))
    assert np.allclose(now, view, atol=1e-3)
    p = b.eval(f"mocapkitViewer.screenPoint({pelvis})")
    assert abs(p["x"] - x) < 0.1 * r["width"] and abs(p["y"] - y) < 0.15 * r["height"]
    _assert_no_errors(b)


def test_cmu_is_drawn_at_its_true_scale(browser, shared_path, tmp_path):
    b = browser
    _open_rig(b, shared_path, tmp_path, "cmu")
    d = b.eval(
        "(() => { const D = mocapkitViewer.data, m = D.motions[0];"
        " return {units: D.units, mpu: D.metresPerUnit, stature: m.stature, height: m.height}; })()"
    )
    assert d["mpu"] == pytest.approx(0.0254 / 0.45, rel=1e-6)  # the ASF's :units length 0.45 in
    assert 1.55 < d["stature"] < 1.85, d
    assert 1.4 < d["height"] < 1.85, d
    _assert_no_errors(b)


def test_side_by_side_takes_from_far_apart_stand_in_one_row(browser, shared_path, tmp_path):
    """A CMU take (starting metres from the capture origin), a Bandai take and a copy of it
    moved 20 m away: side by side, each starts in its own lane, all on stage, left to right."""
    from mocapkit.core.motion import Motion

    cmu = shared_path("cmu-asfamc/03") / "03_03.amc"
    bandai = shared_path(RIGS["bandai"][0]) / RIGS["bandai"][1]
    m = read_motion(bandai)
    away = np.array([2000.0, 0.0, -2000.0])  # 20 m along x and z (the take is in cm)
    far = Motion(m.skeleton, m.rotations, m.root_positions + away, m.frame_time, m.translations)
    if far.translations is not None:
        far.translations[:, 0] += away
    moved = write_motion(far, tmp_path / "far.bvh")
    page = view_files([cmu, bandai, moved], tmp_path / "row.html")
    b = browser
    b.errors.clear()
    b.open(page, ready=READY)
    _assert_no_errors(b)
    assert b.eval("mocapkitViewer.data.motions.length") == 3
    r = b.eval("mocapkitViewer.stageRect()")
    pts = [b.eval(f"mocapkitViewer.screenPoint(mocapkitViewer.data.motions[{i}].pelvis, {i})")
           for i in range(3)]  # fmt: skip
    xs = [p["x"] for p in pts]
    assert xs == sorted(xs), xs
    for p in pts:
        assert r["x"] < p["x"] < r["x"] + r["width"] and r["y"] < p["y"] < r["y"] + r["height"]
    assert max(p["y"] for p in pts) - min(p["y"] for p in pts) < 0.2 * r["height"]
