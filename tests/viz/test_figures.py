"""The figures (mocapkit.viz.figures): PNGs of capped size from each capability's result, and
matplotlib is only imported when a figure is drawn."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from mocapkit import datasets
from mocapkit.viz.figures import DPI, MAX_HEIGHT_IN, MAX_WIDTH_IN, short_labels, wrap

pytest.importorskip("matplotlib")


def png_size(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def assert_capped(path) -> None:
    w, h = png_size(path)
    assert w <= MAX_WIDTH_IN * DPI + 1 and h <= MAX_HEIGHT_IN * DPI + 1, (w, h)


def test_mdm_heat_map_of_a_long_many_joint_take_is_capped(tmp_path) -> None:
    from mocapkit.viz.figures.clean import plot_mdm

    rng = np.random.default_rng(0)
    names = [f"mixamorig:Joint{i}" for i in range(90)]
    segs = [{"joint_index": 3, "start": 10, "end": 10}]
    p = plot_mdm(rng.random((20000, 90)), names, segs, tmp_path / "m.png", 120.0, "x " * 100)
    assert_capped(p)


def test_clean_report_and_stitch_and_graph_figures(tmp_path) -> None:
    from mocapkit import clean
    from mocapkit.graph import build_graph, compare_metrics
    from mocapkit.stitch import stitch
    from mocapkit.viz.figures.clean import plot_clean_report
    from mocapkit.viz.figures.graph import plot_cost_comparison
    from mocapkit.viz.figures.stitch import plot_stitch

    walk = datasets.procedural_motion("walk", 4.0, seed=0).motion
    idle = datasets.procedural_motion("idle", 3.0, seed=3).motion
    rep = clean.run(walk, source="walk.bvh")
    assert_capped(plot_clean_report(rep, tmp_path / "c.png"))
    res = stitch(walk, "50:60", idle, up="Y", query_name="walk.bvh", data_names=["idle.bvh"])
    assert_capped(plot_stitch(res, tmp_path / "s.png"))
    g, db, _ = build_graph([walk, idle], paths=["a_walk_1.bvh", "a_idle_1.bvh"], transitions=10)
    cmp = compare_metrics([walk, idle], g, db)
    assert cmp.metrics == ("dynamics", "uniform") and cmp.clip_names == (
        "a_walk_1.bvh",
        "a_idle_1.bvh",
    )
    assert cmp.matrices["dynamics"].shape == (len(cmp.frames), len(cmp.frames))
    assert_capped(plot_cost_comparison(cmp, tmp_path / "g.png", title="t"))


def test_labels_and_titles() -> None:
    assert short_labels(["dataset-1_walk_normal_001", "dataset-1_run_happy_001"]) == [
        "walk_normal",
        "run_happy",
    ]
    assert short_labels(["LeftArm", "LeftLeg"]) == ["LeftArm", "LeftLeg"]
    assert all(len(s) <= 10 for s in short_labels(["a" * 40, "b" * 40], 10))
    assert max(len(line) for line in wrap("word " * 40, 30).splitlines()) <= 30


def test_the_library_and_the_cli_do_not_import_matplotlib() -> None:
    code = (
        "import sys, mocapkit, mocapkit.cli, mocapkit.clean, mocapkit.stitch, mocapkit.graph, "
        "mocapkit.viz; print('matplotlib' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_heat_map_decision_panel_shows_what_the_mdm_alone_does_not_decide(tmp_path) -> None:
    """The decision panel colours a flagged cell by its rule, and marks in pale grey a cell
    whose MDM is above the threshold but that no rule flagged (newcomer report: dark MDM
    without a flag read as a miss); the rest is white."""
    from matplotlib.colors import to_rgb
    from matplotlib.image import imread

    from mocapkit.viz.figures.clean import _UNFLAGGED, plot_mdm
    from mocapkit.viz.reasons import REASON_COLOURS

    F, J = 300, 4
    mdm = np.zeros((F, J))
    mdm[100:200, 1] = 0.9  # above the threshold, not flagged
    mdm[100:200, 2] = 0.9
    dec = np.full((F, J), -1)
    dec[100:200, 2] = 0  # flagged by the first reason
    p = plot_mdm(mdm, ["a", "b", "c", "d"], [{"joint_index": 2, "start": 100, "end": 199,
                 "reasons": ["frozen"]}], tmp_path / "h.png", 30.0, "t", decision=dec,
                 reason_names=["frozen"], threshold=0.5)  # fmt: skip

    def pale(path) -> int:  # pixels of the "not flagged" grey
        img = imread(path)[..., :3].reshape(-1, 3)
        return int((np.abs(img - to_rgb(_UNFLAGGED)).max(axis=1) < 0.01).sum())

    img = imread(p)[..., :3]
    colours = {tuple(np.round(c, 2)) for c in img.reshape(-1, 3)}
    assert any(np.abs(np.array(c) - to_rgb(REASON_COLOURS["frozen"])).max() < 0.02 for c in colours)
    # all below the threshold: the pale block is gone (the MDM's own greys may hold that grey)
    q = plot_mdm(mdm * 0.5, ["a", "b", "c", "d"], [], tmp_path / "g.png", 30.0, "t",
                 threshold=0.5)  # fmt: skip
    assert pale(p) > pale(q) + 2000


def test_heat_map_names_every_rule_of_each_segment(tmp_path, monkeypatch) -> None:
    """A segment flagged by three rules is coloured by the first, and all three are written
    beside it (newcomer: a wrong-way knee read as mdm's alone); past 40 segments none are
    written (they would pile up)."""
    import mocapkit.viz.figures.clean as fc

    seen: list[list[str]] = []
    real = fc.save

    def keep(fig, path):
        seen.append([t.get_text() for ax in fig.axes for t in ax.texts])
        sides.append([t.get_horizontalalignment() for ax in fig.axes for t in ax.texts])
        return real(fig, path)

    sides: list[list[str]] = []

    monkeypatch.setattr(fc, "save", keep)
    F, J = 300, 4
    why = ["mdm", "cancelling-jumps", "wrong-way-hinge"]
    seg = {"joint_index": 2, "start": 100, "end": 119, "reasons": why}
    fc.plot_mdm(np.zeros((F, J)), list("abcd"), [seg], tmp_path / "a.png", 30.0, "t")
    assert seen[-1] == ["mdm + cancelling-jumps + wrong-way-hinge"]
    # two segments close on one row: each label on the side with room, never over the other
    near = dict(seg, start=124, end=129, reasons=["frozen"])
    fc.plot_mdm(np.zeros((F, J)), list("abcd"), [seg, near], tmp_path / "c.png", 30.0, "t")
    assert sorted(zip(seen[-1], sides[-1], strict=True)) == [
        ("frozen", "left"), ("mdm + cancelling-jumps + wrong-way-hinge", "right")
    ]
    # a gap that holds one label, not two: the first label placed there takes it (reviewer)
    three = [dict(seg, start=100, end=119, reasons=["mdm"]),
             dict(seg, start=130, end=135, reasons=["mdm"]),
             dict(seg, start=137, end=140, reasons=["spike"])]  # fmt: skip
    fc.plot_mdm(np.zeros((F, J)), list("abcd"), three, tmp_path / "d.png", 30.0, "t")
    assert sorted(zip(seen[-1], sides[-1], strict=True)) == [("mdm", "left"), ("spike", "left")]
    many = [dict(seg, start=s, end=s + 2) for s in range(0, 287, 7)]
    assert len(many) > 40
    fc.plot_mdm(np.zeros((F, J)), list("abcd"), many, tmp_path / "b.png", 30.0, "t")
    assert seen[-1] == []
