"""Body-part masses and the three body-part weightings of Matsunaga & Zordan.

Every weighting has the same shape, which the tiled cost relies on: the weight of part ``b`` for
the frame pair ``(i, j)`` is ``static[b] + frame[i, b] + frame[j, b]``.

* ``uniform`` (Heuristic 1, Kovar et al.): ``static = 1``, ``frame = 0``.
* ``torso`` (Heuristic 2): hand-set static weights, trunk heavier than head and limbs
  (:data:`TORSO_WEIGHTS`), plus a constant extra (:data:`TORSO_EXTRA`) on the single part
  carrying most of the mass in each frame (the contacting part with the largest supported
  mass, i.e. the planted foot; ties: the first foot joint).
* ``dynamics``: ``static = w_mass(b)`` = mass of b and every part outward from it;
  ``frame[f, b] = w_friction(b) = TotalMass - BranchMass(b)`` for the supporting parts of
  frame f (parts in ground contact and their inward parts on the same limb, the pelvis being
  the root body that belongs to no limb), 0 otherwise. Masses in kg.

Masses come from de Leva (1996), "Adjustments to Zatsiorsky-Seluyanov's segment inertia
parameters", male column (% of body mass, :data:`DE_LEVA_MALE`), mapped to joints by the body
model's segments (:mod:`mocapkit.body`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mocapkit.body import body_of
from mocapkit.core.motion import Motion
from mocapkit.features import FootContacts, foot_contacts
from mocapkit.graph.pointcloud import BodyParts

__all__ = [
    "DE_LEVA_MALE",
    "METRICS",
    "TORSO_EXTRA",
    "TORSO_WEIGHTS",
    "PartWeights",
    "clip_contact_parts",
    "contact_parts_of",
    "load_masses",
    "metric_weights",
    "part_categories",
    "part_masses",
    "support_mask",
    "supporting_parts",
]

#: The comparison metrics: "dynamics" (the paper's), "uniform" (Heuristic 1), "torso"
#: (Heuristic 2).
METRICS = ("dynamics", "uniform", "torso")

#: de Leva (1996) segment masses, % of body mass (male). The trunk is split into the lower
#: (pelvis, 11.17), and the middle + upper trunk (16.33 + 15.96, including the shoulder girdle).
DE_LEVA_MALE: dict[str, float] = {
    "head": 6.94,
    "pelvis": 11.17,
    "trunk": 16.33 + 15.96,
    "upperarm": 2.71,
    "forearm": 1.62,
    "hand": 0.61,
    "thigh": 14.16,
    "shank": 4.33,
    "foot": 1.37,
}

#: Heuristic 2's hand-set static weights per category.
TORSO_WEIGHTS: dict[str, float] = {
    "pelvis": 2.0,
    "trunk": 2.0,
    "head": 1.0,
    "upperarm": 1.0,
    "forearm": 1.0,
    "hand": 1.0,
    "thigh": 1.0,
    "shank": 1.0,
    "foot": 1.0,
}
#: Heuristic 2's extra weight on the part carrying most of the mass.
TORSO_EXTRA = 4.0


def part_categories(parts: BodyParts) -> list[str]:
    """de Leva category of each part, from the body model's segments
    (:meth:`mocapkit.body.Body.category`: the pelvis part is "pelvis"; "" for a part no
    segment reaches)."""
    body = body_of(parts.skeleton)
    cats = [body.category(int(j)) for j in parts.joints]
    cats[0] = "pelvis"
    return cats


def _bone_lengths(parts: BodyParts) -> np.ndarray:
    """(B,) length of each part's bone: mean length of the offsets of its children/End Sites."""
    sk = parts.skeleton
    out = np.zeros(parts.num_parts)
    for b, j in enumerate(parts.joints):
        offs = [sk.offsets[c] for c in sk.children(int(j))]
        offs += [sk.end_site_offsets[e] for e in np.flatnonzero(sk.end_site_parents == j)]
        if offs:
            out[b] = float(np.mean(np.linalg.norm(offs, axis=1)))
    return out


def part_masses(
    parts: BodyParts, total_mass: float = 70.0, overrides: dict[str, float] | None = None
) -> np.ndarray:
    """(B,) mass of each body part in kg.

    Each de Leva segment's mass (per side for limbs) is shared among the parts of that category
    on that side in proportion to their bone lengths (evenly if all are zero). Categories absent
    from the skeleton are dropped and the rest rescaled to ``total_mass``. When no part's name
    is recognised, or for the parts left without a category, mass follows bone length.
    ``overrides`` (joint name -> kg) replaces the masses of the named joints afterwards.
    """
    cats = part_categories(parts)
    body = body_of(parts.skeleton)
    lengths = _bone_lengths(parts)
    B = parts.num_parts
    mass = np.zeros(B)
    groups: dict[tuple[str, str], list[int]] = {}
    for b, cat in enumerate(cats):
        if cat:
            side = body.side_of(int(parts.joints[b])) if cat != "trunk" else ""
            side = side if side in ("left", "right") else ""
            if cat in ("pelvis", "head", "trunk"):
                side = ""
            elif not side:
                top = b
                while parts.parents[top] > 0:
                    top = int(parts.parents[top])
                side = f"branch{top}"
            groups.setdefault((cat, side), []).append(b)
    for (cat, _), members in groups.items():
        share = DE_LEVA_MALE[cat] / 100.0
        ln = lengths[members]
        frac = ln / ln.sum() if ln.sum() > 0 else np.full(len(members), 1.0 / len(members))
        mass[members] = share * frac
    unknown = [b for b in range(B) if not cats[b]]
    if unknown:
        ln = lengths[unknown]
        known = mass.sum()
        # the unrecognised parts get mass by bone length, at the known parts' mass per unit length
        per_len = known / max(lengths[[b for b in range(B) if cats[b]]].sum(), 1e-12)
        if known <= 0:
            per_len = 1.0 / max(lengths.sum(), 1e-12)
        mass[unknown] = per_len * ln
    if mass.sum() <= 0:
        mass[:] = 1.0
    mass *= total_mass / mass.sum()
    if overrides:
        for name, m in overrides.items():
            if name not in parts.names:
                raise KeyError(f"mass override for {name!r}: no such body part")
            if not np.isfinite(m) or m < 0:
                raise ValueError(f"mass override for {name!r} must be >= 0, got {m}")
            mass[parts.names.index(name)] = float(m)
    return mass


def load_masses(path: str | Path) -> dict[str, float]:
    """Read a mass override file: a JSON object ``{"joint name": kg, ...}``."""
    data = json.loads(Path(path).read_text())
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object mapping joint names to kg")
    return {str(k): float(v) for k, v in data.items()}


def supporting_parts(parts: BodyParts, contact_parts: np.ndarray) -> np.ndarray:
    """(F, B) bool supporting bodies from (F, B) bool contacts: the parts in contact plus their
    inward parts on the same limb (the pelvis, the root body, is never supporting)."""
    contact_parts = np.asarray(contact_parts, dtype=bool)
    sup = contact_parts.copy()
    for b in range(1, parts.num_parts):
        for a in parts.ancestors(b):
            if a == 0:
                break
            sup[:, a] |= contact_parts[:, b]
    sup[:, 0] = False
    return sup


def contact_parts_of(parts: BodyParts, contacts: FootContacts, num_frames: int) -> np.ndarray:
    """(F, B) bool: contact flags of the foot joints mapped to their body parts."""
    out = np.zeros((num_frames, parts.num_parts), dtype=bool)
    for k, j in enumerate(contacts.joints):
        hit = np.flatnonzero(parts.joints == j)
        if len(hit):
            out[:, hit[0]] |= contacts.contacts[:, k]
    return out


@dataclass(frozen=True, eq=False)
class PartWeights:
    """Body-part weights of one clip: ``static[b] + frame[i, b] + frame[j, b]`` for (i, j).

    Attributes:
        metric: the metric name.
        static: (B,) frame-independent weights.
        frame: (F, B) per-frame additive weights.
    """

    metric: str
    static: np.ndarray
    frame: np.ndarray


def metric_weights(
    metric: str,
    parts: BodyParts,
    contact_parts: np.ndarray,
    masses: np.ndarray | None = None,
) -> PartWeights:
    """Body-part weights of a clip for ``metric`` (see the module doc).

    Args:
        metric: "dynamics", "uniform" or "torso".
        parts: the body parts.
        contact_parts: (F, B) bool ground contacts per part (see :func:`clip_contact_parts`).
        masses: (B,) part masses (kg); default :func:`part_masses`.
    """
    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r}; expected one of {', '.join(METRICS)}")
    contact_parts = np.asarray(contact_parts, dtype=bool)
    F, B = contact_parts.shape
    if parts.num_parts != B:
        raise ValueError(f"contact_parts must be (F, {parts.num_parts}), got {contact_parts.shape}")
    if metric == "uniform":
        return PartWeights(metric, np.ones(B), np.zeros((F, B)))
    masses = part_masses(parts) if masses is None else np.asarray(masses, dtype=np.float64)
    total = float(masses.sum())
    branch = masses.copy()
    for b in range(B - 1, 0, -1):  # parents before children: accumulate outward mass
        branch[parts.parents[b]] += branch[b]
    if metric == "torso":
        cats = part_categories(parts)
        static = np.array([TORSO_WEIGHTS.get(c, 1.0) for c in cats])
        fric = np.where(contact_parts, total - branch[None, :], -np.inf)
        best = np.argmax(fric, axis=1)
        has = contact_parts.any(axis=1)
        frame = np.zeros((F, B))
        frame[np.flatnonzero(has), best[has]] = TORSO_EXTRA
        return PartWeights(metric, static, frame)
    sup = supporting_parts(parts, contact_parts)
    frame = np.where(sup, total - branch[None, :], 0.0)
    return PartWeights(metric, branch.copy(), frame)


def clip_contact_parts(motion: Motion, parts: BodyParts, up: str | None = None) -> np.ndarray:
    """(F, B) bool ground contacts per body part, from :func:`mocapkit.features.foot_contacts`."""
    fc = foot_contacts(motion, up=up)
    return contact_parts_of(parts, fc, motion.num_frames)


def support_mask(metric: str, parts: BodyParts, foot_joints: list[int]) -> np.ndarray:
    """(B,) bool: the parts whose per-frame weight can be non-zero under ``metric`` given the
    joints that can be in contact (used to keep the tiled cost's extra products small)."""
    B = parts.num_parts
    mask = np.zeros(B, dtype=bool)
    if metric == "uniform":
        return mask
    cp = np.zeros((1, B), dtype=bool)
    for j in foot_joints:
        hit = np.flatnonzero(parts.joints == j)
        if len(hit):
            cp[0, hit[0]] = True
    if metric == "torso":
        return cp[0]
    return supporting_parts(parts, cp)[0]
