"""Editing motions: everyday edits (trim, mirror, root motion, rename/drop joints, speed) and
retargeting.

Every edit is a free function from a :class:`~mocapkit.core.motion.Motion` to a new one;
:func:`apply_edits` runs a set of them in the fixed order the ``mocapkit edit`` command uses.
"""

from mocapkit.edit.everyday import EDIT_ORDER, EditResult, apply_edits
from mocapkit.edit.joints import drop_joints, joints_matching, rename_joints
from mocapkit.edit.mirror import Mirrored, joint_mirrors, mirror, mirror_pairs
from mocapkit.edit.retarget import RetargetConfig, Retargeted, retarget
from mocapkit.edit.rootmotion import extract_root_motion, in_place
from mocapkit.edit.timing import change_speed, trim, trim_frames

__all__ = [
    "EDIT_ORDER",
    "EditResult",
    "Mirrored",
    "RetargetConfig",
    "Retargeted",
    "apply_edits",
    "change_speed",
    "drop_joints",
    "extract_root_motion",
    "in_place",
    "joint_mirrors",
    "joints_matching",
    "mirror",
    "mirror_pairs",
    "rename_joints",
    "retarget",
    "trim",
    "trim_frames",
]
