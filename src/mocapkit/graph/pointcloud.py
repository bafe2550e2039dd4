"""Body parts and their representative points ("point clouds") for frame comparison.

A body part is one joint of the pelvis' subtree (the bone from that joint to its children);
joints above the pelvis (e.g. Bandai-Namco's static ``joint_Root`` ground projection) are not
parts. A part's representative points are its joint's position plus the End Sites hanging from
it (so the head, hands and toes tips are represented too). All positions are world positions in
file units; each part's points are weighted equally (the paper's per-part mean).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mocapkit.body import body_of
from mocapkit.core.kinematics import end_site_positions, forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton

__all__ = ["BodyParts", "body_parts", "point_cloud"]


@dataclass(frozen=True, eq=False)
class BodyParts:
    """The body parts of a skeleton.

    Attributes:
        skeleton: the skeleton.
        joints: (B,) joint index of each part (pelvis first, parents before children).
        parents: (B,) index into ``joints`` of each part's parent part, -1 for the pelvis.
        point_part: (P,) part index of each representative point.
        point_source: (P,) joint index (>= 0) or ``-1 - e`` for End Site e, per point.
        names: (B,) joint names of the parts.
    """

    skeleton: Skeleton
    joints: np.ndarray
    parents: np.ndarray
    point_part: np.ndarray
    point_source: np.ndarray
    names: tuple[str, ...]

    @property
    def num_parts(self) -> int:
        return len(self.joints)

    @property
    def num_points(self) -> int:
        return len(self.point_part)

    def points_per_part(self) -> np.ndarray:
        """(B,) number of representative points of each part."""
        return np.bincount(self.point_part, minlength=self.num_parts)

    def children(self, b: int) -> list[int]:
        return [int(c) for c in np.flatnonzero(self.parents == b)]

    def descendants(self, b: int) -> list[int]:
        """Parts outward from part ``b`` (not including ``b``), in part order."""
        return [self.part_of_joint(j) for j in self.skeleton.descendants(int(self.joints[b]))]

    def ancestors(self, b: int) -> list[int]:
        """Parts inward from ``b`` up to and including the pelvis (nearest first)."""
        above = self.skeleton.ancestors(int(self.joints[b]))
        return [self.part_of_joint(j) for j in above if j in self._index]

    @property
    def _index(self) -> dict[int, int]:
        return {int(j): b for b, j in enumerate(self.joints)}

    def part_of_joint(self, joint: int) -> int:
        """Part index of a joint (KeyError if the joint is not a part)."""
        hit = np.flatnonzero(self.joints == joint)
        if len(hit) == 0:
            raise KeyError(f"joint {self.skeleton.names[joint]!r} is not a body part")
        return int(hit[0])


def body_parts(skeleton: Skeleton) -> BodyParts:
    """Body parts of a skeleton: the pelvis (see :attr:`mocapkit.body.Body.pelvis`) and
    every joint below it."""
    pelvis = body_of(skeleton).pelvis
    joints = np.flatnonzero(skeleton.subtree_mask(pelvis))
    where = {int(j): b for b, j in enumerate(joints)}
    parents = np.array(
        [-1 if j == pelvis else where[int(skeleton.parents[j])] for j in joints], dtype=np.int64
    )
    point_part: list[int] = []
    point_source: list[int] = []
    for b, j in enumerate(joints):
        point_part.append(b)
        point_source.append(int(j))
        for e in np.flatnonzero(skeleton.end_site_parents == j):
            point_part.append(b)
            point_source.append(-1 - int(e))
    return BodyParts(
        skeleton,
        joints,
        parents,
        np.array(point_part, dtype=np.int64),
        np.array(point_source, dtype=np.int64),
        tuple(skeleton.names[j] for j in joints),
    )


def point_cloud(motion: Motion, parts: BodyParts | None = None) -> np.ndarray:
    """World positions (F, P, 3) of the representative points of every frame (file units)."""
    parts = body_parts(motion.skeleton) if parts is None else parts
    pos, grot = forward_kinematics(motion)
    src = parts.point_source
    out = np.empty((motion.num_frames, len(src), 3))
    is_joint = src >= 0
    out[:, is_joint] = pos[:, src[is_joint]]
    if (~is_joint).any():
        ends = end_site_positions(motion.skeleton, pos, grot)
        out[:, ~is_joint] = ends[:, -1 - src[~is_joint]]
    return out
