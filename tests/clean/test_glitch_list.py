"""The blind list of real glitches in the raw CMU takes (tests/clean/fixtures)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

FIXTURE = Path(__file__).parent / "fixtures" / "cmu_glitches.json"
ROOT = Path(__file__).resolve().parents[2]
CMU = ROOT.parent / "shared" / "data" / "cmu-asfamc"


def test_glitch_list_is_well_formed() -> None:
    doc = json.loads(FIXTURE.read_text())
    gl = doc["glitches"]
    assert len(gl) > 100 and "blind" in doc["about"]
    for g in gl:
        assert set(g) >= {"take", "joint", "frames", "peak_step_deg", "inspected", "glitch", "seen"}
        a, b = g["frames"]
        assert 0 <= a <= b and g["peak_step_deg"] > doc["criterion"]["step_deg"]
    inspected = [g for g in gl if g["inspected"]]
    assert len(inspected) == 130 and sum(not g["glitch"] for g in inspected) == 15
    # every event within the first 20 s at 120 fps (what bench/eval_clean.py analyses) was
    # checked by eye, and says what was seen
    assert all(g["inspected"] for g in gl if g["frames"][0] < 2400)
    for g in gl:
        assert g["inspected"] == (not g["seen"].startswith("not inspected"))
        assert g["glitch"] or g["inspected"]  # only an inspected event is ever rejected


@pytest.mark.skipif(not CMU.exists(), reason="shared CMU data not present")
def test_glitch_signal_reproduces_the_list_on_a_short_take() -> None:
    from mocapkit.io import read_motion

    spec = importlib.util.spec_from_file_location("eval_clean", ROOT / "bench" / "eval_clean.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    doc = json.loads(FIXTURE.read_text())
    for take in ("03_01", "03_02"):
        found = mod.find_glitches(read_motion(CMU / "03" / f"{take}.amc"))
        listed = [g for g in doc["glitches"] if g["take"] == take]
        assert [(g["joint"], g["frames"]) for g in found] == [
            (g["joint"], g["frames"]) for g in listed
        ]
