"""The blind list of real glitches in the raw CMU takes (tests/clean/fixtures)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

FIXTURE = Path(__file__).parent / "fixtures" / "cmu_glitches.json"
ROOT = Path(__file__).resolve().parents[2]
CMU = ROOT.parent / "shared" / "data" / "cmu-asfamc"
# the eye pass over the jitter signal's events (first 20 s of the six takes eval_clean analyses)
JITTER_JUDGED = 620
JITTER_REJECTED = 111


def _eval_clean():
    spec = importlib.util.spec_from_file_location("eval_clean", ROOT / "bench" / "eval_clean.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _signals(doc: dict) -> tuple[list, list, list, list]:
    gl = doc["glitches"]
    return (
        [g for g in gl if "signal" not in g],
        [g for g in gl if g.get("signal") == "excursion"],
        [g for g in gl if g.get("signal") == "hold"],
        [g for g in gl if g.get("signal") == "jitter"],
    )


def _list_glitches():
    spec = importlib.util.spec_from_file_location(
        "list_glitches", ROOT / "bench" / "list_glitches.py"
    )
    lg = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(lg)
    return lg


def test_glitch_list_is_well_formed() -> None:
    doc = json.loads(FIXTURE.read_text())
    gl = doc["glitches"]
    step, exc, holds, jitter = _signals(doc)
    assert len(step) + len(exc) + len(holds) + len(jitter) == len(gl)
    assert len(step) == 185 and len(exc) == 1396 and len(holds) == 87 and "blind" in doc["about"]
    for g in gl:
        assert set(g) >= {"take", "joint", "frames", "inspected", "glitch", "seen"}
        a, b = g["frames"]
        assert 0 <= a <= b
    # each signal's entries against its own criterion
    assert all(g["peak_step_deg"] > doc["criterion"]["step_deg"] for g in step)
    # peak_dev_deg is rounded to 0.1 deg, so an event just over the threshold reads as equal to it
    assert all(g["peak_dev_deg"] >= doc["criterion_excursion"]["dev_deg"] for g in exc)
    # an excursion entry never overlaps a step-signal entry of the same take and joint
    for g in exc:
        for f in step:
            if f["take"] == g["take"] and f["joint"] == g["joint"]:
                assert g["frames"][1] < f["frames"][0] or f["frames"][1] < g["frames"][0]
    inspected = [g for g in step if g["inspected"]]
    assert len(inspected) == 130 and sum(not g["glitch"] for g in inspected) == 15
    inspected = [g for g in exc if g["inspected"]]
    assert len(inspected) == 854 and sum(not g["glitch"] for g in inspected) == 113
    assert all(g["held_frames"] >= 0.05 * 120 for g in holds)
    assert all(g["held_frames"] == g["frames"][1] - g["frames"][0] + 1 for g in holds)
    inspected = [g for g in holds if g["inspected"]]
    assert len(inspected) == 47 and sum(not g["glitch"] for g in inspected) == 2
    assert all(g["peak_rms_deg"] >= doc["criterion_jitter"]["rms_deg"] for g in jitter)
    inspected = [g for g in jitter if g["inspected"]]
    assert len(inspected) == JITTER_JUDGED and sum(not g["glitch"] for g in inspected) == (
        JITTER_REJECTED
    )
    # every event within the first 20 s at 120 fps (what bench/eval_clean.py analyses; for the
    # jitter signal, of the takes it analyses) was checked by eye, and says what was seen
    must_judge = _list_glitches().must_judge
    assert all(g["inspected"] for g in gl if must_judge(g))
    assert any(g["frames"][0] < 2400 and not g["inspected"] for g in jitter)
    for g in gl:
        assert g["inspected"] == (not g["seen"].startswith("not inspected"))
        assert g["glitch"] or g["inspected"]  # only an inspected event is ever rejected


@pytest.mark.skipif(not CMU.exists(), reason="shared CMU data not present")
def test_the_jitter_verdicts_cover_the_takes_the_evaluation_analyses() -> None:
    """EVAL_TAKES (whose jitter events were judged by eye) are the CMU takes bench/eval_clean.py
    chooses with its defaults."""
    mod = _eval_clean()
    chosen = []
    for files in mod.classes("cmu").values():
        chosen += mod.choose_takes(files, 4, 20.0)[1]
    assert tuple(Path(f).stem for f in chosen) == _list_glitches().EVAL_TAKES


@pytest.mark.skipif(not CMU.exists(), reason="shared CMU data not present")
def test_glitch_signal_reproduces_the_list_on_a_short_take() -> None:
    from mocapkit.io import read_motion

    mod = _eval_clean()
    step = _signals(json.loads(FIXTURE.read_text()))[0]
    for take in ("03_01", "03_02"):
        found = mod.find_glitches(read_motion(CMU / "03" / f"{take}.amc"))
        listed = [g for g in step if g["take"] == take]
        assert [(g["joint"], g["frames"]) for g in found] == [
            (g["joint"], g["frames"]) for g in listed
        ]


@pytest.mark.skipif(not CMU.exists(), reason="shared CMU data not present")
@pytest.mark.parametrize("signal", ["excursion", "hold", "jitter"])
def test_each_later_signal_reproduces_its_entries_on_the_short_takes(signal: str) -> None:
    """bench/list_glitches.py run again on the two short walking takes lists exactly their
    entries of that signal (same frames, same measure, verdicts carried over)."""
    lg = _list_glitches()
    doc = json.loads(FIXTURE.read_text())
    takes = ("03_01", "03_02")
    found = lg.signal_entries(doc, [str(CMU / "03" / f"{t}.amc") for t in takes], signal)
    listed = [g for g in doc["glitches"] if g.get("signal") == signal and g["take"] in takes]
    assert listed and found == listed
    if signal == "hold":  # 03_02 opens without data: every joint that rotates held 0-49
        assert sum(g["frames"] == [0, 49] for g in listed) >= 20
        assert all(g["take"] == "03_02" for g in listed)


def test_find_excursions_finds_a_pop_and_not_a_smooth_swing() -> None:
    from mocapkit.core import rotations as rot
    from mocapkit.core.motion import Motion
    from mocapkit.core.skeleton import Skeleton

    mod = _eval_clean()
    fps, n = 120.0, 480
    t = np.arange(n) / fps
    # joint 1: slow natural sway plus a 15-degree pop for 3 frames (200-202); joint 2: a smooth
    # 40-degree swing out and back over 0.5 s (raised cosine, 2 Hz); joint 3: a smooth 40-degree
    # swing one way over 0.5 s
    a1 = np.radians(5.0) * np.sin(2 * np.pi * 0.5 * t)
    a1[200:203] += np.radians(15.0)
    a2 = np.zeros(n)
    s = (t >= 1.0) & (t < 1.5)
    a2[s] = np.radians(20.0) * (1 - np.cos(2 * np.pi * (t[s] - 1.0) / 0.5))
    a3 = np.radians(20.0) * (1 - np.cos(np.pi * np.clip((t - 2.0) / 0.5, 0.0, 1.0)))
    rv = np.zeros((n, 4, 3))
    rv[:, 1, 0] = a1
    rv[:, 2, 2] = a2
    rv[:, 3, 1] = a3
    rx = ("Xrotation", "Yrotation", "Zrotation")
    skel = Skeleton(
        ("root", "pop", "swing", "turn"), np.array([-1, 0, 0, 0]), np.ones((4, 3)), (rx,) * 4
    )
    m = Motion(skel, rot.rotvec_to_quat(rv), np.zeros((n, 3)), 1.0 / fps)
    assert np.degrees(rot.quat_angle(m.rotations[0, 3], m.rotations[-1, 3])) > 39.0
    ev = mod.find_excursions(m)
    assert [(e["joint"], e["frames"]) for e in ev] == [("pop", [200, 202])]
    assert 14.0 < ev[0]["peak_dev_deg"] < 16.0


def test_find_holds_finds_a_dropout_and_not_a_slow_or_fixed_joint() -> None:
    from mocapkit.core import rotations as rot
    from mocapkit.core.motion import Motion
    from mocapkit.core.skeleton import Skeleton

    mod = _eval_clean()
    fps, n = 120.0, 240
    t = np.arange(n) / fps
    rv = np.zeros((n, 4, 3))
    # joint 1: a sway whose values repeat exactly over frames 100-109 (a 10-frame dropout)
    # and over 5 frames at 150-154 (shorter than 50 ms: not listed); joint 2: a very slow
    # sway (0.01 deg per frame: never the same value twice); joint 3: never rotates
    rv[:, 1, 0] = np.radians(10.0) * np.sin(2 * np.pi * t)
    rv[100:110, 1, 0] = rv[100, 1, 0]
    rv[150:155, 1, 0] = rv[150, 1, 0]
    rv[:, 2, 1] = np.radians(0.01) * np.arange(n)
    rx = ("Xrotation", "Yrotation", "Zrotation")
    skel = Skeleton(
        ("root", "drop", "slow", "fixed"), np.array([-1, 0, 0, 0]), np.ones((4, 3)), (rx,) * 4
    )
    m = Motion(skel, rot.rotvec_to_quat(rv), np.zeros((n, 3)), 1.0 / fps)
    assert mod.find_holds(m) == [{"joint": "drop", "frames": [100, 109], "held_frames": 10}]
    # the same hold at 30 fps is 0.33 s: still a hold (the threshold is in seconds)
    slow = Motion(skel, m.rotations, m.root_positions, 1.0 / 30.0)
    assert [e["frames"] for e in mod.find_holds(slow)] == [[100, 109], [150, 154]]


def test_find_jitter_finds_rough_stretches_and_not_fast_smooth_motion() -> None:
    from mocapkit.core import rotations as rot
    from mocapkit.core.motion import Motion
    from mocapkit.core.skeleton import Skeleton

    mod = _eval_clean()
    fps, n = 120.0, 600
    t = np.arange(n) / fps
    rng = np.random.default_rng(3)
    rv = np.zeros((n, 5, 3))
    # joint 1: a slow sway, rough (4 deg noise frame to frame) over frames 200-259 only;
    # joint 2: a fast smooth swing, 90 deg out and back in 0.4 s (2.5 Hz);
    # joint 3: tremor, 0.5 deg at 9 Hz all along; joint 4: a step of 20 deg that stays
    rv[:, 1, 0] = np.radians(10.0) * np.sin(2 * np.pi * 0.5 * t)
    rv[200:260, 1, 1] = np.radians(4.0) * rng.standard_normal(60)
    s = (t >= 2.0) & (t < 2.4)
    rv[s, 2, 2] = np.radians(45.0) * (1 - np.cos(2 * np.pi * (t[s] - 2.0) / 0.4))
    rv[:, 3, 0] = np.radians(0.5) * np.sin(2 * np.pi * 9.0 * t)
    rv[300:, 4, 1] = np.radians(20.0)
    rx = ("Xrotation", "Yrotation", "Zrotation")
    skel = Skeleton(
        ("root", "rough", "swing", "tremor", "step"), np.array([-1, 0, 0, 0, 0]),
        np.ones((5, 3)), (rx,) * 5,
    )  # fmt: skip
    m = Motion(skel, rot.rotvec_to_quat(rv), np.zeros((n, 3)), 1.0 / fps)
    ev = mod.find_jitter(m)
    rough = [e for e in ev if e["joint"] == "rough"]
    assert len(rough) == 1 and rough[0]["peak_rms_deg"] > 2.0
    a, b = rough[0]["frames"]
    assert 190 <= a <= 205 and 254 <= b <= 270  # the rough stretch, give or take the window
    # a one-frame 20-deg step is broadband: it is listed, but only around the step
    assert all(e["joint"] in ("rough", "step") for e in ev)
    steps = [e["frames"] for e in ev if e["joint"] == "step"]
    assert all(a >= 290 and b <= 310 for a, b in steps)
