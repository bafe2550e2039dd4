"""The everyday edits as one call, in one fixed order (what ``mocapkit edit`` runs).

Every option names frames and joints of the **input**: the trim range reads the input's
timeline and the joint regex and renames read its joint names, whatever else is done. The
order is :data:`EDIT_ORDER`:

1. ``trim``: frames first, so nothing is computed for frames that go;
2. ``mirror``: before joints are dropped, since it needs both sides of the full rig to pair;
3. ``root`` (``"in-place"`` or ``"extract"``): on the body as captured (after the mirror, which
   moves it but keeps its travel a travel);
4. ``drop``: the joint regex (which also sees the ``Root`` joint ``extract`` adds);
5. ``speed``: resampling, on the joints that are left;
6. ``rename``: last, so every other option reads the input's names.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mocapkit.core.motion import Motion
from mocapkit.edit.joints import drop_joints, joints_matching, rename_joints
from mocapkit.edit.mirror import mirror
from mocapkit.edit.rootmotion import ROOT_NAME, extract_root_motion, in_place
from mocapkit.edit.timing import change_speed, trim_frames
from mocapkit.summary import nominal_fps

__all__ = ["EDIT_ORDER", "ROOT_MODES", "EditResult", "apply_edits"]

EDIT_ORDER = ("trim", "mirror", "root", "drop", "speed", "rename")
ROOT_MODES = ("in-place", "extract")


@dataclass
class EditResult:
    """The edited motion and, per edit done, what it did (in :data:`EDIT_ORDER`)."""

    motion: Motion
    input_frames: int
    input_fps: float
    steps: list[dict[str, Any]] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        m = self.motion
        return {
            "input": {"frames": self.input_frames, "fps": self.input_fps},
            "output": {
                "frames": m.num_frames,
                "fps": nominal_fps(m.frame_time),  # 30, not 30.00003 for 0.0333333
                "frame_time": m.frame_time,
                "duration_s": m.duration,
                "joints": m.num_joints,
            },
            "order": [s["edit"] for s in self.steps],  # the edits done, in the order run
            "steps": self.steps,
        }


def apply_edits(
    motion: Motion,
    *,
    trim: tuple[int, int] | None = None,
    mirror_lr: bool = False,
    root: str | None = None,
    drop: str | None = None,
    speed: float | None = None,
    rename: Mapping[str, str] | None = None,
    up: str | None = None,
) -> EditResult:
    """Run the edits asked for, in :data:`EDIT_ORDER` (see the module notes).

    Args:
        motion: the input take.
        trim: frames ``(start, stop)``, 0-based, stop excluded (:mod:`mocapkit.core.ranges`
            reads ``A:B`` and ``1.5s:4.0s`` into this).
        mirror_lr: mirror left/right (:func:`mocapkit.edit.mirror.mirror`).
        root: ``"in-place"`` or ``"extract"`` (:mod:`mocapkit.edit.rootmotion`).
        drop: a regular expression on whole joint names (:func:`drop_joints`).
        speed: play this many times faster (:func:`change_speed`).
        rename: ``{old: new}`` joint names of the input.
        up: the up axis instead of the body model's.

    Everything is checked before anything is computed: an unknown joint in ``rename``, a
    regex that drops the root or nothing, a bad speed or mode is a ValueError / KeyError.
    """
    sk = motion.skeleton
    rename = dict(rename or {})
    if root is not None and root not in ROOT_MODES:
        raise ValueError(f"root motion: expected one of {', '.join(ROOT_MODES)}, got {root!r}")
    if speed is not None and not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"speed: expected a positive factor (1.25 = 25% faster), got {speed!r}")
    dropped: list[str] = []
    if drop is not None:
        dropped = [sk.names[j] for j in joints_matching(sk, drop)]
        if not dropped and not (root == "extract" and joints_matching_name(ROOT_NAME, drop)):
            raise ValueError(f"drop: no joint matches {drop!r}")
        if sk.names[0] in dropped:
            raise ValueError(
                f"drop: {drop!r} matches the root joint {sk.names[0]!r}, which cannot be dropped"
            )
    for old in rename:
        if old not in sk.names and not (root == "extract" and old == ROOT_NAME):
            raise KeyError(f"rename: no joint named {old!r}")
        if old in dropped:
            raise ValueError(f"rename: joint {old!r} is dropped by {drop!r}")

    res = EditResult(motion, motion.num_frames, nominal_fps(motion.frame_time))
    m = motion
    if trim is not None:
        a, b = trim
        m = trim_frames(m, a, b)
        res.steps.append(
            {"edit": "trim", "frames": [a, b], "seconds": [a * m.frame_time, b * m.frame_time]}
        )
    if mirror_lr:
        mr = mirror(m, up)
        m = mr.motion
        res.steps.append({"edit": "mirror", **mr.to_json()})
    if root == "in-place":
        m = in_place(m, up)
        res.steps.append({"edit": "in-place"})
    elif root == "extract":
        before = m.num_joints
        m = extract_root_motion(m, up)
        added = m.skeleton.names[0] if m.num_joints > before else None
        res.steps.append(
            {"edit": "extract", "root": m.skeleton.names[0], "added_joint": added is not None}
        )
    if drop is not None:
        names = [n for n in m.skeleton.names if n in set(dropped) or joints_matching_name(n, drop)]
        m = drop_joints(m, drop)
        res.steps.append({"edit": "drop", "pattern": drop, "dropped": names})
    if speed is not None and speed != 1.0:
        frames_before = m.num_frames
        m = change_speed(m, speed)
        res.steps.append(
            {"edit": "speed", "factor": speed, "frames": [frames_before, m.num_frames]}
        )
    if rename:
        m = rename_joints(m, rename)
        res.steps.append({"edit": "rename", "mapping": rename})
    res.motion = m
    return res


def joints_matching_name(name: str, pattern: str) -> bool:
    """Whether the joint regex ``pattern`` matches the whole of ``name``."""
    return re.fullmatch(pattern, name) is not None
