"""The ``mocapkit`` command: parses arguments, calls the library, prints results.

Only this module and :mod:`mocapkit.viz` talk to people. Defaults come from the library's
function signatures, not from here.
"""

from __future__ import annotations

import functools
import json
import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click
import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.io import MocapFileError, RepairWarning, read_motion, write_motion
from mocapkit.io._atomic import atomic_write_text, refuse_overwrite


class CLIError(click.ClickException):
    """A one-line error with exit status 2 (bad input)."""

    exit_code = 2

    def show(self, file: Any = None) -> None:
        click.echo(f"mocapkit: error: {self.message}", err=True)


def friendly_errors(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Turn library exceptions about bad input into one-line CLI errors (no traceback)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", RepairWarning)
                result = fn(*args, **kwargs)
            for w in caught:
                click.echo(f"mocapkit: repaired: {w.message}", err=True)
            return result
        except MocapFileError as e:
            raise CLIError(str(e)) from None
        except (ValueError, KeyError, FileNotFoundError, ImportError) as e:
            raise CLIError(str(e).strip("'\"")) from None

    return wrapper


@contextmanager
def progress(total: int, description: str, enabled: bool = True) -> Iterator[Callable[[], None]]:
    """A rich progress bar on stderr; yields a function to call once per finished item."""
    if not enabled or total <= 1:
        yield lambda: None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    with Progress(
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=True,
    ) as bar:
        task = bar.add_task(description, total=total)
        yield lambda: bar.advance(task)


def _load(path: str, lenient: bool, asf: str | None = None, fps: float | None = None) -> Motion:
    kwargs: dict[str, Any] = {"lenient": lenient}
    if asf is not None:
        kwargs["asf"] = asf
    if fps is not None:
        kwargs["fps"] = fps
    return read_motion(path, **kwargs)


LENIENT = click.option(
    "--lenient",
    is_flag=True,
    help="Repair what is safe (frame-count mismatch, blank or truncated rows, NaN gaps) and "
    "report it, instead of failing.",
)


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="mocapkit")
def main() -> None:
    """mocapkit: motion-capture data tools (BVH, ASF/AMC).

    \b
    Examples:
      mocapkit info walk.bvh
      mocapkit convert subject.asf walk.amc walk.bvh   (see: mocapkit convert -h)
      mocapkit demo --out demo_out
    """


# --------------------------------------------------------------------------------------- info
def motion_info(
    motion: Motion, path: str, up: str | None = None, units: str | None = None
) -> dict[str, Any]:
    """A JSON-ready summary of a motion (what ``mocapkit info`` prints).

    ``up`` ("Y", "Z", "-Y", ...) and ``units`` ("m", "cm", "mm", "inch") override the guesses.
    """
    from mocapkit import features
    from mocapkit.core.kinematics import forward_kinematics

    sk = motion.skeleton
    info: dict[str, Any] = {
        "path": path,
        "joints": len(sk.names),
        "joint_names": list(sk.names),
        "channels": sk.num_channels,
        "channels_per_joint": [list(c) for c in sk.channels],
        "rotation_orders": sorted(
            set(sk.rotation_orders[j] for j in range(sk.num_joints) if sk.has_rotation[j])
        ),
        "end_sites": len(sk.end_site_parents),
        "frames": motion.num_frames,
        "frame_time": motion.frame_time,
        "fps": motion.fps,
        "duration_s": motion.duration,
    }
    up = up.upper() if up else features.detect_up_axis(motion)
    if units:
        metres = features.metres_per_unit(motion, units)
        units = next(k for k, v in features.UNITS.items() if v == metres)
    else:
        units, metres = features.detect_units(motion)
    info["up_axis"] = up
    info["units_guess"] = units
    info["metres_per_unit"] = metres
    if motion.num_frames:
        pos, _ = forward_kinematics(motion)
        info["bounding_box"] = {
            "min": (pos.min(axis=(0, 1)).round(6) + 0.0).tolist(),
            "max": (pos.max(axis=(0, 1)).round(6) + 0.0).tolist(),
        }
        try:
            fc = features.foot_contacts(motion, up=up, units=metres)
        except ValueError as e:
            info["contacts"] = {"error": str(e)}
        else:
            info["contacts"] = {
                name: {
                    "fraction": round(float(fc.contacts[:, i].mean()), 4),
                    "segments": int(
                        np.sum(np.diff(fc.contacts[:, i].astype(int)) == 1) + int(fc.contacts[0, i])
                    ),
                }
                for i, name in enumerate(fc.names)
            }
    return info


def _print_info(info: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    t = Table(title=info["path"], show_header=False, title_justify="left")
    t.add_column(style="bold")
    t.add_column()
    t.add_row("joints", f"{info['joints']} ({info['end_sites']} End Sites)")
    t.add_row("channels", f"{info['channels']} ({', '.join(info['rotation_orders']) or 'none'})")
    t.add_row("frames", str(info["frames"]))
    t.add_row("frame time", f"{info['frame_time']!r} s ({info['fps']:.6g} fps)")
    t.add_row("duration", f"{info['duration_s']:.3f} s")
    t.add_row("up axis", info["up_axis"])
    t.add_row("units (guess)", f"{info['units_guess']} ({info['metres_per_unit']:g} m per unit)")
    if "bounding_box" in info:
        bb = info["bounding_box"]
        t.add_row("bounding box", f"min {bb['min']}  max {bb['max']}")
        c = info["contacts"]
        if "error" in c:
            t.add_row("contacts", c["error"])
        else:
            t.add_row(
                "contacts",
                ", ".join(
                    f"{k}: {v['fraction'] * 100:.0f}% in {v['segments']} steps"
                    for k, v in c.items()
                ),
            )
    Console().print(t)


@main.command()
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print JSON (a list when several files).")
@click.option("--up", default=None, help="Up axis (Y, Z, -Y, ...) instead of the guess.")
@click.option(
    "--units",
    default=None,
    type=click.Choice(["m", "cm", "mm", "inch"]),
    help="Length unit instead of the guess.",
)
@LENIENT
@friendly_errors
def info(
    files: tuple[str, ...], as_json: bool, up: str | None, units: str | None, lenient: bool
) -> None:
    """Summarise motion files: joints, channels, frames, fps, units, bounding box, contacts.

    \b
    Example:
      mocapkit info walk.bvh
      mocapkit info --json clips/*.bvh > summary.json
      mocapkit info --up Z --units cm zup_clip.bvh
    """
    infos = []
    with progress(len(files), "reading") as step:
        for f in files:
            infos.append(motion_info(_load(f, lenient), f, up=up, units=units))
            step()
    if as_json:
        click.echo(json.dumps(infos[0] if len(infos) == 1 else infos, indent=2))
    else:
        for i in infos:
            _print_info(i)


# ------------------------------------------------------------------------------------ convert
def convert_motion(motion: Motion, fps: float | None = None, scale: float | None = None) -> Motion:
    """Resample and/or scale a motion (what ``mocapkit convert`` does between read and write)."""
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


@main.command()
@click.argument("inputs", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--fps", type=float, default=None, help="Resample to this frame rate.")
@click.option("--order", default=None, help="Rewrite every joint's rotation order (e.g. ZYX).")
@click.option("--scale", type=float, default=None, help="Multiply lengths (e.g. 0.01 for cm->m).")
@click.option(
    "--amc-fps",
    type=float,
    default=120.0,
    show_default=True,
    help="Frame rate of AMC input (AMC files do not store it).",
)
@LENIENT
@friendly_errors
def convert(
    inputs: tuple[str, ...],
    fps: float | None,
    order: str | None,
    scale: float | None,
    amc_fps: float,
    lenient: bool,
) -> None:
    """Convert IN to OUT: BVH <-> BVH/.npz, ASF+AMC -> BVH/.npz.

    The last argument is the output. For ASF/AMC give the ASF, the AMC and the output (or only
    the AMC if its subject's ASF lies beside it). Never overwrites an input; writes atomically.

    \b
    Examples:
      mocapkit convert walk.bvh walk_zyx.bvh --order ZYX
      mocapkit convert walk.bvh walk_60.npz --fps 60
      mocapkit convert 01.asf 01_01.amc 01_01.bvh --scale 2.54
    """
    if len(inputs) < 2:
        raise CLIError("convert needs an input and an output path")
    *srcs, out = inputs
    asf = None
    if len(srcs) == 2 and srcs[0].lower().endswith(".asf"):
        asf, src = srcs
    elif len(srcs) == 1:
        src = srcs[0]
    else:
        raise CLIError("convert takes IN OUT, or ASF AMC OUT")
    refuse_overwrite(out, [*srcs])
    motion = _load(src, lenient, asf=asf, fps=amc_fps if src.lower().endswith(".amc") else None)
    motion = convert_motion(motion, fps=fps, scale=scale)
    write_motion(motion, out, order=order)
    click.echo(f"wrote {out} ({motion.num_frames} frames at {motion.fps:.6g} fps)")


# --------------------------------------------------------------------------------------- demo
@main.command()
@click.option(
    "--out",
    "out_dir",
    default="demo_out",
    show_default=True,
    type=click.Path(file_okay=False),
    help="Folder for the demo's files.",
)
@friendly_errors
def demo(out_dir: str) -> None:
    """Run the tour on generated data (nothing is downloaded).

    Generates the procedural humanoid (walk, run, wave) and the Three-Circles set, writes them as
    BVH/.npz/CSV, reads them back, summarises them and converts one.

    \b
    Example:
      mocapkit demo --out demo_out
    """
    from mocapkit import datasets

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    click.echo(f"mocapkit demo -> {out}/")
    clips = {}
    for kind, seconds in (("walk", 4.0), ("run", 3.0), ("wave", 3.0)):
        synth = datasets.procedural_motion(kind, seconds=seconds, seed=0)
        path = out / f"humanoid_{kind}.bvh"
        write_motion(synth.motion, path)
        clips[kind] = path
        click.echo(f"  generated {path} ({synth.motion.num_frames} frames)")
    circles = datasets.three_circles()
    csv = out / "three_circles.csv"
    rows = ["circle,frame,x,y"]
    for name in ("large", "forward", "backward"):
        arr = getattr(circles, name)
        rows += [f"{name},{i},{x:.9g},{y:.9g}" for i, (x, y) in enumerate(arr)]
    atomic_write_text(csv, "\n".join(rows) + "\n")
    click.echo(f"  generated {csv}")

    click.echo("\n[info] on the generated walk:")
    walk = read_motion(clips["walk"])
    summary = motion_info(walk, str(clips["walk"]))
    _print_info(summary)
    atomic_write_text(out / "humanoid_walk.info.json", json.dumps(summary, indent=2) + "\n")

    click.echo("[convert] walk -> 60 fps, ZYX order, .npz and back to BVH:")
    conv = convert_motion(walk, fps=60.0)
    npz = write_motion(conv, out / "humanoid_walk_60fps.npz", order="ZYX")
    back = read_motion(npz)
    bvh = write_motion(back, out / "humanoid_walk_60fps_zyx.bvh")
    again = read_motion(bvh)
    same = back.allclose(again)
    click.echo(
        f"  {npz} -> {bvh}: {again.num_frames} frames at {again.fps:g} fps, "
        f"round trip {'exact' if same else 'DIFFERENT'}"
    )
    if not same:
        raise CLIError("demo: the BVH round trip changed the motion")
    click.echo("\ndone.")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
