"""``mocapkit demo``: the tour, on generated data. Each capability adds a step to DEMO_STEPS."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click

from mocapkit.cli.common import CLIError, friendly_errors, main, write_json
from mocapkit.cli.io_commands import print_info
from mocapkit.convert import convert_motion
from mocapkit.io import read_motion, write_motion
from mocapkit.io.atomic import atomic_write_text
from mocapkit.summary import summarize

DemoStep = Callable[[Path], None]
"""A demo step: writes into the demo folder and prints what it did (click.echo)."""


def foundation_step(out: Path) -> None:
    """Generate the synthetic data, then read, summarise and convert it."""
    from mocapkit import datasets

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
    summary = summarize(walk, str(clips["walk"])).to_json()
    print_info(summary)
    write_json(out / "humanoid_walk.info.json", summary)

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


# Capabilities add (rank, title, step) here when their CLI module is imported; the demo runs
# them by rank: foundation 0, stitching 10, motion graphs 20, cleaning 30.
DEMO_STEPS: list[tuple[int, str, DemoStep]] = [
    (0, "foundation: synthetic data, info, convert", foundation_step)
]


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
    BVH/.npz/CSV, reads them back, summarises and converts them, then runs each capability's
    example on them.

    \b
    Example:
      mocapkit demo --out demo_out
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    click.echo(f"mocapkit demo -> {out}/")
    for i, (_, title, step) in enumerate(sorted(DEMO_STEPS, key=lambda s: s[0]), 1):
        click.echo(f"\n== {i}. {title}")
        step(out)
    click.echo("\ndone.")
