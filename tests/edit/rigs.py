"""Random rigs and motions for the edit tests (loaded by path, never imported by the library)."""

from __future__ import annotations

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton

SIX = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
THREE = ("Zrotation", "Xrotation", "Yrotation")


def random_motion(rng: np.random.Generator, J: int, F: int, six_every: float = 0.0) -> Motion:
    """A random tree of J joints (parents before children), random offsets, End Sites on the
    leaves, F frames of random rotations and root travel; each non-root joint animates its
    translation with probability ``six_every``."""
    parents = np.array([-1] + [int(rng.integers(0, j)) for j in range(1, J)])
    offsets = rng.normal(size=(J, 3)) * 10
    six = [j == 0 or rng.random() < six_every for j in range(J)]
    channels = tuple(SIX if s else THREE for s in six)
    leaves = [j for j in range(J) if j not in set(parents[1:].tolist())]
    sk = Skeleton(
        tuple(f"j{j}" for j in range(J)),
        parents,
        offsets,
        channels,
        end_site_parents=leaves,
        end_site_offsets=rng.normal(size=(len(leaves), 3)),
    )
    q = rot.quat_normalize(rng.normal(size=(F, J, 4)))
    root = np.cumsum(rng.normal(size=(F, 3)), axis=0)
    tr = None
    if any(six[1:]):
        tr = np.broadcast_to(offsets, (F, J, 3)).copy()
        for j in range(1, J):
            if six[j]:
                tr[:, j] += rng.normal(size=(F, 3))
        tr[:, 0] = root
    return Motion(sk, q, root, 1 / 30, tr)


def _improper(rng: np.random.Generator) -> np.ndarray:
    """A random orthogonal matrix with det -1."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * (-1.0 if np.linalg.det(q) > 0 else 1.0)


def symmetric_motion(
    rng: np.random.Generator, centre: int, limb: int, F: int, frames: str = "random"
) -> tuple[Motion, np.ndarray]:
    """A rig that is its own mirror image across X: a centre chain ``c0..`` and two limbs
    ``Left0..`` / ``Right0..`` hanging from one centre joint. With ``frames="random"`` every
    right joint's local axes differ from its left twin's by a random improper map (as Bandai's
    right bones run along -X), so the rest pose is not symmetric but the rig is. Returns the
    motion (random rotations) and the per-joint mirrors ``B`` the rig was built with."""
    M = np.diag([-1.0, 1.0, 1.0])
    names = [f"c{i}" for i in range(centre)]
    parents = [-1, *range(centre - 1)]
    offsets = [rng.normal(size=3) * 10 for _ in range(centre)]
    offsets[0][0] = 0.0
    for i in range(1, centre):
        offsets[i][0] = 0.0  # the centre line lies on the plane
    hang = int(rng.integers(0, centre))
    lparents = [-1] + [int(rng.integers(0, i)) for i in range(1, limb)]
    loffsets = [rng.normal(size=3) * 10 for _ in range(limb)]
    B = {}  # per left joint (index in the limb): its mirror
    for i in range(limb):
        B[i] = _improper(rng) if frames == "random" else M
    first_left = len(names)
    first_right = first_left + limb
    all_off = list(offsets)
    all_par = list(parents)
    for i in range(limb):
        names.append(f"Left{i}")
        all_par.append(hang if lparents[i] < 0 else first_left + lparents[i])
        all_off.append(loffsets[i])
    for i in range(limb):
        names.append(f"Right{i}")
        all_par.append(hang if lparents[i] < 0 else first_right + lparents[i])
        parent_b = M if lparents[i] < 0 else B[lparents[i]]
        all_off.append(parent_b.T @ loffsets[i])  # o[s(c)] = B[p]^T o[c]
    J = len(names)
    leaves_l = [first_left + i for i in range(limb) if i not in lparents]
    es_par = [*leaves_l, *(x + limb for x in leaves_l)]
    es_l = [rng.normal(size=3) for _ in leaves_l]
    es_off = [*es_l, *(B[x - first_left].T @ o for x, o in zip(leaves_l, es_l, strict=True))]
    sk = Skeleton(
        tuple(names),
        np.array(all_par),
        np.array(all_off),
        (SIX, *([THREE] * (J - 1))),
        end_site_parents=es_par,
        end_site_offsets=np.array(es_off).reshape(-1, 3),
    )
    q = rot.quat_normalize(rng.normal(size=(F, J, 4)))
    root = np.cumsum(rng.normal(size=(F, 3)), axis=0)
    Bs = np.tile(M, (J, 1, 1))
    for i in range(limb):
        Bs[first_left + i] = B[i]
        Bs[first_right + i] = B[i].T
    return Motion(sk, q, root, 1 / 30, None), Bs
