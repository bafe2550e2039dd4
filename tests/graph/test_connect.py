"""The default build connects the library: per-bucket reduction, clip ends, bridges, overlaps,
coverage; and on the shared Bandai data, coverage per class and the duplicate takes."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from mocapkit import datasets
from mocapkit.graph.distance import MinimaReducer, build_database, tiled_local_minima
from mocapkit.graph.graph import COVERAGE_WARNING, MotionGraph, build_graph, load_graph
from mocapkit.graph.select import (
    Candidates,
    blend_slide,
    find_overlaps,
    frame_components,
    on_overlaps,
    select_connected,
)
from mocapkit.graph.skate import transition_skate


@pytest.fixture(scope="module")
def library():
    """Walks, runs, waves and idles of different speeds and seeds: cost scales that differ."""
    kinds = [
        ("walk", 5.5, None), ("walk", 5.0, 1.4), ("run", 5.5, None), ("run", 5.0, 3.5),
        ("wave", 3.0, None), ("idle", 2.5, None), ("wave", 2.0, None), ("walk", 5.5, 0.8),
    ]  # fmt: skip
    return [
        datasets.procedural_motion(k, seconds=s, fps=30, seed=10 + n, speed=v).motion
        for n, (k, s, v) in enumerate(kinds)
    ]


@pytest.fixture(scope="module")
def built(library):
    return build_graph(library, "dynamics", paths=[f"c{k}.bvh" for k in range(len(library))])


def test_default_build_reaches_most_of_the_library(built, library):
    g, db, _ = built
    cov = g.coverage()
    assert cov.fraction >= 0.6, cov.to_json()
    assert cov.clips_reached == len(library)
    assert cov.warning() is None
    sel = g.stats["selection"]
    assert sel["rule"] == "connected" and sel["end"] > 0
    assert set(g.kind.tolist()) <= {"knee", "end", "bridge"}
    assert int((g.kind == "knee").sum()) == sel["knee"]
    # the knee alone (the T cheapest) reaches much less
    knee, _, _ = build_graph(library, transitions=g.T, database=db)
    assert knee.coverage().fraction < cov.fraction
    assert knee.kind is None and knee.stats["selection"]["rule"] == "transitions"


def test_coverage_in_files_and_report(built, library, tmp_path):
    g = built[0]
    p = g.save(tmp_path / "g.json")
    h = load_graph(p)
    assert np.array_equal(h.kind, g.kind)
    rep = h.report(motions=library).to_json()
    c = rep["coverage"]
    assert c["frames"] == sum(m.num_frames for m in library)
    assert len(c["clips"]) == len(library) and c["clips"][0]["path"] == "c0.bvh"
    assert c["frames_in_scc"] == sum(x["frames_in_scc"] for x in c["clips"]) == g.scc_frames()
    assert 0 < c["fraction"] <= 1 and c["warning"] is None
    assert rep["selection"]["rule"] == "connected"
    assert rep["foot_skate_scc"]["transitions"] == int(g.in_scc.sum())
    json.dumps(rep)  # strict JSON
    assert "coverage:" in g.coverage().summary()
    assert h.report(motions=library).coverage_summary() == g.coverage().summary()


def test_warning_when_most_is_unreachable(built, library):
    _, db, _ = built
    few, _, _ = build_graph(library, transitions=3, database=db)
    cov = few.coverage()
    assert cov.fraction < COVERAGE_WARNING
    w = cov.warning()
    assert w is not None and "--transitions" in w and "default" in w
    assert few.report(motions=library).to_json()["coverage"]["warning"] == w


def test_blend_slide_is_the_rendered_skate(built, library):
    g, db, _ = built
    src = db.starts[g.src_clip] + g.src_frame
    dst = db.starts[g.dst_clip] + g.dst_frame
    pred = blend_slide(db, src, dst, g.blend)
    sk = transition_skate(g, library, foot_lock=False)  # the blend itself, before locking
    assert np.array_equal(np.isfinite(pred), sk.supported)
    cm = 100.0  # procedural clips are in metres
    # the prediction blends ankle positions linearly, rendering slerps the joints' rotations:
    # where anchored feet predict no slide at all, the rendered arc leaves a millimetre or two
    np.testing.assert_allclose(pred[sk.supported] * cm, sk.start_to_end[sk.supported],
                               rtol=0.1, atol=0.25)  # fmt: skip
    assert np.median(np.abs(pred[sk.supported] * cm - sk.start_to_end[sk.supported])) < 0.05


def test_frame_components_match_the_graph(built):
    g, db, _ = built
    src = db.starts[g.src_clip] + g.src_frame
    dst = db.starts[g.dst_clip] + g.dst_frame
    lab = frame_components(db, src, dst, g.blend)
    big = np.bincount(lab[lab >= 0]).argmax()
    reached = np.unique(db.clip_of(np.flatnonzero(lab == big)))
    assert reached.tolist() == np.flatnonzero(g.coverage().in_scc > 0).tolist()
    # a transition is in the SCC exactly when both its ends lie on the largest component
    land = np.minimum(dst + g.blend, db.num_frames - 1)
    both = (lab[src] == big) & (lab[land] == big)
    assert np.array_equal(both, g.in_scc)


def test_every_clip_end_gets_a_way_out(built, library):
    g = built[0]
    frames = np.array([m.num_frames for m in library])
    for c in range(len(library)):
        out = g.src_frame[g.src_clip == c]
        inn = g.dst_frame[g.dst_clip == c] + g.blend
        assert len(out) and out.max() >= 0.75 * frames[c], (c, out)
        assert len(inn) and inn.min() <= 0.25 * frames[c], (c, inn)


def test_reducer_is_exact_and_mergeable():
    rng = np.random.default_rng(3)
    starts = np.array([0, 40, 100, 130, 200])
    n = 3000
    pairs = rng.choice(200 * 200, n, replace=False)  # each pair once, as the tiles give them
    i, j = pairs // 200, pairs % 200
    i, j = np.minimum(i, j), np.maximum(i, j)
    c = rng.random(n)

    def reduce(parts):
        r = MinimaReducer(starts, 10, per_bucket=3, max_candidates=50)
        for a, b in parts:
            r.add(i[a:b], j[a:b], c[a:b])
        return r

    whole = reduce([(0, n)]).result()
    merged = reduce([(0, 1000)]).merge(reduce([(1000, 2200)])).merge(reduce([(2200, n)]))
    for x, y in zip(whole, merged.result(), strict=True):
        np.testing.assert_array_equal(x, y)
    # reference: the 50 cheapest, and per bucket of either end its 3 cheapest partner clips
    ci, cj, _ = whole
    got = set(zip(ci.tolist(), cj.tolist(), strict=True))
    want = set(zip(i[np.argsort(c)[:50]].tolist(), j[np.argsort(c)[:50]].tolist(), strict=True))
    clip = np.searchsorted(starts, np.arange(200), side="right") - 1
    bucket = clip * 100 + (np.arange(200) - starts[clip]) // 10
    best: dict[tuple[int, int], tuple[float, int]] = {}
    for end, other in ((i, j), (j, i)):  # a minimum counts for the buckets of both its frames
        for n_ in range(n):
            key = (int(bucket[end[n_]]), int(clip[other[n_]]))
            if key not in best or c[n_] < best[key][0]:
                best[key] = (float(c[n_]), n_)
    per: dict[int, list[tuple[float, int]]] = {}
    for (b, _), v in best.items():
        per.setdefault(b, []).append(v)
    for v in per.values():
        for _, n_ in sorted(v)[:3]:
            want.add((int(i[n_]), int(j[n_])))
    assert got == want


def test_per_bucket_minima_reach_every_clip(library):
    db = build_database(library, "dynamics")
    few = tiled_local_minima(db, 1, 64, np.float64, max_candidates=20, per_bucket=0)
    many = tiled_local_minima(db, 1, 64, np.float64, max_candidates=20)
    assert len(few.cost) == 20
    clips = set(db.clip_of(np.r_[many.i, many.j]).tolist())
    assert clips == set(range(len(library)))
    assert np.all(np.diff(many.cost) >= 0)


def _with_copy(stride_offset: int):
    """A walk, a run, and a copy of part of the walk (frames 21.. of clip 0)."""
    walk = datasets.procedural_motion("walk", 4.0, fps=30, seed=2).motion
    run = datasets.procedural_motion("run", 3.0, fps=30, seed=3).motion
    idle = datasets.procedural_motion("idle", 3.0, fps=30, seed=4).motion
    return [walk, run, walk[20 + stride_offset : 100], idle]


@pytest.mark.parametrize("offset", [0, 1])
def test_duplicate_take_found_and_kept_out(offset):
    clips = _with_copy(offset)
    db = build_database(clips, "dynamics")
    for stride in (1, 2):
        mn = tiled_local_minima(db, stride, 64, np.float64)
        ovs, mask = find_overlaps(db, mn.i, mn.j, mn.cost, stride)
        assert len(ovs) == 1, (stride, ovs)
        o = ovs[0]
        assert (o.clip_a, o.clip_b, o.offset) == (0, 2, -(20 + offset))
        assert o.frames >= 60 and o.rms < 1e-6
        assert mask.any() and not np.any(mn.cost[~mask] < 1e-9)
        ca, cb = db.clip_of(mn.i[mask]), db.clip_of(mn.j[mask])
        off = (mn.j[mask] - db.starts[cb]) - (mn.i[mask] - db.starts[ca])
        assert np.all((ca == 0) & (cb == 2) & (np.abs(off - o.offset) <= stride))
        sel = select_connected(db, mn, db.half)
        ch = sel.chosen
        assert not on_overlaps(db, ch.src, ch.dst, sel.overlaps).any()
        assert np.all(ch.cost > 1e-6)  # no zero-cost jump between the copies
    g, _, _ = build_graph(clips, paths=["a", "b", "copy", "d"], stride=2)
    (ov,) = g.stats["overlaps"]
    assert ov["path_a"] == "a" and ov["path_b"] == "copy" and ov["frames"] >= 60
    assert "duplicate takes: copy frames" in g.coverage().summary()


def test_no_false_overlap_between_different_takes(library):
    db = build_database(library, "dynamics")
    mn = tiled_local_minima(db, 1, 64, np.float64)
    ovs, mask = find_overlaps(db, mn.i, mn.j, mn.cost)
    assert ovs == [] and not mask.any()


def test_explicit_T_unchanged(library, built):
    _, db, _ = built
    g, _, _ = build_graph(library, transitions=12, database=db)
    assert g.num_transitions <= 12 and g.kind is None
    assert np.all(np.diff(g.cost) >= 0)


def test_candidates_merge_keeps_cheapest(built):
    _, db, _ = built
    s = db.starts
    cand = Candidates(
        np.array([s[0] + 20, s[0] + 22, s[0] + 40, s[1] + 20, s[0] + 29]),
        np.array([s[2] + 30, s[2] + 31, s[2] + 30, s[2] + 30, s[2] + 37]),
        np.array([1.0, 0.5, 2.0, 3.0, 0.7]),
    )
    from mocapkit.graph.select import merge_nearby

    m = merge_nearby(db, cand, radius=7)
    assert m.src.tolist() == [s[0] + 22, s[0] + 40, s[1] + 20]


# ------------------------------------------------------------------------------ shared data


def _bandai2(shared_path) -> list[Path]:
    return sorted(shared_path("bandai2/data").glob("*.bvh"))


def _class(p: Path) -> str:
    content = int(json.loads(p.with_suffix(".json").read_text())["content"])
    return "locomotion" if content <= 3 else "gestures"  # cfg/content_label.txt: 0-3 walk/run


@pytest.mark.shared
def test_bandai2_subset_default_build_covers_each_class(shared_path):
    """A fixed subset of ~100 Bandai-2 takes (every 8th of the sorted list, both classes and
    all styles): the default build's component holds >= 60 % of each class's frames (the full
    library's figures: bench/bench_graph.py)."""
    from mocapkit.io import read_motion

    files = _bandai2(shared_path)[3::8]
    assert 90 <= len(files) <= 100
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        motions = [read_motion(f) for f in files]
    g, _, _ = build_graph(motions, paths=[f.name for f in files])
    cov = g.coverage()
    cls = np.array([_class(f) for f in files])
    for c in ("locomotion", "gestures"):
        m = cls == c
        frac = cov.in_scc[m].sum() / cov.frames[m].sum()
        assert frac >= 0.6, (c, frac)
    assert cov.warning() is None
    assert g.stats["overlaps"] == []


@pytest.mark.shared
def test_bandai2_duplicate_take_detected(shared_path):
    """walk-turn-left_normal_033 is byte-identical to frames 35.. of walk-turn-left_normal_029
    (and the same for the right turns, 55..): found, reported, and no transition jumps between
    the copies."""
    from mocapkit.io import read_motion

    d = shared_path("bandai2/data")
    names = [
        "dataset-2_walk-turn-left_normal_029.bvh", "dataset-2_walk-turn-left_normal_033.bvh",
        "dataset-2_walk-turn-right_normal_029.bvh", "dataset-2_walk-turn-right_normal_033.bvh",
        "dataset-2_walk_normal_001.bvh", "dataset-2_run_normal_001.bvh",
    ]  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        motions = [read_motion(d / n) for n in names]
    for stride in (1, 2):
        g, db, _ = build_graph(motions, paths=names, stride=stride)
        ovs = {(o["path_a"], o["path_b"]): o for o in g.stats["overlaps"]}
        left = ovs[(names[0], names[1])]
        right = ovs[(names[2], names[3])]
        assert left["offset"] == -35 and right["offset"] == -55, (left, right)
        assert left["frames"] >= 100 and right["frames"] >= 100
        src = db.starts[g.src_clip] + g.src_frame
        dst = db.starts[g.dst_clip] + g.dst_frame
        from mocapkit.graph.select import Overlap

        objs = [
            Overlap(o["clip_a"], o["clip_b"], *o["a_frames"], *o["b_frames"], o["offset"], 0.0)
            for o in g.stats["overlaps"]
        ]
        assert not on_overlaps(db, src, dst, objs).any()
        assert np.all(g.cost > 1e-6)
        assert g.coverage().fraction >= 0.5


def test_motiongraph_kind_length_checked(built):
    g = built[0]
    with pytest.raises(ValueError, match="kind"):
        MotionGraph(
            g.clips, g.src_clip, g.src_frame, g.dst_clip, g.dst_frame, g.cost,
            half=g.half, blend=g.blend, kind=np.array(["knee"]),
        )  # fmt: skip


def test_tiny_library_builds_with_a_warning():
    """Clips barely longer than the window: no or few candidates, still a graph and a report."""
    clips = [datasets.procedural_motion("walk", 0.5, fps=30, seed=k).motion for k in range(2)]
    g, _, mn = build_graph(clips)
    assert g.num_transitions >= 0 and len(mn.cost) >= 0
    cov = g.coverage()
    assert cov.warning() is not None or cov.fraction >= COVERAGE_WARNING
    empty = MinimaReducer(np.array([0, 10, 30]), 5)
    assert all(len(v) == 0 for v in empty.result())


def test_take_that_repeats_itself():
    """A take holding the same 2 s twice (a copy inside one file) is an overlap of the clip
    with itself, found and kept out at stride 1 and 2."""
    from mocapkit.core.motion import Motion

    w = datasets.procedural_motion("walk", 2.0, fps=30, seed=5).motion
    twice = Motion(
        w.skeleton,
        np.concatenate([w.rotations, w.rotations]),
        np.concatenate([w.root_positions, w.root_positions]),
        w.frame_time,
    )
    run = datasets.procedural_motion("run", 3.0, fps=30, seed=6).motion
    for stride in (1, 2):
        g, _, _ = build_graph([twice, run], stride=stride)
        self_ov = [o for o in g.stats["overlaps"] if o["clip_a"] == o["clip_b"] == 0]
        assert self_ov and abs(self_ov[0]["offset"]) == w.num_frames, g.stats["overlaps"]
        assert np.all(g.cost > 1e-6)


def test_ends_keep_the_least_sliding_frames_they_were_chosen_for(library):
    """Ends are chosen for their slide on the stride grid; moving them to a cheaper frame
    nearby (as the knee's transitions are) could land a foot in toe-off."""
    from mocapkit.graph.select import refine

    g, db, minima = build_graph(library, stride=2)
    assert minima.stride == 2
    end = g.kind == "end"
    assert end.any()
    src = db.starts[g.src_clip[end]] + g.src_frame[end]
    dst = db.starts[g.dst_clip[end]] + g.dst_frame[end]
    chosen = blend_slide(db, src, dst, g.blend)
    moved = refine(db, Candidates(src, dst, g.cost[end]), 2)
    after = blend_slide(db, moved.src, moved.dst, g.blend)
    both = np.isfinite(chosen) & np.isfinite(after)
    # the frames the rule chose, not the cost's local minimum next to them
    assert np.sum(src != moved.src) + np.sum(dst != moved.dst) > 0
    assert np.nansum(chosen[both]) <= np.nansum(after[both]) + 1e-12


@pytest.mark.shared
def test_ten_short_bandai1_runs_connect(shared_path):
    """Ten 1-5 s bandai1 runs (the library where the knee rule found no transition between
    clips): most of it is reachable, and a bridge that slides the feet less than marker noise
    joins a piece whose own transitions do not slide at all."""
    from mocapkit.io import read_motion

    files = sorted(shared_path("bandai1/data").glob("*_run_*.bvh"))[:10]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        motions = [read_motion(f) for f in files]
        g, _, _ = build_graph(motions, paths=[f.name for f in files])
        knee, _, _ = build_graph(motions, transitions=g.T)
    cov = g.coverage()
    assert cov.fraction >= 0.7, cov.summary()  # the knee alone: 14 %
    assert cov.clips_reached >= 7
    assert knee.coverage().fraction < 0.5 * cov.fraction
    # as the metric chose them (no foot locking): no worse than the knee's own transitions
    sk = transition_skate(g, motions, foot_lock=False).subset(g.in_scc)
    ks = transition_skate(knee, motions, foot_lock=False)
    mean = sk.summary()["start_to_end_cm"]["mean"]
    assert mean <= 1.2 * ks.summary()["start_to_end_cm"]["mean"], mean
