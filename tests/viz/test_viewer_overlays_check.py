"""An overlay file must be what its option says."""

from __future__ import annotations

import json

import pytest

from mocapkit.viz.viewer import read_overlay_json


def test_an_inbetweening_result_is_not_a_stitch_result(tmp_path) -> None:
    """Given as --stitch, an in-betweening result drew 'take-off 0, injected frames 1-0':
    it is refused in one line that says what it is and where its overlay comes from."""
    inb = tmp_path / "fill.json"
    inb.write_text(json.dumps({"gap": [60, 90], "blended_from": [], "method": "library"}))
    with pytest.raises(ValueError, match=r"not a stitch result \(no takeoff, landing, k\).*"
                       r"in-betweening result"):  # fmt: skip
        read_overlay_json(inb, "stitch result")
    ok = tmp_path / "stitch.json"
    ok.write_text(json.dumps({"takeoff": 40, "landing": 12, "k": 5}))
    assert read_overlay_json(ok, "stitch result")["k"] == 5
    assert read_overlay_json(inb, "motion graph")["gap"] == [60, 90]  # no keys asked there
