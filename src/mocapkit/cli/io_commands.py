"""``mocapkit info`` and ``mocapkit convert``."""

from __future__ import annotations

from typing import Any

import click

from mocapkit.cli.common import (
    LENIENT,
    MOTION_SUFFIXES,
    CLIError,
    echo_json,
    expand_inputs,
    friendly_errors,
    main,
    progress,
)
from mocapkit.convert import convert_file
from mocapkit.summary import summarize_file


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
    body = info.get("body", {})
    how = "from the file" if body.get("units_source") == "file" else "guess"
    t.add_row(f"units ({how})", f"{info['units_guess']} ({info['metres_per_unit']:g} m per unit)")
    if body:
        t.add_row("height", f"{body['height_m']:.2f} m")
        if body.get("ground_root"):
            t.add_row("ground root", body["ground_root"])
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
@click.argument("files", nargs=-1, required=True, metavar="FILE_DIR_OR_GLOB...")
@click.option("--json", "as_json", is_flag=True, help="Print JSON (a list when several files).")
@click.option("--up", default=None, help="Up axis (Y, Z, -Y, ...) instead of the guess.")
@click.option(
    "--units",
    default=None,
    type=click.Choice(["m", "cm", "mm", "inch"]),
    help="Length unit instead of the guess.",
)
@click.option("--tree", is_flag=True, help="Also print the hierarchy with each joint's body part.")
@LENIENT
@friendly_errors
def info(
    files: tuple[str, ...],
    as_json: bool,
    up: str | None,
    units: str | None,
    tree: bool,
    lenient: bool,
) -> None:
    """Summarise motion files: joints, channels, frames, fps, units, bounding box, contacts.

    Takes files, folders (their .bvh, .npz and .amc files) and quoted glob patterns; an .amc
    needs its subject's .asf beside it. The JSON is mocapkit.summary.summarize(...).to_json().

    \b
    Example:
      mocapkit info walk.bvh
      mocapkit info --json clips/*.bvh > summary.json
      mocapkit info --json 'clips/**/*.bvh' takes/
      mocapkit info --up Z --units cm zup_clip.bvh
      mocapkit info --tree take.bvh              (hierarchy: Hips (pelvis), LeftUpLeg (left_hip)...)
    """
    paths = expand_inputs(files, MOTION_SUFFIXES)
    infos = []
    with progress(len(paths), "reading") as step:
        for f in paths:
            infos.append(summarize_file(f, up=up, units=units, lenient=lenient).to_json())
            step()
    if as_json:
        echo_json(infos[0] if len(infos) == 1 else infos)
    else:
        for i in infos:
            print_info(i)
            if tree:
                for line in tree_lines(i["joint_names"], i["parents"], i["body"]["labels"]):
                    click.echo(line)


# ------------------------------------------------------------------------------------ convert
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
    res = convert_file(
        src, out, asf=asf, fps=fps, scale=scale, order=order, amc_fps=amc_fps, lenient=lenient
    )
    click.echo(f"wrote {res.output} ({res.motion.num_frames} frames at {res.motion.fps:.6g} fps)")
