"""Motion: a skeleton plus per-frame local joint rotations and root translation.

Conventions:
- ``rotations`` is (F, J, 4) unit quaternions in **w, x, y, z** order, each joint's rotation
  relative to its parent (local), in radians-based math (degrees only at file I/O).
- ``root_positions`` is (F, 3): the root joint's local translation per frame, in file units.
  For a root without position channels it repeats the root's OFFSET.
- ``translations`` is ``None`` or (F, J, 3): per-joint local translations, present only when some
  non-root joint animates its position (6-channel joints); column j equals ``offsets[j]`` for joints
  without position channels and column 0 equals ``root_positions``.
- ``frame_time`` is the exact frame time in seconds as read from the file (never rounded through
  an fps integer).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.skeleton import Skeleton


@dataclass(eq=False)
class Motion:
    """Local joint rotations over time.

    Attributes:
        skeleton: the hierarchy.
        rotations: (F, J, 4) unit quaternions w,x,y,z, local to the parent.
        root_positions: (F, 3) root translation.
        frame_time: seconds per frame (exact).
        translations: optional (F, J, 3) local translations when non-root joints animate them.
    """

    skeleton: Skeleton
    rotations: np.ndarray
    root_positions: np.ndarray
    frame_time: float
    translations: np.ndarray | None = None

    def __post_init__(self) -> None:
        J = self.skeleton.num_joints
        self.rotations = np.asarray(self.rotations, dtype=np.float64)
        self.root_positions = np.asarray(self.root_positions, dtype=np.float64)
        if self.rotations.ndim != 3 or self.rotations.shape[1:] != (J, 4):
            raise ValueError(f"rotations must be (F, {J}, 4), got {self.rotations.shape}")
        F = self.rotations.shape[0]
        if self.root_positions.shape != (F, 3):
            raise ValueError(f"root_positions must be ({F}, 3), got {self.root_positions.shape}")
        if self.translations is not None:
            self.translations = np.asarray(self.translations, dtype=np.float64)
            if self.translations.shape != (F, J, 3):
                raise ValueError(
                    f"translations must be ({F}, {J}, 3), got {self.translations.shape}"
                )
        ft = float(self.frame_time)
        if not np.isfinite(ft) or ft <= 0:
            raise ValueError(f"frame_time must be a positive number of seconds, got {ft!r}")
        self.frame_time = ft

    # ---- basic properties ------------------------------------------------------------------
    @property
    def num_frames(self) -> int:
        return int(self.rotations.shape[0])

    def __len__(self) -> int:
        return self.num_frames

    @property
    def num_joints(self) -> int:
        return self.skeleton.num_joints

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Length in seconds: ``num_frames * frame_time``."""
        return self.num_frames * self.frame_time

    def seconds_to_frames(self, seconds: float) -> int:
        """A duration in seconds as a whole number of frames (rounded, at least 0)."""
        return max(0, round(seconds / self.frame_time))

    def local_translations(self) -> np.ndarray:
        """(F, J, 3) local translation of every joint (offsets where not animated)."""
        if self.translations is not None:
            t = self.translations.copy()
        else:
            t = np.broadcast_to(self.skeleton.offsets, (self.num_frames, self.num_joints, 3)).copy()
        t[:, 0] = self.root_positions
        return t

    # ---- editing (all return new motions) ----------------------------------------------------
    def copy(self) -> Motion:
        return Motion(
            self.skeleton,
            self.rotations.copy(),
            self.root_positions.copy(),
            self.frame_time,
            None if self.translations is None else self.translations.copy(),
        )

    def __getitem__(self, index: slice | Sequence[int] | np.ndarray) -> Motion:
        """Frames selected by a slice or an index array (a new Motion sharing nothing); an int
        selects that one frame (negative from the end), IndexError past either end."""
        if isinstance(index, int | np.integer):
            k = int(index)
            if not -self.num_frames <= k < self.num_frames:
                raise IndexError(f"frame {k} out of range for {self.num_frames} frames")
            k %= self.num_frames
            index = slice(k, k + 1)
        return Motion(
            self.skeleton,
            self.rotations[index].copy(),
            self.root_positions[index].copy(),
            self.frame_time,
            None if self.translations is None else self.translations[index].copy(),
        )

    def slice_seconds(self, start: float, stop: float | None = None) -> Motion:
        """Frames whose times lie in [start, stop) seconds."""
        a = self.seconds_to_frames(start)
        b = None if stop is None else self.seconds_to_frames(stop)
        return self[a:b]

    def with_skeleton(self, skeleton: Skeleton) -> Motion:
        """Same data on a skeleton with the same joints (e.g. another channel layout)."""
        if skeleton.num_joints != self.num_joints:
            raise ValueError("the new skeleton must have the same number of joints")
        return Motion(
            skeleton, self.rotations, self.root_positions, self.frame_time, self.translations
        )

    def check_finite(self, source: str = "motion") -> None:
        """Raise ValueError naming the first frame and joint holding NaN or inf."""
        for name, arr in (
            ("rotation", self.rotations),
            ("root position", self.root_positions),
            ("translation", self.translations),
        ):
            if arr is None:
                continue
            bad = ~np.isfinite(arr)
            if bad.any():
                idx = np.argwhere(bad)[0]
                where = f"frame {idx[0]}" + (
                    f", joint {self.skeleton.names[idx[1]]!r}" if arr.ndim == 3 else ""
                )
                raise ValueError(f"{source}: non-finite {name} at {where}")

    def allclose(self, other: Motion, rot_atol: float = 1e-6, pos_atol: float = 1e-6) -> bool:
        """Equal within tolerance: same skeleton and frame time, every local rotation within
        ``rot_atol`` radians (geodesic, so q and -q are equal), translations within ``pos_atol``."""
        if (
            self.num_frames != other.num_frames
            or not self.skeleton.allclose(other.skeleton, atol=pos_atol)
            or self.frame_time != other.frame_time
        ):
            return False
        if self.num_frames == 0:
            return True
        ang = rot.quat_angle(self.rotations, other.rotations)
        if not np.all(ang <= rot_atol):
            return False
        return bool(
            np.allclose(
                self.local_translations(), other.local_translations(), rtol=0, atol=pos_atol
            )
        )


def concatenate(motions: Sequence[Motion]) -> Motion:
    """Join motions end to end (same skeleton layout and frame time), without any alignment."""
    if not motions:
        raise ValueError("concatenate needs at least one motion")
    first = motions[0]
    for m in motions[1:]:
        if not m.skeleton.allclose(first.skeleton):
            raise ValueError("cannot concatenate motions with different skeletons")
        if not np.isclose(m.frame_time, first.frame_time, rtol=1e-9, atol=0):
            raise ValueError(
                f"cannot concatenate motions with frame times {first.frame_time} and {m.frame_time}"
            )
    translations = None
    if any(m.translations is not None for m in motions):
        translations = np.concatenate([m.local_translations() for m in motions])
    return Motion(
        first.skeleton,
        np.concatenate([m.rotations for m in motions]),
        np.concatenate([m.root_positions for m in motions]),
        first.frame_time,
        translations,
    )


def fill_missing(motion: Motion) -> tuple[Motion, list[str]]:
    """Fill non-finite rotations (slerp) and translations (linear) from the nearest valid frames.

    A joint-frame is missing when any component is NaN/inf. Gaps at the start or end hold the
    nearest valid value; a joint with no valid frame gets the identity / its offset. Returns the
    repaired motion and the names of the joints that were touched.
    """
    out = motion.copy()
    F = out.num_frames
    touched: list[str] = []
    frames = np.arange(F)
    for j, name in enumerate(out.skeleton.names):
        q = out.rotations[:, j]
        bad = ~np.all(np.isfinite(q), axis=1)
        t_arrays = [out.root_positions] if j == 0 else []
        if out.translations is not None:
            t_arrays.append(out.translations[:, j])
        t_bad = [~np.all(np.isfinite(t), axis=1) for t in t_arrays]
        if not bad.any() and not any(b.any() for b in t_bad):
            continue
        touched.append(name)
        if bad.any():
            good = np.flatnonzero(~bad)
            if len(good) == 0:
                q[:] = rot.quat_identity()
            else:
                idx = np.flatnonzero(bad)
                hi = np.clip(np.searchsorted(good, idx), 0, len(good) - 1)
                lo = np.clip(hi - 1, 0, len(good) - 1)
                hi = np.where(good[hi] < idx, lo, hi)
                lo = np.where(good[lo] > idx, hi, lo)
                a, b = good[lo], good[hi]
                t = np.where(b > a, (idx - a) / np.maximum(b - a, 1), 0.0)
                q[idx] = rot.quat_slerp(q[a], q[b], t)
        for t_arr, tb in zip(t_arrays, t_bad, strict=True):
            if tb.any():
                good = np.flatnonzero(~tb)
                for c in range(3):
                    if len(good) == 0:
                        t_arr[:, c] = motion.skeleton.offsets[j, c]
                    else:
                        t_arr[tb, c] = np.interp(frames[tb], good, t_arr[good, c])
    if out.translations is not None:
        out.translations[:, 0] = out.root_positions
    return out, touched
