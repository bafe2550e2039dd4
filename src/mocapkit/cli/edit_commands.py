"""``mocapkit edit``: the everyday edits (registered on import; see mocapkit.cli)."""

from __future__ import annotations

import click

from mocapkit.cli.common import (
    LENIENT,
    CLIError,
    check_input_file,
    echo_json,
    friendly_errors,
    load,
    main,
    naming,
    up_option,
    warn_if_up_disagrees,
    warnings_so_far,
)
from mocapkit.core.ranges import RangeError, RangeSpec
from mocapkit.summary import nominal_fps

RANGE_HELP = (
    "0-based frames A:B (B excluded; A: and :B leave an end open) or seconds 1.5s:4.0s "
    "(each end the nearest frame)"
)


def parse_renames(values: tuple[str, ...]) -> dict[str, str]:
    """``--rename OLD=NEW`` (repeatable) as a mapping; one-line CLIError for anything else."""
    out: dict[str, str] = {}
    for v in values:
        old, sep, new = v.partition("=")
        if not sep or not old.strip() or not new.strip():
            raise CLIError(f"--rename {v!r}: expected OLD=NEW (joint names, no blanks)")
        if old in out:
            raise CLIError(f"--rename: joint {old!r} is renamed twice")
        out[old.strip()] = new.strip()
    return out


@main.command("edit")
@click.argument("src", metavar="IN")
@click.argument("out", metavar="OUT")
@click.option("--trim", "trim_spec", metavar="RANGE", default=None, help=f"Keep {RANGE_HELP}.")
@click.option("--mirror", "mirror_lr", is_flag=True, help="Mirror left/right.")
@click.option(
    "--in-place",
    "in_place",
    is_flag=True,
    help="Remove the body's horizontal travel (it stays where it starts; turns are kept).",
)
@click.option(
    "--extract-root",
    "extract_root",
    is_flag=True,
    help="Carry the body's ground path and heading on a root joint (the ground root, or a new "
    "'Root' joint above the old root).",
)
@click.option(
    "--rename",
    "renames",
    multiple=True,
    metavar="OLD=NEW",
    help="Rename a joint of IN (repeatable).",
)
@click.option(
    "--drop-joints",
    "drop",
    metavar="REGEX",
    default=None,
    help="Drop the joints of IN whose whole name matches REGEX; their children hang from the "
    "nearest kept joint and every kept joint moves as before.",
)
@click.option(
    "--speed",
    type=click.FloatRange(min=0.01),
    metavar="FACTOR",
    default=None,
    help=(
        "Play FACTOR times faster (resampled, same frame rate): 2 halves the duration. "
        "Refused where the take is too short to play that fast (the frames left would play "
        "more than 5% off FACTOR)."
    ),
)
@up_option()
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary of what was done.")
@LENIENT
@friendly_errors
def edit_cmd(
    src: str,
    out: str,
    trim_spec: str | None,
    mirror_lr: bool,
    in_place: bool,
    extract_root: bool,
    renames: tuple[str, ...],
    drop: str | None,
    speed: float | None,
    up: str | None,
    as_json: bool,
    lenient: bool,
) -> None:
    """Everyday edits of IN, written to OUT (.bvh or .npz) with its provenance sidecar.

    The edits run in this order, whatever the order of the options: trim, mirror, in-place /
    extract root, drop joints, speed, rename. Every option reads the INPUT: the range is on
    IN's timeline and the regex and the renames use IN's joint names. Ranges follow the one
    syntax of every mocapkit option: A:B are 0-based frames with B excluded (A: and :B leave an
    end open), 1.5s:4.0s are seconds. Mirroring reflects across the vertical plane of the
    forward axis (X -> -X for Y-up) and trades left and right joints (by name, else by the
    limbs' structure); forward kinematics of the result is exactly the mirror image. Dropping
    joints keeps the kept joints' motion exactly. OUT is checked before IN is read, is never
    an input, and is written atomically together with OUT.provenance.json.

    \b
    Examples:
      mocapkit edit walk.bvh walk_cut.bvh --trim 1.5s:4.0s
      mocapkit edit walk.bvh walk_m.bvh --mirror --in-place --speed 1.25
      mocapkit edit take.bvh game.bvh --extract-root --rename Hips=pelvis
      mocapkit edit take.bvh body.bvh --drop-joints '.*(Thumb|Index|Middle|Ring|Pinky).*'
      mocapkit edit 01_01.amc 01_01_left.bvh --trim 120: --mirror --json
    """
    from mocapkit.edit import apply_edits
    from mocapkit.io import WRITABLE, write_motion
    from mocapkit.io.atomic import all_or_nothing, check_outputs
    from mocapkit.provenance import Provenance, Segment, sidecar_path

    if in_place and extract_root:
        raise CLIError("give at most one of --in-place and --extract-root")
    rename = parse_renames(renames)
    try:
        spec = RangeSpec.parse(trim_spec, "--trim") if trim_spec is not None else None
    except RangeError as e:
        raise CLIError(str(e)) from None
    check_input_file(src)
    check_outputs([(out, WRITABLE), sidecar_path(out)], [src])
    motion = load(src, lenient)
    warn_if_up_disagrees(motion, up, src)
    with naming(src):
        trim = spec.frames(motion.fps, motion.num_frames) if spec is not None else None
        res = apply_edits(
            motion,
            trim=trim,
            mirror_lr=mirror_lr,
            root="in-place" if in_place else "extract" if extract_root else None,
            drop=drop,
            speed=speed,
            rename=rename,
            up=up,
        )
    m = res.motion
    a, b = trim if trim is not None else (0, motion.num_frames)
    params = {
        "trim": trim_spec,
        "trim_frames": [a, b] if trim is not None else None,
        "mirror": mirror_lr,
        "root": "in-place" if in_place else "extract" if extract_root else None,
        "drop_joints": drop,
        "rename": rename,
        "speed": speed,
        "up": up,
        "order": res.to_json()["order"],
    }
    resampled = speed is not None and speed != 1.0
    plan = Provenance(
        tool="edit",
        output=str(out),
        fps=m.fps,
        frames=m.num_frames,
        inputs=[str(src)],
        parameters=params,
        segments=[Segment(0, m.num_frames, "generated" if resampled else "clip", str(src), a, b)],
    )
    with naming(src, out), all_or_nothing():  # the motion and its sidecar, or neither
        write_motion(m, out)
        side = plan.write(out)
    if as_json:
        echo_json({"input": str(src), "output": str(out), "provenance": str(side),
                   **res.to_json(), "warnings": warnings_so_far()})  # fmt: skip
        return
    done = ", ".join(s["edit"] for s in res.steps) or "no edit (a copy)"
    click.echo(
        f"wrote {out} ({m.num_frames} frames at {nominal_fps(m.frame_time):.6g} fps, "
        f"{m.num_joints} joints; "
        f"{done}) and {side}"
    )
