"""What ``mocapkit convert`` does: read, resample and/or scale, rewrite the rotation order,
write (:func:`convert_file`); :func:`convert_motion` is the in-memory step between read and
write."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mocapkit.core.motion import Motion

__all__ = ["Converted", "convert_file", "convert_motion", "units_scale"]


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


def units_scale(motion: Motion, units: str) -> float:
    """The factor taking ``motion``'s lengths to ``units`` ("m", "cm", "mm", "inch"): from the
    unit its file states (ASF), else from the guess (:func:`mocapkit.features.detect_units`)."""
    from mocapkit.body import UNITS
    from mocapkit.features import detect_units

    if units not in UNITS:
        raise ValueError(f"--units must be one of {', '.join(UNITS)}, got {units!r}")
    return detect_units(motion)[1] / UNITS[units]


def convert_file(
    source: str | Path,
    output: str | Path,
    *,
    asf: str | Path | None = None,
    fps: float | None = None,
    scale: float | None = None,
    units: str | None = None,
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
    if units is not None:
        if scale is not None:
            raise ValueError("give --units or --scale, not both")
        scale = units_scale(motion, units)
    elif str(output).lower().endswith(".bvh") and motion.skeleton.metres_per_unit is not None:
        from mocapkit.body import UNITS

        mpu = motion.skeleton.metres_per_unit
        if not any(abs(mpu / v - 1) < 1e-9 for v in UNITS.values()) and scale is None:
            warnings.warn(
                f"{source}: its unit ({mpu:g} m) cannot be stated in a BVH file, which readers "
                "will guess as inch or cm; pass --units cm (or m, inch) to rescale",
                UserWarning,
                stacklevel=2,
            )
    motion = convert_motion(motion, fps=fps, scale=scale)
    return Converted(write_motion(motion, output, order=order), motion)
