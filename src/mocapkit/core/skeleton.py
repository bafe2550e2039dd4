"""Skeleton: joint names, parent indices, rest offsets, channel layout and End Sites.

Conventions (used throughout mocapkit):
- Joints are indexed 0..J-1 in file order; ``parents[j] < j`` for every non-root joint and the
  root has parent -1 (parents before children), so a single forward pass does forward kinematics.
- ``offsets`` is (J, 3): each joint's rest translation relative to its parent, in file units.
- ``channels[j]`` is the tuple of BVH channel names of joint j in file order (e.g.
  ``("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")``); it fixes
  the rotation order (intrinsic, "ZXY" here: R = Rz @ Rx @ Ry) and whether the joint animates
  its translation.
- End Sites are leaves without channels: ``end_site_parents`` (E,) and ``end_site_offsets``
  (E, 3), plus the optional trailing token some tools write (``End Site Head_end``).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")
VALID_CHANNELS = frozenset(POSITION_CHANNELS + ROTATION_CHANNELS)


@functools.lru_cache(maxsize=256)
def _channel_problem(ch: tuple[str, ...]) -> str:
    """What is wrong with a joint's channel layout ("" if nothing); cached, layouts repeat."""
    if any(c not in VALID_CHANNELS for c in ch) or len(set(ch)) != len(ch):
        return "invalid channels"
    if sum(c in ROTATION_CHANNELS for c in ch) not in (0, 3):
        return "needs 0 or 3 rotation channels"
    return ""


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint hierarchy.

    Attributes:
        names: J joint names, unique.
        parents: (J,) int array, -1 for the root, ``parents[j] < j`` otherwise.
        offsets: (J, 3) float64 rest offsets from the parent (file units).
        channels: J tuples of channel names in file order (0, 3 or 6 channels, any order).
        end_site_parents: (E,) int array, the joint each End Site hangs from.
        end_site_offsets: (E, 3) float64 End Site offsets.
        end_site_names: E strings, the token written after ``End Site`` ("" if none).
        metres_per_unit: the length unit in metres where the file states it (ASF ``:units``);
            None where it does not (BVH), and the unit is then guessed (:mod:`mocapkit.body`).
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    end_site_parents: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    end_site_offsets: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    end_site_names: tuple[str, ...] = ()
    metres_per_unit: float | None = None

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.names)
        parents = np.asarray(self.parents, dtype=np.int64).reshape(-1)
        offsets = np.asarray(self.offsets, dtype=np.float64).reshape(-1, 3)
        channels = tuple(tuple(str(c) for c in ch) for ch in self.channels)
        ep = np.asarray(self.end_site_parents, dtype=np.int64).reshape(-1)
        eo = np.asarray(self.end_site_offsets, dtype=np.float64).reshape(-1, 3)
        en = tuple(self.end_site_names) if self.end_site_names else ("",) * len(ep)
        J = len(names)
        if J == 0:
            raise ValueError("a skeleton needs at least one joint")
        if len(parents) != J or len(offsets) != J or len(channels) != J:
            raise ValueError(
                f"names ({J}), parents ({len(parents)}), offsets ({len(offsets)}) and "
                f"channels ({len(channels)}) must have the same length"
            )
        if len(set(names)) != J:
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"duplicate joint names: {dup}")
        if parents[0] != -1 or np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, J)):
            raise ValueError("parents must be -1 for joint 0 and < j for every other joint j")
        for j, ch in enumerate(channels):
            problem = _channel_problem(ch)
            if problem:
                raise ValueError(f"joint {names[j]!r}: {problem}, got {ch}")
        if len(ep) != len(eo) or len(en) != len(ep):
            raise ValueError(
                "end_site_parents, end_site_offsets and end_site_names differ in length"
            )
        mpu = self.metres_per_unit
        if mpu is not None:
            mpu = float(mpu)
            if not (np.isfinite(mpu) and mpu > 0):
                raise ValueError(f"metres_per_unit must be a positive number, got {mpu!r}")
            object.__setattr__(self, "metres_per_unit", mpu)
        if np.any((ep < 0) | (ep >= J)):
            raise ValueError("end_site_parents must index joints")
        for name, arr in (("offsets", offsets), ("end_site_offsets", eo)):
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} contain NaN or inf")
        for arr in (parents, offsets, ep, eo):
            arr.setflags(write=False)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "end_site_parents", ep)
        object.__setattr__(self, "end_site_offsets", eo)
        object.__setattr__(self, "end_site_names", en)

    # ---- derived views -------------------------------------------------------------------
    @property
    def num_joints(self) -> int:
        return len(self.names)

    @property
    def num_channels(self) -> int:
        return sum(len(c) for c in self.channels)

    def index(self, name: str) -> int:
        """Index of the joint called ``name`` (KeyError naming the joint otherwise)."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no joint named {name!r}") from None

    def rotation_order(self, j: int) -> str:
        """Intrinsic rotation order of joint j as written in the file, e.g. "ZXY".

        Joints without rotation channels report "ZXY" (their rotation is always identity).
        """
        order = "".join(c[0] for c in self.channels[j] if c in ROTATION_CHANNELS)
        return order or "ZXY"

    # Derived views are cached (the skeleton is immutable), so per-joint loops over them stay
    # linear on rigs of thousands of joints.
    @functools.cached_property
    def rotation_orders(self) -> tuple[str, ...]:
        return tuple(self.rotation_order(j) for j in range(self.num_joints))

    @functools.cached_property
    def has_rotation(self) -> np.ndarray:
        """(J,) bool, read-only: joint j has rotation channels."""
        out = np.array([any(c in ROTATION_CHANNELS for c in ch) for ch in self.channels])
        out.setflags(write=False)
        return out

    @functools.cached_property
    def has_position(self) -> np.ndarray:
        """(J,) bool, read-only: joint j has position channels (animated translation)."""
        out = np.array([any(c in POSITION_CHANNELS for c in ch) for ch in self.channels])
        out.setflags(write=False)
        return out

    @functools.cached_property
    def _children(self) -> tuple[tuple[int, ...], ...]:
        kids: list[list[int]] = [[] for _ in range(self.num_joints)]
        for j in range(1, self.num_joints):
            kids[int(self.parents[j])].append(j)
        return tuple(tuple(k) for k in kids)

    def children(self, j: int) -> list[int]:
        """Direct children of joint ``j``, in joint order."""
        return list(self._children[j])

    def ancestors(self, j: int) -> list[int]:
        """The joints above ``j``: its parent first, the root last (empty for the root)."""
        out: list[int] = []
        p = int(self.parents[j])
        while p >= 0:
            out.append(p)
            p = int(self.parents[p])
        return out

    def subtree_mask(self, j: int) -> np.ndarray:
        """(J,) bool: ``j`` and every joint below it. One pass, since parents come first."""
        inside = np.zeros(self.num_joints, dtype=bool)
        inside[j] = True
        parents = self.parents
        for k in range(j + 1, self.num_joints):
            inside[k] = inside[parents[k]]
        return inside

    def subtree(self, j: int) -> list[int]:
        """``j`` and every joint below it, in joint order."""
        return [int(k) for k in np.flatnonzero(self.subtree_mask(j))]

    def descendants(self, j: int) -> list[int]:
        """Every joint below ``j`` (not ``j`` itself), in joint order."""
        return self.subtree(j)[1:]

    def common_ancestor(self, a: int, b: int) -> int:
        """The lowest joint that is ``a`` or above it and ``b`` or above it."""
        above_a = {a, *self.ancestors(a)}
        return next(j for j in (b, *self.ancestors(b)) if j in above_a)

    def leaves(self) -> list[int]:
        """Joints without child joints (End Sites do not count), in joint order."""
        has_child = np.zeros(self.num_joints, dtype=bool)
        has_child[self.parents[1:]] = True
        return [int(j) for j in np.flatnonzero(~has_child)]

    def depth(self) -> np.ndarray:
        """(J,) number of ancestors of each joint."""
        d = np.zeros(self.num_joints, dtype=np.int64)
        for j in range(1, self.num_joints):
            d[j] = d[self.parents[j]] + 1
        return d

    def rest_positions(self) -> np.ndarray:
        """(J, 3) joint positions in the rest pose (all rotations identity, root at its offset)."""
        pos = np.zeros((self.num_joints, 3))
        for j, p in enumerate(self.parents):
            pos[j] = self.offsets[j] + (pos[p] if p >= 0 else 0.0)
        return pos

    def with_channels(self, channels: Sequence[Sequence[str]]) -> Skeleton:
        """Same hierarchy with another channel layout (e.g. another rotation order)."""
        return Skeleton(
            self.names,
            self.parents,
            self.offsets,
            tuple(tuple(c) for c in channels),
            self.end_site_parents,
            self.end_site_offsets,
            self.end_site_names,
            self.metres_per_unit,
        )

    def with_rotation_order(self, order: str) -> Skeleton:
        """Same layout with every joint's rotation channels in ``order`` (e.g. "ZYX")."""
        order = order.upper()
        if sorted(order) != ["X", "Y", "Z"]:
            raise ValueError(f"rotation order must be a permutation of XYZ, got {order!r}")
        new = []
        for ch in self.channels:
            pos = [c for c in ch if c in POSITION_CHANNELS]
            if not any(c in ROTATION_CHANNELS for c in ch):
                new.append(tuple(ch))
                continue
            rot = [f"{a}rotation" for a in order]
            rot_first = ch[0] in ROTATION_CHANNELS and bool(pos)
            new.append(tuple(rot + pos) if rot_first else tuple(pos + rot))
        return self.with_channels(new)

    def scaled(self, factor: float) -> Skeleton:
        """Offsets (and End Site offsets) multiplied by ``factor``; a stated unit shrinks by it."""
        return Skeleton(
            self.names,
            self.parents,
            self.offsets * factor,
            self.channels,
            self.end_site_parents,
            self.end_site_offsets * factor,
            self.end_site_names,
            None if self.metres_per_unit is None else self.metres_per_unit / factor,
        )

    def allclose(self, other: Skeleton, atol: float = 1e-9) -> bool:
        """Same names, hierarchy, channels and End Sites; offsets equal within ``atol``."""
        return (
            self.names == other.names
            and np.array_equal(self.parents, other.parents)
            and self.channels == other.channels
            and np.array_equal(self.end_site_parents, other.end_site_parents)
            and np.allclose(self.offsets, other.offsets, rtol=0, atol=atol)
            and np.allclose(self.end_site_offsets, other.end_site_offsets, rtol=0, atol=atol)
        )

    def height(self) -> float:
        """Rough size of the character: extent of rest-pose joint positions (file units)."""
        p = self.rest_positions()
        ext = p.max(axis=0) - p.min(axis=0)
        return float(ext.max()) if ext.max() > 0 else 1.0


def skeleton_difference(skeleton: Skeleton, reference: Skeleton, reference_name: str) -> str:
    """What keeps ``skeleton`` from being ``reference``'s rig (the same joint names, each with
    the same parent, in any order), in words to follow ``"NAME: "``; "" when nothing does."""
    rs, ds = reference, skeleton
    if set(rs.names) != set(ds.names) or len(rs.names) != len(ds.names):
        missing = sorted(set(rs.names) - set(ds.names))
        extra = sorted(set(ds.names) - set(rs.names))
        return (
            f"a different skeleton from {reference_name}: missing joints "
            f"{missing[:5]}{'...' if len(missing) > 5 else ''}, extra joints {extra[:5]}"
            f"{'...' if len(extra) > 5 else ''} (the same joint names are needed; "
            "mocapkit retarget puts a motion on another rig)"
        )
    order = [ds.names.index(n) for n in rs.names]
    for j, n in enumerate(rs.names):
        pr, pd = int(rs.parents[j]), int(ds.parents[order[j]])
        if (pr < 0) != (pd < 0) or (pr >= 0 and rs.names[pr] != ds.names[pd]):
            return f"joint {n!r} has a different parent than in {reference_name}"
    return ""
