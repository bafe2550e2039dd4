"""What ``mocapkit info`` says about a motion file: :func:`summarize` returns a
:class:`MotionSummary`, whose :meth:`~MotionSummary.to_json` is exactly what ``info --json``
prints.

The summary is the place to add what more ``info`` should report (body parts, height, the joint
tree): add a field with a default, fill it in :func:`summarize`, and give it a key in
:meth:`MotionSummary.to_json` (``extra`` holds keys that have no field yet).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mocapkit.core.motion import Motion

__all__ = ["ContactSummary", "MotionSummary", "nominal_fps", "summarize", "summarize_file"]


def nominal_fps(frame_time: float) -> float:
    """The frame rate of ``frame_time``: the integer ``n`` when the frame time is ``1/n``
    as written with its digits (``0.0333333`` -> 30, ``0.008333`` -> 120, ``0.04`` -> 25,
    rounded or truncated to within one unit of its last digit, at least 4 significant digits
    unless exact), else ``1 / frame_time``."""
    import math

    if not (math.isfinite(frame_time) and frame_time > 0):
        return float("nan") if frame_time != 0 else float("inf")
    exact = 1.0 / frame_time
    n = round(exact)
    if n < 1:
        return exact
    if abs(frame_time * n - 1.0) <= 1e-12:
        return float(n)
    digits = repr(frame_time)
    if "e" in digits or "E" in digits:
        return exact
    significant = digits.replace("-", "").replace(".", "").lstrip("0")
    if len(significant) < 4:
        return exact
    unit = 10.0 ** (math.floor(math.log10(frame_time)) - len(significant) + 1)
    return float(n) if abs(frame_time - 1.0 / n) <= unit * (1 + 1e-9) else exact


@dataclass(frozen=True)
class ContactSummary:
    """One foot joint's contacts: the fraction of frames in contact and the number of contact
    runs (steps)."""

    fraction: float
    segments: int


#: The range of people's heights (metres; children from about 3 years to the tallest adults).
PERSON_HEIGHT_M = (0.9, 2.3)


@dataclass(frozen=True)
class MotionSummary:
    """A motion's skeleton, timing, axes, extent and foot contacts.

    ``bounding_box``: ``(min xyz, max xyz)`` of the joint positions over all frames, file units
    (None without frames). ``contacts``: per foot joint name, or None without frames;
    ``contacts_error`` says why there are none when feet could not be found.
    """

    path: str
    joints: int
    joint_names: tuple[str, ...]
    channels: int
    channels_per_joint: tuple[tuple[str, ...], ...]
    rotation_orders: tuple[str, ...]
    end_sites: int
    frames: int
    frame_time: float
    fps: float
    duration_s: float
    up_axis: str
    units_guess: str
    metres_per_unit: float
    bounding_box: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    contacts: dict[str, ContactSummary] | None = None
    contacts_error: str | None = None
    parents: tuple[int, ...] = ()
    offsets: tuple[tuple[float, float, float], ...] = ()
    body: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    units_note: str | None = None

    def to_json(self) -> dict[str, Any]:
        """The JSON-ready dict ``mocapkit info --json`` prints (keys in this order)."""
        out: dict[str, Any] = {
            "path": self.path,
            "joints": self.joints,
            "joint_names": list(self.joint_names),
            "channels": self.channels,
            "channels_per_joint": [list(c) for c in self.channels_per_joint],
            "rotation_orders": list(self.rotation_orders),
            "end_sites": self.end_sites,
            "frames": self.frames,
            "frame_time": self.frame_time,
            "fps": self.fps,
            "duration_s": self.duration_s,
            "up_axis": self.up_axis,
            "units_guess": self.units_guess,
            "metres_per_unit": self.metres_per_unit,
        }
        if self.units_note is not None:
            out["units_note"] = self.units_note
        if self.bounding_box is not None:
            lo, hi = self.bounding_box
            out["bounding_box"] = {"min": list(lo), "max": list(hi)}
        if self.contacts_error is not None:
            out["contacts"] = {"error": self.contacts_error}
        elif self.contacts is not None:
            out["contacts"] = {
                name: {"fraction": c.fraction, "segments": c.segments}
                for name, c in self.contacts.items()
            }
        out["parents"] = list(self.parents)
        out["offsets"] = [list(o) for o in self.offsets]
        out["body"] = self.body
        out.update(self.extra)
        return out


def summarize(
    motion: Motion, path: str | Path = "", up: str | None = None, units: str | None = None
) -> MotionSummary:
    """Summarise ``motion`` (read from ``path``, which is only recorded).

    ``up`` ("Y", "Z", "-Y", ...) and ``units`` ("m", "cm", "mm", "inch") override the guesses
    (:func:`mocapkit.features.detect_up_axis`, :func:`mocapkit.features.detect_units`).
    Contacts: :func:`mocapkit.features.foot_contacts`, fraction rounded to 4 digits.
    """
    from mocapkit import features
    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.core.runs import true_runs

    sk = motion.skeleton
    body = body_of(motion)
    if up:
        up = up.upper()
        found = features.up_disagreement(motion, up)
        if found is not None:
            warnings.warn(
                f"{path}: up axis {up} given, but its body stands along {found} (head above "
                f"the feet); the summary uses {up} as asked",
                UserWarning,
                stacklevel=2,
            )
    else:
        up = features.detect_up_axis(motion)
    guessed = not units and sk.metres_per_unit is None
    if units:
        metres = features.metres_per_unit(motion, units)
        units = next(k for k, v in features.UNITS.items() if v == metres)
    else:
        units, metres = features.detect_units(motion)
    note = None
    h = body.stature * metres
    if guessed and not (PERSON_HEIGHT_M[0] <= h <= PERSON_HEIGHT_M[1]):
        # the guess picks the unit that makes the body closest to an adult's size: a height
        # outside a person's range means no unit fits, so the guess is no more than a guess
        note = (
            f"a height of {h:.2f} m is not a person's: the unit guess ({units}) may be wrong, "
            "or the rig is not a human; give --units"
        )
    box = contacts = error = None
    if motion.num_frames:
        pos, _ = forward_kinematics(motion)
        lo = pos.min(axis=(0, 1)).round(6) + 0.0  # + 0.0: no negative zeros
        hi = pos.max(axis=(0, 1)).round(6) + 0.0
        box = (tuple(float(v) for v in lo), tuple(float(v) for v in hi))
        try:
            fc = features.foot_contacts(motion, up=up, units=metres)
        except ValueError as e:
            error = str(e)
        else:
            contacts = {
                name: ContactSummary(
                    round(float(fc.contacts[:, i].mean()), 4), len(true_runs(fc.contacts[:, i]))
                )
                for i, name in enumerate(fc.names)
            }
    return MotionSummary(
        path=str(path),
        joints=len(sk.names),
        joint_names=tuple(sk.names),
        channels=sk.num_channels,
        channels_per_joint=tuple(tuple(c) for c in sk.channels),
        rotation_orders=tuple(
            sorted({sk.rotation_orders[j] for j in range(sk.num_joints) if sk.has_rotation[j]})
        ),
        end_sites=len(sk.end_site_parents),
        frames=motion.num_frames,
        frame_time=motion.frame_time,
        fps=nominal_fps(motion.frame_time),
        duration_s=motion.duration,
        up_axis=up,
        units_guess=units,
        metres_per_unit=metres,
        bounding_box=box,
        contacts=contacts,
        contacts_error=error,
        parents=tuple(int(p) for p in sk.parents),
        offsets=tuple((float(x), float(y), float(z)) for x, y, z in sk.offsets),
        body=body.to_json(),
        units_note=note,
    )


def summarize_file(
    path: str | Path,
    up: str | None = None,
    units: str | None = None,
    lenient: bool = False,
    amc_fps: float = 120.0,
) -> MotionSummary:
    """Read ``path`` (:func:`mocapkit.io.read_motion`; an AMC finds its ASF beside it) and
    :func:`summarize` it: what ``mocapkit info`` does per file."""
    from mocapkit.io import read_motion

    return summarize(read_motion(path, lenient=lenient, fps=amc_fps), str(path), up, units)
