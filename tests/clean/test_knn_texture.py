"""Textures, groups, word layout, local minima and the KNN search."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit import datasets, features
from mocapkit.clean import knn, texture, words
from mocapkit.clean.words import JointGroup
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion

from . import naive


@pytest.fixture(scope="module")
def walk() -> Motion:
    return datasets.procedural_motion("walk", seconds=5.0, seed=2, heading=0.7).motion


def test_word_lengths_scale_with_rate() -> None:
    assert words.word_lengths(24.0) == (15, 5, 20)
    assert words.word_lengths(48.0) == (30, 10, 40)
    starts = words.source_word_starts(50, 15, 5)
    assert starts[0] == 0 and starts[-1] == 35 and np.all(np.diff(starts) <= 5)
    assert words.source_word_starts(10, 15, 5).tolist() == [0]


def test_default_groups_follow_the_body(walk: Motion) -> None:
    sk = walk.skeleton
    groups = {g.name: g for g in texture.default_groups(sk)}
    assert set(groups) == {"body", "upper", "lower", "left", "right"}
    names = lambda g: {sk.names[j] for j in groups[g].joints}  # noqa: E731
    assert groups["body"].trim == 3 and groups["upper"].trim == 1
    assert "LeftLeg" in names("lower") and "LeftLeg" not in names("upper")
    assert "LeftForeArm" in names("upper") and "LeftForeArm" in names("left")
    assert "RightForeArm" not in names("left") and "RightForeArm" in names("right")
    assert "Spine" in names("left") and "Spine" in names("right")  # groups may overlap


def test_texture_removes_heading_and_root_translation(walk: Motion) -> None:
    tex = texture.make_texture(walk, 24.0)
    assert tex.rotations.shape[0] == round(walk.duration * 24)
    assert tex.file_rotations.shape == walk.rotations.shape
    aligned = Motion(walk.skeleton, tex.file_rotations, walk.root_positions, walk.frame_time)
    h = features.heading_angles(aligned)
    assert np.max(np.abs(h)) < 1e-6
    # only the pelvis column changes
    pel = features.pelvis_index(walk.skeleton)
    other = [j for j in range(walk.num_joints) if j != pel]
    assert np.allclose(rot.quat_angle(tex.file_rotations[:, other], walk.rotations[:, other]), 0)
    # turning the whole take about up leaves the texture unchanged
    turn = rot.rotvec_to_quat(np.array([0.0, 1.2, 0.0]))
    q = walk.rotations.copy()
    q[:, 0] = rot.quat_mul(turn, q[:, 0])
    turned = Motion(walk.skeleton, q, walk.root_positions + 3.0, walk.frame_time)
    t2 = texture.make_texture(turned, 24.0)
    assert np.max(rot.quat_angle(t2.rotations, tex.rotations)) < 1e-6


def test_local_minima_and_knn_selection_match_reference() -> None:
    rng = np.random.default_rng(0)
    dist = rng.random((6, 40))
    seg = np.zeros(40, dtype=np.int64)
    centres = np.arange(40)
    lo = np.array([5, 0, 10, 30, 0, 0])
    hi = np.array([12, 3, 20, 40, 0, 0])
    sel = knn.select_knn(dist, seg, centres, 5, lo, hi)
    for w in range(6):
        ref = naive.knn_minima(dist[w], 5, (lo[w], hi[w]))
        got = [c for c in sel[w] if c >= 0]
        assert got == ref
    # segment edges: minima never compare across takes
    d = np.array([[3.0, 1.0, 2.0, 0.5, 4.0]])
    s = np.array([0, 0, 0, 1, 1])
    assert knn.local_minima(d, s).tolist() == [[False, True, False, True, False]]


def test_search_finds_the_other_cycles_of_a_periodic_take() -> None:
    # a joint group rotating periodically (period 24 frames): neighbours lie a whole period away
    F, J = 120, 3
    t = np.arange(F)
    rv = np.zeros((F, J, 3))
    for j in range(J):
        rv[:, j, j % 3] = 0.6 * np.sin(2 * np.pi * t / 24 + j)
    q = texture.texture_from_rotations(rot.rotvec_to_quat(rv))
    ctx = knn.Context.build([q], self_clip=0)
    group = JointGroup("g", (0, 1, 2), 0)
    starts = np.array([24, 48])
    gn = knn.search_group(q, ctx, group, starts, 15, 20, k=3)
    for w, a in enumerate(starts):
        # DTW anchors both words at their first frame: matches start a whole period apart
        off = (gn.index[w] - a) % 24
        assert np.all(np.minimum(off, 24 - off) <= 1)
        assert np.all(np.abs(gn.index[w] - a) >= 12)
        assert np.all(gn.distance[w] < 1e-3)
    assert gn.words.shape == (2, 3, 15, 3, 4)
    assert np.allclose(np.linalg.norm(gn.words, axis=-1), 1.0)


def test_pruned_scan_selects_the_same_neighbours() -> None:
    from mocapkit.clean import dtw

    take = datasets.procedural_motion("walk", seconds=6.0, seed=21).motion
    others = [datasets.procedural_motion(k, seconds=5.0, seed=22).motion for k in ("walk", "run")]
    src = texture.make_texture(take).rotations
    ctx = knn.Context.build(
        [src] + [texture.make_texture(m).rotations for m in others], self_clip=0
    )
    groups = texture.default_groups(take.skeleton)
    P = dtw.pose_distance_matrices(src, ctx.rotations, groups)
    starts = words.source_word_starts(src.shape[0], 15, 5)
    tst = ctx.target_starts(20)
    seg = ctx.clip[tst]
    lo, hi = starts - 7, starts + 22
    for g in range(len(groups)):
        full = dtw.scan_words(P[g], starts, 15, tst, 20, 2)
        pruned, n = dtw.scan_words_pruned(P[g], starts, 15, tst, seg, 20, 5, lo, hi)
        assert n < full.size
        exact = np.isfinite(pruned)
        np.testing.assert_array_equal(pruned[exact], full[exact])
        a = knn.select_knn(pruned, seg, tst + 10, 5, lo, hi)
        b = knn.select_knn(full, seg, tst + 10, 5, lo, hi)
        np.testing.assert_array_equal(a, b)


def test_search_group_matches_the_naive_reference() -> None:
    take = datasets.procedural_motion("walk", seconds=2.0, seed=31).motion
    src = texture.make_texture(take).rotations  # 48 analysis frames
    ctx = knn.Context.build([src], self_clip=0)
    group = JointGroup("g", (1, 2, 5, 6, 7, 13, 14), 1)
    starts = np.array([0, 20])
    for prune in (True, False):
        gn = knn.search_group(src, ctx, group, starts, 15, 20, k=3, prune=prune)
        ref = naive.knn_search(src, src, list(group.joints), 1, [0, 20], 15, 20, 3, 7, 2)
        for w in range(2):
            assert [int(t) for t in gn.index[w] if t >= 0] == ref[w]


def test_untainted_bars_neighbour_frames_on_bad_cells_per_joint() -> None:
    from mocapkit.clean import mdm

    rng = np.random.default_rng(0)
    g = JointGroup("pair", (1, 3))
    W, K, N = 2, 3, 4
    words = rot.quat_normalize(rng.normal(size=(W, K, N, 2, 4)))
    index = np.array([[2, 40, 100], [7, 60, -1]])  # 100, 60: context frames after the take
    gn = knn.GroupNeighbours(g, np.array([0, 5]), index, np.ones((W, K)), words)
    tainted = np.zeros((50, 4), dtype=bool)
    tainted[42, 1] = True  # word frame n of the target at 40 reads frame 40 + 2n (M=7, N=4)
    out = knn.untainted(gn, tainted, target_len=7)
    use = out.usable_mask()
    barred = np.argwhere(~use & gn.usable_mask())
    assert barred.tolist() == [[0, 1, 1, 0]]  # word 0, neighbour 1, frame 1, joint 1
    # the mean word of joint 1 at that frame no longer holds neighbour 1; elsewhere it does
    mw, full = mdm.mean_word(out), mdm.mean_word(gn)
    expect = words[0, [0, 2], 1, 0].sum(axis=0)
    assert np.allclose(mw[0, 1, 0], expect / np.linalg.norm(expect))
    assert np.allclose(mw[0, [0, 2, 3]], full[0, [0, 2, 3]]) and np.allclose(mw[1], full[1])
    # the median word of joint 1 is a neighbour clean on all its frames
    med = mdm.median_word(out)
    assert any(np.allclose(med[0, :, 0], words[0, k, :, 0]) for k in (0, 2))
    # with the whole take tainted only the context's neighbours speak, and a word frame whose
    # neighbours all lie in the take keeps them all
    everything = np.ones((50, 4), dtype=bool)
    use = knn.untainted(gn, everything, 7).usable_mask()
    assert use[:, :, 0, 0].tolist() == [[False, False, True], [False, True, False]]
    inside = knn.GroupNeighbours(
        g, gn.starts, np.array([[2, 30, 9], [7, 20, -1]]), gn.distance, words
    )
    assert np.array_equal(knn.untainted(inside, everything, 7).usable_mask(), inside.usable_mask())


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_warp_word_filter_is_resample_polys_own(dtype):
    """The FIR filter made once per ratio is the one resample_poly designs: the same bits."""
    from scipy.signal import resample_poly

    from mocapkit.clean.knn import _resample_filter

    rng = np.random.default_rng(3)
    for n, p in [(8, 7), (12, 9), (5, 11), (16, 19), (24, 30)]:
        x = rng.normal(size=(p, 3, 4)).astype(dtype)
        ref = resample_poly(x, n, p, axis=0, padtype="line")
        got = resample_poly(x, n, p, axis=0, window=_resample_filter(n, p, x.dtype.str),
                            padtype="line")  # fmt: skip
        assert got.dtype == ref.dtype
        np.testing.assert_array_equal(got, ref)
