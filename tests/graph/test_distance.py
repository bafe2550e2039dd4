"""The aligned windowed cost: closed form vs brute force, tiles vs the per-pair reference."""

from __future__ import annotations

import numpy as np
import pytest
from testsupport import load_sibling

from mocapkit import datasets
from mocapkit.graph.distance import (
    build_database,
    candidate_grid,
    cost_matrix,
    cost_tile,
    pair_alignment,
    pair_costs,
    tiled_local_minima,
    window_weights,
)

naive = load_sibling(__file__, "naive")


@pytest.fixture(scope="module")
def clips():
    a = datasets.procedural_motion("walk", seconds=2.0, fps=30, seed=1).motion
    b = datasets.procedural_motion("run", seconds=1.5, fps=30, seed=2, heading=0.7).motion
    c = datasets.procedural_motion("wave", seconds=1.0, fps=30, seed=3).motion
    return [a, b, c]


@pytest.fixture(scope="module", params=["dynamics", "uniform", "torso"])
def db(request, clips):
    return build_database(clips, metric=request.param, window=0.3)


def test_window_weights():
    w = window_weights(3)
    assert w.shape == (7,) and np.isclose(w.sum(), 1.0)
    assert np.argmax(w) == 3 and np.all(np.diff(w[:4]) > 0) and np.allclose(w, w[::-1])
    with pytest.raises(ValueError):
        window_weights(-1)


def test_closed_form_equals_brute_force_theta(db):
    rng = np.random.default_rng(0)
    ok = np.flatnonzero(db.valid_centres())
    for _ in range(3):
        i, j = rng.choice(ok, 2)
        ref = naive.brute_force_theta(db, i, j)
        got = pair_costs(db, np.array([i]), np.array([j]))[0]
        assert got <= ref + 1e-9 * max(1.0, ref)
        assert got == pytest.approx(ref, rel=1e-6, abs=1e-9)


def test_pair_costs_equal_reference(db):
    rng = np.random.default_rng(1)
    ok = np.flatnonzero(db.valid_centres())
    i = rng.choice(ok, 25)
    j = rng.choice(ok, 25)
    got = pair_costs(db, i, j)
    ref = np.array([naive.window_cost(db, a, b) for a, b in zip(i, j, strict=True)])
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-12)


def test_tile_equals_reference(db):
    ok = np.flatnonzero(db.valid_centres())
    rows = ok[::7]
    cols = ok[3::5]
    t64 = cost_tile(db, rows, cols, dtype=np.float64)
    ref = np.array([[naive.window_cost(db, a, b) for b in cols] for a in rows])
    np.testing.assert_allclose(t64, ref, rtol=1e-9, atol=1e-10)
    t32 = cost_tile(db, rows, cols, dtype=np.float32)
    scale = ref.max()
    assert np.max(np.abs(t32 - ref)) < 2e-4 * scale


def test_tile_invalid_centres_are_inf(db):
    t = cost_tile(db, np.array([0, db.half]), np.array([db.half, 1]))
    assert np.isinf(t[0]).all() and np.isinf(t[:, 1]).all() and np.isfinite(t[1, 0])


def test_cost_symmetric_and_zero_on_diagonal(db):
    m = cost_matrix(db)
    fin = np.isfinite(m)
    np.testing.assert_allclose(m[fin], m.T[fin], rtol=1e-7, atol=1e-7 * m[fin].max())
    d = np.diag(m)[np.isfinite(np.diag(m))]
    assert np.all(d < 1e-6 * m[fin].max())


def test_alignment_invariance(clips):
    from mocapkit.features import GroundTransform, apply_ground_transform

    moved = apply_ground_transform(clips[1], GroundTransform(1.1, np.array([3.0, 0.0, -2.0])))
    d1 = build_database([clips[0], clips[1]], "dynamics", 0.3)
    d2 = build_database([clips[0], moved], "dynamics", 0.3)
    ok = np.flatnonzero(d1.valid_centres())
    i = ok[ok < d1.starts[1]][::9]
    j = ok[ok >= d1.starts[1]][::9]
    n = min(len(i), len(j))
    np.testing.assert_allclose(
        pair_costs(d1, i[:n], j[:n]), pair_costs(d2, i[:n], j[:n]), rtol=1e-7, atol=1e-9
    )
    # the recovered alignment moves clip 2 back onto itself
    theta, t = pair_alignment(d2, int(j[0]), int(j[0]))
    assert abs(theta) < 1e-7 and np.allclose(t, 0, atol=1e-7)


def test_tiled_minima_match_dense(db):
    m = cost_matrix(db)
    res = tiled_local_minima(db, stride=1, tile=16, dtype=np.float64)
    grid = candidate_grid(db, 1)
    G = len(grid)
    full = np.full((G, G), np.inf)
    v = grid >= 0
    full[np.ix_(v, v)] = m[np.ix_(grid[v], grid[v])]
    gi, gj = np.nonzero(naive.local_minima(full))
    fi, fj = grid[gi + 1], grid[gj + 1]
    clip = db.clip_of
    keep = (fj > fi) & ~((clip(fi) == clip(fj)) & (np.abs(fj - fi) < 2 * db.half + 1))
    dense = set(zip(fi[keep].tolist(), fj[keep].tolist(), strict=True))
    tiled = set(zip(res.i.tolist(), res.j.tolist(), strict=True))
    assert dense == tiled
    np.testing.assert_allclose(res.cost, pair_costs(db, res.i, res.j), rtol=1e-8, atol=1e-9)
    assert np.all(np.diff(res.cost) >= 0)


def test_stride_grid_costs_exact(db):
    res = tiled_local_minima(db, stride=3, tile=32, dtype=np.float64)
    assert res.stride == 3 and len(res.i) > 0
    np.testing.assert_allclose(res.cost, pair_costs(db, res.i, res.j), rtol=1e-8, atol=1e-9)


def test_bad_input(clips, db):
    with pytest.raises(ValueError, match="metric"):
        build_database(clips, metric="nope")
    with pytest.raises(ValueError, match="valid window centre"):
        pair_costs(db, np.array([0]), np.array([db.half]))
    with pytest.raises(ValueError, match="frame rate"):
        build_database([clips[0], datasets.procedural_motion("walk", 1.0, fps=60).motion])
