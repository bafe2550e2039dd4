"""Replacing erroneous joint values (Sec. 4), on the take's own frames.

Which cells change: for every joint, the frames the detection flags ("flagged cells": the
cleaner's mask, its pipeline's decision, not the MDM alone), each run of them dilated by
``margin`` frames on both sides (the *blend margin*); then, with the foot lock
(:func:`lock_repaired_feet`), the leg joints it turns on the frames it holds. Exactly those
(joint, frame) cells are written; every other rotation of the take, and every root position,
is copied bit for bit.

What they get: a composite track (the take's rotation outside the flagged cells, the replacement
inside, made hemisphere-continuous) smoothed by a quadratic Savitzky-Golay filter of
``2 * margin + 1`` frames, so the amended part joins the original smoothly; only the written
cells take the smoothed values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from mocapkit.clean.mdm import jump_size
from mocapkit.core import rotations as rot
from mocapkit.core.checks import whole_number
from mocapkit.core.motion import Motion
from mocapkit.core.runs import true_runs
from mocapkit.features import character_height


def default_margin(fps: float) -> int:
    """Blend margin in frames: about 0.1 s, at least 2."""
    return max(2, round(0.1 * fps))


def dilate(mask: np.ndarray, margin: int) -> np.ndarray:
    """Dilate a (F, J) bool mask by ``margin`` frames along axis 0."""
    m = np.asarray(mask, dtype=bool)
    if margin <= 0 or not m.any():
        return m.copy()
    out = m.copy()
    for s in range(1, margin + 1):
        out[s:] |= m[:-s]
        out[:-s] |= m[s:]
    return out


@dataclass
class RepairResult:
    """A repaired take and what changed.

    Attributes:
        motion: the repaired Motion.
        flagged: (F, J) bool, the cells the detection flagged (the cleaner's mask).
        written: (F, J) bool, cells written (flagged dilated by the blend margin, and the leg
            cells the foot lock turned).
        margin: the blend margin in frames.
        held_contacts: the foot contacts held by :func:`lock_repaired_feet` (a
            :class:`~mocapkit.features.FootContacts`), None when feet were not locked.
        contacts: how each :class:`ContactConstraint` given to the repair held
            (:class:`ContactHeld`), in the order given.
        how: (F, J) int8, per flagged cell the index in :data:`REPAIR_METHODS` of how its
            replacement was made (-1 elsewhere; None: all the median's). The foot lock and a
            contact's IK adjust cells afterwards without changing their method here.
    """

    motion: Motion
    flagged: np.ndarray
    written: np.ndarray
    margin: int
    held_contacts: object | None = None
    contacts: tuple[ContactHeld, ...] = ()
    how: np.ndarray | None = None

    def methods(self, joint: int, start: int, end: int) -> dict[str, int]:
        """How the flagged cells of ``joint``, frames ``start`` to ``end`` inclusive, were
        repaired: {method (:data:`REPAIR_METHODS`): cells}. ``how`` (F, J) int8 holds, per flagged
        cell, the index of its method (-1 elsewhere); without it, every flagged cell is the
        median's."""
        if self.how is None:
            n = int(self.flagged[start : end + 1, joint].sum())
            return {REPAIR_METHODS[0]: n} if n else {}
        codes = self.how[start : end + 1, joint]
        counts = {m: int((codes == i).sum()) for i, m in enumerate(REPAIR_METHODS)}
        return {m: n for m, n in counts.items() if n}


REPAIR_METHOD_NOTES = {
    "median": "the neighbours' median (the KNN words' rotations)",
    "turned back": "turned back by the one rotation that turned the stretch (read at its edges)",
    "reflected": "the knee's or elbow's flexion reflected back across straight",
    "captured kept": "the captured rotation kept (beside a turned-back stretch, only the words' "
    "digression flags it)",
    "contact word": "the neighbour word whose effector lands nearest a --contact point",
}
"""How a flagged cell is repaired (:attr:`RepairResult.how`), and what each way means (the
report's ``repair_methods_are``)."""

REPAIR_METHODS = tuple(REPAIR_METHOD_NOTES)
"""The methods' names in :attr:`RepairResult.how`'s order."""


@dataclass(frozen=True)
class ContactHeld:
    """Where a contact's effector ended up in the repaired take.

    Attributes:
        joint: the effector's name; start, end: the contact's frames (inclusive).
        target: the contact point (the take's units and axes).
        max_error, mean_error: the effector's distance from it over those frames (take units).
        pinned: whether the repair wrote any joint of the effector's chain there; the pin
            changes only written cells, so a contact where nothing was repaired keeps the
            effector where the take has it (``max_error`` says how far that is).
        tolerance: how close counts as held (take units): :data:`HELD_FRACTION` of the
            character's height.
        pinned_max_error: the largest distance over the frames where the repair wrote the
            effector's chain (the frames the pin could move); ``held`` says whether it is
            within ``tolerance``. Frames the repair did not touch are the take's own.
    """

    joint: str
    start: int
    end: int
    target: tuple[float, float, float]
    max_error: float
    mean_error: float
    pinned: bool
    tolerance: float = math.inf
    pinned_max_error: float = 0.0

    @property
    def held(self) -> bool:
        return self.pinned_max_error <= self.tolerance

    def as_dict(self) -> dict:
        return {
            "joint": self.joint,
            "frames": [self.start, self.end + 1],  # start:stop, stop excluded, as --gap A:B
            "target": list(self.target),
            "max_error": self.max_error,
            "mean_error": self.mean_error,
            "pinned": self.pinned,
            "held": self.held,
            "tolerance": self.tolerance if math.isfinite(self.tolerance) else None,
            "pinned_max_error": self.pinned_max_error,
        }

    def __str__(self) -> str:
        where = f"contact {self.joint} frames {self.start}:{self.end + 1}"
        if not self.pinned:
            return (
                f"{where}: not pinned (the repair wrote no joint of its chain there); the "
                f"effector is {self.max_error:.3g} (take units) from the point at most"
            )
        if not self.held:
            return (
                f"{where}: NOT held: on the frames the repair wrote the effector ends up to "
                f"{self.pinned_max_error:.3g} (take units) from the point, more than the "
                f"{self.tolerance:.3g} a hold allows ({HELD_FRACTION:.0%} of the character's "
                "height): is the point within the limb's reach?"
            )
        text = (
            f"{where}: held to {self.max_error:.3g} (take units) of the point at most "
            f"({self.mean_error:.3g} mean)"
        )
        if self.max_error > self.tolerance:  # off where the repair wrote nothing
            text = (
                f"{where}: held to {self.pinned_max_error:.3g} (take units) of the point on the "
                f"frames the repair wrote; the take's own frames are up to "
                f"{self.max_error:.3g} from it ({self.mean_error:.3g} mean over the contact)"
            )
        return text


def unturned(
    rotations: np.ndarray, cells: np.ndarray, within: np.ndarray | None = None, search: int = 2
) -> tuple[np.ndarray, np.ndarray]:
    """``(out, done)``: (F, J, 4) ``rotations`` with each run of ``cells`` (per joint) turned back
    by the one rotation that turned it, and (F, J) bool of the cells so turned back (a run whose
    turn does not read as one rotation is left as it was, for another repair).

    The turn is read at the run's edges: the frame beside the run continued one frame at the joint's
    own velocity (from the two frames beside it) is where the run's edge frame should be; each
    edge's turn is the run's rotation against that prediction, on the joint's own side (``q d``) or
    its parent's (``d q``): with two edges the side whose two turns agree, with one (a run reaching
    the take's start or end) the side that keeps the joint's acceleration across the edge the
    smaller. The turn goes from the first edge's to the last's along the run. A run is left when its
    edges' turns differ by over 10 deg (and a quarter of the turn) but for turns about one axis
    by different angles (:func:`_one_axis`), or when a turn is under half or
    over twice the joint's jump at that edge (:func:`~mocapkit.clean.mdm.jump_size`): then the run
    was not one rotation (a pairing of the wrong jumps, a spike beside it); an edge next to the
    take's first or last frame, read without the joint's velocity, takes the other edge's turn. With
    ``within`` ((F, J) bool, holding ``cells``: the flagged runs) an edge whose jump is measured
    moves, inside ``within``, to a frame within ``search`` of it that jumps over 1.5 times as much:
    a prediction made across the jump itself would turn the stretch by it twice.

    Relies on: an offset, a flip or a spike turns a stretch by one constant rotation (what
    :class:`~mocapkit.clean.detect.CancellingJumps` finds), and the joint's velocity is continuous
    across the stretch's edges; undoing the turn restores the captured motion, where the neighbours'
    median is another moment's pose (a resting hand repaired with the waving hand's median: 54 deg
    off where the error was 30; newcomer)."""
    q = np.asarray(rotations, dtype=np.float64)
    out = q.copy()
    done = np.zeros(q.shape[:2], dtype=bool)
    F = q.shape[0]
    cells = np.asarray(cells, dtype=bool)
    for j in np.flatnonzero(cells.any(axis=0)):
        track = q[:, j]
        jumps = jump_size(q[:, j : j + 1])[:, 0]
        for a, b in true_runs(cells[:, j]):
            if within is not None:
                a, b = _edges_at_jumps(a, b, jumps, within[:, j], search)
            # per edge: (the edge frame, the frame its jump enters, the outside frame beside
            # it, the prediction of the edge frame from outside, of the outside frame from
            # inside)
            ends = []
            if a >= 1:
                inside = _predicted(track, a, min(a + 1, b))
                ends.append((a, a, a - 1, _predicted(track, a - 1, max(a - 2, 0)), inside))
            if b <= F - 2:
                inside = _predicted(track, b, max(b - 1, a))
                ends.append((b, b + 1, b + 1, _predicted(track, b + 1, min(b + 2, F - 1)), inside))
            if not ends:
                continue
            sides = ("body", "parent")
            turns = {s: [_turn(track[e], p, s) for e, _, _, p, _ in ends] for s in sides}
            # an edge at the take's first or last frame but one is predicted with no velocity
            # (one frame beyond it): the other edge's turn, read at full velocity, holds for it
            # (the side is still the one whose two turns, as read, agree the better: with both
            # taken from one edge they agree on either side, and a tie chose by rounding)
            rough = [a == 1, b == F - 2]
            if len(ends) == 2 and not any(rough) and b > a:
                # read both ways too (_edge_turn); the reading whose two edges agree the better
                # is the one rotation (inside a glitch the frames need not move as the capture)
                both = {
                    s: [_edge_turn(track[e], track[o], p, q, s) for e, _, o, p, q in ends]
                    for s in sides
                }
                if min(rot.quat_angle(v[0], v[1]) for v in both.values()) < min(
                    rot.quat_angle(v[0], v[1]) for v in turns.values()
                ):
                    turns = both
            gap = {s: rot.quat_angle(v[0], v[-1]) for s, v in turns.items()}
            if len(ends) == 2 and rough[0] != rough[1]:
                good = 1 if rough[0] else 0
                turns = {s: [v[good], v[good]] for s, v in turns.items()}
            if len(ends) == 2:
                side = min(gap, key=gap.get)
                gap = {s: rot.quat_angle(v[0], v[1]) for s, v in turns.items()}
                size = max(rot.quat_angle(turns[side][0], _ID), rot.quat_angle(turns[side][1], _ID))
                if gap[side] > max(np.radians(10.0), 0.25 * size) and not _one_axis(*turns[side]):
                    continue
            else:
                side = _one_edge_side(track, a, b, ends[0], turns)
                if side is None:
                    continue
            if not all(
                _plausible(rot.quat_angle(d, _ID), jumps[f], f, F)
                for d, (_, f, *_) in zip(turns[side], ends, strict=True)
            ):
                continue
            d0, d1 = turns[side][0], turns[side][-1]
            u = np.linspace(0.0, 1.0, b - a + 1) if b > a else np.zeros(1)
            d = rot.quat_slerp(np.broadcast_to(d0, (len(u), 4)), np.broadcast_to(
                rot.quat_fix_hemisphere(d1, d0), (len(u), 4)), u)  # fmt: skip
            out[a : b + 1, j] = rot.quat_normalize(_unturn(track[a : b + 1], d, side))
            done[a : b + 1, j] = True
    return out, done


_ID = np.array([1.0, 0.0, 0.0, 0.0])

ONE_AXIS_COS = 0.9
"""Two edge turns whose rotation axes are this close (cosine, as the cancelling-jumps rule's
default ``DetectConfig.pair_axis_cos`` pairs jumps) turn the run about one axis
(:func:`_one_axis`)."""


def _one_axis(d0: np.ndarray, d1: np.ndarray) -> bool:
    """Whether turns ``d0`` and ``d1`` (unit quaternions) are about one axis, the same way, by
    10 to 150 deg each, the larger at most 3 times the smaller: a wrong-way bend mirrors the
    joint's flexion, so the turn that made it grows and shrinks along the run about that one
    axis, and the slerp from one edge's turn to the other's follows it where the joint's own
    neighbours (another moment's pose) do not. A turn near 180 deg has no reliable axis (a flip
    reads either way round), and edges far apart in size are no one error's."""
    v0, v1 = rot.quat_to_rotvec(d0), rot.quat_to_rotvec(d1)
    n0, n1 = float(np.linalg.norm(v0)), float(np.linalg.norm(v1))
    lo, hi = sorted((n0, n1))
    if lo < np.radians(10.0) or hi > np.radians(150.0) or hi > 3.0 * lo:
        return False
    return float(v0 @ v1) / (n0 * n1) > ONE_AXIS_COS


def _unturn(q: np.ndarray, d: np.ndarray, side: str) -> np.ndarray:
    inv = rot.quat_inv(d)
    return rot.quat_mul(q, inv) if side == "body" else rot.quat_mul(inv, q)


def _plausible(turn: float, jump: float, frame: int, F: int) -> bool:
    """A turn read at an edge is the joint's jump there (within a factor of 2), where the jump
    is measured (frames 2 .. F - 2)."""
    if not 2 <= frame <= F - 2:
        return True
    return 0.5 * jump <= turn <= 2.0 * jump


def _one_edge_side(track: np.ndarray, a: int, b: int, end: tuple, turns: dict) -> str | None:
    """The side of a run with one edge (``end``): where turning back on either side gives the
    same frames (within 1 deg: a joint nearly still over the run), the joint's own; else the
    side that changes the joint's velocity less over the three frames past the edge, when it
    does so by under half as much as the other; else None (left for another repair)."""
    fixed = {s: _unturn(track[a : b + 1], np.broadcast_to(d[0], (b - a + 1, 4)), s)
             for s, d in turns.items()}  # fmt: skip
    if float(rot.quat_angle(fixed["body"], fixed["parent"]).max()) < np.radians(1.0):
        return "body"
    e, f, *_ = end
    entry = f == e
    jolt = {}
    for s, fx in fixed.items():
        # the run's frames from its edge inwards, after the frame outside it
        inner = fx if entry else fx[::-1]
        outside = track[a - 1] if entry else track[b + 1]
        seq = np.concatenate([outside[None], inner[:4]])
        jolt[s] = sum(
            float(rot.quat_angle(_predicted(seq, i, i - 1), seq[i + 1]))
            for i in range(1, len(seq) - 1)
        )
    lo, hi = sorted(jolt.values())
    if lo >= 0.5 * hi:
        return None
    return min(jolt, key=jolt.get)


def _edges_at_jumps(
    a: int, b: int, jumps: np.ndarray, within: np.ndarray, search: int
) -> tuple[int, int]:
    """The run ``a..b`` with its first frame moved to a frame within ``search`` of ``a`` whose
    jump (the step into it) is over 1.5 times ``a``'s, and its last to the frame before such a
    jump near ``b + 1``, staying inside ``within``'s run around it. An edge whose jump is not
    measured (frames under 2 or over F - 2) stays."""
    F = len(jumps)
    lo, hi = a, b
    while lo > 0 and within[lo - 1]:
        lo -= 1
    while hi < F - 1 and within[hi + 1]:
        hi += 1

    def better(edge: int, frames: np.ndarray) -> int:
        if not 2 <= edge <= F - 2 or not len(frames):
            return edge
        best = int(frames[np.argmax(jumps[frames])])
        return best if jumps[best] > 1.5 * jumps[edge] else edge

    if a > 0:  # the entry: the step into frame e, for e in a - search .. a + search
        a = better(a, np.arange(max(a - search, lo, 1), min(a + search, b) + 1))
    if b < F - 1:  # the exit: the step into frame e = b + 1
        b = (
            better(
                b + 1, np.arange(max(b + 1 - search, a + 1), min(b + 1 + search, hi + 1, F - 1) + 1)
            )
            - 1
        )
    return a, b


def _predicted(q: np.ndarray, near: int, far: int) -> np.ndarray:
    """Frame ``near`` of the track ``q`` (T, 4) continued one frame away from frame ``far``
    at the same velocity: ``q[near] q[far]^-1 q[near]`` (the same whether the step is read in
    the joint's frame or its parent's)."""
    qn, qf = q[near], rot.quat_fix_hemisphere(q[far], q[near])
    return rot.quat_mul(qn, rot.quat_mul(rot.quat_inv(qf), qn))


def _edge_turn(
    edge: np.ndarray,
    outside: np.ndarray,
    from_outside: np.ndarray,
    from_inside: np.ndarray,
    side: str,
) -> np.ndarray:
    """The turn at a run's edge, read both ways across it and averaged: the ``edge`` frame
    against its prediction ``from_outside`` (the frames beyond it continued at their velocity),
    and the prediction ``from_inside`` (the run's frames continued past the edge) against the
    ``outside`` frame. The joint's acceleration bends both predictions the same way along the
    motion, so the two readings err by about as much in opposite directions.

    Relies on: the captured motion's acceleration changes little over the few frames at an
    edge. A dancer's elbow swinging fast under a 30 deg offset was read 32 and 31 deg at the two
    edges from outside alone, 18 deg apart in direction, and the stretch went to the median,
    39 deg off (newcomer). :func:`unturned` takes this reading where its two edges agree the
    better: inside a real glitch (a thumb popping) the frames need not move as the capture's
    do."""
    out = _turn(edge, from_outside, side)
    back = _turn(from_inside, outside, side)
    return rot.quat_slerp(out, rot.quat_fix_hemisphere(back, out), 0.5)


def _turn(actual: np.ndarray, predicted: np.ndarray, side: str) -> np.ndarray:
    """The rotation ``d`` with ``actual = predicted d`` (body) or ``d predicted`` (parent)."""
    inv = rot.quat_inv(predicted)
    d = rot.quat_mul(inv, actual) if side == "body" else rot.quat_mul(actual, inv)
    return d if d[0] >= 0 else -d


def repair_cells(
    motion: Motion,
    flagged: np.ndarray,
    replacement: np.ndarray,
    margin: int | None = None,
    to_file: np.ndarray | None = None,
    pelvis: int | None = None,
    exact: np.ndarray | None = None,
) -> RepairResult:
    """Write ``replacement`` into the flagged cells of ``motion`` with Savitzky-Golay blending.

    Args:
        motion: the take (F frames).
        flagged: (F, J) bool.
        replacement: (F, J, 4) replacement rotations, in the same space as ``motion.rotations``
            except for joint ``pelvis`` when ``to_file`` is given.
        margin: blend margin (frames); default :func:`default_margin`.
        to_file: (F, 4) ``X``: the pelvis column of ``replacement`` (and of the composite) is in
            the facing-aligned space ``X * q``; it is mapped back with ``X^-1``.
        pelvis: the pelvis joint index for ``to_file``.
        exact: (F, J) int (or bool), flagged cells whose replacement is the capture's own
            motion moved as a whole (a stretch turned back, a bend reflected, captured frames
            kept), non-zero, one value per source: smooth already, so the blend reaches into
            them only near a seam (a frame where the composite changes source: the capture, a
            replacement smoothed whole, or another value of ``exact``), fading from the smoothed
            value there to the replacement itself ``margin`` frames in. Elsewhere the whole
            composite is smoothed: a Savitzky-Golay fit (order 2) over ``2 margin + 1`` frames
            takes the curve out of a fast joint's motion, 25 frames at 120 fps (a reflected CMU
            elbow 0.1 deg off became 2.7 deg off).
    """
    F, J = motion.num_frames, motion.num_joints
    flagged = np.asarray(flagged, dtype=bool)
    if flagged.shape != (F, J):
        raise ValueError(f"flagged must be ({F}, {J}), got {flagged.shape}")
    replacement = np.asarray(replacement, dtype=np.float64)
    if replacement.shape != (F, J, 4):
        raise ValueError(f"replacement must be ({F}, {J}, 4), got {replacement.shape}")
    margin = default_margin(motion.fps) if margin is None else int(margin)
    if margin < 0:
        raise ValueError("margin must be >= 0")
    written = dilate(flagged, margin)
    out = motion.rotations.copy()
    window = 2 * margin + 1
    for j in np.flatnonzero(flagged.any(axis=0)):
        orig = motion.rotations[:, j]
        rep = replacement[:, j]
        if to_file is not None and j == pelvis:
            rep = rot.quat_mul(rot.quat_inv(to_file), rep)
        comp = np.where(flagged[:, j, None], rep, orig)
        comp = rot.quat_unroll(rot.quat_normalize(comp), axis=0)
        w = min(window, F if F % 2 == 1 else F - 1)
        if w >= 3:
            smooth = savgol_filter(comp, w, min(2, w - 1), axis=0, mode="interp")
            smooth = rot.quat_normalize(smooth)
        else:
            smooth = comp
        if exact is not None and margin > 0 and (exact[:, j] != 0).any():
            own = np.where(flagged[:, j], np.asarray(exact[:, j], dtype=np.int64), 0)
            smooth = _fade_into(comp, smooth, flagged[:, j], own, margin)
        cells = written[:, j]
        new = smooth[cells]
        # keep the file's sign convention (w >= 0 where the input had it) for stable output
        sign = np.where(np.sum(new * orig[cells], axis=-1, keepdims=True) < 0, -1.0, 1.0)
        out[cells, j] = new * sign
    result = Motion(
        motion.skeleton,
        out,
        motion.root_positions.copy(),
        motion.frame_time,
        None if motion.translations is None else motion.translations.copy(),
    )
    return RepairResult(result, flagged, written, margin)


def _fade_into(
    comp: np.ndarray, smooth: np.ndarray, flagged: np.ndarray, sources: np.ndarray, margin: int
) -> np.ndarray:
    """``smooth`` (F, 4) with the exact frames of one joint's composite ``comp`` (``sources``
    (F,) int, non-zero there, one value per source) faded back to ``comp``: the smoothed value
    at a seam (where the composite's source changes: the capture, a replacement smoothed whole,
    another exact source), the composite ``margin`` frames in, slerped between."""
    exact = sources != 0
    source = np.where(exact, sources + 1, np.where(flagged, 1, 0))
    seams = np.flatnonzero(np.diff(source) != 0) + 0.5  # between frames s and s + 1
    if len(seams) == 0:
        return np.where(exact[:, None], comp, smooth)
    frames = np.arange(len(source))
    dist = np.abs(frames[:, None] - seams[None]).min(axis=1) - 0.5  # 0 beside a seam
    keep = np.clip(dist / margin, 0.0, 1.0)  # share of the composite
    out = smooth.copy()
    out[exact] = rot.quat_slerp(smooth[exact], comp[exact], keep[exact])
    return out


# ------------------------------------------------------------------------ contact constraints


@dataclass(frozen=True)
class ContactConstraint:
    """An end effector that must touch a point over a range of the take's frames.

    Attributes:
        joint: the end-effector joint index (or its name, for
            :meth:`SelfSimilarityCleaner.repair <mocapkit.clean.SelfSimilarityCleaner.repair>`).
        start, end: first and last frame (inclusive, the take's frames).
        position: (3,) world position (file units); ``None``: where the input has the effector
            at ``start`` (a planted hand or foot).
    """

    joint: int | str
    start: int
    end: int
    position: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if isinstance(self.joint, bool) or not isinstance(self.joint, int | np.integer | str):
            raise ValueError(f"contact: joint is an index or a name, got {self.joint!r}")
        for name in ("start", "end"):
            whole_number(getattr(self, name), f"contact {name}")
        if self.position is not None:
            p = np.asarray(self.position, dtype=np.float64)
            if p.shape != (3,) or not np.all(np.isfinite(p)):
                raise ValueError(
                    f"contact: position is three finite numbers, got {self.position!r}"
                )

    def frames(self, num_frames: int) -> np.ndarray:
        if self.start > self.end:
            raise ValueError(f"contact: start {self.start} after end {self.end}")
        if self.start < 0 or self.end >= num_frames:
            raise ValueError(f"contact frames {self.start}-{self.end} outside 0-{num_frames - 1}")
        return np.arange(self.start, self.end + 1)

    def target(self, motion: Motion) -> np.ndarray:
        if self.position is not None:
            return np.asarray(self.position, dtype=np.float64)
        from mocapkit.core.kinematics import forward_kinematics

        pos, _ = forward_kinematics(motion[self.start : self.start + 1])
        return pos[0, self.joint].copy()


HELD_FRACTION = 0.03
"""A contact counts as held where its effector stays within this fraction of the character's
height of the point (about 5 cm for a person, a hand's or a foot's width): further off, it is
not on the point. The IK's residual on a point within reach is well under it (a procedural
walk's pinned toe: 1.9 cm at most, 0.7 cm mean); a point out of reach is far over it (a hand
pinned for 20 frames of a Bandai walk, 120 cm)."""


def chain_of(motion: Motion, joint: int, length: int = 2) -> list[int]:
    """The ``length`` ancestors of ``joint`` that move it (parent first), e.g. elbow, shoulder."""
    return motion.skeleton.ancestors(joint)[:length]


def effector_error(motion: Motion, contact: ContactConstraint, target: np.ndarray) -> np.ndarray:
    """(n,) distance of the effector from the target over the contact's frames."""
    from mocapkit.core.kinematics import forward_kinematics

    fr = contact.frames(motion.num_frames)
    pos, _ = forward_kinematics(motion[int(fr[0]) : int(fr[-1]) + 1])
    return np.linalg.norm(pos[:, contact.joint] - target, axis=-1)


def contact_held(
    motion: Motion, contact: ContactConstraint, target: np.ndarray, written: np.ndarray
) -> ContactHeld:
    """How ``contact`` (joint as an index) held in the repaired ``motion``: see
    :class:`ContactHeld`."""
    err = effector_error(motion, contact, target)
    fr = contact.frames(motion.num_frames)
    chain = chain_of(motion, contact.joint)
    moved = written[fr][:, chain].any(axis=1)
    return ContactHeld(
        motion.skeleton.names[contact.joint],
        int(fr[0]),
        int(fr[-1]),
        (float(target[0]), float(target[1]), float(target[2])),
        float(err.max()),
        float(err.mean()),
        bool(moved.any()),
        HELD_FRACTION * character_height(motion),
        float(err[moved].max()) if moved.any() else 0.0,
    )


def pin_with_ik(
    motion: Motion,
    contact: ContactConstraint,
    writable: np.ndarray,
    target: np.ndarray,
    iterations: int = 12,
) -> Motion:
    """Cyclic-coordinate-descent IK on the effector's chain, changing only ``writable`` (F, J)
    cells; returns a new Motion."""
    from mocapkit.core.kinematics import forward_kinematics

    fr = contact.frames(motion.num_frames)
    chain = chain_of(motion, contact.joint)
    q = motion.rotations.copy()
    sub = slice(int(fr[0]), int(fr[-1]) + 1)
    # with the animated translations (Bandai's pelvis moves under its ground root): without
    # them the effector was aimed from the rest pose's pelvis, 6 cm off on a Bandai bow
    tr = None if motion.translations is None else motion.translations[sub]
    for _ in range(iterations):
        for c in chain:
            ok = writable[sub, c]
            if not ok.any():
                continue
            m = Motion(motion.skeleton, q[sub], motion.root_positions[sub], motion.frame_time, tr)
            pos, grot = forward_kinematics(m)
            e = pos[:, contact.joint] - pos[:, c]
            t = target[None, :] - pos[:, c]
            r = rot.quat_between(e, t)
            p = int(motion.skeleton.parents[c])
            gp = grot[:, p] if p >= 0 else rot.quat_identity((len(fr),))
            new_local = rot.quat_mul(rot.quat_inv(gp), rot.quat_mul(r, grot[:, c]))
            new_local = np.where(
                np.sum(new_local * q[sub, c], -1, keepdims=True) < 0, -new_local, new_local
            )
            q[sub, c] = np.where(ok[:, None], new_local, q[sub, c])
    return Motion(
        motion.skeleton,
        q,
        motion.root_positions.copy(),
        motion.frame_time,
        None if motion.translations is None else motion.translations.copy(),
    )


# ------------------------------------------------------------------------ planted feet


@dataclass
class FootLockResult:
    """What :func:`lock_repaired_feet` did: the motion, the written cells (the repair's plus
    the leg cells the IK changed), and the contact runs it held (``contacts``, or None when
    the rig has no legs the IK can drive)."""

    motion: Motion
    written: np.ndarray
    contacts: object | None


def lock_repaired_feet(
    repaired: Motion, written: np.ndarray, config: object | None = None
) -> FootLockResult:
    """Keep planted feet planted where the repair changed a leg, and change nothing else.

    A foot joint is *touched* at the frames where the repair wrote a cell of a joint that moves
    it (every joint above it, pelvis included: a joint's own rotation does not move the joint,
    so a repaired toe alone leaves the leg as it was). Contacts are those
    :func:`mocapkit.features.foot_contacts` detects on the repaired take; a contact run with
    touched frames is held by damped-least-squares IK on the whole leg (:func:`mocapkit.ik.solve`,
    ``config`` a :class:`~mocapkit.ik.FootLockConfig`) at the positions its untouched frames
    plant the foot (interpolated between them; :func:`mocapkit.ik.lock_targets` ``pins``), so
    the held foot meets the capture's own foot where the repair ends. Only touched frames
    change: away from a contact the pull fades out before the first untouched frame, and every
    untouched frame stays bit for bit (a whole run held at one point moved good frames by
    centimetres and made the foot jump where the run ended).

    Around a held run the correction fades as an offset on the foot's own path
    (:class:`~mocapkit.ik.FootLockConfig` ``ramp="offset"``, unless ``config`` says otherwise),
    not as a pull toward the held point: pulled, a swinging foot was dragged to where it would
    land and its ankle turned 42-61 deg off the clean take (newcomer report). Largest turn of a
    leg joint off the clean take near the errors, Bandai-1 (bench/eval_clean.py --repair;
    chosen on the tuning half, validation half reported): 24.4 / 37.2 / 6.4 deg pulled, 16.6 /
    33.0 / 5.9 as an offset (locomotion / dance-fight / gestures; 6.5 / 24.9 / 4.0 unlocked),
    for a little more foot slide (0.122 / 0.125 / 0.014 m/s against 0.115 / 0.120 / 0.013).

    Relies on: a repaired leg is rebuilt from other steps of the take, whose foot lands a few
    centimetres elsewhere; the performer's foot did not slide while planted, and the frames the
    repair did not write show where it was."""
    import dataclasses

    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.core.runs import true_runs
    from mocapkit.features import foot_contacts, ground_frame
    from mocapkit.ik import FootLockConfig, leg_chains, lock_targets, solve

    written = np.asarray(written, dtype=bool)
    try:
        chains = leg_chains(repaired)
        contacts = foot_contacts(repaired) if chains else None
    except (ValueError, KeyError):  # no legs, no feet or no ground: nothing to hold
        return FootLockResult(repaired, written, None)
    if not chains or contacts is None or not len(contacts.joints):
        return FootLockResult(repaired, written, None)
    sk = repaired.skeleton
    effs = [e for c in chains for e in c.effectors]
    F = repaired.num_frames
    touched = np.stack([written[:, list(sk.ancestors(e))].any(axis=1) for e in effs], axis=1)
    flags = np.zeros((F, len(effs)), dtype=bool)
    held = np.zeros_like(contacts.contacts)
    for k, foot in enumerate(contacts.joints):
        if int(foot) not in effs:
            continue
        e = effs.index(int(foot))
        for a, b in true_runs(contacts.contacts[:, k]):
            if touched[a : b + 1, e].any():
                held[a : b + 1, k] = flags[a : b + 1, e] = True
    held_contacts = dataclasses.replace(contacts, contacts=held)
    if not flags.any():
        return FootLockResult(repaired, written, held_contacts)
    cfg = config if config is not None else FootLockConfig(ramp="offset")
    body = body_of(repaired)
    pos, _ = forward_kinematics(repaired)
    blend = repaired.seconds_to_frames(cfg.blend)
    up = None if cfg.lock_height else ground_frame(body.up)[1]
    targets, weights = lock_targets(
        pos[:, effs], flags, blend, cfg.anchor, up, cfg.ramp, pins=flags & ~touched
    )
    # frames from the nearest untouched one: the pull outside a contact fades to 0 before it
    # (inside a run the pinned targets already meet the untouched foot)
    edge = np.full((F, len(effs)), float(F))
    for e in range(len(effs)):
        free = np.flatnonzero(~touched[:, e])
        if len(free):
            i = np.arange(F)
            j = np.clip(np.searchsorted(free, i), 1, len(free)) - 1
            nxt = np.clip(j + 1, 0, len(free) - 1)
            edge[:, e] = np.minimum(np.abs(i - free[j]), np.abs(free[nxt] - i))
    x = np.clip(edge / (blend + 1), 0.0, 1.0)
    fade = np.where(flags, 1.0, x * x * (3 - 2 * x))
    weights = weights * fade * touched
    res = solve(repaired, chains, targets, weights, cfg.ik, body)
    changed = np.any(res.motion.rotations != repaired.rotations, axis=-1)
    return FootLockResult(res.motion, written | changed, held_contacts)


def foot_slide(motion: Motion, contacts: object, frames: np.ndarray | None = None) -> float:
    """Mean horizontal speed (metres per second) of the foot joints of ``contacts`` (a
    :class:`~mocapkit.features.FootContacts`) over their planted frames (restricted to the
    (F,) bool ``frames`` when given); NaN when no foot is planted there."""
    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.features import ground_frame

    body = body_of(motion)
    pos, _ = forward_kinematics(motion)
    up = ground_frame(body.up)[1]
    feet = pos[:, list(contacts.joints)]
    feet = feet - (feet @ up)[..., None] * up
    v = np.zeros(feet.shape[:2])
    v[1:-1] = np.linalg.norm(feet[2:] - feet[:-2], axis=-1) / (2 * motion.frame_time)
    planted = np.asarray(contacts.contacts, dtype=bool).copy()
    planted[[0, -1]] = False
    if frames is not None:
        planted &= np.asarray(frames, dtype=bool)[:, None]
    if not planted.any():
        return float("nan")
    return float(v[planted].mean() * body.metres_per_unit)
