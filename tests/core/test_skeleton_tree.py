"""Tree walks of a Skeleton: ancestors, subtree, descendants, common ancestor, leaves."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from mocapkit.core.skeleton import Skeleton


def _skeleton(parents: list[int]) -> Skeleton:
    J = len(parents)
    return Skeleton(
        tuple(f"j{j}" for j in range(J)),
        np.array(parents),
        np.arange(J * 3, dtype=float).reshape(J, 3),
        tuple(() for _ in range(J)),
    )


@st.composite
def trees(draw: st.DrawFn) -> list[int]:
    n = draw(st.integers(1, 40))
    return [-1] + [draw(st.integers(0, j - 1)) for j in range(1, n)]


def _walk_up(parents: list[int], j: int) -> list[int]:
    out = []
    while parents[j] >= 0:
        j = parents[j]
        out.append(j)
    return out


@given(trees())
def test_tree_walks_agree_with_a_walk_up_the_parents(parents: list[int]) -> None:
    sk = _skeleton(parents)
    J = len(parents)
    for j in range(J):
        up = _walk_up(parents, j)
        assert sk.ancestors(j) == up
        below = [k for k in range(J) if j in _walk_up(parents, k)]
        assert sk.descendants(j) == below
        assert sk.subtree(j) == [j, *below]
    for a in range(J):
        for b in range(J):
            c = sk.common_ancestor(a, b)
            assert c in [a, *sk.ancestors(a)] and c in [b, *sk.ancestors(b)]
            # nothing lower is shared
            assert not any(
                k in [b, *sk.ancestors(b)] for k in sk.descendants(c) if k in [a, *sk.ancestors(a)]
            )
    assert sk.leaves() == [j for j in range(J) if j not in parents]


def test_deep_chain_walks_without_recursion() -> None:
    sk = _skeleton([-1, *range(4999)])
    assert len(sk.ancestors(4999)) == 4999
    assert len(sk.descendants(0)) == 4999
    assert sk.common_ancestor(4999, 2500) == 2500


def test_rest_positions_sum_offsets_down_the_chain() -> None:
    sk = _skeleton([-1, 0, 1, 0])
    p = sk.rest_positions()
    np.testing.assert_allclose(p[2], sk.offsets[0] + sk.offsets[1] + sk.offsets[2])
    np.testing.assert_allclose(p[3], sk.offsets[0] + sk.offsets[3])
