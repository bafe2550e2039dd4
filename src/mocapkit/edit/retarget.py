"""Retargeting: a motion on one rig played by another rig.

Correspondence comes from the body model (:func:`mocapkit.body.body_of`): pelvis, the spine
chain, neck and head, and per side hip, knee, ankle, toe, clavicle, shoulder, elbow, wrist and hand.
Spines of different lengths are matched by arc-length fraction between pelvis and neck; a JSON
map (``{"TargetJoint": "SourceJoint", "OtherTarget": null}``) overrides or removes entries.

Rest poses differ (T-pose or A-pose, bone axes along X or along Y, Bandai's rest with every bone
along X). So each rig gets a **reference pose**: its zero pose where that is a standing pose (the
legs below the pelvis, the spine above), else the frame of its own motion with the straightest
legs. In that pose every mapped bone gets a **canonical frame**: the primary axis along the bone
(to the next mapped joint), the secondary the body's forward (left for feet, which point
forward), both rigs measured the same way. Per frame, the target bone's global rotation is the
source bone's global rotation carried through both canonical frames
(``G_T = U G_S B_S B_T^-1``, ``B = G_ref^-1 F_ref``), then swung so that the bone points exactly
along the source's posed bone: positions follow the source's directions, twist follows its
rotations. Joints between mapped ones keep their reference pose relative to their parent.
Then each two-bone limb (hip-knee-ankle, shoulder-elbow-wrist) is re-aimed so that its end
sits in the source's direction from the limb root at the source's reach as a fraction of the
limb's length, the hinge in the source's bending plane (rigs divide a limb between its two
bones differently; see :func:`_match_reach`). Last, the effector goals
(``RetargetConfig.effector_goals``, head and wrists by default): the effector's path relative
to the pelvis, scaled by its limb's length, is the source's plus the clip's mean offset of the
bone-copied pose (the rig's own proportions); the spine joints bend to bring the head there
(:func:`_aim_spine`), each arm re-aims its wrist there from the shoulder, the elbow bending
about the source's plane normal and never backwards, the reach clamped and the shortfall
reported. Without them the head's and shoulders' offsets from the pelvis, which differ between
rigs relative to the spine's and arm's lengths, turn with the torso and carry the effector
along a path that is not the source's.

The pelvis path is scaled by the ratio of leg lengths (hip to ankle), units converted
(``metres_per_unit``) and the up axis turned (``U``). Then, optionally, the feet are locked over
the source's contacts (:func:`mocapkit.ik.lock_feet`; the detected runs kept only where the
source joint is really still, ``RetargetConfig.contact_drift``), and a ground root (Bandai's
``joint_Root``) is put back on the body's ground path.

:func:`retarget` also measures the result (:class:`Retargeted.to_json`): foot slide during the
source's detected contacts (source, output without and with IK), the end-effector paths relative
to the pelvis scaled by the pelvis-to-effector chain length, and hinge joints bent backwards.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.body import Body, body_of
from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import fk_arrays, forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.core.runs import true_runs
from mocapkit.features import (
    FootContacts,
    foot_contacts,
    ground_frame,
    ground_root_on_path,
    heading_angles,
    resample,
)
from mocapkit.ik import FootLockConfig, flexion_angles, hinge_axis, lock_feet
from mocapkit.summary import nominal_fps

__all__ = [
    "RetargetConfig",
    "Retargeted",
    "RigError",
    "load_map",
    "read_target",
    "retarget",
]


class RigError(ValueError):
    """A rig that cannot take part in retargeting; ``role`` says which: "source" or "target"."""

    def __init__(self, role: str, message: str):
        super().__init__(f"the {role} rig: {message}")
        self.role = role


_LIMBS = (
    ("hip", "knee", "ankle", "toe"),
    ("clavicle", "shoulder", "elbow", "wrist", "hand"),
)
_HINGES = (("hip", "knee", "ankle"), ("shoulder", "elbow", "wrist"))
_EFFECTORS = ("left_ankle", "right_ankle", "left_wrist", "right_wrist", "head")
_EPS = 1e-6


@dataclass(frozen=True)
class RetargetConfig:
    """Tunables of :func:`retarget` (seconds, degrees)."""

    #: Lock planted feet with IK over the source's detected contacts: retargeting to other
    #: proportions makes planted feet slide (the pelvis path is scaled, the legs are not).
    foot_lock: bool = True
    #: How feet are locked (blend time, anchor, solver). The blends ramp a fading offset: a
    #: foot swings into and out of a contact fast, and pulling it toward the planted point over
    #: the blend would reshape the swing (the ankle's path relative to the pelvis).
    lock: FootLockConfig = field(default_factory=lambda: FootLockConfig(ramp="offset"))
    #: Match each limb's reach (hip-knee-ankle, shoulder-elbow-wrist) by a two-bone solve: the
    #: end effector's direction from the limb root and its distance as a fraction of the limb's
    #: length equal the source's, the hinge in the source's bending plane. Rigs split a limb
    #: differently (CMU upper arm / forearm 1.63, Bandai 1.09), so copying each bone's
    #: direction alone moves a bent limb's end to another place relative to the body.
    match_reach: bool = True
    #: Effectors whose path relative to the pelvis, scaled by their limb's length, is a goal
    #: (``"head"``, ``"wrist"``, ``"ankle"``): the effector is aimed at the source's pelvis-
    #: relative position times (target limb / source limb), plus the clip's mean offset of the
    #: bone-copied pose (the rig's own proportions). Copying bone directions leaves the head and
    #: shoulders where the rig's spine and torso put them: their offset from the pelvis,
    #: relative to the arm's (or spine's) length, differs between rigs (CMU's shoulders sit
    #: wider and higher for its arm), and that offset turns with the torso, so the wrist's path
    #: relative to the pelvis turns with it. The head is reached by bending the spine joints
    #: (spread over them), a wrist or ankle by its two-bone limb from the shoulder or hip;
    #: beyond the limb's reach the goal is clamped and reported (``effector_goals``).
    effector_goals: tuple[str, ...] = ("head", "wrist")
    #: A source foot joint counts as planted only within this distance (metres, horizontal) of
    #: where its contact run holds it (the run's median position); frames further away leave
    #: the run, which may split it. A planted joint moves by marker noise and shoe compression
    #: (1-2 cm); further, it has lifted (heel-off rolls the ankle forward over the toe, which
    #: carries the contact) or slides, and locking it at one point drags the leg there.
    contact_drift: float = 0.03
    #: A hinge (knee, elbow) bent backwards by more than this counts as a limit violation
    #: (degrees): a straight capture leg reads a few degrees either side of 0 from marker noise.
    hyperextension: float = 10.0
    #: Output frame rate (None: keep the source's exact frame time).
    fps: float | None = None


# =============================================================================================
# inputs


def read_target(path: str | Path, lenient: bool = False) -> Motion:
    """The target rig from any file mocapkit reads, an ASF skeleton alone included (then a
    one-frame motion in its zero pose)."""
    from mocapkit.io import read_motion

    p = Path(path)
    if p.suffix.lower() == ".asf":
        from mocapkit.io.asfamc import read_asf

        sk = read_asf(p).to_skeleton()
        q = rot.quat_identity((1, sk.num_joints))
        return Motion(sk, q, sk.offsets[:1].copy(), 1.0 / 120.0)
    return read_motion(p, lenient=lenient)


def load_map(path: str | Path) -> dict[str, str | None]:
    """A joint map file: a JSON object ``{"TargetJoint": "SourceJoint" | null}``. A ValueError
    naming the file says what is wrong in one line."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise ValueError(
            f"{p}: not valid JSON (line {e.lineno}, column {e.colno}: {e.msg})"
        ) from None
    except UnicodeDecodeError:
        raise ValueError(f"{p}: not a UTF-8 text file") from None
    if not isinstance(data, dict):
        raise ValueError(
            f'{p}: a joint map must be a JSON object {{"TargetJoint": "SourceJoint", ...}}'
        )
    for k, v in data.items():
        if v is not None and not isinstance(v, str):
            raise ValueError(
                f"{p}: the value for {k!r} must be a source joint name or null, got {v!r}"
            )
    return dict(data)


# =============================================================================================
# reference poses and canonical frames


def _is_standing(body: Body, pos: np.ndarray) -> bool:
    """Whether a pose (J, 3) stands: both legs point away from the spine, feet off the legs."""
    up_j = body.neck if body.neck is not None else body.head
    if up_j is None:
        return False
    spine = pos[up_j] - pos[body.pelvis]
    n = np.linalg.norm(spine)
    if n < _EPS:
        return False
    spine = spine / n
    for side in ("left", "right"):
        hip, ank, toe = (body.joint(f"{side}_{k}") for k in ("hip", "ankle", "toe"))
        if hip is None or ank is None:
            return False
        leg = pos[ank] - pos[hip]
        if np.dot(leg, spine) > -0.8 * np.linalg.norm(leg):
            return False
        if toe is not None and toe != ank:
            foot = pos[toe] - pos[ank]
            if abs(np.dot(foot, leg)) > 0.7 * np.linalg.norm(foot) * np.linalg.norm(leg):
                return False
    return True


def _ever_upright(motion: Motion, body: Body) -> bool:
    """Whether the rig's zero pose or any frame of ``motion`` (every frame up to 400, else 400
    spread over it) holds the body upright: the pelvis-to-neck direction within 45 deg of the
    up axis and both ankles below the pelvis by a third of their leg's length or more. A person
    stands, walks or runs upright in some frame of nearly any take (every Bandai, CMU and
    corpus take but a 1-frame pose tilted 45 deg); a four-legged rig never does (the corpus'
    Bip01 elephant)."""
    up_j = body.neck if body.neck is not None else body.head
    legs = [(body.joint(f"{side}_hip"), body.joint(f"{side}_ankle")) for side in ("left", "right")]
    if up_j is None or any(j is None for leg in legs for j in leg):
        return True  # nothing to judge by: the mapping itself says what is missing
    _, u, _ = ground_frame(body.up)
    sk = motion.skeleton
    zero = Motion(sk, rot.quat_identity((1, sk.num_joints)), sk.offsets[:1].copy(), 1.0)
    step = max(1, motion.num_frames // 400)
    pos = np.concatenate([forward_kinematics(zero)[0], forward_kinematics(motion[::step])[0]])
    spine = pos[:, up_j] - pos[:, body.pelvis]
    ok = spine @ u > np.cos(np.radians(45.0)) * np.linalg.norm(spine, axis=-1)
    for hip, ankle in legs:
        length = np.linalg.norm(pos[:, ankle] - pos[:, hip], axis=-1)
        ok &= (pos[:, body.pelvis] - pos[:, ankle]) @ u > length / 3.0
    return bool(ok.any())


def _reference(motion: Motion, body: Body) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference pose of a rig: (positions (J,3), global rotations (J,4), local rotations
    (J,4)). The zero pose when it stands, else the motion's frame with the straightest legs."""
    sk = motion.skeleton
    zero = Motion(sk, rot.quat_identity((1, sk.num_joints)), sk.offsets[:1].copy(), 1.0)
    zp, zg = forward_kinematics(zero)
    if _is_standing(body, zp[0]) or motion.num_frames == 0:
        return zp[0], zg[0], zero.rotations[0]
    step = max(1, motion.num_frames // 400)
    sub = motion[::step]
    pos, grot = forward_kinematics(sub)
    score = np.zeros(sub.num_frames)
    for side in ("left", "right"):
        hip, knee, ank = (body.joint(f"{side}_{k}") for k in ("hip", "knee", "ankle"))
        if None in (hip, knee, ank):
            continue
        u = pos[:, knee] - pos[:, hip]
        v = pos[:, ank] - pos[:, knee]
        c = np.einsum("fi,fi->f", u, v) / np.maximum(
            np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1), 1e-12
        )
        score += np.arccos(np.clip(c, -1, 1))
    f = int(np.argmin(score))
    return pos[f], grot[f], sub.rotations[f]


def _body_axes(body: Body, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(forward, left) unit vectors of a pose (J, 3): left from the hips (else shoulders), up
    from pelvis to neck, forward = left x up."""
    pair = body.pair("hip") or body.pair("shoulder")
    up_j = body.neck if body.neck is not None else body.head
    up = pos[up_j] - pos[body.pelvis] if up_j is not None else np.array([0.0, 1.0, 0.0])
    up = up / max(np.linalg.norm(up), _EPS)
    left = np.cross(up, [0.0, 0.0, 1.0]) if pair is None else pos[pair[0]] - pos[pair[1]]
    left = left - np.dot(left, up) * up
    left = left / max(np.linalg.norm(left), _EPS)
    fwd = np.cross(left, up)
    return fwd, left


def _frame_quat(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """(..., 4) rotation whose x axis is ``primary`` and y axis ``secondary`` made orthogonal."""
    p = primary / np.maximum(np.linalg.norm(primary, axis=-1, keepdims=True), 1e-12)
    s = secondary - np.sum(secondary * p, axis=-1, keepdims=True) * p
    ns = np.linalg.norm(s, axis=-1, keepdims=True)
    # a secondary along the bone: any perpendicular does (only for degenerate rigs)
    alt = np.cross(p, np.array([0.0, 0.0, 1.0]) if abs(p.reshape(-1, 3)[0, 2]) < 0.9 else [1, 0, 0])
    s = np.where(ns > 1e-6, s / np.maximum(ns, 1e-12), alt / np.linalg.norm(alt))
    m = np.stack([p, s, np.cross(p, s)], axis=-1)
    return rot.matrix_to_quat(m)


# =============================================================================================
# correspondence


@dataclass
class _Entry:
    """One mapped target joint: where it sits on the source (a point between source joints a
    and b, weight w toward b), the source joint whose rotation drives it, its chain role."""

    a: int
    b: int
    w: float
    key: str
    chord: int | None = None  # the target joint its bone points at
    prev: int | None = None  # for a bone without chord: the mapped joint above it


def _src_point(pos: np.ndarray, e: _Entry) -> np.ndarray:
    return (1.0 - e.w) * pos[..., e.a, :] + e.w * pos[..., e.b, :]


def _chain_fraction(ref: np.ndarray, chain: list[int]) -> np.ndarray:
    d = np.linalg.norm(np.diff(ref[chain], axis=0), axis=-1)
    c = np.concatenate([[0.0], np.cumsum(d)])
    return c / c[-1] if c[-1] > _EPS else np.linspace(0, 1, len(chain))


def _auto_map(
    bS: Body, bT: Body, refS: np.ndarray, refT: np.ndarray
) -> tuple[dict[int, _Entry], list[list[int]]]:
    """Target joint -> entry, and the chains (lists of target joints, top first)."""
    entries: dict[int, _Entry] = {}
    chains: list[list[int]] = []
    # centre: pelvis .. neck by arc-length fraction, then neck, head
    anchors = [
        k for k in ("pelvis", "neck", "head") if bS.joint(k) is not None and bT.joint(k) is not None
    ]
    if "pelvis" not in anchors:
        anchors.insert(0, "pelvis")
    centre: list[int] = []
    for k0, k1 in itertools.pairwise(anchors):
        segT = _between(bT, k0, k1)
        segS = _between(bS, k0, k1)
        fT = _chain_fraction(refT, segT)
        fS = _chain_fraction(refS, segS)
        for j, f in zip(segT[:-1], fT[:-1], strict=True):
            i = int(np.clip(np.searchsorted(fS, f, side="right") - 1, 0, len(segS) - 2))
            span = fS[i + 1] - fS[i]
            w = 0.0 if span < _EPS else float((f - fS[i]) / span)
            a, b = segS[i], segS[i + 1]
            if w > 1 - 1e-9:
                a, w = b, 0.0
            if j == segT[0]:  # the anchor itself (not a zero-length joint beside it)
                a, b, w = segS[0], segS[0], 0.0
            entries[j] = _Entry(a, b, w, k0 if j == segT[0] else "spine")
            centre.append(j)
    last = anchors[-1]
    entries[bT.joint(last) if last != "pelvis" else bT.pelvis] = _Entry(
        bS.joint(last) or bS.pelvis, bS.joint(last) or bS.pelvis, 0.0, last
    )
    centre.append(bT.joint(last) if last != "pelvis" else bT.pelvis)
    chains.append(centre)
    for side in ("left", "right"):
        for limb in _LIMBS:
            chain: list[int] = []
            for k in limb:
                jt, js = bT.joint(f"{side}_{k}"), bS.joint(f"{side}_{k}")
                if jt is None or js is None or jt in entries:
                    continue
                if k == "hand" and (
                    bT.joint(f"{side}_wrist") == jt or bS.joint(f"{side}_wrist") == js
                ):
                    continue  # a rig whose hand is its wrist: nothing more to map
                entries[jt] = _Entry(js, js, 0.0, k)
                chain.append(jt)
            if chain:
                chains.append(chain)
    return entries, chains


def _between(body: Body, k0: str, k1: str) -> list[int]:
    """Joints from part k0 down to part k1 (both included) along the skeleton."""
    j0 = body.pelvis if k0 == "pelvis" else body.joint(k0)
    j1 = body.joint(k1)
    path = [j1]
    for a in body.skeleton.ancestors(j1):
        path.append(a)
        if a == j0:
            break
    return path[::-1]


def _apply_map(
    entries: dict[int, _Entry],
    chains: list[list[int]],
    user: Mapping[str, str | None],
    skT: Any,
    skS: Any,
    where: str,
) -> list[list[int]]:
    for tname, sname in user.items():
        if tname not in skT.names:
            raise ValueError(f"{where}: target joint {tname!r} is not in the target skeleton")
        j = skT.names.index(tname)
        if sname is None:
            entries.pop(j, None)
            continue
        if sname not in skS.names:
            raise ValueError(
                f"{where}: source joint {sname!r} (for {tname!r}) is not in the source"
            )
        s = skS.names.index(sname)
        old = entries.get(j)
        entries[j] = _Entry(s, s, 0.0, old.key if old else "custom")
    chains = [[j for j in c if j in entries] for c in chains]
    in_chain = {j for c in chains for j in c}
    chains += [[j] for j in sorted(entries) if j not in in_chain]
    return [c for c in chains if c]


def _link(entries: dict[int, _Entry], chains: list[list[int]], refT, refS, skT) -> None:
    """Each mapped joint's chord (the next chain joint at a distance in both rigs) or, for the
    last of a chain, the mapped joint above it."""
    mapped = set(entries)
    for c in chains:
        for i, j in enumerate(c):
            e = entries[j]
            for k in c[i + 1 :]:
                dT = np.linalg.norm(refT[k] - refT[j])
                dS = np.linalg.norm(_src_point(refS, entries[k]) - _src_point(refS, e))
                if dT > _EPS and dS > _EPS:
                    e.chord = k
                    break
            if e.chord is None:
                prev = [k for k in c[:i] if np.linalg.norm(refT[k] - refT[j]) > _EPS]
                if prev:
                    e.prev = prev[-1]
                else:  # nearest mapped ancestor
                    e.prev = next((a for a in skT.ancestors(j) if a in mapped), None)


# =============================================================================================
# the result


@dataclass(frozen=True, eq=False)
class Retargeted:
    """What :func:`retarget` returns.

    Attributes:
        motion: the retargeted motion on the target skeleton.
        without_ik: the same before foot locking (equal to ``motion`` without it).
        mapping: target joint name -> source joint name (the driving joint; spine joints
            between two source joints name the upper one's lower neighbour too, as "a|b").
        scale: the pelvis path's scale (target leg length / source leg length, in metres).
        figures: the measured figures (see :meth:`to_json`).
    """

    motion: Motion
    without_ik: Motion
    mapping: dict[str, str]
    scale: float
    figures: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        """``frames``, ``fps``, ``scale``, ``mapping``, and the figures: ``foot_slide_cm``
        (mean and max horizontal distance of each planted foot joint from its contact run's
        mean position, over the source's detected contacts: ``source``, ``output_without_ik``,
        ``output``; the contacts are the detector's runs kept where the source joint stays
        within ``contact_drift``: ``contacts`` gives both frame counts), ``ik_residual_cm``
        (mean and max distance the foot-lock IK left a planted joint from its target on fully
        locked frames; None without foot locking), ``effector_path_error_pct`` (per
        effector, mean and 95th percentile of |d - mean(d)| x 100, d = p_T/L_T - p_S/L_S in
        the source's heading frame, p the effector relative to the pelvis,
        L its limb's length (hip-knee-ankle, shoulder-elbow-wrist, pelvis to head); the mean
        offset removed is the rigs' constant difference in proportions, reported as
        ``uncentred_mean``), ``effector_goals`` (the effectors aimed at goals, and per goal
        how far it was out of reach: frames clamped, mean and max shortfall in cm),
        ``joint_limits`` (per knee and elbow, frames bent backwards
        beyond the margin in the source and in the output, and whether the output kept every
        limit the source kept), ``warnings`` (a rig that never stands upright)."""
        return {
            "frames": self.motion.num_frames,
            "fps": nominal_fps(self.motion.frame_time),  # 30, not 30.00003
            "scale": self.scale,
            "mapping": dict(self.mapping),
            **self.figures,
        }


# =============================================================================================
# the transfer


def _transfer(
    source: Motion,
    bS: Body,
    target: Motion,
    bT: Body,
    user_map: Mapping[str, str | None] | None,
    map_name: str,
    match_reach: bool = True,
    goals: tuple[str, ...] = (),
) -> tuple[Motion, dict[str, Any]]:
    skS, skT = source.skeleton, target.skeleton
    refS_p, refS_g, _ = _reference(source, bS)
    refT_p, refT_g, refT_l = _reference(target, bT)
    entries, chains = _auto_map(bS, bT, refS_p, refT_p)
    # joints the map removes keep their reference pose: no later stage may move them again
    # (the reach matching and the goals re-aimed a limb whose thigh was mapped to null)
    unmapped = frozenset(
        skT.names.index(t) for t, v in (user_map or {}).items() if v is None and t in skT.names
    )
    if user_map:
        chains = _apply_map(entries, chains, user_map, skT, skS, map_name)
    if not entries:
        raise ValueError("no joint of the target corresponds to one of the source")
    _link(entries, chains, refT_p, refS_p, skT)
    fwdS, leftS = _body_axes(bS, refS_p)
    fwdT, leftT = _body_axes(bT, refT_p)

    # canonical frames in each reference pose -> constant B per mapped joint
    order = sorted(entries)
    B_S, B_T = [], []
    for j in order:
        e = entries[j]
        if e.chord is not None:
            pT = refT_p[e.chord] - refT_p[j]
            pS = _src_point(refS_p, entries[e.chord]) - _src_point(refS_p, e)
        elif e.prev is not None:
            pT = refT_p[j] - refT_p[e.prev]
            pS = _src_point(refS_p, e) - _src_point(refS_p, entries[e.prev])
        else:
            pT, pS = refT_p[j] - refT_p[0], _src_point(refS_p, e) - refS_p[0]
            if np.linalg.norm(pT) < _EPS or np.linalg.norm(pS) < _EPS:
                pT, pS = np.cross(fwdT, leftT), np.cross(fwdS, leftS)
        feet = e.key in ("ankle", "toe")
        FT = _frame_quat(pT, leftT if feet else fwdT)
        FS = _frame_quat(pS, leftS if feet else fwdS)
        B_S.append(rot.quat_mul(rot.quat_inv(refS_g[e.a]), FS))
        B_T.append(rot.quat_mul(rot.quat_inv(refT_g[j]), FT))

    # world: source up axis -> target up axis, units, leg-length scale
    upS, upT = ground_frame(bS.up)[1], ground_frame(bT.up)[1]
    U = rot.quat_between(upS, upT)
    legS, legT = _leg_length(bS, refS_p, "source"), _leg_length(bT, refT_p, "target")
    scale = (legT * bT.metres_per_unit) / max(legS * bS.metres_per_unit, 1e-12)
    k = scale * bS.metres_per_unit / bT.metres_per_unit  # source units -> target units

    posS, grotS = forward_kinematics(source)
    F = source.num_frames
    JT = skT.num_joints
    G = np.empty((F, JT, 4))
    Uf = np.broadcast_to(U, (F, 4))
    mapped = {j: i for i, j in enumerate(order)}
    for j in range(JT):
        p = int(skT.parents[j])
        if j in mapped:
            e = entries[j]
            i = mapped[j]
            C = rot.quat_mul(Uf, rot.quat_mul(grotS[:, e.a], B_S[i]))
            if e.chord is not None:
                want = _src_point(posS, entries[e.chord]) - _src_point(posS, e)
                cur = rot.quat_apply(C, np.array([1.0, 0.0, 0.0]))
                C = rot.quat_mul(rot.quat_between(cur, rot.quat_apply(Uf, want)), C)
            G[:, j] = rot.quat_mul(C, rot.quat_inv(B_T[i]))
        elif p < 0:
            G[:, j] = rot.quat_identity(F) if bT.ground_root == j else refT_l[j]
        else:
            G[:, j] = rot.quat_mul(G[:, p], refT_l[j])
    free = [j for j in range(JT) if j not in mapped and skT.parents[j] >= 0]
    face = rot.rotvec_to_quat(-heading_angles(source, bS.up)[:, None] * upT)
    goals_on = set(goals)
    clamped: dict[str, Any] = {}
    refS_l = source.skeleton.rest_positions()
    refT_r = skT.rest_positions()

    def goal(Gc: np.ndarray, key: str) -> np.ndarray | None:
        """Where ``key`` should be relative to the target pelvis (F, 3): the source's
        pelvis-relative path times LT / LS in the source's heading frame, plus the mean
        offset of the pose ``Gc`` from it (the rig's own proportions)."""
        js, jt = bS.joint(key), bT.joint(key)
        if js is None or jt is None:
            return None
        LS, LT = _limb_len(bS, refS_l, key), _limb_len(bT, refT_r, key)
        if LS < _EPS or LT < _EPS:
            return None
        pc = _positions(Gc, skT)
        hS = rot.quat_apply(face, rot.quat_apply(Uf, posS[:, js] - posS[:, bS.pelvis])) / LS
        hT = rot.quat_apply(face, pc[:, jt] - pc[:, bT.pelvis]) / LT
        c = (hT - hS).mean(axis=0)
        return rot.quat_apply(rot.quat_inv(face), (hS + c) * LT)

    head = bT.joint("head")
    spine = set(_between(bT, "pelvis", "head")) if head is not None else set()
    if "head" in goals_on and head is not None and not spine & unmapped:
        want = goal(G, "head")
        if want is not None:
            G = _aim_spine(G, skT, bT, want, free, refT_l, clamped)
    L = _local(G, skT)
    if match_reach:
        G1 = _match_reach(G, L, skT, bT, source, posS, grotS, bS, Uf, keep=unmapped)
        limb_goals = {}
        for key in ("left_wrist", "right_wrist", "left_ankle", "right_ankle"):
            if key.split("_")[1] in goals_on:
                w = goal(G1, key)
                if w is not None:
                    limb_goals[key] = w
        if limb_goals:
            G1 = _match_reach(G, L, skT, bT, source, posS, grotS, bS, Uf, limb_goals, clamped,
                              keep=unmapped)  # fmt: skip
        G = G1
        L = _local(G, skT)

    # the pelvis path
    pel = rot.quat_apply(Uf, posS[:, bS.pelvis]) * k
    trans = np.broadcast_to(skT.offsets, (F, JT, 3)).copy()
    root = np.broadcast_to(skT.offsets[0], (F, 3)).copy()
    if bT.ground_root is not None:
        root[:] = 0.0
    out = Motion(
        skT, L, root, source.frame_time, trans if target.translations is not None else None
    )
    out = _place_pelvis(out, bT, pel)
    # feet on the source's ground (scaled): the lowest foot point over the clip
    pT, _ = forward_kinematics(out)
    feetT = [j for _, j in bT.feet] or [0]
    feetS = [j for _, j in bS.feet] or [0]
    gS = np.percentile((rot.quat_apply(U, posS[:, feetS]) * k) @ upT, 2)
    gT = np.percentile(pT[:, feetT] @ upT, 2)
    out = _place_pelvis(out, bT, pel + (gS - gT) * upT)
    names = {
        skT.names[j]: skS.names[e.a] if e.w == 0 else f"{skS.names[e.a]}|{skS.names[e.b]}"
        for j, e in sorted(entries.items())
    }
    info = {
        "mapping": names,
        "scale": float(scale),
        "U": U,
        "B_S": dict(zip(order, B_S, strict=True)),
        "B_T": dict(zip(order, B_T, strict=True)),
        "clamped": clamped,
        "unmapped": unmapped,
        "upright": {"source": _ever_upright(source, bS), "target": _ever_upright(target, bT)},
    }
    return out, info


def _local(G: np.ndarray, sk: Any) -> np.ndarray:
    """Local rotations (F, J, 4) from global ones."""
    L = G.copy()
    nonroot = sk.parents >= 0
    L[:, nonroot] = rot.quat_mul(rot.quat_inv(G[:, sk.parents[nonroot]]), G[:, nonroot])
    return rot.quat_unroll(rot.quat_normalize(L), axis=0)


def _positions(G: np.ndarray, sk: Any) -> np.ndarray:
    """Joint positions (F, J, 3) of global rotations (F, J, 4) on the skeleton's offsets, the
    root at its offset (only positions relative to one another are meant)."""
    F, J = G.shape[:2]
    pos = np.empty((F, J, 3))
    for j in range(J):
        p = int(sk.parents[j])
        pos[:, j] = sk.offsets[j] if p < 0 else pos[:, p] + rot.quat_apply(G[:, p], sk.offsets[j])
    return pos


def _aim_spine(
    G: np.ndarray,
    sk: Any,
    body: Body,
    want: np.ndarray,
    free: list[int],
    ref_local: np.ndarray,
    clamped: dict[str, Any],
) -> np.ndarray:
    """Global rotations with the joints between the pelvis and the head swung so that the
    head sits at ``want`` relative to the pelvis (F, 3): bottom-up, each joint takes its share
    (1 / joints left) of the swing that aims the head from it, the joints above it swung with
    it; the head's own rotation and every other mapped joint's (clavicles) stay, unmapped
    joints (``free``) follow their parents. A head distance the rigid chain cannot reach is
    left short (``clamped["head"]``, target units)."""
    head = body.joint("head")
    chain = _between(body, "pelvis", "head")[1:-1]
    if not chain:
        return G
    G = G.copy()
    n = len(chain)
    for i, j in enumerate(chain):
        pos = _positions(G, sk)
        goal = pos[:, body.pelvis] + want
        q = rot.quat_between(pos[:, head] - pos[:, j], goal - pos[:, j])
        q = rot.rotvec_to_quat(rot.quat_to_rotvec(q) / (n - i))
        for k in chain[i:]:
            G[:, k] = rot.quat_mul(q, G[:, k])
    for j in free:
        G[:, j] = rot.quat_mul(G[:, int(sk.parents[j])], ref_local[j])
    pos = _positions(G, sk)
    miss = np.linalg.norm(pos[:, head] - pos[:, body.pelvis] - want, axis=-1)
    clamped["head"] = {"mean_shortfall": float(miss.mean()), "max_shortfall": float(miss.max())}
    return G


def _leg_of(body: Body, key: str, foot: int) -> set[int]:
    """The joints of the leg above ``foot`` (body part ``key``, e.g. ``left_toe``), hip to
    foot: those a foot lock turns (not the pelvis or a ground root above it)."""
    hip = body.joint(f"{key.split('_')[0]}_hip")
    path = None if hip is None else _path_down(body.skeleton, hip, foot)
    return {foot, *(path or [])}


def _path_down(sk: Any, top: int, bottom: int) -> list[int] | None:
    """Joints from ``top`` down to ``bottom``'s parent (``top`` included), or None when
    ``top`` is not an ancestor of ``bottom``."""
    path = []
    for a in sk.ancestors(bottom):
        path.append(a)
        if a == top:
            return path[::-1]
    return None


def _match_reach(
    G: np.ndarray,
    L: np.ndarray,
    skT: Any,
    bT: Body,
    source: Motion,
    posS: np.ndarray,
    grotS: np.ndarray,
    bS: Body,
    Uf: np.ndarray,
    goals: Mapping[str, np.ndarray] | None = None,
    clamped: dict[str, Any] | None = None,
    keep: frozenset[int] = frozenset(),
) -> np.ndarray:
    """Global rotations (F, J, 4) with each two-bone limb (hip-knee-ankle, shoulder-elbow-
    wrist) re-aimed so that its end effector sits where the source's does relative to the
    limb root: the same direction, and the same reach as a fraction of the limb's length
    (upper + lower segment). The hinge (knee, elbow) lies in the source's bending plane, on
    the source's side of the root-to-end line, so a hinge bends the way the source's does
    (never backwards unless the source's does). Only the two segments swing (the least
    rotation that aims each); the end joint's own rotation (foot, hand) is untouched.

    Relies on a limb's end effector position relative to the body being what the motion
    means (a hand reaching a point, a foot under the body), whereas how the limb divides its
    length between its two bones is the rig's: a bent limb whose bones copy the source's
    directions reaches elsewhere when its upper/lower ratio differs.

    ``goals``: end effector key (``"left_wrist"``) -> where the limb's end should be relative
    to the target's pelvis (F, 3); that limb then aims its end there instead (reach clamped to
    the limb's, ``clamped`` receives per key the frames clamped and the largest shortfall in
    target units), the hinge still in the source's bending plane. A limb holding a joint of
    ``keep`` (unmapped by the user) is left as it is."""
    F = G.shape[0]
    ltrans = np.broadcast_to(skT.offsets, (F, skT.num_joints, 3))
    posT, _ = fk_arrays(skT.parents, L, ltrans)
    G = G.copy()
    for side in ("left", "right"):
        for trio in _HINGES:
            s = [bS.joint(f"{side}_{k}") for k in trio]
            t = [bT.joint(f"{side}_{k}") for k in trio]
            if None in s or None in t or len(set(t)) < 3 or len(set(s)) < 3:
                continue
            up_seg, lo_seg = _path_down(skT, t[0], t[1]), _path_down(skT, t[1], t[2])
            if up_seg is None or lo_seg is None or keep & {*t, *up_seg, *lo_seg}:
                continue
            # the source limb in the target's world axes (directions only; lengths relative)
            eS = rot.quat_apply(Uf, posS[:, s[1]] - posS[:, s[0]])
            rS = rot.quat_apply(Uf, posS[:, s[2]] - posS[:, s[0]])
            lenS = np.linalg.norm(eS, axis=-1) + np.linalg.norm(
                posS[:, s[2]] - posS[:, s[1]], axis=-1
            )
            dS = np.linalg.norm(rS, axis=-1)
            if np.any(lenS < _EPS):
                continue
            rhat = rS / np.maximum(dS, _EPS)[:, None]
            # the bending plane: the source hinge's offset from the root-to-end line; a straight
            # limb leaves it undefined, so its hinge axis (majority flexion) breaks the tie
            p = eS - np.einsum("fi,fi->f", eS, rhat)[:, None] * rhat
            ax = hinge_axis(posS, grotS, *s)
            axw = rot.quat_apply(Uf, rot.quat_apply(grotS[:, s[0]], np.broadcast_to(ax, (F, 3))))
            p = p / lenS[:, None] + 1e-4 * np.cross(rhat, axw)
            p = p - np.einsum("fi,fi->f", p, rhat)[:, None] * rhat
            phat = p / np.maximum(np.linalg.norm(p, axis=-1), 1e-12)[:, None]
            # the target limb: segment lengths as posed (rigid), reach the source's fraction
            root, mid, end = posT[:, t[0]], posT[:, t[1]], posT[:, t[2]]
            a = np.linalg.norm(mid - root, axis=-1)
            b = np.linalg.norm(end - mid, axis=-1)
            key = f"{side}_{trio[2]}"
            if goals is not None and key in goals:
                want = posT[:, bT.pelvis] + goals[key] - root
                dw = np.linalg.norm(want, axis=-1)
                ok = dw > _EPS
                new = np.where(ok[:, None], want / np.maximum(dw, _EPS)[:, None], rhat)
                # the source's bending plane normal kept (the hinge bends about the same
                # axis, so never backwards where the source's does not), the elbow or knee
                # on its side of the new root-to-end line
                nrm = np.cross(rhat, phat)
                p2 = np.cross(nrm, new)
                n2 = np.linalg.norm(p2, axis=-1)
                alt = phat - np.einsum("fi,fi->f", phat, new)[:, None] * new
                alt = alt / np.maximum(np.linalg.norm(alt, axis=-1), 1e-12)[:, None]
                phat = np.where((n2 > 1e-3)[:, None], p2 / np.maximum(n2, 1e-12)[:, None], alt)
                # a source limb straight or bent backwards within marker noise gives no side
                # to a target limb that must bend further to reach its goal: bend it forwards
                fwd = np.cross(new, axw)
                phat = np.where((np.einsum("fi,fi->f", phat, fwd) < 0)[:, None], -phat, phat)
                rhat = new
                if clamped is not None:
                    over = dw - (a + b)
                    clamped[key] = {
                        "frames": int((over > 1e-9 * (a + b)).sum()),
                        "mean_shortfall": float(np.maximum(over, 0.0).mean()),
                        "max_shortfall": float(max(over.max(initial=0.0), 0.0)),
                    }
                d = np.clip(dw, np.abs(a - b) + 1e-9 * (a + b), a + b)
            else:
                d = np.clip(dS / lenS * (a + b), np.abs(a - b) + 1e-9 * (a + b), a + b)
            cos_al = np.clip((a * a + d * d - b * b) / np.maximum(2 * a * d, 1e-12), -1.0, 1.0)
            sin_al = np.sqrt(1.0 - cos_al * cos_al)
            mid_new = root + a[:, None] * (cos_al[:, None] * rhat + sin_al[:, None] * phat)
            end_new = root + d[:, None] * rhat
            q1 = rot.quat_between(mid - root, mid_new - root)
            q2 = rot.quat_between(end - mid, end_new - mid_new)
            for j in up_seg:
                G[:, j] = rot.quat_mul(q1, G[:, j])
            for j in lo_seg:
                G[:, j] = rot.quat_mul(q2, G[:, j])
    return G


def _leg_length(body: Body, ref: np.ndarray, role: str) -> float:
    out = []
    for side in ("left", "right", "unknown"):
        hip, knee, ank = (body.joint(f"{side}_{k}") for k in ("hip", "knee", "ankle"))
        if None not in (hip, knee, ank):
            out.append(np.linalg.norm(ref[knee] - ref[hip]) + np.linalg.norm(ref[ank] - ref[knee]))
    if not out:
        raise RigError(role, "no legs the body model can find (hip, knee and ankle of a side)")
    return float(np.mean(out))


def _place_pelvis(m: Motion, body: Body, pel: np.ndarray) -> Motion:
    """The motion with its pelvis at world positions ``pel`` (F, 3) (through its own
    translation when it has one below the root, else through the root's)."""
    out = m.copy()
    sk = m.skeleton
    pv = body.pelvis
    if pv == 0:
        out.root_positions = pel.copy()
        if out.translations is not None:
            out.translations[:, 0] = pel
        return out
    pos, grot = forward_kinematics(out)
    par = int(sk.parents[pv])
    if out.translations is not None and sk.has_position[pv]:
        out.translations[:, pv] = rot.quat_apply(rot.quat_inv(grot[:, par]), pel - pos[:, par])
    else:
        out.root_positions = out.root_positions + (pel - pos[:, pv])
        if out.translations is not None:
            out.translations[:, 0] = out.root_positions
    return out


# =============================================================================================
# measurements


def _slide_cm(pos: np.ndarray, flags: np.ndarray, up: np.ndarray, mpu: float) -> dict[str, Any]:
    """Horizontal distance of each planted joint from its run's mean position (cm)."""
    d: list[np.ndarray] = []
    for k in range(flags.shape[1]):
        for a, b in true_runs(flags[:, k]):
            seg = pos[a : b + 1, k]
            dev = seg - seg.mean(axis=0)
            dev = dev - (dev @ up)[:, None] * up
            d.append(np.linalg.norm(dev, axis=-1))
    if not d:
        return {"mean": None, "max": None, "contact_frames": 0}
    x = np.concatenate(d) * mpu * 100.0
    return {"mean": float(x.mean()), "max": float(x.max()), "contact_frames": len(x)}


def _limb_len(body: Body, ref: np.ndarray, key: str) -> float:
    """A limb's length in a rest pose: hip-knee-ankle, shoulder-elbow-wrist, pelvis to head."""
    if key == "head":
        return _chain_len(body.skeleton, ref, body.pelvis, body.joint("head"))
    side, name = key.split("_")
    trio = ("hip", "knee", "ankle") if name == "ankle" else ("shoulder", "elbow", "wrist")
    j = [body.joint(f"{side}_{k}") for k in trio]
    return float(np.linalg.norm(ref[j[1]] - ref[j[0]]) + np.linalg.norm(ref[j[2]] - ref[j[1]]))


def _chain_len(sk: Any, ref: np.ndarray, top: int, j: int) -> float:
    path = [j]
    for a in sk.ancestors(j):
        path.append(a)
        if a == top:
            break
    return float(np.linalg.norm(np.diff(ref[path], axis=0), axis=-1).sum())


def _measure(
    source: Motion,
    bS: Body,
    out: Motion,
    plain: Motion,
    bT: Body,
    info: dict[str, Any],
    contacts: FootContacts,
    flagsT: np.ndarray,
    featT: list[int],
    margin: float,
) -> dict[str, Any]:
    posS, grotS = forward_kinematics(source)
    posT, grotT = forward_kinematics(out)
    posP, _ = forward_kinematics(plain)
    upS, upT = ground_frame(bS.up)[1], ground_frame(bT.up)[1]
    fS = contacts.contacts
    slide = {
        "source": _slide_cm(posS[:, list(contacts.joints)], fS, upS, bS.metres_per_unit),
        "output_without_ik": _slide_cm(posP[:, featT], flagsT, upT, bT.metres_per_unit),
        "output": _slide_cm(posT[:, featT], flagsT, upT, bT.metres_per_unit),
    }
    U = info["U"]
    refS = source.skeleton.rest_positions()
    refT = out.skeleton.rest_positions()
    eff: dict[str, Any] = {}
    face = rot.rotvec_to_quat(-heading_angles(source, bS.up)[:, None] * upT)
    for key in _EFFECTORS:
        js, jt = bS.joint(key), bT.joint(key)
        if js is None or jt is None:
            continue
        LS, LT = _limb_len(bS, refS, key), _limb_len(bT, refT, key)
        # in the source body's heading frame: a constant body-relative difference of the
        # rigs stays constant while the character turns
        rS = rot.quat_apply(face, rot.quat_apply(U, posS[:, js] - posS[:, bS.pelvis])) / LS
        rT = rot.quat_apply(face, posT[:, jt] - posT[:, bT.pelvis]) / LT
        d = rT - rS
        # the path: each clip's mean offset removed, so that the rigs' constant proportions
        # (wider shoulders, a longer spine) do not count as a path error
        err = np.linalg.norm(d - d.mean(axis=0), axis=-1) * 100.0
        eff[key] = {
            "mean": float(err.mean()),
            "p95": float(np.percentile(err, 95)),
            "uncentred_mean": float(np.linalg.norm(d, axis=-1).mean() * 100.0),
        }
    eff_all = float(np.mean([v["mean"] for v in eff.values()])) if eff else None
    limits: dict[str, Any] = {}
    B_S, B_T = info["B_S"], info["B_T"]
    for side in ("left", "right"):
        for trio in _HINGES:
            s = [bS.joint(f"{side}_{k}") for k in trio]
            t = [bT.joint(f"{side}_{k}") for k in trio]
            if None in s or None in t or t[0] not in B_T:
                continue
            axS = hinge_axis(posS, grotS, *s)
            # the same axis on the target: carried through both canonical frames
            q = rot.quat_mul(B_T[t[0]], rot.quat_inv(B_S[t[0]]))
            axT = rot.quat_apply(q, axS)
            flexS = np.degrees(flexion_angles(posS, grotS, *s, axS))
            flexT = np.degrees(flexion_angles(posT, grotT, *t, axT))
            vs, vt = int((flexS < -margin).sum()), int((flexT < -margin).sum())
            limits[f"{side}_{trio[1]}"] = {
                "source_frames_bent_backwards": vs,
                "output_frames_bent_backwards": vt,
                "output_min_flexion_deg": float(flexT.min()) if len(flexT) else None,
                "kept": vt <= vs,
            }
    return {
        "foot_slide_cm": slide,
        "effector_path_error_pct": {"mean": eff_all, "per_effector": eff},
        "joint_limits": {
            "hyperextension_margin_deg": margin,
            "per_joint": limits,
            "all_kept": all(v["kept"] for v in limits.values()),
        },
        "contacts": {
            "joints": [source.skeleton.names[j] for j in contacts.joints],
            "frames": int(fS.any(axis=1).sum()),
        },
    }


def _planted(contacts: FootContacts, source: Motion, body: Body, drift: float) -> FootContacts:
    """The contacts with each run kept only on frames where its joint is within ``drift``
    metres (horizontally) of the run's median position; a run whose kept frames are apart
    splits. Relies on a planted joint staying put: the detector's test (near the ground and
    slower than a walking foot's swing) also passes a heel rolling off over the toe or a foot
    sliding slowly, and one lock point for such a run drags the leg."""
    pos, _ = forward_kinematics(source)
    up = ground_frame(body.up)[1]
    lim = drift / body.metres_per_unit
    flags = np.zeros_like(contacts.contacts)
    for k, j in enumerate(contacts.joints):
        for a, b in true_runs(contacts.contacts[:, k]):
            seg = pos[a : b + 1, j]
            dev = seg - np.median(seg, axis=0)
            dev = dev - (dev @ up)[:, None] * up
            flags[a : b + 1, k] = np.linalg.norm(dev, axis=-1) <= lim
    return replace(contacts, contacts=flags)


def retarget(
    source: Motion,
    target: Motion,
    config: RetargetConfig | None = None,
    joint_map: Mapping[str, str | None] | None = None,
    map_name: str = "joint map",
) -> Retargeted:
    """Play ``source`` on ``target``'s skeleton (see the module notes).

    Args:
        source: the motion to retarget.
        target: any motion on the target rig (its skeleton; its frames only pick a reference
            pose when the zero pose does not stand).
        config: tunables.
        joint_map: target joint name -> source joint name (or None to leave it unmapped),
            over the body model's correspondence.
        map_name: how errors about ``joint_map`` name it (its file).

    Returns:
        :class:`Retargeted` with the motion (source frame time unless ``config.fps``) and the
        figures.
    """
    cfg = config or RetargetConfig()
    if source.num_frames == 0:
        raise ValueError("the source motion has no frames")
    source.check_finite("source")
    bS, bT = body_of(source), body_of(target)
    plain, info = _transfer(
        source, bS, target, bT, joint_map, map_name, cfg.match_reach, cfg.effector_goals
    )
    detected = foot_contacts(source)
    contacts = _planted(detected, source, bS, cfg.contact_drift)
    # the source's contacts on the target's feet (by body part)
    keyS = {p.joint: p.key for p in bS.parts if p.name in ("ankle", "toe")}
    featT: list[int] = []
    cols: list[np.ndarray] = []
    names: list[str] = []
    sides: list[str] = []
    held = info["unmapped"]
    for k, js in enumerate(contacts.joints):
        key = keyS.get(js)
        jt = bT.joint(key) if key else None
        if jt is None or jt in featT or held & _leg_of(bT, key, jt):
            continue  # (a leg the map left unmapped is not locked either)
        featT.append(jt)
        cols.append(contacts.contacts[:, k])
        names.append(target.skeleton.names[jt])
        sides.append(contacts.sides[k])
    flagsT = np.stack(cols, axis=1) if cols else np.zeros((source.num_frames, 0), dtype=bool)
    out = plain
    residual = None
    if cfg.foot_lock and featT:
        cT = FootContacts(tuple(featT), tuple(names), tuple(sides), flagsT, 0.0, 0.0)
        fl = lock_feet(plain, cT, cfg.lock, bT)
        out = fl.motion
        # how far the IK left a planted foot from its target, on fully locked frames
        held = fl.residual[fl.weights >= 1.0] * bT.metres_per_unit * 100.0
        residual = {
            "mean": float(held.mean()) if held.size else None,
            "max": float(held.max()) if held.size else None,
        }
    figures = _measure(
        source, bS, out, plain, bT, info, contacts, flagsT, featT, cfg.hyperextension
    )
    figures["foot_lock"] = bool(cfg.foot_lock and featT)
    figures["ik_residual_cm"] = residual
    cm = bT.metres_per_unit * 100.0
    figures["effector_goals"] = {
        "effectors": list(cfg.effector_goals),
        "clamped": {
            k: {
                **({"frames": v["frames"]} if "frames" in v else {}),
                "mean_shortfall_cm": v["mean_shortfall"] * cm,
                "max_shortfall_cm": v["max_shortfall"] * cm,
            }
            for k, v in info["clamped"].items()
        },
    }
    # a rig none of whose poses stands upright (a four-legged rig named like a biped, a take
    # that lies or crawls throughout on a rig whose rest pose does not stand either) has no
    # pose in which its bones can be matched to a standing body's
    figures["warnings"] = [
        f"the {role} never stands upright (no pose with its legs below the pelvis and its "
        "spine above): retargeting matches upright two-legged bodies, so a four-legged rig "
        "comes out wrong"
        for role, upright in info["upright"].items()
        if not upright
    ]
    figures["contacts"]["detected_frames"] = int(detected.contacts.any(axis=1).sum())
    figures["contacts"]["contact_drift_m"] = cfg.contact_drift
    if bT.ground_root is not None:
        out = ground_root_on_path(out, bT.up)
        plain = ground_root_on_path(plain, bT.up)
    if cfg.fps is not None:
        out, plain = resample(out, cfg.fps), resample(plain, cfg.fps)
    return Retargeted(out, plain, info["mapping"], info["scale"], figures)
