"""`mocapkit stitch` end to end (click's runner) on the procedural humanoid, and the demo step."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from testsupport import load_sibling

from mocapkit import datasets
from mocapkit.cli import main
from mocapkit.cli.stitch_commands import stitch_demo_step
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.io import read_motion, write_motion

with_ground_root = load_sibling(__file__, "motions").with_ground_root


def run(*args: str) -> tuple[int, str, str]:
    res = CliRunner().invoke(main, list(args))
    return res.exit_code, res.stdout, res.stderr


@pytest.fixture(scope="module")
def clips(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("clips")
    out = {}
    for name, kind, seed in (("walk", "walk", 0), ("idle", "idle", 3), ("run", "run", 1)):
        out[name] = write_motion(
            datasets.procedural_motion(kind, 4.0, seed=seed).motion, d / f"{name}.bvh"
        )
    return out


def steps(pos: np.ndarray) -> np.ndarray:
    """Largest joint displacement between consecutive frames (F-1,) of FK positions (F, J, 3)."""
    return np.linalg.norm(np.diff(pos, axis=0), axis=-1).max(axis=1)


def test_stitch_cli_searches_writes_bvh_json_plot_and_is_continuous(clips, tmp_path) -> None:
    out, js, png = tmp_path / "s.bvh", tmp_path / "s.json", tmp_path / "s.png"
    code, stdout, stderr = run(
        "stitch", str(clips["walk"]), str(clips["run"]), str(clips["idle"]),
        "--takeoff", "50:70", "--out", str(out), "--json", str(js), "--plot", str(png),
    )  # fmt: skip
    assert code == 0, stderr
    assert "best:" in stdout
    rep = json.loads(js.read_text())
    for key in ("query", "takeoff", "data", "landing", "k", "lscore", "lscore_by_k",
                "euclidean", "window"):  # fmt: skip
        assert key in rep
    assert rep["query"] == str(clips["walk"]) and rep["window"] == 5
    assert len(rep["lscore_by_k"]) == 31  # k = 0..30: 1 s at 30 fps
    assert rep["lscore"] == pytest.approx(min(rep["lscore_by_k"]))
    assert rep["k"] == int(np.argmin(rep["lscore_by_k"]))
    assert 50 <= rep["takeoff"] < 70
    assert png.stat().st_size > 1000

    query, data = read_motion(clips["walk"]), read_motion(rep["data"])
    stitched = read_motion(out)
    a, k, b = rep["takeoff"], rep["k"], rep["landing"]
    assert stitched.num_frames == a + 1 + k + data.num_frames - b
    assert stitched.skeleton.names == query.skeleton.names
    pos, _ = forward_kinematics(stitched)
    qpos, _ = forward_kinematics(query)
    dpos, _ = forward_kinematics(data)
    np.testing.assert_allclose(pos[: a + 1], qpos[: a + 1], atol=1e-6)
    own = max(steps(qpos).max(), steps(dpos).max())
    seam = steps(pos)[a : a + k + 1]  # take-off → generated → landing
    assert seam.max() <= own * 1.05, (seam.max(), own)
    root_seam = np.linalg.norm(np.diff(stitched.root_positions, axis=0), axis=1)[a : a + k + 1]
    own_root = max(
        np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1).max() for m in (query, data)
    )
    assert root_seam.max() <= own_root * 1.05


def test_stitch_cli_landing_score_method_and_max_inject(clips, tmp_path) -> None:
    js = tmp_path / "l.json"
    code, _, stderr = run(
        "stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", "60", "--landing", "30",
        "--max-inject", "10", "--window", "4", "--json", str(js), "--score", "euclidean",
    )  # fmt: skip
    assert code == 0, stderr
    rep = json.loads(js.read_text())
    assert (rep["takeoff"], rep["landing"], rep["window"]) == (60, 30, 4)
    assert len(rep["lscore_by_k"]) == 11 and rep["score"] == "euclidean"
    for method in ("crossfade", "slerp", "linear"):
        out = tmp_path / f"{method}.bvh"
        code, _, stderr = run(
            "stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", "60",
            "--landing", "30", "--method", method, "--out", str(out),
        )  # fmt: skip
        assert code == 0, stderr
        assert read_motion(out).num_frames > 60


def test_stitch_cli_errors(clips, tmp_path) -> None:
    walk = read_motion(clips["walk"])
    other = write_motion(with_ground_root(walk), tmp_path / "grounded.bvh")
    code, _, err = run("stitch", str(clips["walk"]), str(other), "--takeoff", "50")
    assert code == 2 and "same joint names" in err
    code, _, err = run("stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", "2")
    assert code == 2 and "take-off frame 2" in err
    code, _, err = run("stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", "9:3")
    assert code == 2 and "--takeoff '9:3': reversed range" in err and len(err.splitlines()) == 1
    for bad in ("x", "1:2:3", "99s"):
        code, _, err = run("stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", bad)
        assert code == 2 and "--takeoff" in err and len(err.splitlines()) == 1, err
    code, _, err = run(
        "stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", "50", "--landing", "3:9"
    )
    assert code == 2 and "--landing '3:9': expected one frame" in err
    code, _, err = run(
        "stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", "50", "--landing", "5000"
    )
    assert code == 2 and "landing frame 5000" in err
    code, _, err = run(
        "stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", "50",
        "--out", str(clips["idle"]),
    )  # fmt: skip
    assert code == 2 and "overwrite" in err


def test_demo_step_writes_the_stitch(tmp_path) -> None:
    stitch_demo_step(tmp_path)
    rep = json.loads((tmp_path / "stitch_walk_idle.json").read_text())
    assert rep["k"] > 0
    assert read_motion(tmp_path / "stitch_walk_idle.bvh").num_frames > 100


def test_stitch_cli_reads_frames_and_seconds_alike(clips, tmp_path) -> None:
    """One range syntax: ``--takeoff 60`` = ``2.0s``, ``50:60`` = ``1.6667s:2s`` at 30 fps,
    ``--landing 30`` = ``1.0s``; the results are the same."""
    reps = []
    for takeoff, landing in (("50:60", "30"), ("1.6667s:2s", "1.0s"), ("60", None), ("2.0s", None)):
        js = tmp_path / f"{len(reps)}.json"
        args = ["stitch", str(clips["walk"]), str(clips["idle"]), "--takeoff", takeoff,
                "--max-inject", "8", "--json", str(js)]  # fmt: skip
        if landing is not None:
            args += ["--landing", landing]
        code, _, stderr = run(*args)
        assert code == 0, stderr
        reps.append(json.loads(js.read_text()))
    for a, b in ((0, 1), (2, 3)):
        for key in ("takeoff", "landing", "k", "lscore"):
            assert reps[a][key] == reps[b][key], key
    assert 50 <= reps[0]["takeoff"] < 60 and reps[0]["landing"] == 30
    assert reps[2]["takeoff"] == 60


def test_a_library_folder_holding_the_query_leaves_the_query_out(clips, tmp_path) -> None:
    """The query's own next frames would be its best continuation: a folder that holds it
    searches the other clips; the query alone as DATA (to loop it) is still searched."""
    folder = clips["walk"].parent
    code, so, se = run("stitch", str(clips["walk"]), str(folder), "--takeoff", "40:80",
                       "--json", str(tmp_path / "r.json"))  # fmt: skip
    assert code == 0, so + se
    assert "left out of the library" in se
    r = json.loads((tmp_path / "r.json").read_text())
    assert Path(r["data"]).name != "walk.bvh", r
    code, so, se = run("stitch", str(clips["walk"]), str(clips["walk"]), "--takeoff", "40",
                       "--json", str(tmp_path / "loop.json"))  # fmt: skip
    assert code == 0 and "left out" not in se
