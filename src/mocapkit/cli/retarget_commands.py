"""``mocapkit retarget``: play a motion on another rig (:func:`mocapkit.edit.retarget.retarget`)."""

from __future__ import annotations

import warnings
from pathlib import Path

import click

from mocapkit.cli.common import (
    LENIENT,
    CLIError,
    check_input_file,
    echo_json,
    friendly_errors,
    main,
    naming,
    warnings_so_far,
)
from mocapkit.io.atomic import all_or_nothing, check_outputs

_POSITIVE = click.FloatRange(min=0, min_open=True)


@main.command()
@click.argument("source", metavar="IN")
@click.option(
    "--to",
    "target",
    required=True,
    metavar="TARGET",
    help="The rig to play IN on: any motion file mocapkit reads, or an ASF skeleton.",
)
@click.option("--out", "out", required=True, help="Output motion (.bvh, .npz, .glb or .gltf).")
@click.option(
    "--map",
    "map_",
    default="auto",
    show_default=True,
    metavar="auto|MAP.json",
    help='Joint correspondence: the body model ("auto"), or a JSON object '
    '{"TargetJoint": "SourceJoint" | null} over it.',
)
@click.option("--fps", type=_POSITIVE, default=None, help="Output frame rate (default: IN's).")
@click.option(
    "--no-foot-lock",
    is_flag=True,
    help="Skip the IK that keeps planted feet planted over IN's detected contacts.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the measured figures as JSON.")
@LENIENT
@friendly_errors
def retarget(
    source: str,
    target: str,
    out: str,
    map_: str,
    fps: float | None,
    no_foot_lock: bool,
    as_json: bool,
    lenient: bool,
) -> None:
    """Retarget IN onto the rig of TARGET and write OUT (with OUT.provenance.json beside it).

    Joints correspond by body part (pelvis, spine, neck, head, hips, knees, ankles, toes,
    clavicles, shoulders, elbows, wrists); rest-pose differences (T-pose, A-pose, other bone
    axes) are aligned; the pelvis path is scaled by leg length; units and up axis follow
    TARGET; planted feet are held by IK. Prints foot slide during contacts (source and
    output), effector path error and knees/elbows bent backwards, and warns when either rig
    never stands upright (a four-legged rig: retargeting matches upright two-legged bodies).

    \b
    Examples:
      mocapkit retarget 01_01.amc --to bandai_walk.bvh --out 01_01_bandai.bvh
      mocapkit retarget walk.bvh --to 01.asf --out walk_cmu.bvh --json
      mocapkit retarget walk.bvh --to other.bvh --map map.json --out walk_other.bvh --fps 60
    """
    from mocapkit.edit.retarget import RetargetConfig, RigError, load_map, read_target
    from mocapkit.edit.retarget import retarget as run
    from mocapkit.io import WRITABLE, find_asf, write_motion
    from mocapkit.provenance import Provenance, Segment, sidecar_path
    from mocapkit.summary import nominal_fps

    check_input_file(source)
    check_input_file(target, "motion or ASF file")
    map_file = None if map_ == "auto" else check_input_file(map_, "joint map (JSON)")
    inputs = [source, target, *([map_file] if map_file else [])]
    if source.lower().endswith(".amc"):
        with naming(source):
            inputs.append(find_asf(Path(source)))
    check_outputs([(out, WRITABLE), sidecar_path(out)], inputs)
    joint_map = None
    if map_file is not None:
        joint_map = load_map(map_file)
    with naming(source):
        from mocapkit.io import read_motion

        src = read_motion(source, lenient=lenient)
    with naming(target):
        tgt = read_target(target, lenient=lenient)
    cfg = RetargetConfig(foot_lock=not no_foot_lock, fps=fps)
    with naming(source, target), all_or_nothing():
        try:
            res = run(src, tgt, cfg, joint_map, str(map_file) if map_file else "joint map")
        except RigError as e:  # name the file whose rig it is
            raise CLIError(
                f"{source if e.role == 'source' else target}: cannot retarget {e}"
            ) from None
        m = res.motion
        write_motion(m, out)
        plan = Provenance(
            tool="retarget",
            output=str(out),
            fps=m.fps,
            frames=m.num_frames,
            inputs=[str(p) for p in inputs],
            parameters={"to": target, "map": map_, "fps": fps, "foot_lock": not no_foot_lock},
            segments=[Segment(0, m.num_frames, "generated", str(source), 0, src.num_frames)],
        )
        side = plan.write(out)
    # warned through the command's warnings: printed at its end with any others (a unit the
    # output cannot state), and the same lines in --json
    for line in res.figures["warnings"]:
        warnings.warn(line, UserWarning, stacklevel=1)
    if not res.figures["foot_lock"] and not no_foot_lock:
        warnings.warn("no foot contacts map onto the target; feet not locked", stacklevel=1)
    if as_json:
        echo_json({"output": str(out), **res.to_json(), "warnings": warnings_so_far()})
        return
    fs = res.figures["foot_slide_cm"]

    def cm(d: dict) -> str:
        return "n/a" if d["mean"] is None else f"{d['mean']:.2f} cm mean, {d['max']:.2f} cm max"

    eff = res.figures["effector_path_error_pct"]["mean"]
    lim = res.figures["joint_limits"]
    click.echo(
        f"wrote {out} ({m.num_frames} frames at {nominal_fps(m.frame_time):g} fps, "
        f"pelvis path x{res.scale:.3f}) and its plan {side}"
    )
    click.echo(f"foot slide in contacts: source {cm(fs['source'])}; output {cm(fs['output'])}")
    click.echo(
        "effector path error: "
        + ("n/a" if eff is None else f"{eff:.2f} % of limb length")
        + "; joint limits "
        + ("kept" if lim["all_kept"] else "NOT kept (see --json)")
    )
