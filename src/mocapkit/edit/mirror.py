"""Mirror a take left/right.

The world is reflected across the **world mirror** ``M_w``: the vertical plane through the
origin spanned by the up axis (the body model's, measured on the poses) and the ground axis
nearer the character's mean facing (:func:`mocapkit.features.facing_directions`), so that the
character keeps facing and travelling the way it did: X -> -X for a character facing Z, Y -> -Y
for one facing X. (A fixed plane turned Z-up characters that face Y round, their travel
reversed.) The mirrored take faces the same axis, so mirroring twice uses the same plane. (A
take facing about 45 deg between the axes gets one plane or the other.)
Each joint ``j`` and its counterpart ``s(j)`` (:func:`mirror_pairs`) trade places, so that,
exactly, ``P'[s(j)] = M_w P[j]`` for every joint position and End Site.

Rigs do not agree on how a right joint's local axes relate to its left twin's (CMU and Mixamo
mirror them across one plane; Bandai's bones run along +X on the left and -X on the right), so
each joint gets its own mirror ``B[j]``, an improper orthogonal matrix (det -1) that takes its
twin's rest offsets to its own: ``B[j] o[s(c)] ~ o[c]`` for its children and End Sites ``c``,
solved by orthogonal Procrustes, leaning on the parent's ``B`` where the offsets leave a twist
open (a chain with one child) and on ``M_w`` at the root; where that leaves each limb's
local rotations half a turn from the rig's own encoding (Bandai), the limb is turned half
round its bones (:func:`_nearest_encoding`: the FK is the same, and blending the mirrored
take with unmirrored ones no longer swings its limbs round); ``B[s(j)] = B[j]^T`` and
``B[j]^2 = I`` for a centre joint, so mirroring a symmetric rig twice gives the take back
exactly (on an asymmetric one the FK comes back exactly and the rotations within ~1e-3 degrees,
since the second fit sees the traded bone lengths). With global rotations
``G'[s(j)] = M_w G[j] B[j]`` the local rotations follow as
``L'[s(j)] = B[p]^T L[j] B[j]`` (``L'[0] = M_w L[0] B[0]`` at the root), and local
translations as ``t'[s(j)] = B[p]^T t[j]``. Since FK multiplies exactly these along each chain,
``P'[s(j)] = M_w P[j]`` holds on any rig. The offsets are set to ``B[p]^T o[j]`` too: on a
symmetric rig that is the skeleton it had, and on one whose left and right bones differ (CMU
subjects) the bone lengths trade sides (:attr:`Mirrored.offset_change` says by how much).
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from mocapkit.body import Body, body_of, split_name
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton
from mocapkit.features import (
    GroundTransform,
    apply_ground_transform,
    facing_directions,
    ground_frame,
)

__all__ = ["Mirrored", "joint_mirrors", "mirror", "mirror_pairs"]


def mirror_pairs(skeleton: Skeleton, body: Body | None = None) -> np.ndarray:
    """(J,) the counterpart of each joint: its mirror twin on the other side, or itself for a
    centre joint. An involution that respects the tree (the twin's parent is the parent's twin).

    Names first: a joint whose name states a side (:func:`mocapkit.body.split_name`) pairs with
    the one joint of the other side with the same side-less name (``LeftHandIndex1`` with
    ``RightHandIndex1``, ``lfemur`` with ``rfemur``). On a rig whose names pair nothing,
    structure: the body model's left and right limbs (:meth:`mocapkit.body.Body.side_of`) are
    walked in parallel from their tops, children matched in joint order (same number of
    children required). Refused (ValueError naming a joint): a sided joint
    without a counterpart, or pairs that do not form mirror-image trees.
    """
    body = body_of(skeleton) if body is None else body
    J = skeleton.num_joints
    twin = np.arange(J)
    paired = np.zeros(J, dtype=bool)
    split = [split_name(n) for n in skeleton.names]
    groups: dict[str, dict[str, list[int]]] = defaultdict(lambda: {"left": [], "right": []})
    for j, (side, base) in enumerate(split):
        if side:
            groups[base][side].append(j)
    for g in groups.values():
        if len(g["left"]) == 1 and len(g["right"]) == 1:
            a, b = g["left"][0], g["right"][0]
            twin[a], twin[b] = b, a
            paired[a] = paired[b] = True

    # Structure, on rigs whose names state no sides: match the left and right limbs' subtrees.
    # (Where names pair joints they are the rig's own convention, and the structural limbs of
    # an unusual rig could cut across it.)
    sides = [body.side_of(j) for j in range(J)]
    by_structure = not paired.any()
    if by_structure:
        if "unknown" in sides:
            raise ValueError(
                "mirror: cannot tell left from right on this rig (no joint name states a side "
                "and the poses tell no forward direction)"
            )
        for name in ("hip", "clavicle", "shoulder"):
            pr = body.pair(name)
            if pr is not None:
                tops = [_limb_top(skeleton, j, sides) for j in pr]
                _pair_subtrees(skeleton, tops[0], tops[1], twin, paired)

    for j in range(J):
        if not paired[j] and (split[j][0] or (by_structure and sides[j] in ("left", "right"))):
            raise ValueError(
                f"mirror: joint {skeleton.names[j]!r} is on one side but has no counterpart "
                "on the other (by name or by the limb's structure)"
            )
    for j in range(1, J):
        t, p = int(twin[j]), int(skeleton.parents[j])
        if twin[t] != j or skeleton.parents[t] != twin[p]:
            raise ValueError(
                f"mirror: {skeleton.names[j]!r} and {skeleton.names[t]!r} pair by name, but their "
                "parents are not each other's counterparts (the two sides are not mirror images)"
            )
    return twin


def _limb_top(sk: Skeleton, j: int, sides: list[str]) -> int:
    """The first joint of ``j``'s side branch (its highest ancestor of the same side)."""
    top = j
    for a in sk.ancestors(j):
        if sides[a] != sides[j]:
            break
        top = a
    return top


def _pair_subtrees(sk: Skeleton, a: int, b: int, twin: np.ndarray, paired: np.ndarray) -> None:
    """Pair ``a`` with ``b`` and their subtrees child by child, where names did not."""
    stack = [(a, b)]
    while stack:
        x, y = stack.pop()
        if paired[x] or paired[y]:
            if twin[x] != y:  # names paired them otherwise: names win
                continue
        else:
            twin[x], twin[y] = y, x
            paired[x] = paired[y] = True
        cx, cy = sk.children(x), sk.children(y)
        if len(cx) == len(cy):
            stack.extend(zip(cx, cy, strict=True))


def _skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _improper_fit(h: np.ndarray, prior: np.ndarray, symmetric: bool) -> np.ndarray:
    """The orthogonal matrix ``B`` with det -1 that maximises ``tr(B^T h)`` (orthogonal
    Procrustes with a reflection), ``h = sum o_c o_s(c)^T``.

    Where ``h`` has rank 2 or more the answer is unique. Where it has rank 1 (one bone, or
    collinear ones) every ``B`` that takes the one direction onto the other fits exactly, and
    the twist about it is the one closest to ``prior`` (the parent's mirror); with rank 0,
    ``prior`` itself. The tie is broken explicitly rather than by a small weight on the prior,
    so the fit is exact and does not depend on noise in the offsets (mirroring twice gives the
    same ``B``). With ``symmetric`` (a centre joint, ``h`` symmetric) ``B`` is symmetric, so
    ``B^2 = I``."""
    u, sv, vt = np.linalg.svd(h)
    if sv[0] <= 1e-300:
        return prior
    if sv[1] > 1e-9 * sv[0]:
        if symmetric:
            lam, q = np.linalg.eigh(0.5 * (h + h.T))
            sgn = np.where(lam >= 0, 1.0, -1.0)
            if np.prod(sgn) > 0:
                sgn[int(np.argmin(np.abs(lam)))] *= -1.0
            return (q * sgn) @ q.T
        d = np.ones(3)
        d[2] = -1.0 if np.linalg.det(u @ vt) > 0 else 1.0
        return (u * d) @ vt
    tgt, src = u[:, 0], vt[0]  # B src = tgt
    if symmetric and src @ tgt < 0:
        # B turns the one direction round: the reflection across the plane normal to it, or
        # the point inversion, whichever is nearer the prior.
        cands = (np.eye(3) - 2.0 * np.outer(tgt, tgt), -np.eye(3))
        return max(cands, key=lambda c: float(np.trace(c.T @ prior)))
    if symmetric:
        # B fixes the one direction and reflects across a plane through it: the plane's normal
        # is the prior's most reflected direction across it.
        q = np.eye(3) - np.outer(tgt, tgt)
        lam, vecs = np.linalg.eigh(q @ (0.5 * (prior + prior.T)) @ q)
        cand = [k for k in np.argsort(lam) if abs(vecs[:, k] @ tgt) < 0.5]
        w = vecs[:, cand[0]]
        return np.eye(3) - 2.0 * np.outer(w, w)
    # A reflection taking src to tgt, then the twist about src that best matches the prior.
    diff = src - tgt
    if np.linalg.norm(diff) > 1e-3:
        w = diff / np.linalg.norm(diff)
    else:  # the same direction to rounding (under 0.06 deg): a reflection through it, one
        # chosen by the direction alone, not by the rounding (whose direction is arbitrary)
        w = np.cross(src, np.eye(3)[int(np.argmin(np.abs(src)))])
        w /= np.linalg.norm(w)
    b0 = np.eye(3) - 2.0 * np.outer(w, w)
    k = b0.T @ prior
    along = np.outer(src, src)
    sin_part, cos_part = np.trace(_skew(src).T @ k), np.trace(k) - src @ k @ src
    if math.hypot(sin_part, cos_part) < 1e-3:
        # the prior is a half turn across the bone from every candidate: it prefers no twist,
        # and following it would let rounding in the offsets pick one (takes of one Bandai rig
        # got leg mirrors 150 deg apart); the plain reflection is the same for every take
        return b0
    phi = np.arctan2(sin_part, cos_part)
    twist = along + np.cos(phi) * (np.eye(3) - along) + np.sin(phi) * _skew(src)
    return b0 @ twist


def joint_mirrors(
    sk: Skeleton, twin: np.ndarray, world: np.ndarray, poses: np.ndarray | None = None
) -> np.ndarray:
    """(J, 3, 3) the per-joint mirrors ``B`` (see the module notes), ``world`` = ``M_w``.

    ``poses``: (J, 3, 3) the take's mean local rotations (:func:`_mean_poses`); with them, a
    joint with one bone below it is turned half round that bone where that brings the
    mirrored take's mean poses nearer the take's own (:func:`_nearest_encoding`)."""
    J = sk.num_joints
    B = np.zeros((J, 3, 3))
    one_bone: dict[int, np.ndarray] = {}  # joint -> its one bone's direction, twin's frame
    follows: set[int] = set()  # joints whose mirror is their parent's (nothing else fits it)
    es_of = [np.flatnonzero(sk.end_site_parents == j) for j in range(J)]
    for j in range(J):
        t = int(twin[j])
        if t < j:
            B[j] = B[t].T
            continue
        p = int(sk.parents[j])
        prior = world if p < 0 else B[p]
        if not sk.has_rotation[j] or not sk.has_rotation[t]:
            # a joint that cannot rotate needs L' = B[p]^T I B[j] = I
            B[j] = prior if p >= 0 else world
            if t != j:
                B[t] = B[j].T
            if p >= 0:
                follows.update((j, t))
            continue
        h = np.zeros((3, 3))
        for c in sk.children(j):
            h = h + np.outer(sk.offsets[c], sk.offsets[int(twin[c])])
        mine, theirs = es_of[j], es_of[t]
        if len(mine) == len(theirs):
            for e, f in zip(mine, theirs, strict=True):
                h = h + np.outer(sk.end_site_offsets[e], sk.end_site_offsets[f])
        B[j] = _improper_fit(h, prior, symmetric=t == j)
        _, sv, vt = np.linalg.svd(h)
        if p >= 0 and sv[0] > 1e-300 and sv[1] <= 1e-9 * sv[0]:
            one_bone[j] = vt[0]
        elif p >= 0 and sv[0] <= 1e-300:  # no offset below it to fit: the prior, its parent's
            follows.update((j, t))
        if t != j:
            B[t] = B[j].T
    if poses is not None and one_bone:
        B = _nearest_encoding(sk, twin, B, one_bone, follows, poses)
    return B


def _nearest_encoding(
    sk: Skeleton,
    twin: np.ndarray,
    B: np.ndarray,
    one_bone: dict[int, np.ndarray],
    follows: set[int],
    poses: np.ndarray,
) -> np.ndarray:
    """``B`` with each chain of one-bone joints (a limb from the joint it hangs from down to
    a joint with two bones or none) kept, or turned half round each of its bones, whichever
    brings the mirrored take's mean local rotations nearer the take's own; a joint whose
    mirror is its parent's (``follows``: nothing below it to fit, or it cannot rotate) still
    is once the parent's has turned.

    Why: FK fixes a one-bone joint's mirror only up to a twist about the bone, and the twist
    decides which local rotations encode the mirrored poses. On a rig whose left bones run
    along +X and right ones along -X (Bandai), the parent's mirror does not decide the twist
    (it is half a turn across the bone from every candidate) or decides it half a turn from
    where the rig keeps its poses: the FK is exact, but the spine, arms and legs of the
    mirrored take are encoded with each elbow and knee bent the other way round, undone by
    the next joint, and whatever blends local rotations with unmirrored takes (a stitch's
    transition, an in-between, an average) swings them round (a Bandai walk stitched to its
    own mirror: the chest turned up to 150 deg a frame). Relies on a limb's mean pose in the
    mirrored take being far nearer its mean in the take than half a turn, which the hinge
    joints decide (an elbow or knee bends the same way on both sides, whatever the take
    does). A rig's left/right conventions differ by sign flips, so only half turns are
    offered, and per limb rather than per joint (a quarter turn, or a joint alone, would
    chase a take's asymmetry, such as one hand waving, rather than the rig's convention).

    A chain hangs from a joint whose mirror the offsets fix, so chains are chosen
    independently; the twins' chains turn with them (``B[s(j)] = B[j]^T``). The cost is the
    sum over joints ``k`` of the squared angle between the mirrored mean pose
    ``B[p(s(k))]^T P[s(k)] B[s(k)]`` and the take's ``P[k]``. Each candidate maps to itself
    under mirroring the mirrored take, so that makes the same choice: twice is still the
    identity."""
    J = sk.num_joints
    parents = sk.parents

    def head(j: int) -> int:
        while int(parents[j]) in one_bone:
            j = int(parents[j])
        return j

    chains: dict[int, list[int]] = {}
    for j in one_bone:
        chains.setdefault(head(j), []).append(j)

    def with_turns(turned: set[int]) -> np.ndarray:
        out = B.copy()
        for j in turned:
            u = one_bone[j]
            out[j] = B[j] @ (2.0 * np.outer(u, u) - np.eye(3))
            if twin[j] != j:
                out[int(twin[j])] = out[j].T
        for j in range(J):  # parents first: a follower takes its parent's final mirror
            if j in follows:
                out[j] = out[int(parents[j])]
        return out

    def cost(b: np.ndarray) -> float:
        total = 0.0
        for k in range(1, J):
            s_k, ps = int(twin[k]), int(parents[twin[k]])
            r = poses[k].T @ b[ps].T @ poses[s_k] @ b[s_k]
            total += float(np.arccos(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))) ** 2
        return total

    turned: set[int] = set()
    for members in chains.values():  # independent: each hangs from a joint the offsets fix
        if cost(with_turns(turned | set(members))) < cost(with_turns(turned)):
            turned |= set(members)
    return with_turns(turned)


@dataclass(frozen=True, eq=False)
class Mirrored:
    """What :func:`mirror` did.

    Attributes:
        motion: the mirrored motion.
        twins: (J,) each joint's counterpart (:func:`mirror_pairs`).
        world_normal: (3,) normal of the world mirror plane ``M_w``.
        joint_mirrors: (J, 3, 3) the per-joint mirrors ``B``.
        offset_change: largest change of a joint offset (file units): 0 on a symmetric rig.
    """

    motion: Motion
    twins: np.ndarray
    world_normal: np.ndarray
    joint_mirrors: np.ndarray
    offset_change: float

    def to_json(self) -> dict[str, object]:
        names = self.motion.skeleton.names
        return {
            "pairs": [[names[j], names[int(t)]] for j, t in enumerate(self.twins) if t > j],
            "world_normal": [float(x) for x in self.world_normal],
            "offset_change": self.offset_change,
        }


def _mean_poses(q: np.ndarray) -> np.ndarray:
    """(J, 3, 3) each joint's mean local rotation over the frames (the principal eigenvector
    of the summed quaternion outer products, which ignores the quaternions' signs)."""
    acc = np.einsum("fji,fjk->jik", q, q)
    _, vecs = np.linalg.eigh(acc)
    return rot.quat_to_matrix(vecs[..., -1])


def mirror(motion: Motion, up: str | None = None) -> Mirrored:
    """The take mirrored left/right (see the module notes for the plane and the formulas).

    ``up`` overrides the body model's up axis. Mirroring twice gives the take back.
    """
    sk = motion.skeleton
    body = body_of(motion)
    twin = mirror_pairs(sk, body)
    up = up or body.up
    side, _, fwd = ground_frame(up)
    n_w = np.abs(side)  # the sign of a normal does not matter
    M_w = np.eye(3) - 2.0 * np.outer(n_w, n_w)
    B = joint_mirrors(sk, twin, M_w, _mean_poses(motion.rotations) if motion.num_frames else None)
    # -B is a proper rotation (det(-B) = -det B = 1 in 3-D), and B^T R B' = (-B)^T R (-B').
    qb = rot.matrix_to_quat(-B)
    parents = sk.parents
    src = motion.rotations[:, twin]  # L[j] feeding joint s(j): row k holds L[s(k)]
    # Joint k = s(j) gets B[p]^T L[j] B[j] with p = parent(j); s(parent(j)) = parent(k).
    pj = parents[twin]
    q_left = np.where((pj >= 0)[:, None], rot.quat_conj(qb[np.maximum(pj, 0)]), 0.0)
    rots = rot.quat_mul(rot.quat_mul(q_left, src), qb[twin])
    # Root: M_w L B[0] = (-M_w) L (-B[0]), -M_w being the half turn about n_w.
    half_turn = np.array([0.0, *n_w])
    rots[:, 0] = rot.quat_mul(rot.quat_mul(half_turn, motion.rotations[:, 0]), qb[0])
    rots = rot.quat_normalize(rots)
    root = motion.root_positions @ M_w.T
    # t'[s(j)] = B[p]^T t[j]: row k = s(j) takes t[j] @ B[p] (row vectors).
    Bp = B[np.maximum(pj, 0)]
    offsets = np.einsum("ki,kij->kj", sk.offsets[twin], Bp)
    offsets[0] = M_w @ sk.offsets[0]
    translations = None
    if motion.translations is not None:
        translations = np.einsum("fki,kij->fkj", motion.translations[:, twin], Bp)
        translations[:, 0] = root
    es_off = sk.end_site_offsets.copy()
    for j in range(sk.num_joints):
        mine = np.flatnonzero(sk.end_site_parents == j)
        theirs = np.flatnonzero(sk.end_site_parents == twin[j])
        src_es = theirs if len(mine) == len(theirs) else mine
        # End Site of s(j) = k-th of joint j mirrored: B[j]^T o, with B[twin]^T = B[j] here.
        es_off[mine] = sk.end_site_offsets[src_es] @ B[int(twin[j])]
    new_sk = Skeleton(
        sk.names,
        sk.parents,
        offsets,
        sk.channels,
        sk.end_site_parents,
        es_off,
        sk.end_site_names,
        sk.metres_per_unit,
    )
    diffs = [np.abs(offsets - sk.offsets).max(initial=0.0)]
    if len(es_off):
        diffs.append(np.abs(es_off - sk.end_site_offsets).max(initial=0.0))
    out = Motion(new_sk, rots, root, motion.frame_time, translations)
    if motion.num_frames:
        facing = facing_directions(motion, up).mean(axis=0)
        # a margin: at a tie (facing 45 deg) the mirrored take, whose facing is reflected,
        # must choose the same plane, or mirroring twice is not the identity
        if abs(facing @ side) > abs(facing @ fwd) + 1e-9:
            # a character facing the side axis: the plane holding it is the other one, whose
            # mirror is this one's followed by a half turn about up (they commute: twice is
            # still the identity, and the rig's joint mirrors B are the same)
            out = apply_ground_transform(out, GroundTransform(np.pi, np.zeros(3), up))
            n_w = np.abs(fwd)
    return Mirrored(out, twin, n_w, B, float(max(diffs)))
