"""What ``mocapkit convert`` does: read, resample and/or scale, rewrite the rotation order,
write (:func:`convert_file`); :func:`convert_motion` is the in-memory step between read and
write; :func:`convert_many` converts a list of files into a folder, going on past bad ones."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mocapkit.core.motion import Motion
from mocapkit.summary import nominal_fps

__all__ = [
    "FOLDER_FORMATS",
    "Converted",
    "ConvertedMany",
    "ItemResult",
    "convert_file",
    "convert_many",
    "convert_motion",
    "convert_one",
    "output_path",
    "units_scale",
]

FOLDER_FORMATS = ("bvh", "npz", "glb", "gltf")
"""What :func:`convert_many` writes (``--to``)."""


def convert_motion(motion: Motion, fps: float | None = None, scale: float | None = None) -> Motion:
    """Resample to ``fps`` (:func:`mocapkit.features.resample`) and/or multiply every length
    (bone offsets, root and joint translations) by ``scale`` (e.g. 0.01 for cm -> m). A rate
    that would leave a take of two or more frames a single frame is refused (ValueError)."""
    from mocapkit import features

    if fps is not None:
        out = features.resample(motion, fps)
        if motion.num_frames >= 2 and out.num_frames < 2:  # its motion would be gone
            span = (motion.num_frames - 1) * motion.frame_time
            raise ValueError(
                f"--fps {fps:g} leaves 1 frame of the take's {motion.num_frames}: its "
                f"{span:.3g} s are under half a frame at {fps:g} fps"
            )
        motion = out
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
            "fps": nominal_fps(self.motion.frame_time),  # 30, as info gives it
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
    motion = convert_motion(motion, fps=fps, scale=scale)
    return Converted(write_motion(motion, output, order=order), motion)


@dataclass(frozen=True)
class ItemResult:
    """One input of :func:`convert_many`: what was written, or why not (one line naming the
    input file)."""

    source: Path
    output: Path | None
    frames: int | None = None
    fps: float | None = None
    error: str | None = None
    resumed: bool = False

    @property
    def ok(self) -> bool:
        return self.error is None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"source": str(self.source)}
        if self.error is None:
            out.update(output=str(self.output), frames=self.frames, fps=self.fps)
        else:
            out["error"] = self.error
        return out


@dataclass(frozen=True)
class ConvertedMany:
    """Every input of :func:`convert_many`, in order."""

    items: tuple[ItemResult, ...]

    @property
    def failed(self) -> list[ItemResult]:
        return [i for i in self.items if not i.ok]

    @property
    def resumed(self) -> int:
        """Inputs found complete and unchanged from an earlier run, not converted again."""
        return sum(1 for i in self.items if i.resumed)

    def to_json(self) -> dict[str, Any]:
        return {
            "converted": len(self.items) - len(self.failed),
            "resumed": self.resumed,
            "failed": len(self.failed),
            "items": [i.to_json() for i in self.items],
        }


def output_path(source: str | Path, out_dir: str | Path, to: str, sub: str | Path = "") -> Path:
    """Where :func:`convert_many` writes ``source``: ``out_dir/<sub>/<its stem>.<to>`` (``sub``:
    the source's sub-folder below the folder it was found in, so that a library's layout is
    kept and ``a/x.bvh`` and ``b/x.bvh`` do not meet)."""
    to = to.lower().lstrip(".")
    if to not in FOLDER_FORMATS:
        raise ValueError(f"cannot convert to {to!r}; expected one of {', '.join(FOLDER_FORMATS)}")
    return Path(out_dir) / sub / f"{Path(source).stem}.{to}"


def _error_line(source: Path, e: BaseException) -> str:
    """One line naming ``source`` and what went wrong (the message as it is when it names a
    path already, as file readers' and output-path errors do)."""
    from mocapkit.io.atomic import OutputPathError

    if isinstance(e, OutputPathError):
        msg = str(e)
    elif isinstance(e, OSError):
        where = e.filename if e.filename is not None else source
        msg = f"{where}: {e.strerror or e}"
    else:
        msg = str(e.args[0]) if isinstance(e, KeyError) and e.args else str(e)
    msg = " ".join(msg.split())
    return msg if str(source) in msg else f"{source}: {msg}"


def convert_one(task: tuple[str | Path, str | Path, dict[str, Any]]) -> ItemResult:
    """One input of :func:`convert_many`, ``(source, output, options)``: :func:`convert_file`,
    or the error line naming the input (on whichever process runs it)."""
    from mocapkit.io import MocapFileError

    src, out, options = Path(task[0]), Path(task[1]), task[2]
    try:
        res = convert_file(src, out, **options)
    except (MocapFileError, ValueError, KeyError, OSError) as e:
        return ItemResult(src, None, error=_error_line(src, e))
    return ItemResult(src, res.output, res.motion.num_frames, nominal_fps(res.motion.frame_time))


def _resume_key(src: Path, to: str, options: dict[str, Any]) -> str:
    """The manifest key of one conversion (:mod:`mocapkit.batch.manifest`): the source's path
    and sha256, an AMC's ASF beside it, the target format, the options, the version."""
    from mocapkit.batch.manifest import file_sha256, input_key

    context = []
    if src.suffix.lower() == ".amc":
        from mocapkit.io import MocapFileError, find_asf

        try:
            asf = find_asf(src)
            context.append((str(asf), file_sha256(asf)))
        except (MocapFileError, OSError, ValueError):
            context.append(("asf", "missing"))
    config = {"to": to, **{k: options[k] for k in sorted(options)}}
    # by name, not by path: the same source converts to the same output however it is spelled
    context = [(Path(name).name, digest) for name, digest in context]
    return input_key(src.name, file_sha256(src), context, config)


def convert_many(
    sources: Sequence[str | Path],
    out_dir: str | Path,
    to: str,
    *,
    on_item: Callable[[ItemResult], None] | None = None,
    runner: Any = None,
    progress: Callable[[int, int], None] | None = None,
    subfolders: Sequence[str | Path] | None = None,
    **options: Any,
) -> ConvertedMany:
    """Convert every file of ``sources`` into ``out_dir`` as ``<stem>.<to>`` (``to``: one of
    :data:`FOLDER_FORMATS`; in ``out_dir/<subfolders[k]>/`` when given: the layout of the
    folders the sources were found in) with :func:`convert_file` and ``options`` (``fps``,
    ``scale``, ``units``, ``order``, ``amc_fps``, ``lenient``; an AMC's ASF is the one beside
    it).

    A file that cannot be converted (unreadable, or its output name taken by an earlier input
    or by one of the inputs) is recorded with one error line and the others go on; each output
    is written atomically on its own. ``on_item`` is called with each result, in input order,
    as it is done. ``runner`` (a :class:`mocapkit.batch.Runner`) runs the conversions, in this
    process by default or on a Dask cluster: the files written are the same;
    ``progress(done, total)`` counts its finished conversions.

    Each written output gets an entry in ``out_dir/.mocapkit-manifest`` (the source's sha256,
    the options, the version; the output's sha256): a rerun skips the inputs whose output is
    there unchanged and whose source and options are the same (``resumed``), so an
    interrupted folder convert resumes.
    """
    from mocapkit.batch.manifest import Manifest
    from mocapkit.io import MocapFileError
    from mocapkit.io.atomic import refuse_overwrite, remove_stale_temporaries

    manifest = Manifest(Path(out_dir))
    srcs = [Path(s) for s in sources]
    subs = [Path(x) for x in subfolders] if subfolders is not None else [Path()] * len(srcs)
    if len(subs) != len(srcs):
        raise ValueError("subfolders must name one folder per source")
    results: dict[int, ItemResult] = {}
    written: dict[Path, tuple[Path, Path]] = {}  # case-folded output -> (source, output)
    emitted = 0

    def emit() -> None:
        nonlocal emitted
        while emitted in results:
            if on_item is not None:
                on_item(results[emitted])
            emitted += 1

    # waves: of several inputs with one output name, the first is converted, and the next
    # only if that one failed (as one after the other would)
    pending = list(range(len(srcs)))
    while pending:
        wave: list[tuple[int, Path, Path]] = []
        later: list[int] = []
        claimed: set[Path] = set()
        for k in pending:
            src = srcs[k]
            out = output_path(src, out_dir, to, subs[k])
            try:
                # names that differ only by case are one file on macOS and Windows: an output
                # folder must not hold two of them
                key = Path(str(out.resolve()).casefold())
                if key in written:
                    first, there = written[key]
                    if there == out.resolve():
                        why = f"its output {out} is already written from {first}"
                    else:  # e.g. walk.bvh after Walk.npz
                        why = (
                            f"its output {out} and {there}, written from {first}, differ only "
                            "by case: one file on macOS and Windows"
                        )
                    raise ValueError(f"{src}: {why}; rename one of them")
                if key in claimed:
                    later.append(k)
                    continue
                refuse_overwrite(out, srcs)  # never over any input, not only this one
                resume = _resume_key(src, to, options)
            except (MocapFileError, ValueError, KeyError, OSError) as e:
                results[k] = ItemResult(src, None, error=_error_line(src, e))
                continue
            claimed.add(key)
            entry = manifest.is_complete((subs[k] / out.name).as_posix(), resume)
            if entry is not None and entry.get("result"):
                r = entry["result"]
                results[k] = ItemResult(src, out, r["frames"], r["fps"], resumed=True)
                written[key] = (src, out.resolve())
                continue
            wave.append((k, out, key, resume))
        emit()
        tasks = [(str(srcs[k]), str(out), options) for k, out, _, _ in wave]
        if runner is None:
            done = (convert_one(t) for t in tasks)
        else:
            done = runner.imap(convert_one, tasks, progress=progress, name="convert")
        for (k, out, key, resume), item in zip(wave, done, strict=True):
            results[k] = item
            if item.ok:
                written[key] = (srcs[k], out.resolve())
                manifest.record(
                    (subs[k] / out.name).as_posix(), resume, [out],
                    {"frames": item.frames, "fps": item.fps},
                )  # fmt: skip
            emit()
        pending = later
        if runner is not None:  # a worker killed mid-write leaves a temporary file
            remove_stale_temporaries(out for _, out, _, _ in wave)
    return ConvertedMany(tuple(results[k] for k in range(len(srcs))))
