"""``mocapkit info`` and ``mocapkit convert``."""

from __future__ import annotations

import json
from typing import Any

import click
import numpy as np

from mocapkit.cli.common import LENIENT, CLIError, friendly_errors, load, main, progress
from mocapkit.core.motion import Motion
from mocapkit.io import write_motion
from mocapkit.io.atomic import refuse_overwrite


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


def print_info(info: dict[str, Any]) -> None:
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
            infos.append(motion_info(load(f, lenient), f, up=up, units=units))
            step()
    if as_json:
        click.echo(json.dumps(infos[0] if len(infos) == 1 else infos, indent=2))
    else:
        for i in infos:
            print_info(i)


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
    motion = load(src, lenient, asf=asf, fps=amc_fps if src.lower().endswith(".amc") else None)
    motion = convert_motion(motion, fps=fps, scale=scale)
    write_motion(motion, out, order=order)
    click.echo(f"wrote {out} ({motion.num_frames} frames at {motion.fps:.6g} fps)")
