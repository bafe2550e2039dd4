"""Inverse kinematics on joint chains, vectorised over frames, and foot locking built on it.

One IK module below the capabilities: cleaning (foot locking over detected contacts) and
retargeting (planted feet stay planted) both call it.

The solver is damped least squares (DLS) on the chain's joint rotations. Per frame and iteration:
forward kinematics; the Jacobian of every effector position with respect to a small world-axis
rotation of every chain joint above it (3 columns per ball joint, 1 per hinge: the knee turns
about its own hinge axis only, so the leg keeps its plane and the knee cannot twist); the step
``d = J^T (J J^T + lambda^2 I)^-1 e``; the step applied top-down as rotations of the chain's
segments. Starting from the input pose with a damped step, the result stays close to the input
(the minimum-norm change that reaches the targets). Hinges never extend past straight (or past
the input's own extension where the input already does), so knees do not bend backwards.

Frames whose targets all carry zero weight are not touched at all (bit-for-bit).

Conventions: positions in file units inside, lengths in the API in metres (converted with the
body's ``metres_per_unit``), durations in seconds. Quaternions w, x, y, z.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mocapkit.body import Body, body_of
from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import fk_arrays, forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.core.runs import true_runs
from mocapkit.features import FootContacts, foot_contacts, ground_frame

__all__ = [
    "Chain",
    "FootLock",
    "FootLockConfig",
    "IKConfig",
    "IKResult",
    "flexion_angles",
    "hinge_axis",
    "leg_chains",
    "lock_feet",
    "lock_targets",
    "solve",
]


@dataclass(frozen=True)
class IKConfig:
    """Tunables of the DLS solver (lengths in metres)."""

    #: DLS converges from a nearby input pose in < 10 iterations on a leg; 30 leaves margin
    #: for the far targets a retargeted leg of other proportions can have.
    iterations: int = 30
    #: Damping lambda (metres): near a straight leg (a singular Jacobian) steps stay bounded;
    #: 1 cm is small beside a leg (~0.9 m), so reachable targets are still met closely.
    damping: float = 0.01
    #: A frame stops iterating once every effector is this close (metres): far below capture
    #: noise (~1 mm).
    tolerance: float = 1e-4
    #: The largest rotation one iteration applies to one joint (degrees): keeps the linear
    #: model valid so the iteration does not overshoot into a flipped knee.
    max_step: float = 20.0
    #: Hinges (knees) do not extend past straight by more than this (degrees), unless the input
    #: already did at that frame: knees and elbows do not bend backwards.
    hinge_min_flexion: float = 0.0


@dataclass(frozen=True)
class Chain:
    """A chain of joints the solver may rotate, top to bottom, each the parent of the next
    (hip, knee, ankle), and the effectors it moves (ankle, toe: joints at or below its end).

    ``hinges`` are joints of ``joints`` that turn about one axis only; ``hinge_axes`` (one row
    each) is that axis in the frame of the hinge's parent joint (the thigh for a knee), signed
    so that positive rotation flexes.
    """

    joints: tuple[int, ...]
    effectors: tuple[int, ...]
    hinges: tuple[int, ...] = ()
    hinge_axes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        ax = np.asarray(self.hinge_axes, dtype=np.float64).reshape(-1, 3)
        if len(ax) != len(self.hinges):
            raise ValueError("one hinge axis per hinge joint")
        if any(h not in self.joints or h == self.joints[0] for h in self.hinges):
            raise ValueError("hinges must be chain joints below the chain's first joint")
        object.__setattr__(self, "hinge_axes", ax)


@dataclass(frozen=True, eq=False)
class IKResult:
    """What :func:`solve` returns.

    Attributes:
        motion: the edited motion (only the chains' local rotations differ).
        residual: (F, E) distance from each effector to its target after solving (file units;
            0 on frames not solved).
        solved: (F,) bool, the frames the solver touched.
        iterations: iterations run.
    """

    motion: Motion
    residual: np.ndarray
    solved: np.ndarray
    iterations: int


# =============================================================================================
# geometry helpers


def _skew_cross_cols(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) matrix M with ``M @ d == d x r`` (a rotation d about a point moves a point at
    offset r by d x r)."""
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    zero = np.zeros_like(x)
    # d x r = -(r x d) = -[r]x d
    return -np.stack(
        [
            np.stack([zero, -z, y], -1),
            np.stack([z, zero, -x], -1),
            np.stack([-y, x, zero], -1),
        ],
        -2,
    )


def flexion_angles(
    pos: np.ndarray, grot: np.ndarray, parent: int, hinge: int, child: int, axis_local: np.ndarray
) -> np.ndarray:
    """(F,) signed flexion (radians) of the hinge ``hinge`` between the bones parent->hinge and
    hinge->child about ``axis_local`` (in ``parent``'s frame): 0 straight, positive flexed,
    negative bent the wrong way."""
    u = pos[:, hinge] - pos[:, parent]
    v = pos[:, child] - pos[:, hinge]
    a = rot.quat_apply(grot[:, parent], np.broadcast_to(axis_local, u.shape))
    s = np.einsum("fi,fi->f", np.cross(u, v), a)
    c = np.einsum("fi,fi->f", u, v)
    return np.arctan2(s, c)


def hinge_axis(
    pos: np.ndarray,
    grot: np.ndarray,
    parent: int,
    hinge: int,
    child: int,
    fallback: np.ndarray | None = None,
    min_bend: float = math.radians(15.0),
) -> np.ndarray:
    """The hinge's flexion axis in ``parent``'s frame (unit (3,)), estimated from the poses: the
    mean of ``(parent->hinge) x (hinge->child)`` over frames bent at least ``min_bend`` radians,
    each expressed in the parent's frame. Relies on a knee or elbow bending one way in almost
    every bent frame of a take (the majority direction is the natural one). Without bent frames:
    ``fallback`` (a world axis of the first frame, e.g. the body's left-right axis), else x."""
    u = pos[:, hinge] - pos[:, parent]
    v = pos[:, child] - pos[:, hinge]
    n = np.cross(u, v)
    nu = np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1)
    sin = np.linalg.norm(n, axis=-1) / np.maximum(nu, 1e-12)
    bent = sin > math.sin(min_bend)
    if bent.sum() >= 1:
        loc = rot.quat_apply(rot.quat_inv(grot[bent, parent]), n[bent] / nu[bent, None])
        m = loc.sum(axis=0)
        if np.linalg.norm(m) > 1e-9:
            return m / np.linalg.norm(m)
    if fallback is not None and len(pos):
        f = rot.quat_apply(rot.quat_inv(grot[0, parent]), np.asarray(fallback, dtype=float))
        if np.linalg.norm(f) > 1e-9:
            return f / np.linalg.norm(f)
    return np.array([1.0, 0.0, 0.0])


def leg_chains(
    motion: Motion, body: Body | None = None, reference: Motion | None = None
) -> list[Chain]:
    """Per leg with hip, knee and ankle: the chain hip -> knee -> ankle, the knee a hinge
    (axis from :func:`hinge_axis` on ``reference``'s poses, default ``motion``), effectors the
    ankle and, where the rig has one, the toe. Left leg first."""
    body = body or body_of(motion)
    ref = motion if reference is None else reference
    pos, grot = forward_kinematics(ref)
    left_axis = None
    pair = body.pair("hip")
    if pair is not None and len(pos):
        left_axis = pos[0, pair[0]] - pos[0, pair[1]]
    out: list[Chain] = []
    for side in ("left", "right", "unknown"):
        hip, knee, ankle = (body.joint(f"{side}_{k}") for k in ("hip", "knee", "ankle"))
        if hip is None or knee is None or ankle is None:
            continue
        if side == "unknown" and any(c.joints[0] == hip for c in out):
            continue
        sk = motion.skeleton
        if sk.parents[ankle] != knee or sk.parents[knee] != hip:
            continue  # a twist bone in between: not a plain leg chain (left alone)
        toe = body.joint(f"{side}_toe")
        if toe is not None and ankle not in sk.ancestors(toe):
            toe = None
        effectors = (ankle,) if toe is None or toe == ankle else (ankle, toe)
        axis = hinge_axis(pos, grot, hip, knee, ankle, fallback=left_axis)
        out.append(Chain((hip, knee, ankle), effectors, (knee,), axis[None]))
    return out


def legs_and_feet(motion: Motion, body: Body | None = None) -> tuple[list[Chain], list[int]]:
    """:func:`leg_chains` and their effectors in chain order: ``([], [])`` on a rig with no leg
    the solver can turn (what every foot-holding caller checks first)."""
    try:
        chains = list(leg_chains(motion, body))
    except ValueError:  # no legs to hold
        return [], []
    return chains, [e for c in chains for e in c.effectors]


# =============================================================================================
# the solver


def _prepare(chains: Sequence[Chain], parents: np.ndarray) -> list[dict]:
    """Per chain: joint list, DOF slices, which effector each joint moves (ancestry)."""
    plan = []
    col = 0
    row = 0
    for c in chains:
        for a, b in zip(c.joints[:-1], c.joints[1:], strict=True):
            if parents[b] != a:
                raise ValueError("each chain joint must be the parent of the next")
        cols = []
        for j in c.joints:
            n = 1 if j in c.hinges else 3
            cols.append((col, n))
            col += n
        moves = np.zeros((len(c.joints), len(c.effectors)), dtype=bool)
        for e_i, e in enumerate(c.effectors):
            anc = set()
            k = e
            while k >= 0:
                anc.add(k)
                k = int(parents[k])
            if c.joints[-1] not in anc:
                raise ValueError("effectors must lie at or below the chain's last joint")
            for j_i, j in enumerate(c.joints):
                moves[j_i, e_i] = j in anc and j != e
        hinge_ax = {h: c.hinge_axes[i] for i, h in enumerate(c.hinges)}
        plan.append({"chain": c, "cols": cols, "rows": row, "moves": moves, "hinge": hinge_ax})
        row += len(c.effectors)
    return plan


def _hinge_flex(gpos, grot, parents, j, ax_local, child):
    """Signed flexion of hinge j about its parent-frame axis (vectorised over frames)."""
    p = int(parents[j])
    u = gpos[:, j] - gpos[:, p]
    v = gpos[:, child] - gpos[:, j]
    a = rot.quat_apply(grot[:, p], np.broadcast_to(ax_local, u.shape))
    return np.arctan2(np.einsum("fi,fi->f", np.cross(u, v), a), np.einsum("fi,fi->f", u, v)), a


def _independent_groups(parents: np.ndarray, plan: list[dict]) -> list[tuple[list[int], list[int]]]:
    """The chains of ``plan`` in groups that move each other's effectors (a chain turning a
    joint above another chain's effectors), each as (joints, effector columns): a group's pose
    is judged and kept whole, so the residual returned is the pose's own (reviewer: chains kept
    apart, an arm below a spine chain took another iteration's spine)."""

    def above(j: int) -> set[int]:
        out = set()
        while j >= 0:
            out.add(j)
            j = int(parents[j])
        return out

    n = len(plan)
    group = list(range(n))

    def root(i: int) -> int:
        while group[i] != i:
            i = group[i]
        return i

    reach = [set().union(*(above(e) for e in p["chain"].effectors)) for p in plan]
    for i in range(n):
        for k in range(n):
            if i != k and reach[i] & set(plan[k]["chain"].joints):
                group[root(i)] = root(k)
    out = []
    for r in sorted({root(i) for i in range(n)}):
        members = [plan[i] for i in range(n) if root(i) == r]
        joints = sorted({j for p in members for j in p["chain"].joints})
        cols = [p["rows"] + e for p in members for e in range(len(p["chain"].effectors))]
        out.append((joints, cols))
    return out


_STRAIGHT = math.radians(1.0)
"""A hinge flexed less than this is straight (:func:`_solve_frames`)."""
_UNSTICK = math.radians(5.0)
"""How far :func:`_solve_frames` bends a straight hinge whose chain must shorten."""


def _solve_frames(
    parents: np.ndarray,
    lrot: np.ndarray,
    ltrans: np.ndarray,
    plan: list[dict],
    targets: np.ndarray,
    min_flex: list[np.ndarray],
    damping: float,
    tol: float,
    max_step: float,
    iterations: int,
) -> tuple[np.ndarray, np.ndarray, int]:
    """The hot loop, vectorised over the (Fa) frames given: returns the new local rotations,
    the residual (Fa, E) and the iterations run. ``min_flex``: per hinge (in plan order), the
    (Fa,) lowest flexion allowed."""
    lrot = lrot.copy()
    Fa = lrot.shape[0]
    E = targets.shape[1]
    D = sum(n for p in plan for _, n in p["cols"])
    eye = np.eye(3 * E) * damping**2
    it = 0
    active = np.ones(Fa, dtype=bool)
    res = np.zeros((Fa, E))
    # the best pose met so far per frame and chain: near a straight leg pulled at an
    # unreachable target the steps can wander off (a leg kicked out on one frame); each chain
    # keeps its best pose. (Judged per frame over every chain, one leg's unreachable target
    # kept the other leg at its start pose too: a fill's foot left 6 cm under the floor.)
    best_rot = lrot.copy()
    best_res = np.full((Fa, E), np.inf)
    spans = _independent_groups(parents, plan)

    def keep_best(lrot: np.ndarray, res: np.ndarray) -> None:
        for joints, cols in spans:
            better = res[:, cols].max(axis=1) < best_res[:, cols].max(axis=1)
            rows = np.flatnonzero(better)
            best_rot[np.ix_(rows, joints)] = lrot[np.ix_(rows, joints)]
            best_res[np.ix_(rows, cols)] = res[np.ix_(rows, cols)]

    for it in range(1, iterations + 1):  # noqa: B007 - `it` is reported
        gpos, grot = fk_arrays(parents, lrot, ltrans)
        eff = np.concatenate([gpos[:, list(p["chain"].effectors)] for p in plan], axis=1)
        err = targets - eff
        res = np.linalg.norm(err, axis=-1)
        keep_best(lrot, res)
        active = res.max(axis=1) > tol
        if not active.any():
            break
        J = np.zeros((Fa, 3 * E, D))
        hinge_world: dict[int, np.ndarray] = {}
        hinge_flex: dict[int, np.ndarray] = {}
        for p in plan:
            c = p["chain"]
            for j_i, j in enumerate(c.joints):
                c0, n = p["cols"][j_i]
                if n == 1:
                    child = c.joints[j_i + 1] if j_i + 1 < len(c.joints) else c.effectors[0]
                    flex, a = _hinge_flex(gpos, grot, parents, j, p["hinge"][j], child)
                    hinge_world[j], hinge_flex[j] = a, flex
                for e_i, e in enumerate(c.effectors):
                    if not p["moves"][j_i, e_i]:
                        continue
                    r = gpos[:, e] - gpos[:, j]
                    r0 = 3 * (p["rows"] + e_i)
                    if n == 3:
                        J[:, r0 : r0 + 3, c0 : c0 + 3] = _skew_cross_cols(r)
                    else:
                        J[:, r0 : r0 + 3, c0] = np.cross(hinge_world[j], r)
        e_flat = err.reshape(Fa, 3 * E)
        # d = J^T (J J^T + lambda^2 I)^-1 e: the damped minimum-norm step
        JJt = J @ J.transpose(0, 2, 1) + eye
        d = (J.transpose(0, 2, 1) @ np.linalg.solve(JJt, e_flat[..., None]))[..., 0]
        d[~active] = 0.0
        # apply top-down per chain: segment k turns by Delta_k = exp(d_k) Delta_{k-1}
        h_i = 0
        for p in plan:
            c = p["chain"]
            delta = rot.quat_identity(Fa)
            g_prev_new = None
            for j_i, j in enumerate(c.joints):
                c0, n = p["cols"][j_i]
                if n == 3:
                    step = d[:, c0 : c0 + 3]
                else:
                    ang = d[:, c0]
                    # a straight hinge is a singular pose: bending it moves the effector across
                    # the limb, not along it, at first order, so the step never bends it (a
                    # straight knee under a foot aimed higher stayed straight: the foot left
                    # 6 cm under the floor). Where the chain must shorten to reach its aim, it
                    # is bent a little, and the steps go on from there.
                    root = gpos[:, c.joints[0]]
                    reach = np.linalg.norm(gpos[:, c.effectors[0]] - root, axis=-1)
                    aim = np.linalg.norm(targets[:, p["rows"]] - root, axis=-1)
                    stuck = (hinge_flex[j] < _STRAIGHT) & (aim < reach - tol)
                    ang = np.where(stuck, np.maximum(ang, _UNSTICK - hinge_flex[j]), ang)
                    lo = min_flex[h_i] - hinge_flex[j]
                    ang = np.maximum(ang, lo)  # no flexing past the allowed extension
                    ang = np.where(active, ang, 0.0)
                    h_i += 1
                    step = hinge_world[j] * ang[:, None]
                ang_n = np.linalg.norm(step, axis=-1, keepdims=True)
                lim = math.radians(max_step)
                step = np.where(ang_n > lim, step * lim / np.maximum(ang_n, 1e-300), step)
                delta = rot.quat_mul(rot.rotvec_to_quat(step), delta)
                g_old = grot[:, j]
                g_new = rot.quat_mul(delta, g_old)
                if j_i == 0:
                    pj = int(parents[j])
                    g_par = grot[:, pj] if pj >= 0 else rot.quat_identity(Fa)
                    new_l = rot.quat_mul(rot.quat_inv(g_par), g_new)
                else:
                    new_l = rot.quat_mul(rot.quat_inv(g_prev_new), g_new)
                lrot[:, j] = np.where(active[:, None], rot.quat_normalize(new_l), lrot[:, j])
                g_prev_new = g_new
    else:
        gpos, _ = fk_arrays(parents, lrot, ltrans)
        eff = np.concatenate([gpos[:, list(p["chain"].effectors)] for p in plan], axis=1)
        res = np.linalg.norm(targets - eff, axis=-1)
    keep_best(lrot, res)
    return best_rot, best_res, it


def _rigid_pairs_apart(tgt: np.ndarray, cur: np.ndarray, chains: Sequence[Chain], sk) -> None:
    """Put each effector that hangs rigidly below another effector of its chain (a toe below
    its ankle: no chain joint between them) at its own distance from that one's target, in
    place: targets pulling the two apart can be met by no pose, and a solver pulled both ways
    settles on a different compromise each frame (a knee jittering by centimetres)."""
    col = 0
    for c in chains:
        cols = {e: col + i for i, e in enumerate(c.effectors)}
        col += len(c.effectors)
        moving = set(c.joints)
        for child in c.effectors:
            for above in sk.ancestors(child):
                if above in cols:  # the nearest effector above, nothing moving between
                    a, b = cols[above], cols[child]
                    length = np.linalg.norm(cur[:, b] - cur[:, a], axis=-1)
                    d = tgt[:, b] - tgt[:, a]
                    n = np.linalg.norm(d, axis=-1)
                    ok = n > 1e-12
                    tgt[ok, b] = tgt[ok, a] + d[ok] * (length[ok] / n[ok])[:, None]
                    break
                if above in moving:
                    break


def solve(
    motion: Motion,
    chains: Sequence[Chain],
    targets: np.ndarray,
    weights: np.ndarray | None = None,
    config: IKConfig | None = None,
    body: Body | None = None,
) -> IKResult:
    """Move the chains' effectors toward ``targets`` per frame, staying close to the input pose.

    Args:
        motion: the motion to edit.
        chains: the chains (e.g. :func:`leg_chains`); their effectors, in chain order, are the
            E columns of ``targets``.
        targets: (F, E, 3) effector positions (file units).
        weights: (F, E) in [0, 1]: each target is pulled ``weight`` of the way from the input's
            effector position (0: hold the input, 1: reach the target). Frames where every
            weight is 0 are left exactly as they are, and so is a chain on a frame where all
            its effectors' weights are 0. Default: all ones.
        config: solver tunables; lengths in metres.
        body: the motion's body (for its unit), computed when None.

    Returns:
        :class:`IKResult`.
    """
    cfg = config or IKConfig()
    body = body or body_of(motion)
    sk = motion.skeleton
    F = motion.num_frames
    effs = [e for c in chains for e in c.effectors]
    E = len(effs)
    targets = np.asarray(targets, dtype=np.float64)
    if targets.shape != (F, E, 3):
        raise ValueError(f"targets must be (F, E, 3) = ({F}, {E}, 3), got {targets.shape}")
    w = np.ones((F, E)) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (F, E):
        raise ValueError(f"weights must be (F, E) = ({F}, {E}), got {w.shape}")
    if not (np.all(np.isfinite(targets)) and np.all(np.isfinite(w))):
        raise ValueError("IK targets and weights must be finite")
    w = np.clip(w, 0.0, 1.0)
    plan = _prepare(chains, sk.parents)
    out = motion.copy()
    solved = (w > 0).any(axis=1)
    residual = np.zeros((F, E))
    if not solved.any() or E == 0:
        return IKResult(out, residual, solved, 0)
    idx = np.flatnonzero(solved)
    ltrans = motion.local_translations()[idx]
    lrot = motion.rotations[idx]
    gpos, grot = fk_arrays(sk.parents, lrot, ltrans)
    cur = gpos[:, effs]
    tgt = cur + w[idx, :, None] * (targets[idx] - cur)
    _rigid_pairs_apart(tgt, cur, chains, sk)
    min_flex = []
    for p in plan:
        c = p["chain"]
        for h, ax in zip(c.hinges, c.hinge_axes, strict=True):
            k = c.joints.index(h)
            child = c.joints[k + 1] if k + 1 < len(c.joints) else c.effectors[0]
            flex, _ = _hinge_flex(gpos, grot, sk.parents, h, ax, child)
            min_flex.append(np.minimum(flex, math.radians(cfg.hinge_min_flexion)))
    mpu = body.metres_per_unit
    new_l, res, it = _solve_frames(
        sk.parents,
        lrot,
        ltrans,
        plan,
        tgt,
        min_flex,
        cfg.damping / mpu,
        cfg.tolerance / mpu,
        cfg.max_step,
        cfg.iterations,
    )
    # a chain none of whose effectors has a weight on a frame is left exactly as it was (its
    # solve only moved it by rounding: 1e-6 deg on a leg nothing asked to move)
    e0 = 0
    for c in chains:
        idle = ~(w[idx, e0 : e0 + len(c.effectors)] > 0).any(axis=1)
        joints = list(c.joints)
        new_l[np.ix_(idle, joints)] = lrot[np.ix_(idle, joints)]
        e0 += len(c.effectors)
    out.rotations[idx] = new_l
    residual[idx] = res
    return IKResult(out, residual, solved, it)


# =============================================================================================
# foot locking


@dataclass(frozen=True)
class FootLockConfig:
    """Tunables of :func:`lock_feet` (seconds, metres)."""

    #: Blend in before and out after each contact run over this long (seconds): about a quarter
    #: of a walking step, long enough that the correction has no visible pop at 30 or 120 fps.
    blend: float = 0.15
    #: Where a planted foot is held: "mean" (the run's mean position: the least total change)
    #: or "first" (where it landed).
    anchor: str = "mean"
    #: How the blends around a run ramp: "target" pulls the foot toward the run's anchor with
    #: the ramping weight; "offset" adds the correction the run needs at its first (last) frame
    #: to the foot's own position, fading to nothing. A foot swings in and out of a contact fast
    #: (~1-3 m/s, 15-45 cm over a 0.15 s blend), so pulling it toward a fixed point reshapes
    #: its swing; the fading offset keeps the swing's shape and still meets the anchor.
    ramp: str = "target"
    #: Hold the planted height too. Off by default: an ankle's height changes legitimately while
    #: its foot is planted (the foot rolls heel to toe), and a straight leg cannot reach lower;
    #: the slide that reads as skating is horizontal.
    lock_height: bool = False
    #: The solver's tunables.
    ik: IKConfig = field(default_factory=IKConfig)

    def __post_init__(self) -> None:
        if self.ramp not in ("target", "offset"):
            raise ValueError(f"ramp must be 'target' or 'offset', got {self.ramp!r}")
        if self.anchor not in ("mean", "first"):
            raise ValueError(f"anchor must be 'mean' or 'first', got {self.anchor!r}")
        if not (math.isfinite(self.blend) and self.blend >= 0):
            raise ValueError(f"blend must be >= 0 seconds, got {self.blend!r}")


@dataclass(frozen=True, eq=False)
class FootLock:
    """What :func:`lock_feet` returns: the motion, the targets and weights it used per foot
    joint (columns in chain effector order), the residual (file units) and the contacts."""

    motion: Motion
    effectors: tuple[int, ...]
    targets: np.ndarray
    weights: np.ndarray
    residual: np.ndarray
    contacts: FootContacts


def lock_targets(
    positions: np.ndarray,
    flags: np.ndarray,
    blend_frames: int,
    anchor: str = "mean",
    up: np.ndarray | None = None,
    ramp: str = "target",
    pins: np.ndarray | None = None,
    drift: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Per foot joint (columns): targets (F, n, 3) and weights (F, n) for :func:`solve`.

    Over each run of True in ``flags[:, k]`` the target is the run's anchor (mean or first
    position) with weight 1; for ``blend_frames`` frames before and after, the weight ramps
    smoothly (smoothstep) to 0 toward the nearest run's anchor (``ramp="target"``) or, with
    ``ramp="offset"``, the target is the joint's own position plus the correction the run needs
    at its nearest end frame (anchor - position there), so the swing keeps its shape while the
    correction fades. Elsewhere weight 0. With ``up`` (a unit vector) only the ground-plane
    part is held: the target keeps the input's height.

    ``pins`` (F, n) bool marks frames whose positions are fixed by something else (the context
    around a filled gap, which the fill must not change): a run holding pinned frames is
    anchored on them instead (at a pinned frame its own position, between two pinned frames
    interpolated, beyond the last one that one's), so the foot stays where the fixed frames
    plant it and does not have to slide there when the lock lets go.

    ``drift`` (F, n, 3): how far a planted foot is meant to move into each frame from the one
    before (the small motion of the captured foot a fill was made from: its roll and settling).
    Within a run the hold moves by it: the anchors above are taken of the positions less the
    run's accumulated drift, which is then added back, so a foot that moves as meant is left
    where it is, and pinned frames are still met exactly. None: held still."""
    F, n = flags.shape
    targets = positions.copy()
    weights = np.zeros((F, n))
    u = None if up is None else np.asarray(up, dtype=np.float64)
    for k in range(n):
        best = np.full(F, -1.0)
        for a, b in true_runs(flags[:, k]):
            cum = np.zeros((b + 1 - a, 3))
            if drift is not None:
                cum[1:] = np.cumsum(drift[a + 1 : b + 1, k], axis=0)
            seg = positions[a : b + 1, k] - cum
            pinned = np.flatnonzero(pins[a : b + 1, k]) if pins is not None else ()
            if len(pinned):  # per frame of the run: the pinned positions, interpolated
                i = np.arange(len(seg))
                pts = np.stack([np.interp(i, pinned, seg[pinned, d]) for d in range(3)], -1)
            else:
                pts = np.broadcast_to(seg.mean(axis=0) if anchor == "mean" else seg[0], seg.shape)
            pts = pts + cum
            lo, hi = max(0, a - blend_frames), min(F - 1, b + blend_frames)
            fr = np.arange(lo, hi + 1)
            dist = np.where(fr < a, a - fr, np.where(fr > b, fr - b, 0))
            x = 1.0 - dist / (blend_frames + 1)
            wk = x * x * (3 - 2 * x)  # smoothstep: zero slope at both ends, no pop
            take = wk > best[fr]
            best[fr[take]] = wk[take]
            end = np.clip(fr, a, b)
            pt = pts[end - a][take]
            if ramp == "offset":
                off = pt - positions[end[take], k]
                if u is not None:
                    off = off - (off @ u)[:, None] * u
                targets[fr[take], k] = positions[fr[take], k] + off
            elif u is None:
                targets[fr[take], k] = pt
            else:  # the anchor's ground-plane position at the input's own height
                h = positions[fr[take], k] @ u
                targets[fr[take], k] = pt - (pt @ u)[:, None] * u + h[:, None] * u
        weights[:, k] = np.maximum(best, 0.0)
    return targets, weights


def effector_contacts(contacts: FootContacts, effectors: Sequence[int]) -> np.ndarray:
    """(F, n) bool: frames where each of ``effectors`` (joint indices, the columns) is in
    contact, from ``contacts`` (:func:`mocapkit.features.foot_contacts`); a joint it does not
    cover is never in contact."""
    flags = np.zeros((contacts.contacts.shape[0], len(effectors)), dtype=bool)
    effs = list(effectors)
    for k, j in enumerate(contacts.joints):
        if j in effs:
            flags[:, effs.index(j)] |= contacts.contacts[:, k]
    return flags


def lock_feet(
    motion: Motion,
    contacts: FootContacts | None = None,
    config: FootLockConfig | None = None,
    body: Body | None = None,
    chains: Sequence[Chain] | None = None,
) -> FootLock:
    """Hold planted feet still: over each contact run (``contacts``, default
    :func:`mocapkit.features.foot_contacts` of ``motion``) the foot joint is held at the run's
    anchor position, blending in and out over ``config.blend`` seconds around the run, by IK on
    the whole leg (hip, knee, ankle; the ankle turns too, so a planted toe stays planted while
    the heel lifts). Frames outside every run and its blend are returned unchanged.

    Relies on contacts meaning "this joint is on the ground and should not move" (flat ground,
    no skating steps in the input's intent).
    """
    cfg = config or FootLockConfig()
    body = body or body_of(motion)
    if contacts is None:
        contacts = foot_contacts(motion)
    if contacts.contacts.shape[0] != motion.num_frames:
        raise ValueError(
            f"contacts cover {contacts.contacts.shape[0]} frames, the motion has "
            f"{motion.num_frames}"
        )
    chains = list(leg_chains(motion, body) if chains is None else chains)
    effs = tuple(e for c in chains for e in c.effectors)
    flags = effector_contacts(contacts, effs)
    pos, _ = forward_kinematics(motion)
    blend = motion.seconds_to_frames(cfg.blend)
    up = None if cfg.lock_height else ground_frame(body.up)[1]
    targets, weights = lock_targets(pos[:, list(effs)], flags, blend, cfg.anchor, up, cfg.ramp)
    res = solve(motion, chains, targets, weights, cfg.ik, body)
    return FootLock(res.motion, effs, targets, weights, res.residual, contacts)
