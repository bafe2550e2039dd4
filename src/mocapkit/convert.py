"""What ``mocapkit convert`` does: read, resample and/or scale, rewrite the rotation order,
write (:func:`convert_file`); :func:`convert_motion` is the in-memory step between read and
write."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mocapkit.core.motion import Motion

__all__ = ["Converted", "convert_file", "convert_motion"]


def convert_motion(motion: Motion, fps: float | None = None, scale: float | None = None) -> Motion:
    """Resample to ``fps`` (:func:`mocapkit.features.resample`) and/or multiply every length
    (bone offsets, root and joint translations) by ``scale`` (e.g. 0.01 for cm -> m)."""
    from mocapkit import features

    if fps is not None:
        motion = features.resample(motion, fps)
    if scale is not None:
        if not scale > 0:
            raise ValueError(f"--scale must be positive, got {scale}")
        motion = Motion(
            motion.skeleton.scaled(scale),
            motion.rotations,
            motion.root_positions * scale,
            motion.frame_time,
            None if motion.translations is None else motion.translations * scale,
        )
    return motion


@dataclass(frozen=True, eq=False)
class Converted:
    """A written conversion: the output path and the motion written."""

    output: Path
    motion: Motion

    def to_json(self) -> dict[str, Any]:
        return {
            "output": str(self.output),
            "frames": self.motion.num_frames,
            "fps": self.motion.fps,
        }


def convert_file(
    source: str | Path,
    output: str | Path,
    *,
    asf: str | Path | None = None,
    fps: float | None = None,
    scale: float | None = None,
    order: str | None = None,
    amc_fps: float = 120.0,
    lenient: bool = False,
) -> Converted:
    """Read ``source`` (BVH, .npz, or AMC with ``asf`` or the ASF found beside it, at
    ``amc_fps``), :func:`convert_motion` it, and write ``output`` (BVH or .npz by its
    extension, every joint's rotation order rewritten to ``order`` when given) atomically.
    Refuses to overwrite ``source`` or ``asf``."""
    from mocapkit.io import read_motion, write_motion
    from mocapkit.io.atomic import refuse_overwrite

    refuse_overwrite(output, [p for p in (source, asf) if p is not None])
    motion = read_motion(source, lenient=lenient, asf=asf, fps=amc_fps)
    motion = convert_motion(motion, fps=fps, scale=scale)
    return Converted(write_motion(motion, output, order=order), motion)
