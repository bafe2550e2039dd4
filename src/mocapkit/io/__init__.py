"""File formats: BVH, ASF/AMC (read), mocapkit's .npz and glTF 2.0 (.glb/.gltf), behind one pair
of entry points."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from mocapkit.core.motion import Motion
from mocapkit.io.bvh import read_bvh, write_bvh
from mocapkit.io.errors import (
    ASFAMCError,
    BVHError,
    DecodingWarning,
    FilledFramesWarning,
    MocapFileError,
    NonFiniteError,
    RepairWarning,
)
from mocapkit.io.npz import read_npz, write_npz

__all__ = [
    "ASFAMCError",
    "BVHError",
    "DecodingWarning",
    "FilledFramesWarning",
    "MocapFileError",
    "NonFiniteError",
    "RepairWarning",
    "files_under",
    "find_asf",
    "read_bvh",
    "read_gltf",
    "read_motion",
    "read_npz",
    "write_bvh",
    "write_gltf",
    "write_motion",
    "write_npz",
]

READABLE = (".bvh", ".npz", ".amc", ".glb", ".gltf")
WRITABLE = (".bvh", ".npz", ".glb", ".gltf")
GLTF = (".glb", ".gltf")


def files_under(root: Path, suffixes: Sequence[str] = READABLE) -> list[Path]:
    """The files under the folder ``root`` (its sub-folders included, linked ones too: a
    library is often one folder per subject or session, or links to them) whose extension is
    one of ``suffixes`` (any case), sorted by their path below ``root``. Hidden files and
    folders (``.git``, ``.mocapkit-manifest``) are skipped, and a folder already visited (a
    link back up, or two links to one folder) is not listed again. Raises OSError when
    ``root`` cannot be listed."""
    want = tuple(s.lower() for s in suffixes)

    def fail(e: OSError) -> None:
        if Path(e.filename or "") == Path(root):
            raise e  # the folder itself; an unreadable sub-folder is passed over

    out = []
    seen: set[str] = set()
    for folder, dirs, files in os.walk(root, onerror=fail, followlinks=True):
        real = os.path.realpath(folder)
        if real in seen:
            dirs[:] = []
            continue
        seen.add(real)
        dirs[:] = [d for d in dirs if not d.startswith(".")]
        for name in files:
            p = Path(folder, name)
            if not name.startswith(".") and p.suffix.lower() in want and p.is_file():
                out.append(p)
    return sorted(out, key=lambda p: p.relative_to(root).parts)


def find_asf(amc: Path) -> Path:
    """The ASF skeleton of a CMU-style AMC: ``<subject>.asf`` beside it (``01_02.amc`` ->
    ``01.asf``), else the only ``.asf`` in its folder; for an AMC that is a link, then the same
    beside the file it links to (a library of links to the takes)."""
    subject = amc.stem.split("_")[0]
    real = Path(os.path.realpath(amc))
    places = [amc] if real.parent == amc.parent.resolve() else [amc, real]
    for at in places:
        for cand in (at.with_suffix(".asf"), at.with_name(f"{at.stem.split('_')[0]}.asf")):
            if cand.exists():
                return cand
        found = sorted(at.parent.glob("*.asf"))
        if len(found) == 1:
            return found[0]
    raise MocapFileError(
        amc,
        None,
        f"cannot find its ASF skeleton file: put {subject}.asf beside it (looked for "
        f"{subject}.asf and a single .asf in {' and in '.join(str(p.parent) for p in places)}), "
        "or convert it with the ASF named "
        "first: mocapkit convert SUBJECT.asf TAKE.amc OUT",
    )


def read_motion(
    path: str | Path, lenient: bool = False, asf: str | Path | None = None, fps: float = 120.0
) -> Motion:
    """Read a BVH, .npz, AMC (+ ASF) or glTF (.glb/.gltf) file by its extension.

    ``asf`` and ``fps`` apply to AMC files only (AMC stores no frame rate; CMU's is 120). A
    glTF motion comes back in glTF's frame: metres, +Y up (:func:`mocapkit.io.gltf.read_gltf`).
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".bvh":
        return read_bvh(path, lenient=lenient)
    if ext == ".npz":
        return read_npz(path)
    if ext == ".amc":
        from mocapkit.io.asfamc import read_asfamc

        return read_asfamc(Path(asf) if asf else find_asf(path), path, fps=fps, lenient=lenient)
    if ext in GLTF:
        return read_gltf(path)
    if ext == ".asf":  # a skeleton alone: its motions are the .amc files beside it
        raise MocapFileError(
            path, None, "an .asf file holds the skeleton only; give an .amc take (its .asf is "
            "found beside it; mocapkit convert SUBJECT.asf TAKE.amc OUT names another)"
        )  # fmt: skip
    raise MocapFileError(path, None, f"unknown file type {ext!r}; expected one of {READABLE}")


def write_motion(motion: Motion, path: str | Path, order: str | None = None) -> Path:
    """Write a motion as BVH, .npz or glTF 2.0 (.glb/.gltf: metres, +Y up, see
    :func:`mocapkit.io.gltf.write_gltf`) by the extension (atomically)."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".bvh":
        return write_bvh(motion, path, order=order)
    if ext == ".npz":
        if order is not None:
            motion = motion.with_skeleton(motion.skeleton.with_rotation_order(order))
        return write_npz(motion, path)
    if ext in GLTF:
        if order is not None:
            motion = motion.with_skeleton(motion.skeleton.with_rotation_order(order))
        return write_gltf(motion, path)
    raise ValueError(f"cannot write {path}: unknown file type {ext!r}; expected one of {WRITABLE}")


def read_gltf(path: str | Path, animation: int = 0) -> Motion:
    """:func:`mocapkit.io.gltf.read_gltf` (imported on first use: it needs pygltflib)."""
    from mocapkit.io.gltf import read_gltf as _read

    return _read(path, animation)


def write_gltf(
    motion: Motion, path: str | Path, up: str | None = None, metres_per_unit: float | None = None
) -> Path:
    """:func:`mocapkit.io.gltf.write_gltf` (imported on first use: it needs pygltflib)."""
    from mocapkit.io.gltf import write_gltf as _write

    return _write(motion, path, up, metres_per_unit)
