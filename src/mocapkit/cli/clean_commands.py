"""``mocapkit clean`` and ``mocapkit reconstruct`` (registered on import; see mocapkit.cli)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import click

from mocapkit import clean
from mocapkit.batch.clean_library import CONTEXT_BY
from mocapkit.clean import THRESHOLD
from mocapkit.cli.batch_commands import clean_folder, runner_options
from mocapkit.cli.common import (
    LENIENT,
    MOTION_SUFFIXES,
    CLIError,
    JsonFile,
    check_input_file,
    data_output,
    expand_inputs,
    friendly_errors,
    load,
    load_all,
    main,
    naming,
    no_joint_named,
    npy_output,
    plot_output,
    progress_callback,
    report_lines,
    warnings_so_far,
    write_json,
)
from mocapkit.cli.demo import DEMO_STEPS
from mocapkit.core.motion import Motion
from mocapkit.core.ranges import RangeError, parse_frame
from mocapkit.io import WRITABLE, write_motion
from mocapkit.io.atomic import all_or_nothing, check_outputs


def _contact_point(text: str, spec: str, form: str) -> tuple[float, float, float]:
    try:
        xyz = [float(x) for x in text.split(",")]
        if len(xyz) != 3:
            raise ValueError
    except ValueError:
        raise CLIError(f"--contact {spec!r}: expected {form}") from None
    return (xyz[0], xyz[1], xyz[2])


def parse_contact(spec: str, motion: Motion) -> Any:
    """``JOINT@RANGE[@X,Y,Z]`` -> a ContactConstraint. RANGE is the range syntax of every
    option (:mod:`mocapkit.core.ranges`: ``55:71`` frames with the end excluded, or
    ``1.8s:2.4s``); ``@`` separates, so joint names with colons (``mixamorig:LeftHand``) work.
    The older ``JOINT:START-END[:X,Y,Z]`` (frames inclusive, 0-based) is still read."""
    from mocapkit.clean import ContactConstraint
    from mocapkit.core.ranges import RangeError, RangeSpec

    names = list(motion.skeleton.names)
    if "@" in spec:
        form = "JOINT@A:B[@X,Y,Z] (frames A..B-1, or seconds 1.8s:2.4s)"
        parts = spec.split("@")
        if len(parts) not in (2, 3):
            raise CLIError(f"--contact {spec!r}: expected {form}")
        if parts[0] not in names:
            raise CLIError(f"--contact {spec!r}: {no_joint_named(parts[0], motion.skeleton)}")
        try:
            # the range's messages name the whole argument, not its range alone
            r = RangeSpec.parse(parts[1], f"--contact {spec!r}")
            r = dataclasses.replace(r, option="--contact", text=spec)
            lo, hi = r.frames(motion.fps, motion.num_frames)
        except RangeError as e:
            raise CLIError(str(e)) from None
        pos = _contact_point(parts[2], spec, form) if len(parts) == 3 else None
        return ContactConstraint(names.index(parts[0]), lo, hi - 1, pos)
    form = "JOINT@A:B[@X,Y,Z] or JOINT:START-END[:X,Y,Z]"
    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise CLIError(f"--contact {spec!r}: expected {form}")
    if parts[0] not in names:
        raise CLIError(f"--contact {spec!r}: {no_joint_named(parts[0], motion.skeleton)}")
    try:
        a, b = (int(x) for x in parts[1].split("-"))
    except ValueError:
        raise CLIError(f"--contact {spec!r}: expected {form}") from None
    pos = _contact_point(parts[2], spec, form) if len(parts) == 3 else None
    c = ContactConstraint(names.index(parts[0]), a, b, pos)
    try:
        c.frames(motion.num_frames)
    except ValueError as e:
        raise CLIError(f"--contact {spec!r}: {e}") from None
    return c


def parse_explain(spec: str, motion: Motion) -> tuple[int, int]:
    """``JOINT:FRAME`` -> (joint index, frame). FRAME is a 0-based frame or seconds (``1.5s``);
    the last ``:`` separates, so joint names with colons (``mixamorig:LeftHand``) work."""
    form = "JOINT:FRAME (a 0-based frame, or seconds like 1.5s)"
    if ":" not in spec:
        raise CLIError(f"--explain {spec!r}: expected {form}")
    joint, when = spec.rsplit(":", 1)
    names = list(motion.skeleton.names)
    if joint not in names:
        raise CLIError(f"--explain {spec!r}: {no_joint_named(joint, motion.skeleton)}")
    try:  # the CLI's one reading of a frame or a time (a time in the last frame's span is it)
        frame = parse_frame(when, motion.fps, motion.num_frames, "--explain", shown=spec)
    except RangeError as e:
        raise CLIError(str(e)) from None
    return names.index(joint), frame


@main.command("clean")
@click.argument("input_path", metavar="IN")
@click.option(
    "--context",
    "contexts",
    multiple=True,
    metavar="FILE_OR_DIR",
    help="Related clean takes (same skeleton) to search: a file, a folder (its .bvh, .npz, "
    ".amc, .glb and .gltf files, sub-folders included) or a quoted glob pattern. Repeatable. "
    "Without it the take is compared with itself (local context).",
)
@click.option(
    "--two-stage",
    is_flag=True,
    help="Search the take itself with whole-body words first, then the context with sub-group "
    "words only around what stage one flagged (faster with large contexts).",
)
@click.option(
    "--threshold",
    type=click.FloatRange(0.0, 1.0),
    default=THRESHOLD,
    show_default=True,
    help="MDM level of the mdm rule: a flagged stretch of a joint extends down to it "
    "(DetectConfig.threshold). The other rules of mocapkit.clean.detect.PIPELINE (jumps, "
    "spikes, holds, noise, wrong-way hinges) do not read it, so it changes little where they "
    "find the errors; --explain shows every rule's verdict on one cell.",
)
@click.option("--out", "out_path", type=click.Path(dir_okay=False), help="Write the repaired take.")
@click.option(
    "--json",
    "--report",
    "json_path",
    type=JsonFile(),
    help="Write the JSON report (-: print it, and the summary lines go to standard error; a "
    'failure, a mistyped option too, prints {"error": LINE} there), as stitch and inbetween '
    "do; --report is the same option.",
)
@click.option(
    "--mdm",
    "mdm_path",
    type=click.Path(dir_okay=False),
    help="Write the MDM as a float32 .npy array (frames x joints, in [0, 1]).",
)
@click.option(
    "--plot", "plot_path", type=click.Path(dir_okay=False), help="Write the MDM heat map."
)
@click.option(
    "--baseline",
    type=click.Choice(["a", "b", "c"]),
    default=None,
    help="Detect with a baseline instead: (a) rotation limits, (b) rotation-change rate, "
    "(c) both, learned from the --context takes (repair still uses the KNN words).",
)
@click.option(
    "--contact",
    "contact_specs",
    multiple=True,
    metavar="JOINT@RANGE[@X,Y,Z]",
    help="Keep an end effector on a contact point over RANGE (frames A:B with B excluded, or "
    "seconds 1.8s:2.4s, as in every option; the older JOINT:START-END with START-END "
    "inclusive is still read) while repairing: the KNN word that keeps it nearest wins, then "
    "IK pins it. Without X,Y,Z the point is where the input has the joint at the range's "
    "first frame. Repeatable.",
)
@click.option(
    "--explain",
    "explain_specs",
    multiple=True,
    metavar="JOINT:FRAME",
    help="Print why this cell was or was not flagged: every detection rule's verdict and what "
    "it measured there (FRAME: 0-based, or seconds like 1.5s). Repeatable; also in --report.",
)
@click.option(
    "--out-dir",
    default=None,
    metavar="DIR",
    help="Folder mode (IN is a folder of takes): where the repaired takes go (DIR/<take>; not "
    "inside IN). Without it, only the reports are written.",
)
@click.option(
    "--report-dir",
    default=None,
    metavar="DIR",
    help="Folder mode: where the reports go: DIR/takes/<take>.json, DIR/summary.json (every "
    "flagged segment with its reasons) and DIR/overview.html (takes ranked by flagged seconds).",
)
@click.option(
    "--context-by",
    type=click.Choice(CONTEXT_BY),
    default=None,
    help="Folder mode: each take's related takes are the same folder (CMU's subject folders), "
    "the same folder and the longest name prefix up to a '_' that three other takes share "
    "(the default: Bandai's content_style_NNN, or every style of the content; a take sharing "
    "no prefix with three others is compared with the whole folder), or every take.",
)
@click.option(
    "--context-max",
    type=click.IntRange(min=0),
    default=None,
    help="Folder mode: at most this many related takes per take, the nearest in name order "
    "(default 8).",
)
@runner_options
@LENIENT
@click.option("--quiet", is_flag=True, help="Print nothing but errors and what --explain asks for.")
@friendly_errors
def clean_command(
    input_path: str,
    contexts: tuple[str, ...],
    two_stage: bool,
    threshold: float,
    out_path: str | None,
    json_path: str | None,
    mdm_path: str | None,
    plot_path: str | None,
    baseline: str | None,
    contact_specs: tuple[str, ...],
    explain_specs: tuple[str, ...],
    out_dir: str | None,
    report_dir: str | None,
    context_by: str | None,
    context_max: int | None,
    workers: int | None,
    scheduler: str | None,
    lenient: bool,
    quiet: bool,
) -> None:
    """Find which joints of a take are wrong, and when, and repair them (self-similarity analysis).
    IN is a take (.bvh, .npz, .glb/.gltf, or a CMU .amc with its subject's .asf beside it:
    NN.asf for NN_MM.amc, or the folder's only .asf), or a folder of takes (folder mode: every take
    cleaned against its related takes, in this process or on a Dask cluster; see "Running on
    a cluster" in the README).

    Every short window of each joint group ("motion-word") is compared by constrained DTW with every
    window of the context; joints whose rotation digresses from their nearest neighbours' mean are
    flagged (rule "mdm": stretches with MDM > threshold, or abrupt cells, that hold a near-certain
    or abrupt cell; an abrupt cell may lie below the threshold), and so, whatever their MDM, are
    stretches turned by one rotation (a jump away and, within 1.5 s, back by the same turn, or
    back about the same axis by two large jumps: cancelling-jumps; a one-frame pop is left to
    the spike rule), noise bursts, joints held still
    while their neighbours move on (frozen; a dropout repeats one value bit for bit; a joint held
    through the whole take is one it does not animate), knees or elbows bent the wrong way or
    swung out of the plane they bend in (on a rig whose hinges keep to it), and
    spikes (a joint off its own smooth path for at most 1/15 s by 20 to 40 deg, more the more the
    joint itself jumps). Vetoes clear mdm, cancelling-jumps and frozen stretches where the motion is
    natural: no step near the stretch (smooth), a motif the joint repeats (recurring), a joint
    leaving a limit its solver clamps it at (limit-release), a take's first or last movement,
    performed once, with no jump at its edge inside the take (once-at-ends). --explain JOINT:FRAME
    says which rule decided a cell and why. Joint rotations are judged; translations (the root's
    path over the ground, animated bone offsets) are not checked. With --out, flagged cells are
    replaced by the neighbours' median (a stretch the cancelling-jumps rule found turned by one
    rotation, or about one axis by a changing angle, is turned back by it instead, and the rest
    of its flagged run keeps its captured rotations; a knee or elbow bent the wrong way has its
    flexion reflected back across straight where that meets the frames beside it better than
    the median, as on a one-off gesture, else only a half-turn flip or a bend whose flexion
    changes linearly over the run is turned back), blended over 0.1 s on each side of a flagged
    run (those frames are written too; a turned-back or reflected run is written as it is from
    0.1 s inside its edges), and where a repaired joint moves a planted foot (a hip, knee or
    ankle, or the pelvis, under a foot on the ground)
    IK on that leg holds the foot where it was planted. All other joints and frames keep their
    rotations bit for bit (the written file's angles are derived from them again, to 1e-12 deg
    and 12 significant digits, so an unchanged angle reads as the input file had it).

    \b
    Examples:
      mocapkit clean take.bvh --report report.json --plot mdm.png
      mocapkit clean take.bvh --context takes/ --out fixed.bvh --mdm mdm.npy
      mocapkit clean take.bvh --context takes/ --two-stage --threshold 0.6 --out fixed.bvh
      mocapkit clean take.bvh --out fixed.bvh --contact LeftHand@1.8s:2.4s
      mocapkit clean bandai/ --out-dir fixed/ --report-dir reports/
      mocapkit clean bandai/ --report-dir reports/      (reports only: which takes are bad)
      mocapkit clean cmu/ --out-dir fixed/ --report-dir reports/ --context-by folder --workers 8
      mocapkit clean lib/ --out-dir fixed/ --report-dir reports/ \\
          --scheduler tcp://127.0.0.1:8786

    In folder mode each take's outputs are written atomically, then its manifest entry (hashes
    of the take, its context takes, the settings and the mocapkit version): a rerun skips the
    takes that are complete and unchanged, so an interrupted job resumes. A take that cannot be
    read or cleaned is listed in the summary and the others go on (exit status 2 at the end).
    The outputs are the same bytes in-process, with --workers or on --scheduler.
    """
    single = {"--out": out_path, "--json/--report": json_path, "--mdm": mdm_path,
              "--plot": plot_path, "--baseline": baseline, "--contact": contact_specs,
              "--explain": explain_specs, "--context": contexts}  # fmt: skip
    folder = {"--out-dir": out_dir, "--report-dir": report_dir, "--context-by": context_by,
              "--context-max": context_max, "--workers": workers,
              "--scheduler": scheduler}  # fmt: skip
    if Path(input_path).is_dir():
        given = [k for k, v in single.items() if v]
        if given:
            raise CLIError(
                f"{input_path} is a folder: {', '.join(given)} "
                f"{'works' if len(given) == 1 else 'work'} on one take; a folder takes "
                "--out-dir and --report-dir (and --context-by, --context-max)"
            )
        if not report_dir:
            raise CLIError(
                f"{input_path} is a folder: give --report-dir DIR (and --out-dir DIR for the "
                "repaired takes)"
            )
        # the library's own default threshold unless one was given (it keys the manifest)
        source = click.get_current_context().get_parameter_source("threshold")
        given_threshold = None if source is click.core.ParameterSource.DEFAULT else threshold
        clean_folder(
            input_path, out_dir, report_dir, context_by or "prefix",
            8 if context_max is None else context_max, given_threshold, two_stage, lenient,
            workers, scheduler, quiet,
        )  # fmt: skip
        return
    check_input_file(input_path)
    given = [k for k, v in folder.items() if v is not None]
    if given:
        raise CLIError(f"{', '.join(given)}: only for a folder of takes ({input_path} is a file)")
    ctx_paths = expand_inputs(contexts, MOTION_SUFFIXES, exclude=[input_path])
    check_outputs(
        [
            (out_path, WRITABLE) if out_path else None,
            data_output(json_path, "report", ".json"),
            npy_output(mdm_path, "MDM"),
            plot_output(plot_path),
        ],
        [input_path, *ctx_paths],
    )
    motion = load(input_path, lenient)
    context = load_all(ctx_paths, lenient, "loading context", show=not quiet)
    contacts = [parse_contact(c, motion) for c in contact_specs]
    # one explanation per cell, however often or however spelt (ltoes:180, ltoes:1.5s)
    cells = list(dict.fromkeys(parse_explain(e, motion) for e in explain_specs))
    with (
        naming(input_path, *ctx_paths),
        all_or_nothing(),
        progress_callback("analysing", enabled=not quiet) as step,
    ):
        report = clean.run(
            motion,
            context,
            threshold=threshold,
            two_stage=two_stage,
            baseline=baseline,
            contacts=contacts,
            explain=cells,
            source=input_path,
            context_names=[str(p) for p in ctx_paths],
            output=out_path,
            progress=step,
        )
        if out_path:
            write_motion(report.motion, out_path)
        if mdm_path:
            report.save_mdm(mdm_path)
        if plot_path:
            from mocapkit.viz.figures.clean import plot_clean_report

            plot_clean_report(report, plot_path)
        if json_path:  # what standard error warns of too (a unit lost, a repaired row)
            write_json(json_path, {**report.to_json(), "warnings": warnings_so_far()})
    say = report_lines(json_path)
    if quiet:
        for e in report.explanations:
            say(str(e))
        return
    say(
        f"{input_path}: {report.frames} frames at {report.fps:g} fps, "
        f"{len(report.context)} context take(s), analysed in {report.analysis_seconds:.1f} s"
    )
    segments = report.segments
    if not segments:
        say("  no flagged segment")
    for s in segments[:50]:
        how = ""
        if out_path:  # how the repair wrote it: cells per method
            done = report.repair.methods(s.joint_index, s.start, s.end)
            how = "; repaired: " + ", ".join(f"{m} {n}" for m, n in done.items())
        say(
            f"  {s.joint:>16s}  frames {s.start:5d}:{s.end + 1:<5d}  MDM peak {s.peak:.2f}  "
            f"{', '.join(s.reasons)}{how}"
        )
    if len(segments) > 50:
        say(f"  ... {len(segments) - 50} more (see --report)")
    for c in report.repair.contacts:
        say(f"  {c}")
    for e in report.explanations:
        say(str(e))
    for label, path in (
        ("repaired take", out_path),
        ("report", json_path),
        ("MDM", mdm_path),
        ("plot", plot_path),
    ):
        if path and path != "-":
            say(f"  wrote {label}: {path}")


@main.command("reconstruct")
@click.argument("sparse_path", metavar="SPARSE")
@click.option(
    "--database",
    "databases",
    multiple=True,
    required=True,
    metavar="FILE_OR_DIR",
    help="Complete takes (one skeleton) to take the missing joints from: a file, a folder or a "
    "quoted glob pattern; repeatable.",
)
@click.option("--out", "out_path", required=True, type=click.Path(dir_okay=False))
@click.option(
    "--joints",
    default=None,
    help="Comma-separated joint names to trust in SPARSE (default: every SPARSE joint found in "
    "the database skeleton).",
)
@LENIENT
@friendly_errors
def reconstruct_command(
    sparse_path: str, databases: tuple[str, ...], out_path: str, joints: str | None, lenient: bool
) -> None:
    """Rebuild the full skeleton of a take that holds only some joints.

    The known joints' motion-words are matched in the database takes and the best-chained
    full-body neighbours fill in the rest; the known joints are kept as they are.

    \b
    Example:
      mocapkit reconstruct sparse.bvh --database takes/ --out full.bvh
    """
    from mocapkit.clean import reconstruct

    check_input_file(sparse_path)
    db_paths = expand_inputs(databases, MOTION_SUFFIXES, exclude=[sparse_path])
    if not db_paths:
        raise CLIError("the database is empty")
    check_outputs([(out_path, WRITABLE)], [sparse_path, *db_paths])
    sparse = load(sparse_path, lenient)
    db = load_all(db_paths, lenient, "loading database")
    known = [j.strip() for j in joints.split(",") if j.strip()] if joints else None
    with naming(sparse_path, *db_paths), all_or_nothing():
        full = reconstruct(sparse, db, known)
        write_motion(full, out_path)
    click.echo(
        f"{sparse_path}: {sparse.num_joints} joints -> {full.num_joints} joints from "
        f"{len(db_paths)} database take(s); wrote {out_path}"
    )


# ----------------------------------------------------------------------------------- demo


def cleaning_step(out: Path) -> None:
    """Procedural walk with injected errors: detected, repaired, plotted."""
    from mocapkit import datasets
    from mocapkit.clean import evaluate
    from mocapkit.clean.texture import rotating_joints
    from mocapkit.viz.figures.clean import plot_clean_report

    walk = datasets.procedural_motion("walk", seconds=8.0, seed=3).motion
    ctx = datasets.procedural_motion("walk", seconds=8.0, seed=4).motion
    plan = [("spike", "LeftForeArm", 60), ("offset", "RightLeg", 130), ("flip", "Head", 190)]
    bad = evaluate.inject_errors(walk, plan, rng=0)
    for kind, joint, first, last in bad.spans():
        click.echo(f"  injected {kind} on {joint}, frames {first}-{last}")
    src = write_motion(bad.motion, out / "humanoid_walk_corrupted.bvh")
    ctx_path = write_motion(ctx, out / "humanoid_walk_context.bvh")
    fixed_path = out / "humanoid_walk_repaired.bvh"
    report = clean.run(bad.motion, [ctx], source=src, context_names=[ctx_path], output=fixed_path)
    click.echo(f"  [clean] {src} with context {ctx_path}:")
    for s in report.segments:
        click.echo(f"    flagged {s.joint} frames {s.start}:{s.end + 1} (MDM peak {s.peak:.2f})")
    score = evaluate.detection_counts(bad.truth, report.mask, walk.fps, rotating_joints(walk))
    click.echo(f"    detection: recall {score.recall:.2f}, precision {score.precision:.2f}")
    fixed = write_motion(report.motion, fixed_path)
    before = evaluate.worst_error_deg(walk, bad.motion, bad.frames)
    after = evaluate.worst_error_deg(walk, report.motion, bad.frames)
    click.echo(
        f"    repaired {report.repaired_cells} cells -> {fixed} "
        f"(worst error on corrupted frames {before:.0f} deg -> {after:.0f} deg)"
    )
    png = plot_clean_report(report, out / "humanoid_walk_mdm.png", "demo walk")
    report.save_mdm(out / "humanoid_walk_mdm.npy")
    write_json(out / "humanoid_walk_clean_report.json", report.to_json())
    click.echo(f"    plotted {png}")


DEMO_STEPS.append((30, "cleaning: detect, repair and plot injected errors", cleaning_step))
