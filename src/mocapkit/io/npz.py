"""Motion <-> ``.npz``: a lossless binary form of mocapkit's arrays (NumPy's zip of arrays).

Stored arrays: ``names`` (J,) str, ``parents`` (J,), ``offsets`` (J, 3), ``channels`` (J,) str
(space-joined channel names), ``end_site_parents`` (E,), ``end_site_offsets`` (E, 3),
``end_site_names`` (E,) str, ``rotations`` (F, J, 4) w,x,y,z, ``root_positions`` (F, 3),
``frame_time`` () and optionally ``translations`` (F, J, 3) and ``metres_per_unit`` () where
the skeleton states its unit; ``format`` names the layout version.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton
from mocapkit.io.atomic import atomic_write_bytes
from mocapkit.io.errors import MocapFileError

FORMAT = "mocapkit-motion-1"


def write_npz(motion: Motion, path: str | Path) -> Path:
    """Write a motion to ``path`` (.npz) atomically."""
    motion.check_finite("cannot write npz")
    sk = motion.skeleton
    arrays = {
        "format": np.array(FORMAT),
        "names": np.array(sk.names, dtype=str),
        "parents": sk.parents,
        "offsets": sk.offsets,
        "channels": np.array([" ".join(c) for c in sk.channels], dtype=str),
        "end_site_parents": sk.end_site_parents,
        "end_site_offsets": sk.end_site_offsets,
        "end_site_names": np.array(sk.end_site_names, dtype=str),
        "rotations": motion.rotations,
        "root_positions": motion.root_positions,
        "frame_time": np.array(motion.frame_time),
    }
    if motion.translations is not None:
        arrays["translations"] = motion.translations
    if sk.metres_per_unit is not None:
        arrays["metres_per_unit"] = np.array(sk.metres_per_unit)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return atomic_write_bytes(path, buf.getvalue())


def read_npz(path: str | Path) -> Motion:
    """Read a motion written by :func:`write_npz` (MocapFileError on anything else)."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            head = f.read(4)
    except OSError as e:
        raise MocapFileError(path, None, f"cannot read file: {e.strerror or e}") from None
    if head != b"PK\x03\x04":  # an .npz is a zip archive; numpy's own message then spoke of
        # pickled data and allow_pickle, which is no help (and unsafe advice)
        what = " (it starts like a BVH file: name it .bvh)" if head == b"HIER" else ""
        raise MocapFileError(path, None, f"not an .npz archive{what}")
    try:
        with np.load(path, allow_pickle=False) as z:
            if "format" not in z or str(z["format"]) != FORMAT:
                raise MocapFileError(path, None, f"not a mocapkit motion file (expected {FORMAT})")
            sk = Skeleton(
                tuple(str(n) for n in z["names"]),
                z["parents"],
                z["offsets"],
                tuple(tuple(str(c).split()) for c in z["channels"]),
                z["end_site_parents"],
                z["end_site_offsets"].reshape(-1, 3),
                tuple(str(n) for n in z["end_site_names"]),
                float(z["metres_per_unit"]) if "metres_per_unit" in z else None,
            )
            motion = Motion(
                sk,
                z["rotations"],
                z["root_positions"],
                float(z["frame_time"]),
                z.get("translations", None),
            )
    except MocapFileError:
        raise
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as e:
        raise MocapFileError(path, None, f"cannot read npz motion: {e}") from None
    try:
        motion.check_finite(str(path))
    except ValueError as e:
        raise MocapFileError(path, None, str(e)) from None
    return motion
