"""mocapkit: motion-capture data tools.

The data model is plain NumPy arrays in thin containers: a :class:`Skeleton` (names, parents with
root -1 and parents before children, offsets) and a :class:`Motion` (local rotations (F, J, 4) as
unit quaternions w,x,y,z, root translation (F, 3), exact frame time). Radians inside; degrees
only at file I/O; durations in the API in seconds.
"""

from mocapkit.core.kinematics import forward_kinematics
from mocapkit.core.motion import Motion, concatenate
from mocapkit.core.skeleton import Skeleton
from mocapkit.io import (
    BVHError,
    MocapFileError,
    RepairWarning,
    read_bvh,
    read_motion,
    write_bvh,
    write_motion,
)
from mocapkit.summary import MotionSummary, summarize

__version__ = "0.1.0"

__all__ = [
    "BVHError",
    "MocapFileError",
    "Motion",
    "MotionSummary",
    "RepairWarning",
    "Skeleton",
    "__version__",
    "concatenate",
    "forward_kinematics",
    "read_bvh",
    "read_motion",
    "summarize",
    "write_bvh",
    "write_motion",
]
