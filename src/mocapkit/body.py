"""The body model: which joint of a skeleton is the pelvis, the left knee, the head...

This is the one place in mocapkit that knows joint names. From any :class:`Skeleton` (and,
better, a :class:`Motion` on it, whose poses tell up from down where the rest pose does not),
:func:`body_of` returns a :class:`Body` naming the canonical parts:

* centre: ``pelvis`` (the body's root: the lowest common ancestor of both hips and the head),
  the ``spine`` chain (the joints strictly between the pelvis and the neck), ``neck``, ``head``;
* per side (``left`` / ``right``): ``hip`` (the thigh's joint), ``knee``, ``ankle``, ``toe``,
  ``clavicle`` (the collar bone's joint; Bandai's ``Shoulder_L``, Mixamo's ``LeftShoulder``),
  ``shoulder`` (the upper arm's joint: ``UpperArm_L``, ``LeftArm``, CMU's ``lhumerus``),
  ``elbow``, ``wrist`` (the joint the hand turns about: ``Hand_L``, ``LeftHand``, ``lwrist``)
  and ``hand`` (a hand joint below the wrist where the rig has one, CMU's ``lhand``; else the
  wrist itself).

Every part carries a ``confidence`` in [0, 1] and how it was found (``"name"``,
``"structure"``). Names are tried first: Bandai, CMU ASF, Mixamo (namespaces such as
``mixamorig7:`` stripped), 3ds Max Biped, iClone/Character Creator, Xsens, Perception Neuron,
SMPL and Blender (``upper_arm.L``) conventions; twist, roll, share and helper bones are
skipped. Where names fail, structure is used: the pelvis is the first joint from the root with
three long branches (two legs and the spine, each at least :data:`LIMB_FRACTION` of the body's
span); the spine branch is the one that branches again into two long limbs (the arms); in each
limb the middle hinge (knee, elbow) joins the two longest consecutive bones. Sides then come
from rest-pose (or mean-pose) geometry: the toes point forward, so ``left = up x forward``;
where nothing tells forward (no toes, a symmetric pose), the limbs' side is ``"unknown"`` with
a low confidence, never a guess.

Also here: the **ground root** (a first joint that is the body's ground projection, whose child
chain carries the body, as Bandai's ``joint_Root`` -> ``Hips``), the **up axis**, and the
character's **stature**: the vertical distance from the lowest foot point to the top of the head
(the head's End Site; where the head has none, or a zero one, the head joint plus
:data:`HEAD_TOP_FRACTION` of the head-to-ankle chain), measured on the motion's poses (98th
percentile over frames) or on a standing rest pose, and in metres when the file states its units
(ASF ``:units length``) or by :func:`guess_units` otherwise.
"""

from __future__ import annotations

import math
import re
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mocapkit.core.kinematics import end_site_positions, forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton

__all__ = [
    "CENTRE_PARTS",
    "SIDED_PARTS",
    "UNITS",
    "Body",
    "Part",
    "body_of",
    "chain_size",
    "guess_units",
    "name_side",
    "split_name",
    "up_from_poses",
]

CENTRE_PARTS = ("pelvis", "neck", "head")
SIDED_PARTS = (
    "hip", "knee", "ankle", "toe", "clavicle", "shoulder", "elbow", "wrist", "hand",
)  # fmt: skip
SIDES = ("left", "right")

#: Candidate length units and their size in metres.
UNITS: dict[str, float] = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    # the CMU database's ASF unit (":units length 0.45": one unit is 1/0.45 inch), kept by
    # the many BVH conversions of CMU takes, which cannot say so
    "cmu": 0.0254 / 0.45,
}

#: Nominal head-to-ankle chain of an adult (metres): ~0.85 of a 1.7 m stature. The unit guess
#: compares a file's chain with it.
NOMINAL_CHAIN_M = 1.45

#: A long branch or limb spans at least this fraction of the body's size (head-to-ankle chain,
#: or the rest pose's extent without names): legs and arms do, a neck or a finger does not.
LIMB_FRACTION = 0.3

#: The top of the head lies this fraction of the head-to-ankle chain above the head joint when
#: the rig gives the head no End Site (an adult's head joint sits ~0.1 of the stature below the
#: crown, and the chain is ~0.85 of it: 0.13 / 0.85).
HEAD_TOP_FRACTION = 0.15

_AXES = "XYZ"


# =============================================================================================
# names


_SEP = re.compile(r"[^A-Za-z0-9]+")
_CAMEL = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|[0-9]+")
_LEFT = frozenset({"left", "l", "lft", "lt"})
_RIGHT = frozenset({"right", "r", "rgt", "rt"})
# Body-part words that may follow a glued one-letter side prefix (CMU ASF: lfemur, rtoes...).
_GLUED_PARTS = (
    "hip", "upleg", "upperleg", "thigh", "femur", "leg", "knee", "tibia", "shin", "calf",
    "foot", "ankle", "toe", "heel", "ball", "shoulder", "clavicle", "collar", "humerus", "arm",
    "uparm", "upperarm", "forearm", "elbow", "radius", "wrist", "hand", "finger", "thumb",
    "index", "middle", "ring", "pinky", "lowarm", "lowleg",
)  # fmt: skip
# Bones that move with a part but are not it: twist/roll/share bones, IK targets, End-Site
# joints, CMU's hipjoint (pelvis to hip) and Biped's nubs.
_HELPER = re.compile(
    r"twist|roll|share|end$|nub|site|^ik|ik$|pole|target|helper|dummy|ctrl|null|hipjoint|top$"
)

# Per part, the name patterns (on the side-less lower-case base) in priority order. Context
# rules in _name_parts settle the words that mean different joints in different conventions
# (a "shoulder" is a clavicle beside an "arm", an upper arm beside a "collar"; a "hand" is the
# wrist unless a "wrist" exists; a "foot" is the ankle unless an "ankle" exists).
_PATTERNS: dict[str, tuple[str, ...]] = {
    "hip": (r"^up(per)?leg$", r"thigh", r"femur", r"^hip$", r"upleg|upperleg"),
    "knee": (r"^low(er)?leg$", r"^leg$", r"knee", r"calf", r"shin", r"tibia", r"crus"),
    "ankle": (r"ankle", r"^foot$", r"foot$", r"tarsus"),
    "toe": (r"^toes?(base|0)?$", r"toe", r"ball", r"^foot$"),
    "clavicle": (r"clavicle", r"collar", r"^shoulder$"),
    "shoulder": (r"^up(per)?arm$", r"humerus", r"^arm$", r"^shoulder$"),
    "elbow": (r"^fore ?arm$", r"^low(er)?arm$", r"elbow", r"radius", r"forearm"),
    "wrist": (r"wrist", r"^hand$"),
    "hand": (r"^hand$", r"palm"),
}
_PELVIS = (r"^(hips?|pelvis)$", r"hips|pelvis", r"^hip$", r"^center$", r"^root$")
_NECK = (r"neck",)
_HEAD = (r"^head$", r"head", r"skull")


def split_name(name: str) -> tuple[str, str]:
    """``(side, base)`` of a joint name: side ``"left"``, ``"right"`` or ``""``; base the
    lower-case rest with separators and the side marker removed (``mixamorig:LeftUpLeg`` ->
    ``("left", "upleg")``, ``lfemur`` -> ``("left", "femur")``, ``upper_arm.L`` ->
    ``("left", "upperarm")``, ``Bip01 L Thigh`` -> ``("left", "bip01thigh")``)."""
    name = name.rsplit(":", 1)[-1]
    tokens: list[str] = []
    for part in _SEP.split(name):
        tokens.extend(t.lower() for t in _CAMEL.findall(part))
    # prefixes that name the rig, not the part (Biped's Bip01, Character Creator's CC_Base)
    while len(tokens) > 1 and re.fullmatch(r"bip\d*|\d+|cc|base|rl|bn", tokens[0]):
        tokens = tokens[1:]
    side = ""
    rest: list[str] = []
    for t in tokens:
        if not side and t in _LEFT:
            side = "left"
        elif not side and t in _RIGHT:
            side = "right"
        elif not side and t.startswith("left") and len(t) > 4:
            side = "left"
            rest.append(t[4:])
        elif not side and t.startswith("right") and len(t) > 5:
            side = "right"
            rest.append(t[5:])
        elif not side and len(t) > 1 and t[0] in "lr" and t[1:].startswith(_GLUED_PARTS):
            side = "left" if t[0] == "l" else "right"
            rest.append(t[1:])
        else:
            rest.append(t)
    return side, "".join(rest)


def name_side(name: str) -> str:
    """The side a joint's name states: ``"left"``, ``"right"`` or ``""``."""
    return split_name(name)[0]


def _first_match(base: str, patterns: Sequence[str]) -> int | None:
    for prio, pat in enumerate(patterns):
        if re.search(pat, base):
            return prio
    return None


# =============================================================================================
# the result


@dataclass(frozen=True)
class Part:
    """One canonical body part.

    Attributes:
        name: the part (``"knee"``, ``"pelvis"``...).
        side: ``"left"``, ``"right"``, ``"centre"`` or ``"unknown"`` (a limb whose side no cue
            tells).
        joint: its joint index.
        confidence: 1.0 for a name of a known convention, lower for weaker names, ~0.6 for
            structure with geometric sides, 0.2 where the side is unknown.
        source: ``"name"`` or ``"structure"``.
    """

    name: str
    side: str
    joint: int
    confidence: float
    source: str

    @property
    def key(self) -> str:
        """``"left_knee"``, ``"pelvis"``; ``"unknown_knee"`` for a limb without a side."""
        return self.name if self.side == "centre" else f"{self.side}_{self.name}"


@dataclass(frozen=True, eq=False)
class Body:
    """The canonical parts of a skeleton (see the module notes). Build it with
    :func:`body_of`; a Body is computed once per skeleton and passed around.

    Attributes:
        skeleton: the skeleton it describes.
        parts: every part found (limbs with an unknown side appear twice with side "unknown").
        spine: joints strictly between the pelvis and the neck (pelvis side first).
        ground_root: joint 0 when it is the body's ground projection (see the module notes),
            else None.
        up: the up axis (``"Y"``, ``"Z"``, ``"-Y"``...), from the motion's poses when given.
        size: the head-to-ankle chain (file units; ~0.85 x stature), the scale that
            thresholds follow.
        stature: the character's height in file units (see the module notes).
        metres_per_unit: from the file where it states it, else guessed from the stature.
        units_source: ``"file"`` or ``"guess"``.
        measured_on: ``"motion"`` or ``"rest"`` (the poses the geometry came from).
    """

    skeleton: Skeleton
    parts: tuple[Part, ...]
    spine: tuple[int, ...]
    ground_root: int | None
    up: str
    size: float
    stature: float
    metres_per_unit: float
    units_source: str
    measured_on: str = "rest"
    _by_key: dict[str, Part] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self._by_key.update({p.key: p for p in self.parts})

    # ---- look-ups --------------------------------------------------------------------------
    def part(self, key: str) -> Part | None:
        """The part called ``key`` (``"left_knee"``, ``"head"``), or None."""
        return self._by_key.get(key)

    def joint(self, key: str) -> int | None:
        """The joint index of part ``key``, or None."""
        p = self._by_key.get(key)
        return None if p is None else p.joint

    def joints_meant(self, name: str) -> list[int]:
        """The joints a name from another convention means on this rig (``"Knee_L"``,
        ``"left knee"``, ``"LeftLeg"`` -> Bandai's ``LowerLeg_L``): the name's side and base
        (:func:`split_name`) against every convention's part names; every side when it states
        none. For suggestions to a user who typed a joint the rig does not have."""
        side, base = split_name(name)
        meant = []
        centre = {"pelvis": _PELVIS, "neck": _NECK, "head": _HEAD}
        for part, pats in (*_PATTERNS.items(), *centre.items()):
            if not any(re.search(p, base) for p in pats) and base != part:
                continue
            for p in self.parts:
                if p.name == part and (not side or p.side in (side, "unknown")):
                    meant.append(p.joint)
        return sorted(set(meant))

    def pair(self, name: str) -> tuple[int, int] | None:
        """``(left, right)`` joints of a sided part, or None unless both sides are known."""
        a, b = self.joint(f"left_{name}"), self.joint(f"right_{name}")
        return None if a is None or b is None else (a, b)

    def both(self, name: str) -> list[int]:
        """The joints of a sided part on every limb that has it (known sides or not)."""
        return sorted({p.joint for p in self.parts if p.name == name})

    @property
    def pelvis(self) -> int:
        """The body's root joint (0 when nothing better is found)."""
        j = self.joint("pelvis")
        return 0 if j is None else j

    @property
    def head(self) -> int | None:
        return self.joint("head")

    @property
    def neck(self) -> int | None:
        return self.joint("neck")

    @property
    def sides_known(self) -> bool:
        return not any(p.side == "unknown" for p in self.parts)

    @property
    def height_m(self) -> float:
        """Stature in metres."""
        return self.stature * self.metres_per_unit

    @property
    def hinges(self) -> list[int]:
        """Knees and elbows, in joint order."""
        return sorted({*self.both("knee"), *self.both("elbow")})

    @property
    def feet(self) -> list[tuple[str, int]]:
        """``[(side, joint)]``: per leg the ankle then, when present, a distinct toe ("" for an
        unknown side)."""
        out: list[tuple[str, int]] = []
        for side in (*SIDES, "unknown"):
            ank = [p for p in self.parts if p.name == "ankle" and p.side == side]
            for a in ank:
                label = "" if side == "unknown" else side
                out.append((label, a.joint))
                toe = self._toe_below(a.joint, side)
                if toe is not None and toe != a.joint:
                    out.append((label, toe))
        return out

    def _toe_below(self, ankle: int, side: str) -> int | None:
        for p in self.parts:
            if p.name == "toe" and p.side == side and ankle in self.skeleton.ancestors(p.joint):
                return p.joint
        return None

    def side_of(self, j: int) -> str:
        """``"left"``/``"right"`` for a joint on (or below) a limb of known side, ``"unknown"``
        on a limb of unknown side, ``"centre"`` elsewhere (pelvis, spine, head, and the joints
        above the pelvis)."""
        return self._sides[j]

    @property
    def _sides(self) -> tuple[str, ...]:
        cached = getattr(self, "_sides_cache", None)
        if cached is not None:
            return cached
        sk = self.skeleton
        out = ["centre"] * sk.num_joints
        for p in self.parts:
            if p.name in ("hip", "clavicle", "shoulder"):
                for k in sk.subtree(self._limb_top(p.joint)):
                    if out[k] == "centre":
                        out[k] = p.side
        sides = tuple(out)
        object.__setattr__(self, "_sides_cache", sides)
        return sides

    def _limb_top(self, j: int) -> int:
        """The first joint of the limb branch that holds ``j``: the child of the pelvis (legs)
        or of the spine's branching joint (arms) on the way to ``j``."""
        sk = self.skeleton
        centre = {self.pelvis, *self.spine}
        if self.neck is not None:
            centre.add(self.neck)
        top = j
        for a in sk.ancestors(j):
            if a in centre:
                break
            top = a
        return top

    def category(self, j: int) -> str:
        """The body segment joint ``j``'s bone belongs to, for mass tables: "pelvis",
        "trunk" (spine and clavicles), "head" (neck, head and below), "upperarm", "forearm",
        "hand" (wrist, hand, fingers), "thigh", "shank", "foot" (ankle, toes), or "" for the
        joints above the pelvis and those no part reaches."""
        return self._categories[j]

    @property
    def _categories(self) -> tuple[str, ...]:
        cached = getattr(self, "_categories_cache", None)
        if cached is not None:
            return cached
        sk = self.skeleton
        cats = [""] * sk.num_joints
        seg = {
            "hip": "thigh", "knee": "shank", "ankle": "foot", "toe": "foot", "clavicle": "trunk",
            "shoulder": "upperarm", "elbow": "forearm", "wrist": "hand", "hand": "hand",
            "neck": "head", "head": "head",
        }  # fmt: skip
        start = {p.joint: seg[p.name] for p in self.parts if p.name in seg}
        for j in self.spine:
            start.setdefault(j, "trunk")
        pelvis = self.pelvis
        inside = sk.subtree_mask(pelvis)
        for j in range(sk.num_joints):
            if not inside[j]:
                continue
            if j == pelvis:
                cats[j] = "pelvis"
            elif j in start:
                cats[j] = start[j]
            else:
                p = int(sk.parents[j])
                # a helper between the pelvis and a limb (CMU's hipjoint) belongs to the pelvis
                cats[j] = cats[p] if p != pelvis else "pelvis"
        out = tuple(cats)
        object.__setattr__(self, "_categories_cache", out)
        return out

    def to_json(self) -> dict[str, object]:
        """JSON-ready: each part's joint name, confidence and source; ground root, up axis,
        stature in metres and where the units came from."""
        names = self.skeleton.names
        return {
            "parts": {
                p.key: {"joint": names[p.joint], "confidence": p.confidence, "source": p.source}
                for p in self.parts
            },
            "spine": [names[j] for j in self.spine],
            "ground_root": None if self.ground_root is None else names[self.ground_root],
            "up_axis": self.up,
            "height_m": round(self.height_m, 4),
            "metres_per_unit": self.metres_per_unit,
            "units_source": self.units_source,
            "labels": self.labels(),
        }

    def labels(self) -> list[str]:
        """Per joint, the part key it is (``"left_knee"``), ``"spine"``, ``"ground root"`` or
        ``""``: what ``mocapkit info --tree`` prints beside each joint."""
        out = [""] * self.skeleton.num_joints
        for j in self.spine:
            out[j] = "spine"
        for p in self.parts:
            out[p.joint] = p.key if not out[p.joint] or out[p.joint] == "spine" else out[p.joint]
        if self.ground_root is not None:
            out[self.ground_root] = "ground root"
        return out


# =============================================================================================
# finding parts by name


_NAME_PARTS: dict[tuple, tuple[dict, dict]] = {}
_NAME_PARTS_MAX = 256


def _name_parts(sk: Skeleton) -> tuple[dict[str, int], dict[tuple[str, str], tuple[int, float]]]:
    """Centre parts {name: joint} and sided parts {(side, name): (joint, confidence)}, kept per
    skeleton content (names, parents, offsets): a library's takes are read into separate
    Skeleton objects of one rig, and matching its names again for each cost a tenth of a
    library clean."""
    key = (tuple(sk.names), np.asarray(sk.parents).tobytes(), np.asarray(sk.offsets).tobytes())
    hit = _NAME_PARTS.get(key)
    if hit is None:
        hit = _name_parts_of(sk)
        if len(_NAME_PARTS) >= _NAME_PARTS_MAX:
            _NAME_PARTS.clear()
        _NAME_PARTS[key] = hit
    return dict(hit[0]), dict(hit[1])


def _name_parts_of(sk: Skeleton) -> tuple[dict[str, int], dict[tuple[str, str], tuple[int, float]]]:
    """:func:`_name_parts`, computed."""
    depth = sk.depth()
    split = [split_name(n) for n in sk.names]
    usable = [not _HELPER.search(base) for _, base in split]

    def best(side: str, patterns: Sequence[str], within: set[int] | None = None):
        found: tuple[int, int, int] | None = None
        for j, (s, base) in enumerate(split):
            if s != side or not usable[j] or (within is not None and j not in within):
                continue
            prio = _first_match(base, patterns)
            if prio is not None:
                key = (prio, int(depth[j]), j)
                if found is None or key < found:
                    found = key
        return found

    sided: dict[tuple[str, str], tuple[int, float]] = {}
    for side in SIDES:
        has = {
            w: best(side, (pat,)) is not None
            for w, pat in (
                ("arm", r"^up(per)?arm$|humerus|^arm$"),
                ("collar", r"clavicle|collar"),
                ("wrist", r"wrist"),
                ("ankle", r"ankle"),
                ("upleg", r"^up(per)?leg$|thigh|femur"),
            )
        }
        for part, pats in _PATTERNS.items():
            pats = list(pats)
            if part == "clavicle" and not has["arm"]:
                pats.remove(r"^shoulder$")  # a lone "shoulder" is the upper arm
            if part == "shoulder" and has["arm"]:
                pats.remove(r"^shoulder$")  # beside an "arm", "shoulder" is the clavicle
            if part == "wrist" and has["wrist"]:
                pats.remove(r"^hand$")
            if part == "hand" and not has["wrist"]:
                continue  # the hand is the wrist joint
            if part == "ankle" and has["ankle"]:
                pats = [p for p in pats if "foot" not in p]
            if part == "toe" and not has["ankle"]:
                pats.remove(r"^foot$")
            if part == "hip" and has["upleg"]:
                pats.remove(r"^hip$")  # mocapbank's LeftHip beside LeftUpLeg would be odd
            hit = best(side, pats)
            if hit is not None:
                sided[(side, part)] = (hit[2], 1.0 if hit[0] == 0 else 0.9)
        # parts must lie on one chain: drop a knee that is not below its hip, and so on
        for upper, lower in (("hip", "knee"), ("knee", "ankle"), ("ankle", "toe"),
                             ("shoulder", "elbow"), ("elbow", "wrist"), ("wrist", "hand"),
                             ("clavicle", "shoulder")):  # fmt: skip
            u, lo = sided.get((side, upper)), sided.get((side, lower))
            if u and lo and u[0] not in sk.ancestors(lo[0]):
                del sided[(side, lower)]
        if (side, "wrist") in sided and (side, "hand") not in sided:
            sided[(side, "hand")] = sided[(side, "wrist")]

    centre: dict[str, int] = {}
    for part, pats in (("neck", _NECK), ("head", _HEAD)):
        hit = best("", pats)
        if hit is not None:
            centre[part] = hit[2]
    if "head" not in centre and "neck" in centre:
        # a rig that ends in neck joints (video-to-BVH, some CMU conversions): the top of the
        # neck chain stands for the head
        length = _bone_lengths(sk)
        centre["head"] = _main_chain(sk, centre["neck"], _reach(sk, length), length)[-1]
    hips = [sided[(s, "hip")][0] for s in SIDES if (s, "hip") in sided]
    if len(hips) == 2:
        top = sk.common_ancestor(*hips)
        head = centre.get("head", centre.get("neck"))
        centre["pelvis"] = top if head is None else sk.common_ancestor(top, head)
    else:
        hit = best("", _PELVIS)
        if hit is not None:
            centre["pelvis"] = hit[2]
    return centre, sided


# =============================================================================================
# finding parts by structure


def _bone_lengths(sk: Skeleton) -> np.ndarray:
    """(J,) length of the bone into each joint (its offset)."""
    return np.linalg.norm(sk.offsets, axis=1)


def _reach(sk: Skeleton, length: np.ndarray | None = None) -> np.ndarray:
    """(J,) the longest path length from each joint down to a leaf or End Site tip."""
    length = _bone_lengths(sk) if length is None else length
    reach = np.zeros(sk.num_joints)
    for e, p in enumerate(sk.end_site_parents):
        reach[p] = max(reach[p], float(np.linalg.norm(sk.end_site_offsets[e])))
    for j in range(sk.num_joints - 1, 0, -1):
        p = int(sk.parents[j])
        reach[p] = max(reach[p], reach[j] + length[j])
    return reach


def _main_chain(sk: Skeleton, start: int, reach: np.ndarray, length: np.ndarray) -> list[int]:
    """``start`` and, repeatedly, the child with the longest reach."""
    chain = [start]
    while True:
        kids = sk.children(chain[-1])
        if not kids:
            return chain
        chain.append(max(kids, key=lambda c: (reach[c] + length[c], -c)))


def _hinge_on(chain: list[int], length: np.ndarray) -> int | None:
    """The middle hinge (knee, elbow) of a limb chain: the parent of the joint that ends the
    chain's last long bone (at least half its longest), since the two long bones of a limb
    (thigh and shin, upper arm and forearm) end at the ankle or wrist, where short bones
    (foot, hand) follow."""
    bones = length[chain[1:]]
    if len(bones) < 2 or not bones.max() > 0:
        return None
    last = int(np.flatnonzero(bones >= 0.5 * bones.max())[-1]) + 1  # index in chain
    return chain[last - 1] if last >= 2 else None


def _head_of(sk: Skeleton, chain: list[int]) -> int:
    """The head on a neck chain: the first joint past the neck that branches (jaw and eyes of a
    face rig), else the last joint, unless that is an end marker past the head (a leaf whose
    End Site, if any, is under half its own bone, as Mixamo's ``HeadTop_End``)."""
    for j in chain[1:]:
        if len(sk.children(j)) >= 2:
            return j
    last = chain[-1]
    ends = sk.end_site_offsets[sk.end_site_parents == last]
    tip = float(np.linalg.norm(ends, axis=1).max()) if len(ends) else 0.0
    marker = not sk.children(last) and tip < 0.5 * float(np.linalg.norm(sk.offsets[last]))
    if len(chain) >= 3 and marker:
        return chain[-2]
    return last


def _structure(
    sk: Skeleton, length: np.ndarray
) -> tuple[dict[str, int], list[dict[str, int]], list[int]]:
    """Centre parts, limbs (each {part: joint}, legs first then arms) and the spine, by
    structure alone (see the module notes)."""
    reach = _reach(sk, length)
    # the body's span: the longest path through any joint (head to toe through the pelvis, or
    # fingertip to fingertip through the chest), pose-independent
    down = reach[1:] + length[1:]
    span = 1e-9
    for j in range(sk.num_joints):
        kids = np.sort(down[sk.parents[1:] == j])[::-1]
        if len(kids) >= 2:
            span = max(span, float(kids[:2].sum()))
    long = LIMB_FRACTION * span

    def branches(j: int, hubs: bool = False) -> list[int]:
        """Long branches of ``j``; with ``hubs``, a short bone that splits into two long ones
        (Character Creator's pelvis bone under its hip) counts as those two."""
        out: list[int] = []
        for c in sk.children(j):
            if reach[c] + length[c] < long:
                continue
            sub = [g for g in sk.children(c) if reach[g] + length[g] >= long]
            out += sub if hubs and len(sub) >= 2 and length[c] < 0.1 * span else [c]
        return out

    pelvis = next((j for j in range(sk.num_joints) if len(branches(j, True)) >= 3), None)
    if pelvis is None:
        return {}, [], []

    def chest_in(top: int) -> int | None:
        return next((j for j in sk.subtree(top) if len(branches(j)) >= 2), None)

    br = branches(pelvis, True)
    spine_top = next((c for c in sorted(br, key=lambda c: -reach[c]) if chest_in(c) is not None),
                     None)  # fmt: skip
    legs = sorted((c for c in br if c != spine_top), key=lambda c: -(reach[c] + length[c]))[:2]
    limbs: list[dict[str, int]] = []
    for top in legs:
        chain = _main_chain(sk, top, reach, length)
        knee = _hinge_on(chain, length)
        if knee is None:
            continue
        i = chain.index(knee)
        limb = {"hip": chain[i - 1], "knee": knee}
        if i + 1 < len(chain):
            limb["ankle"] = chain[i + 1]
        if i + 2 < len(chain):
            limb["toe"] = chain[i + 2]
        limbs.append(limb)
    centre = {"pelvis": pelvis}
    spine: list[int] = []
    if spine_top is not None:
        chest = chest_in(spine_top)
        assert chest is not None
        arms = sorted(branches(chest), key=lambda c: -(reach[c] + length[c]))[:2]
        for top in arms:
            chain = _main_chain(sk, top, reach, length)
            elbow = _hinge_on(chain, length)
            if elbow is None:
                continue
            i = chain.index(elbow)
            limb = {"shoulder": chain[i - 1], "elbow": elbow}
            if i >= 2:
                limb["clavicle"] = chain[i - 2]
            if i + 1 < len(chain):
                limb["wrist"] = chain[i + 1]
                wk = sk.children(chain[i + 1])
                limb["hand"] = wk[0] if len(wk) == 1 else chain[i + 1]
            limbs.append(limb)
        above_arms = {k for a in arms for k in sk.subtree(a)}
        rest = [c for c in sk.children(chest) if c not in above_arms]
        if rest:
            neck_chain = _main_chain(sk, max(rest, key=lambda c: reach[c]), reach, length)
            centre["neck"] = neck_chain[0]
            centre["head"] = _head_of(sk, neck_chain)
        inside = sk.subtree_mask(pelvis)
        spine = [j for j in reversed(sk.ancestors(chest)) if inside[j] and j != pelvis]
        spine.append(chest)
    return centre, limbs, spine


# =============================================================================================
# geometry: poses, up axis, sides, stature


def _poses(obj: Motion | Skeleton, max_frames: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Joint and End Site positions (F, J, 3), (F, E, 3) of up to ``max_frames`` evenly spaced
    frames of a motion, or of the rest pose."""
    if isinstance(obj, Motion) and obj.num_frames:
        m = obj
        if m.num_frames > max_frames:
            idx = np.unique(np.linspace(0, m.num_frames - 1, max_frames).round().astype(int))
            m = m[idx]
        pos, grot = forward_kinematics(m)
        return pos, end_site_positions(m.skeleton, pos, grot)
    sk = obj.skeleton if isinstance(obj, Motion) else obj
    pos = sk.rest_positions()[None]
    ends = pos[:, sk.end_site_parents] + sk.end_site_offsets[None]
    return pos, ends


def _unit(v: np.ndarray, eps: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    n = np.linalg.norm(v, axis=-1)
    ok = n > eps
    return v / np.where(ok, n, 1.0)[..., None], ok


def up_from_poses(pos: np.ndarray, head: int | None, pelvis: int, ankles: list[int]) -> str:
    """Up from poses (F, J, 3): the sum of the mean unit vectors from the feet to the head and
    to the pelvis (both point up for a standing human; the pelvis term keeps a quadruped, whose
    head is far forward, right), reduced to its dominant signed axis. Without feet: the axis
    of largest typical extent, signed so that more joints lie above the pelvis than below."""
    if ankles:
        low = pos[:, ankles].mean(axis=1)
        total = np.zeros(3)
        for top in {head, pelvis} - {None}:
            if top in ankles:
                continue
            d, ok = _unit(pos[:, top] - low)
            if ok.any():
                total += d[ok].mean(axis=0)
        a = int(np.argmax(np.abs(total)))
        if abs(total[a]) > 0.3:
            return ("-" if total[a] < 0 else "") + _AXES[a]
    ext = np.median(pos.max(axis=1) - pos.min(axis=1), axis=0)
    a = int(np.argmax(ext))
    rel = pos[:, :, a] - pos[:, pelvis, a][:, None]
    above = np.sum(rel > 1e-9 * max(ext[a], 1e-12))
    below = np.sum(rel < -1e-9 * max(ext[a], 1e-12))
    return ("-" if below > above else "") + _AXES[a]


def _up_vector(up: str) -> np.ndarray:
    v = np.zeros(3)
    v[_AXES.index(up[-1])] = -1.0 if up.startswith("-") else 1.0
    return v


def _forward(pos: np.ndarray, limbs: list[dict[str, int]], u: np.ndarray) -> np.ndarray | None:
    """The body's forward direction per frame (F, 3) from the poses: the toes point forward of
    the ankles; without toes, bent knees point forward of the hip-ankle line. None when
    neither tells (no toes, straight or symmetric legs)."""
    vecs = [
        pos[:, lb["toe"]] - pos[:, lb["ankle"]] for lb in limbs if {"ankle", "toe"} <= lb.keys()
    ]
    if not vecs:
        for lb in limbs:
            if {"hip", "knee", "ankle"} <= lb.keys():
                vecs.append(pos[:, lb["knee"]] - 0.5 * (pos[:, lb["hip"]] + pos[:, lb["ankle"]]))
    if not vecs:
        return None
    v = np.mean(vecs, axis=0)
    v = v - (v @ u)[:, None] * u
    n = np.linalg.norm(v, axis=1)
    scale = max(float(np.median(np.ptp(pos, axis=1).max(axis=1))), 1e-12)
    ok = n > 0.01 * scale
    if not ok.any():
        return None
    v = v[ok] / n[ok, None]
    return _fill(v, ok, len(n))


def _fill(v: np.ndarray, ok: np.ndarray, n: int) -> np.ndarray:
    """(n, 3) with the rows where ``ok`` from ``v`` and the others NaN."""
    out = np.full((n, 3), np.nan)
    out[ok] = v
    return out


def _chain_length(sk: Skeleton, lengths: np.ndarray, a: int, b: int) -> float:
    c = sk.common_ancestor(a, b)
    total = 0.0
    for j in (a, b):
        while j != c:
            total += lengths[j]
            j = int(sk.parents[j])
    return total


def _animated_lengths(obj: Motion | Skeleton) -> np.ndarray:
    """(J,) bone lengths, using the median animated translation where a joint has one."""
    sk = obj.skeleton if isinstance(obj, Motion) else obj
    lengths = _bone_lengths(sk)
    if isinstance(obj, Motion) and obj.translations is not None and obj.num_frames:
        anim = sk.has_position.copy()
        anim[0] = False
        if anim.any():
            lengths[anim] = np.median(np.linalg.norm(obj.translations[:, anim], axis=2), axis=0)
    return lengths


def chain_size(obj: Motion | Skeleton, body: Body) -> float:
    """The head-to-ankle chain of ``body`` measured on ``obj`` (its median animated bone
    lengths where it has them), the mean over the legs; 0.0 without a head or ankles."""
    sk = body.skeleton
    ankles = body.both("ankle")
    if body.head is None or not ankles:
        return 0.0
    lengths = _animated_lengths(obj)
    return float(np.mean([_chain_length(sk, lengths, body.head, a) for a in ankles]))


def guess_units(size: float, candidates: dict[str, float] | None = None) -> tuple[str, float]:
    """``(name, metres_per_unit)`` of the candidate unit that makes a head-to-ankle chain of
    ``size`` file units closest, on a log scale, to an adult's :data:`NOMINAL_CHAIN_M`.

    The log-midpoints between units give the boundaries on the chain in file units:
    m < 9.1 <= inch < 91 <= cm < 459 <= mm. Humans 1.0-2.2 m tall are classified correctly in
    every unit except between cm and inch (ratio 2.54): a character under ~1.07 m in cm reads as
    inches. Files that state their units (ASF) are not guessed."""
    cands = UNITS if candidates is None else candidates
    if not (size > 0 and math.isfinite(size)):
        return ("m", 1.0) if "m" in cands else next(iter(cands.items()))
    name, mpu = min(cands.items(), key=lambda kv: abs(math.log(size * kv[1] / NOMINAL_CHAIN_M)))
    return name, float(mpu)


# =============================================================================================
# assembling a Body


_CACHE: weakref.WeakKeyDictionary[Skeleton, Body] = weakref.WeakKeyDictionary()


def body_of(obj: Motion | Skeleton) -> Body:
    """The :class:`Body` of a skeleton, or of a motion's skeleton measured on its poses.

    Parts come from the skeleton alone; the up axis, geometric sides and stature use the
    motion's frames when given (the rest pose of some rigs, Bandai's among them, is not a
    standing pose). A Body is cached per skeleton (the first motion seen measures it), so every
    capability asking about the same skeleton gets the same answer at no cost.
    """
    sk = obj.skeleton if isinstance(obj, Motion) else obj
    if not isinstance(sk, Skeleton):
        raise TypeError(f"expected a Motion or a Skeleton, got {type(obj).__name__}")
    cached = _CACHE.get(sk)
    wants_motion = isinstance(obj, Motion) and obj.num_frames > 0
    if cached is not None and (cached.measured_on == "motion" or not wants_motion):
        return cached
    body = _build(obj, sk)
    _CACHE[sk] = body
    return body


def _build(obj: Motion | Skeleton, sk: Skeleton) -> Body:
    pos, ends = _poses(obj)
    centre, sided = _name_parts(sk)
    parts: list[Part] = []
    named_limbs = sum(1 for s in SIDES if (s, "hip") in sided or (s, "shoulder") in sided)
    use_structure = "pelvis" not in centre or named_limbs == 0
    spine: list[int] = []
    up: str
    if not use_structure:
        for name, j in centre.items():
            parts.append(Part(name, "centre", j, 1.0, "name"))
        for (side, name), (j, conf) in sided.items():
            parts.append(Part(name, side, j, conf, "name"))
        pelvis = centre["pelvis"]
        top = centre.get("neck", centre.get("head"))
        if top is not None and pelvis in sk.ancestors(top):
            spine = [j for j in reversed(sk.ancestors(top)) if pelvis in sk.ancestors(j)]
        ankles = [j for (s, n), (j, _) in sided.items() if n == "ankle"]
        up = up_from_poses(pos, centre.get("head"), pelvis, ankles)
    else:
        c, limbs, spine = _structure(sk, _animated_lengths(obj))
        pelvis = c.get("pelvis", 0)
        ankles = [lb["ankle"] for lb in limbs if "ankle" in lb]
        up = up_from_poses(pos, c.get("head"), pelvis, ankles)
        for name, j in c.items():
            parts.append(Part(name, "centre", j, 0.6, "structure"))
        parts += _sided_by_geometry(sk, pos, limbs, pelvis, up)
    head = next((p.joint for p in parts if p.name == "head"), None)
    ankles = sorted({p.joint for p in parts if p.name == "ankle"})
    lengths = _animated_lengths(obj)
    size = float(np.mean([_chain_length(sk, lengths, head, a) for a in ankles])) if (
        head is not None and ankles) else 0.0  # fmt: skip
    u = _up_vector(up)
    if not size > 0:
        h = (pos @ u) if len(pos) else np.zeros((1, 1))
        size = float(np.percentile(h.max(axis=1) - h.min(axis=1), 90)) if h.size else 0.0
    if not size > 0:
        size = sk.height()
    stature = _stature(sk, obj, pos, ends, head, ankles, u, size)
    mpu_file = sk.metres_per_unit
    if mpu_file:
        mpu, source = float(mpu_file), "file"
    else:
        mpu, source = guess_units(size)[1], "guess"
    ground = _ground_root(sk, pos, pelvis, ankles, u, stature)
    measured = "motion" if isinstance(obj, Motion) and obj.num_frames else "rest"
    return Body(sk, tuple(parts), tuple(spine), ground, up, size, stature, mpu, source, measured)


def _sided_by_geometry(
    sk: Skeleton, pos: np.ndarray, limbs: list[dict[str, int]], pelvis: int, up: str
) -> list[Part]:
    """Parts of structurally found limbs, with sides from the pose: ``left = up x forward``."""
    u = _up_vector(up)
    fwd = _forward(pos, [lb for lb in limbs if "hip" in lb], u)
    out: list[Part] = []
    for kind in ("hip", "shoulder"):
        pair = [lb for lb in limbs if kind in lb]
        if len(pair) == 2 and fwd is not None:
            left_dir = np.cross(u, fwd)  # (F, 3), NaN where the frame tells no forward
            lat = [float(np.nanmean(np.sum((pos[:, lb[kind]] - pos[:, pelvis]) * left_dir, 1)))
                   for lb in pair]  # fmt: skip
            if abs(lat[0] - lat[1]) > 1e-9:
                order = ("left", "right") if lat[0] > lat[1] else ("right", "left")
                for side, lb in zip(order, pair, strict=True):
                    out += [Part(n, side, j, 0.6, "structure") for n, j in lb.items()]
                continue
        for lb in pair:
            out += [Part(n, "unknown", j, 0.2, "structure") for n, j in lb.items()]
    return out


def _stature(
    sk: Skeleton,
    obj: Motion | Skeleton,
    pos: np.ndarray,
    ends: np.ndarray,
    head: int | None,
    ankles: list[int],
    u: np.ndarray,
    size: float,
) -> float:
    """Lowest foot point to the top of the head along up (see the module notes)."""
    if head is None:
        return size / 0.85
    tips = [e for e, p in enumerate(sk.end_site_parents) if p == head]
    tip_len = [float(np.linalg.norm(sk.end_site_offsets[e])) for e in tips]
    if tips and max(tip_len) > 0.02 * size:
        top = ends[:, tips[int(np.argmax(tip_len))]] @ u
    else:
        top = pos[:, head] @ u + HEAD_TOP_FRACTION * size
    foot = [j for j in range(sk.num_joints) if any(a == j or a in sk.ancestors(j) for a in ankles)]
    foot_pts = [pos[:, foot] @ u] if foot else []
    foot_ends = [e for e, p in enumerate(sk.end_site_parents) if p in foot]
    if foot_ends:
        foot_pts.append(ends[:, foot_ends] @ u)
    if not foot_pts:
        return size / 0.85
    low = np.min(np.concatenate(foot_pts, axis=1), axis=1)
    heights = top - low
    standing = isinstance(obj, Motion) and obj.num_frames > 0
    h = float(np.percentile(heights, 98)) if standing else float(heights.max())
    # a rest pose that is not standing (bones along one axis) says nothing: use the chain
    if not (0.9 * size < h < 1.6 * size):
        h = size / 0.85
    return h


def _ground_root(
    sk: Skeleton,
    pos: np.ndarray,
    pelvis: int,
    ankles: list[int],
    u: np.ndarray,
    stature: float,
) -> int | None:
    """Joint 0 when it is the body's ground projection: a strict ancestor of the pelvis with a
    single child chain down to it, near the feet's ground level (within 0.1 of the stature)
    while the pelvis stands at least 0.3 of the stature above it."""
    if pelvis == 0 or not ankles or 0 not in sk.ancestors(pelvis):
        return None
    if any(len(sk.children(j)) != 1 for j in sk.ancestors(pelvis)):
        return None
    h = pos @ u
    ground = np.percentile(h[:, ankles].min(axis=1), 5)
    root_h = float(np.median(h[:, 0]))
    pelvis_h = float(np.median(h[:, pelvis]))
    if abs(root_h - ground) < 0.1 * stature and pelvis_h - root_h > 0.3 * stature:
        return 0
    return None
