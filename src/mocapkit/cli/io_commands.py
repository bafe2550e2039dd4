"""``mocapkit info`` and ``mocapkit convert``."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click

from mocapkit.batch.manifest import Manifest
from mocapkit.cli.batch_commands import job_progress, job_runner, runner_options
from mocapkit.cli.common import (
    LENIENT,
    MOTION_SUFFIXES,
    CLIError,
    check_amc,
    check_input_file,
    echo_json,
    expand_item,
    expand_library,
    file_key,
    friendly_errors,
    is_single_file,
    main,
    naming,
    one_line,
    os_error_line,
    up_option,
)
from mocapkit.convert import FOLDER_FORMATS, ConvertedMany, ItemResult, convert_file, convert_many
from mocapkit.io import MocapFileError
from mocapkit.io.atomic import all_or_nothing, check_outputs
from mocapkit.jsonio import NonFiniteWarning
from mocapkit.summary import nominal_fps, summarize_file


# --------------------------------------------------------------------------------------- info
def tree_lines(names: list[str], parents: list[int], labels: list[str]) -> list[str]:
    """The hierarchy as indented lines, each joint with its body part (iterative: rigs can
    nest thousands of joints)."""
    children: list[list[int]] = [[] for _ in names]
    for j, p in enumerate(parents):
        if p >= 0:
            children[p].append(j)
    lines: list[str] = []
    stack = [(j, 0) for j in reversed(range(len(names))) if parents[j] < 0]
    while stack:
        j, depth = stack.pop()
        label = f"  ({labels[j]})" if labels and labels[j] else ""
        lines.append(f"{'  ' * depth}{names[j]}{label}")
        stack.extend((c, depth + 1) for c in reversed(children[j]))
    return lines


def print_info(info: dict[str, Any]) -> None:
    """The ``info`` table. Every string from the file or the command line (the path, joint
    names) is shown as text, never read as rich markup."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    t = Table(title=Text(str(info["path"])), show_header=False, title_justify="left")
    t.add_column(style="bold")
    t.add_column()

    def row(key: str, value: str) -> None:
        t.add_row(Text(key), Text(value))

    def num(v: Any, fmt: str) -> str:
        return "undefined" if v is None else format(v, fmt)

    row("joints", f"{info['joints']} ({info['end_sites']} End Sites)")
    row("channels", f"{info['channels']} ({', '.join(info['rotation_orders']) or 'none'})")
    row("frames", str(info["frames"]))
    row("frame time", f"{info['frame_time']!r} s ({num(info['fps'], '.6g')} fps)")
    row("duration", f"{num(info['duration_s'], '.3f')} s")
    row("up axis", str(info["up_axis"]))
    body = info.get("body", {})
    how = "from the file" if body.get("units_source") == "file" else "guess"
    row(f"units ({how})", f"{info['units_guess']} ({num(info['metres_per_unit'], 'g')} m per unit)")
    if body:
        row("height", f"{num(body.get('height_m'), '.2f')} m")
        if info.get("units_note"):
            row("note", str(info["units_note"]))
        if body.get("ground_root"):
            row("ground root", str(body["ground_root"]))
    if "bounding_box" in info:
        bb = info["bounding_box"]
        lo, hi = ([num(v, "g") for v in bb[k]] for k in ("min", "max"))
        row("bounding box", f"min [{', '.join(lo)}]  max [{', '.join(hi)}]")
        c = info["contacts"]
        if "error" in c:
            row("contacts", str(c["error"]))
        else:
            row(
                "contacts",
                ", ".join(
                    f"{k}: {v['fraction'] * 100:.0f}% in {v['segments']} "
                    f"step{'' if v['segments'] == 1 else 's'}"
                    for k, v in c.items()
                ),
            )
    Console(soft_wrap=False).print(t)


def _info_one(path: Path, up: str | None, units: str | None, lenient: bool) -> dict[str, Any]:
    """``summarize_file(path).to_json()`` as strict JSON values (non-finite -> None, with a
    warning naming the file), with ``warnings`` (the lines warned while reading, e.g. what
    --lenient repaired) when there are any, or a one-line CLIError naming the file."""
    from mocapkit.core.thread_warnings import collected_warnings
    from mocapkit.jsonio import to_jsonable

    # this thread's only (a worker may read several files at once), kept and warned on below
    with naming(path), collected_warnings(forward=False) as caught:
        out = to_jsonable(summarize_file(path, up=up, units=units, lenient=lenient).to_json())
    notes = []
    for w in caught:  # to the command's own catcher, naming the file where they do not
        msg = str(w.message)
        if str(path) not in msg and issubclass(w.category, NonFiniteWarning):
            msg = f"{path}: {msg}"
        warnings.warn_explicit(msg, w.category, w.filename, w.lineno)
        notes.append(msg)
    if notes:  # what a lenient read repaired, or a value it could not keep: scripts see it too
        out["warnings"] = notes
    return out


def info_item(task: tuple[str, Path | None, str | None, str | None, str | None, bool]) -> Any:
    """One entry of ``info``: ``(name, file, error, up, units, lenient)`` -> its JSON object, or
    ``{"path", "error"}`` with one line (on whichever process runs it)."""
    name, f, error, up, units, lenient = task
    try:
        if f is None:
            raise CLIError(error or name)
        if f.suffix.lower() == ".amc":
            check_amc(f)
        with naming(f):
            return _info_one(f, up, units, lenient)
    except (CLIError, MocapFileError, OSError) as e:
        if isinstance(e, CLIError):
            msg = e.message
        elif isinstance(e, MocapFileError):
            msg = one_line(e)
        else:
            msg = one_line(os_error_line(e))
        return {"path": name, "error": msg}


@main.command()
@click.argument("files", nargs=-1, required=True, metavar="FILE_DIR_OR_GLOB...")
@click.option(
    "--json",
    "as_json",
    is_flag=True,
    help="Print JSON: an object for exactly one FILE, a list for several files, a folder or a "
    'glob pattern (a file that cannot be read is {"path": ..., "error": ...} there).',
)
@up_option()
@click.option(
    "--units",
    default=None,
    type=click.Choice(["m", "cm", "mm", "inch"]),
    help="Length unit instead of the guess.",
)
@click.option("--tree", is_flag=True, help="Also print the hierarchy with each joint's body part.")
@LENIENT
@runner_options
@friendly_errors
def info(
    files: tuple[str, ...],
    as_json: bool,
    up: str | None,
    units: str | None,
    tree: bool,
    lenient: bool,
    workers: int | None,
    scheduler: str | None,
) -> None:
    """Summarise motion files: joints, channels, frames, fps, units, bounding box, contacts.

    Takes files, folders (their .bvh, .npz, .amc, .glb and .gltf files, sub-folders included)
    and quoted glob patterns; an .amc
    needs its subject's .asf beside it. Every file that can be read is reported; each one that
    cannot is one error line on stderr, and the exit status is then 2. With --json: one object
    for exactly one FILE argument, else a list (also for one folder or pattern); a file that
    cannot be read is {"path": ..., "error": ...} there (a single one too); the objects are
    mocapkit.summary.summarize(...).to_json() (fps is n exactly, 30.0, when the frame time is a
    rounded 1/n; frame_time is kept exactly as read).

    \b
    Example:
      mocapkit info walk.bvh
      mocapkit info --json clips/*.bvh > summary.json
      mocapkit info --json 'clips/**/*.bvh' takes/
      mocapkit info --up Z --units cm zup_clip.bvh
      mocapkit info --tree take.bvh              (hierarchy: Hips (pelvis), LeftUpLeg (left_hip)...)
      mocapkit info --json lib/ --workers 8       (a local Dask cluster; same JSON)
    """
    single = is_single_file(files)
    entries: list[tuple[str, Path | None, str | None]] = []  # (name, file, error)
    seen: set[tuple[Any, ...]] = set()
    for item in files:
        try:
            found = expand_item(item, MOTION_SUFFIXES)
        except CLIError as e:
            entries.append((str(item), None, e.message))
            continue
        for f in found:
            key = file_key(f)
            if key not in seen:
                seen.add(key)
                entries.append((str(f), f, None))
    results: list[dict[str, Any]] = []
    failed = 0
    tasks = [(name, f, error, up, units, lenient) for name, f, error in entries]
    with job_runner(workers, scheduler) as runner, job_progress("reading", len(tasks) > 1) as step:
        for out in runner.imap(info_item, tasks, progress=step, name="info"):
            if set(out) == {"path", "error"}:
                failed += 1
                click.echo(f"mocapkit: error: {out['error']}", err=True)
            results.append(out)
    if as_json:  # stdout is JSON whatever failed: a script reads the error from it too
        echo_json(results[0] if single else results)
    else:
        for i in results:
            if "error" in i:
                continue
            print_info(i)
            if tree:
                for line in tree_lines(i["joint_names"], i["parents"], i["body"]["labels"]):
                    click.echo(line)
    if failed:
        raise click.exceptions.Exit(2)


# ------------------------------------------------------------------------------------ convert
POSITIVE = click.FloatRange(min=0, min_open=True)


CONVERT_INPUTS = MOTION_SUFFIXES
"""What folder mode converts (an .amc needs its subject's .asf beside it)."""


@main.command()
@click.argument("inputs", nargs=-1, required=True, metavar="IN... [OUT]")
@click.option(
    "--out-dir",
    default=None,
    metavar="DIR",
    help="Folder mode: convert every IN (files, folders, quoted globs) into this folder as "
    "<name>.<--to>.",
)
@click.option(
    "--to",
    "to",
    type=click.Choice(FOLDER_FORMATS, case_sensitive=False),
    default=None,
    help="Folder mode: the format to write.",
)
@click.option("--fps", type=POSITIVE, default=None, help="Resample to this frame rate.")
@click.option("--order", default=None, help="Rewrite every joint's rotation order (e.g. ZYX).")
@click.option(
    "--scale", type=POSITIVE, default=None, help="Multiply lengths (e.g. 0.01 for cm->m)."
)
@click.option(
    "--units",
    type=click.Choice(["m", "cm", "mm", "inch"]),
    default=None,
    help="Rescale to this length unit, from the unit the file states (ASF) or the guess.",
)
@click.option(
    "--amc-fps",
    type=POSITIVE,
    default=120.0,
    show_default=True,
    help="Frame rate of AMC input (AMC files do not store it).",
)
@LENIENT
@runner_options
@friendly_errors
def convert(
    inputs: tuple[str, ...],
    out_dir: str | None,
    to: str | None,
    fps: float | None,
    order: str | None,
    scale: float | None,
    units: str | None,
    amc_fps: float,
    lenient: bool,
    workers: int | None,
    scheduler: str | None,
) -> None:
    """Convert IN to OUT: BVH/.npz/ASF+AMC -> BVH, .npz or glTF 2.0 (.glb, .gltf).

    The last argument is the output. For ASF/AMC give the ASF, the AMC and the output (or only
    the AMC if its subject's ASF lies beside it). glTF output is in metres with +Y up (from the
    file's up axis and unit, as `mocapkit info` finds them): a skinned box per bone and one
    animation. Never overwrites an input (under any spelling, link included); checks the output
    before reading and writes it atomically, so a failed run leaves nothing behind.

    Folder mode (--out-dir with --to): every IN is a file, a folder (its motion files,
    sub-folders included) or a quoted glob; each one is converted to OUT_DIR/<name>.<to> (a
    folder's sub-folders kept: OUT_DIR/<sub-folder>/<name>.<to>) and reported on its own line;
    a file that cannot be converted is one error line and the others go on (exit status 2 at
    the end if any failed). Files an earlier run wrote are not read as inputs.

    \b
    Examples:
      mocapkit convert walk.bvh walk_zyx.bvh --order ZYX
      mocapkit convert walk.bvh walk_60.npz --fps 60
      mocapkit convert take.bvh take.glb                       (Blender, three.js, engines)
      mocapkit convert 01.asf 01_01.amc 01_01.bvh --units cm   (BVH cannot state units)
      mocapkit convert lib/ --out-dir lib_glb/ --to glb         (every motion of a folder)
      mocapkit convert 'takes/*.bvh' --out-dir npz/ --to npz --fps 60
      mocapkit convert lib/ --out-dir out/ --to bvh --fps 30 --workers 8   (on Dask)
    """
    options = {
        "fps": fps,
        "scale": scale,
        "units": units,
        "order": order,
        "amc_fps": amc_fps,
        "lenient": lenient,
    }
    if out_dir is not None or to is not None:
        if out_dir is None or to is None:
            raise CLIError(
                "folder mode needs both --out-dir and --to (e.g. --out-dir out/ --to glb)"
            )
        _convert_folder(inputs, out_dir, to.lower(), options, workers, scheduler)
        return
    if workers is not None or scheduler is not None:
        raise CLIError("--workers and --scheduler are for folder mode (--out-dir and --to)")
    from mocapkit.io import WRITABLE

    if len(inputs) < 2:
        raise CLIError("convert needs an input and an output path (or --out-dir and --to)")
    *srcs, out = inputs
    folders = [p for p in srcs if Path(p).is_dir()]
    if folders:
        raise CLIError(
            f"{folders[0]}: is a folder; to convert every file of a folder give "
            "--out-dir OUT_DIR --to glb|bvh|npz"
        )
    asf = None
    if len(srcs) == 2 and srcs[0].lower().endswith(".asf"):
        asf, src = srcs
    elif len(srcs) == 1:
        src = srcs[0]
    elif len(srcs) == 2 and srcs[1].lower().endswith(".asf"):
        raise CLIError(f"{srcs[1]}: the ASF skeleton comes first: convert ASF AMC OUT")
    else:
        raise CLIError("convert takes IN OUT, or ASF AMC OUT, or IN... --out-dir DIR --to FORMAT")
    if asf is not None and not src.lower().endswith(".amc"):
        raise CLIError(f"{asf}: an ASF skeleton goes with an .amc take, not {src}")
    for p in (asf, src):
        if p is not None:
            check_input_file(p, "ASF file" if p is asf else "motion file")
    check_outputs([(out, WRITABLE)], [p for p in (src, asf) if p is not None])
    with naming(src, asf), all_or_nothing():
        res = convert_file(src, out, asf=asf, **options)
    fps = nominal_fps(res.motion.frame_time)  # as info shows it (30, not 30.0003)
    click.echo(f"wrote {res.output} ({res.motion.num_frames} frames at {fps:.6g} fps)")


def _subfolder(source: Path, inputs: Sequence[str]) -> str:
    """``source``'s folder below the first input folder it was found in ("" for a file named
    directly or by a pattern): where its output goes below --out-dir."""
    for item in inputs:
        root = Path(item)
        if root.is_dir():
            try:
                rel = source.parent.relative_to(root)
            except ValueError:
                continue
            return rel.as_posix() if rel.parts else ""
    return ""


def _convert_folder(
    inputs: tuple[str, ...],
    out_dir: str,
    to: str,
    options: dict[str, Any],
    workers: int | None = None,
    scheduler: str | None = None,
) -> ConvertedMany:
    """``convert --out-dir --to``: every input named by ``inputs`` (an item naming none is one
    error line), one line per file as it is done, exit status 2 at the end if any failed."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise CLIError(f"{out}: is a file, expected a folder for --out-dir")
    sources, errors = expand_library(inputs, CONVERT_INPUTS)  # each file once
    for e in errors:
        click.echo(f"mocapkit: error: {e}", err=True)
    failed = len(errors)
    # files an earlier convert wrote (its --out-dir inside an input folder) are outputs, not
    # inputs: the manifest of that --out-dir, in the folder or a folder above, lists them
    written: dict[Path, set[Path]] = {}
    unique: list[Path] = []
    for f in sources:
        outputs: set[Path] = set()
        for folder in [f.parent, *f.parent.parents]:
            if folder not in written:
                written[folder] = Manifest(folder).outputs()
            outputs |= written[folder]
        if f.resolve() not in outputs:
            unique.append(f)
    if len(unique) < len(sources):
        click.echo(
            f"mocapkit: note: {len(sources) - len(unique)} file(s) that earlier runs wrote left "
            "out (their folder's .mocapkit-manifest lists them)",
            err=True,
        )

    def report(item: ItemResult) -> None:
        if item.resumed:
            return  # counted in the last line
        if item.ok:
            click.echo(f"wrote {item.output} ({item.frames} frames at {item.fps:.6g} fps)")
        else:
            click.echo(f"mocapkit: error: {one_line(item.error)}", err=True)

    with (
        job_runner(workers, scheduler) as runner,
        job_progress("converting", len(unique) > 1) as step,
    ):
        res = convert_many(
            unique, out, to, on_item=report, runner=runner, progress=step,
            subfolders=[_subfolder(f, inputs) for f in unique], **options,
        )  # fmt: skip
    failed += len(res.failed)
    done = len(res.items) - len(res.failed)
    click.echo(
        f"converted {done} of {done + failed} inputs into {out}"
        + (f" ({res.resumed} already complete and unchanged)" if res.resumed else "")
        + (f"; {failed} failed" if failed else "")
    )
    if failed:
        raise click.exceptions.Exit(2)
    return res
