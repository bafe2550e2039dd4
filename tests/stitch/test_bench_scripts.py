"""Smoke tests of the stitching scripts in bench/ (small inputs, so that they cannot rot)."""

from __future__ import annotations

import json

import pytest
from testsupport import load_bench

from mocapkit import datasets
from mocapkit.io import write_motion


def test_three_circles_table_and_figures(tmp_path) -> None:
    exp = load_bench("stitch_experiments")
    rows = {r["data"]: r for r in exp.three_circles_experiment(tmp_path)}
    assert rows["forward"]["lstar"] < rows["backward"]["lstar"]
    assert rows["forward"]["k_opt"] < rows["backward"]["k_opt"]
    assert (tmp_path / "three_circles_paths.png").stat().st_size > 1000
    assert (tmp_path / "three_circles_lk.png").stat().st_size > 1000


def test_blank_out_runs_on_a_small_folder(tmp_path, monkeypatch) -> None:
    exp = load_bench("stitch_experiments")
    monkeypatch.setattr(exp, "CLIP_PATTERNS", ("walk_normal",))
    clip = datasets.procedural_motion("walk", 3.0, seed=0, units="cm").motion
    write_motion(clip, tmp_path / "dataset-1_walk_normal_001.bvh")
    cases, clips = exp.blank_out_experiment(tmp_path, 1, tmp_path)
    rows = exp.blank_out_table(cases)
    assert clips == ["dataset-1_walk_normal_001.bvh"]
    assert [r["g"] for r in rows] == [2, 5, 11, 15, 30]
    for r in rows:
        assert 0 <= r["k_opt_min"] <= r["k_opt_max"] <= 30
        assert all(r[f"err_{k}"] >= 0 for k in ("lstar", "kalman_g", "slerp", "linear"))
    assert rows[0]["err_kalman_g"] < rows[0]["err_slerp"]  # g = 2


def test_bench_stitch_small_library(tmp_path, monkeypatch, capsys) -> None:
    bench = load_bench("bench_stitch")
    lib = tmp_path / "lib"
    lib.mkdir()
    for seed, kind in enumerate(("walk", "run", "idle")):
        m = datasets.procedural_motion(kind, 2.0, seed=seed).motion
        write_motion(m, lib / f"{kind}.bvh")
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setenv("MOCAPKIT_SHARED", str(tmp_path / "no_shared"))
    args = ["--frames", "150", "--data", str(lib), "--repeats", "1", "--k-max", "3", "--json"]
    assert bench.main(args) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["library_frames"] == 150 and res["k_max"] == 3
    assert res["pykalman_max_rel_diff"] < 1e-6
    assert res["speedup_vs_pykalman"] > 1


@pytest.mark.parametrize("name", ["bench_stitch", "stitch_experiments"])
def test_scripts_have_usage(name) -> None:
    assert "Usage" in load_bench(name).__doc__
