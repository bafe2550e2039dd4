"""--inject K: exactly K generated frames, for every method, at k = 0 too."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from mocapkit import datasets
from mocapkit.cli import main
from mocapkit.io import read_motion, write_bvh
from mocapkit.stitch import METHODS, stitch


@pytest.fixture(scope="module")
def clips():
    walk = datasets.procedural_motion("walk", seconds=4.0, seed=1).motion
    run = datasets.procedural_motion("run", seconds=4.0, seed=2).motion
    return walk, run


@pytest.mark.parametrize("method", ["kalman", "slerp", "linear"])
@pytest.mark.parametrize("k", [0, 7])
def test_inject_gives_exactly_k_frames(clips, method, k) -> None:
    walk, run = clips
    res = stitch(walk, "40:60", [run], method=method, inject=k)
    assert res.transition.k == k
    assert res.k == k
    a, b = res.transition.takeoff, res.transition.landing
    assert res.generated.start == a + 1
    if k == 0 and method == "kalman":  # no frame generated: the cut's landing frames eased
        eased = res.generated.stop - res.generated.start  # (and a foot held while planted)
        assert eased >= walk.seconds_to_frames(0.25)
        assert res.landing_index == a + 1 + eased and res.landing_played == b + eased
    else:
        assert res.generated.stop - res.generated.start == k
    assert res.motion.num_frames == (a + 1) + k + (run.num_frames - b)
    # the forced k's L-score, on the whole curve up to the usual 1 s: the optimum stays visible
    L = res.transition.lscore_by_k
    assert len(L) == round(walk.fps) + 1 and res.transition.lscore == L[k]


def test_inject_at_a_given_landing_ranks_by_the_forced_k(clips) -> None:
    """With --landing, the clips are ranked by their L-score at the forced k too."""
    walk, run = clips
    idle = datasets.procedural_motion("idle", seconds=4.0, seed=3).motion
    for k in (0, 6, 20):
        res = stitch(walk, 50, [run, idle], landing=10, inject=k)
        by_clip = [stitch(walk, 50, [c], landing=10, inject=k).transition.lscore
                   for c in (run, idle)]  # fmt: skip
        assert res.transition.lscore == min(by_clip)
        assert res.transition.clip == by_clip.index(min(by_clip))


@pytest.mark.parametrize("method", METHODS)
def test_every_method_survives_k_zero(clips, method) -> None:
    walk, run = clips
    res = stitch(walk, 50, [run], landing=10, method=method, inject=0)
    assert res.motion.num_frames > 0


def test_cli_inject(clips, tmp_path) -> None:
    walk, run = clips
    q, d = write_bvh(walk, tmp_path / "walk.bvh"), write_bvh(run, tmp_path / "run.bvh")
    out = tmp_path / "out.bvh"
    r = CliRunner().invoke(
        main,
        [
            "stitch",
            str(q),
            str(tmp_path),
            "--takeoff",
            "40:60",
            "--inject",
            "9",
            "--out",
            str(out),
            "--json",
            str(tmp_path / "r.json"),
        ],
    )
    assert r.exit_code == 0, r.output
    assert d.exists() and out.exists()
    import json

    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["k"] == 9
    m = read_motion(out)
    assert m.num_frames == rep["frames"]
    from mocapkit.provenance import find_provenance

    plan = find_provenance(out)
    assert plan is not None and plan.tool == "stitch" and plan.frames == m.num_frames
    gen = [s for s in plan.segments if s.kind == "generated"]
    assert len(gen) == 1 and gen[0].output_stop - gen[0].output_start == 9
    assert plan.segments[-1].output_stop == m.num_frames
    bad = CliRunner().invoke(main, ["stitch", str(q), str(d), "--takeoff", "40", "--inject", "-1"])
    assert bad.exit_code == 2
    # newcomer report: --inject 500 was taken, and put the hips 5 m up; more than --max-inject
    # (1 s by default) is refused in one line, which says how to force it
    args = ["stitch", str(q), str(d), "--takeoff", "40", "--landing", "10", "--out", str(out)]
    long = CliRunner().invoke(main, [*args, "--inject", "500"])
    assert long.exit_code == 2 and "--max-inject" in long.output
    assert len(long.output.strip().splitlines()) == 1
    forced = CliRunner().invoke(main, [*args, "--inject", "40", "--max-inject", "40"])
    assert forced.exit_code == 0, forced.output


def test_error_quotes_close(clips, tmp_path) -> None:
    walk, run = clips
    q, d = write_bvh(walk, tmp_path / "walk.bvh"), write_bvh(run, tmp_path / "run.bvh")
    r = CliRunner().invoke(main, ["stitch", str(q), str(d), "--takeoff", "80:40"])
    assert r.exit_code == 2
    line = r.output.strip()
    assert line.count("\n") == 0 and "'80:40'" in line and line.count("'") % 2 == 0
