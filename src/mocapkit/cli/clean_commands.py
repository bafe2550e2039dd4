"""``mocapkit clean`` and ``mocapkit reconstruct`` (registered on import; see mocapkit.cli)."""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click
import numpy as np

from mocapkit.clean import THRESHOLD
from mocapkit.cli.common import (
    LENIENT,
    CLIError,
    expand_inputs,
    friendly_errors,
    load,
    main,
    progress,
)
from mocapkit.cli.demo import DEMO_STEPS
from mocapkit.core.motion import Motion
from mocapkit.io import write_motion
from mocapkit.io.atomic import atomic_write_bytes, atomic_write_text, refuse_overwrite


def parse_contact(spec: str, motion: Motion) -> Any:
    """``JOINT:START-END[:X,Y,Z]`` -> a ContactConstraint (frames inclusive, 0-based)."""
    from mocapkit.clean import ContactConstraint

    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise CLIError(f"--contact {spec!r}: expected JOINT:START-END[:X,Y,Z]")
    names = list(motion.skeleton.names)
    if parts[0] not in names:
        raise CLIError(f"--contact {spec!r}: no joint named {parts[0]!r}")
    try:
        a, b = (int(x) for x in parts[1].split("-"))
        pos = None
        if len(parts) == 3:
            xyz = [float(x) for x in parts[2].split(",")]
            if len(xyz) != 3:
                raise ValueError
            pos = (xyz[0], xyz[1], xyz[2])
    except ValueError:
        raise CLIError(f"--contact {spec!r}: expected JOINT:START-END[:X,Y,Z]") from None
    c = ContactConstraint(names.index(parts[0]), a, b, pos)
    try:
        c.frames(motion.num_frames)
    except ValueError as e:
        raise CLIError(f"--contact {spec!r}: {e}") from None
    return c


def plot_mdm(
    mdm: np.ndarray,
    names: Sequence[str],
    segments: Sequence[dict[str, Any]],
    path: str | Path,
    fps: float,
    title: str = "",
) -> Path:
    """The paper's Figure 1 heat map: joints x time, hot = distinct, flagged segments outlined."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    F, J = mdm.shape
    fig, ax = plt.subplots(figsize=(max(6.0, min(20.0, F / 40)), max(3.0, J * 0.22)))
    im = ax.imshow(
        mdm.T,
        aspect="auto",
        origin="upper",
        cmap="jet",
        vmin=0.0,
        vmax=1.0,
        interpolation="nearest",
        extent=(-0.5, F - 0.5, J - 0.5, -0.5),
    )
    for s in segments:
        j = s["joint_index"]
        ax.add_patch(
            Rectangle(
                (s["start"] - 0.5, j - 0.5),
                s["end"] - s["start"] + 1,
                1.0,
                fill=False,
                edgecolor="white",
                linewidth=1.2,
            )
        )
    ax.set_yticks(range(J))
    ax.set_yticklabels(names, fontsize=7)
    ax.set_xlabel(f"frame ({fps:g} fps)")
    ax.set_title(title or "movement digression map")
    fig.colorbar(im, ax=ax, label="MDM")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


def _load_all(paths: Sequence[Path], lenient: bool) -> list[Motion]:
    out = []
    with progress(len(paths), "loading context") as step:
        for p in paths:
            out.append(load(str(p), lenient))
            step()
    return out


def clean_take(
    motion: Motion,
    context: Sequence[Motion],
    threshold: float = THRESHOLD,
    two_stage: bool = False,
    baseline: str | None = None,
    show_progress: bool = False,
    contacts: Sequence[Any] = (),
) -> tuple[Any, np.ndarray, np.ndarray, list[dict[str, Any]], Any]:
    """Run the analysis: (cleaner, mdm (F, J) float32, mask, segments, repair result)."""
    from mocapkit.clean import RotationBaseline, SelfSimilarityCleaner
    from mocapkit.core.runs import true_runs

    cleaner = SelfSimilarityCleaner(threshold=threshold, two_stage=two_stage)
    bar_total = len(cleaner.groups or []) or 5
    with progress(bar_total, "analysing", enabled=show_progress and not two_stage) as step:
        cleaner.fit(motion, context, progress=lambda stage, done, total: step())
    names = list(motion.skeleton.names)
    if baseline is None:
        mdm = cleaner.scores().astype(np.float32)
        mask = cleaner.mask()
        segments = [s.as_dict() for s in cleaner.segments()]
    else:
        if not context:
            raise CLIError("--baseline needs --context: its limits are learned from clean takes")
        mask = RotationBaseline(baseline).fit(list(context)).mask(motion)
        mdm = mask.astype(np.float32)
        segments = [
            {"joint": names[j], "joint_index": j, "start": a, "end": b, "peak": 1.0}
            for j in range(mask.shape[1])
            for a, b in true_runs(mask[:, j])
        ]
    result = cleaner.repair(mask=mask, contacts=contacts)
    return cleaner, mdm, mask, segments, result


@main.command("clean")
@click.argument("input_path", metavar="IN", type=click.Path(dir_okay=False, exists=True))
@click.option(
    "--context",
    "contexts",
    multiple=True,
    metavar="FILE_OR_DIR",
    help="Related clean takes (same skeleton) to search; a folder adds its .bvh/.npz files. "
    "Repeatable. Without it the take is compared with itself (local context).",
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
    help="MDM level a flagged stretch of a joint extends down to; a stretch is flagged only "
    "if it holds a near-certain cell or an abrupt jump, lies between two jumps that cancel, "
    "leaves the joint's smooth path, or is a frozen run; smooth stretches and motifs the "
    "joint repeats elsewhere are not flagged. Noise bursts and wrong-way knee or elbow bends "
    "are flagged whatever the MDM.",
)
@click.option("--out", "out_path", type=click.Path(dir_okay=False), help="Write the repaired take.")
@click.option(
    "--report", "report_path", type=click.Path(dir_okay=False), help="Write a JSON report."
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
    metavar="JOINT:START-END[:X,Y,Z]",
    help="Keep an end effector on a contact point over frames START-END (inclusive) while "
    "repairing: the KNN word that keeps it nearest wins, then IK pins it. Without X,Y,Z the "
    "point is where the input has the joint at START. Repeatable.",
)
@LENIENT
@click.option("--quiet", is_flag=True, help="Print nothing but errors.")
@friendly_errors
def clean_command(
    input_path: str,
    contexts: tuple[str, ...],
    two_stage: bool,
    threshold: float,
    out_path: str | None,
    report_path: str | None,
    mdm_path: str | None,
    plot_path: str | None,
    baseline: str | None,
    contact_specs: tuple[str, ...],
    lenient: bool,
    quiet: bool,
) -> None:
    """Find which joints are wrong when in a take, and repair them (self-similarity analysis).

    Every short window of each joint group ("motion-word") is compared by constrained DTW with
    every window of the context; joints whose rotation digresses from their nearest neighbours'
    mean are flagged (stretches with MDM > threshold that hold a near-certain, abrupt or frozen
    cell), as are noise bursts and knees or elbows bent the wrong way; with --out, they are
    replaced by the neighbours' median, blended at the edges. Joints and frames that are not
    flagged stay bit-identical.

    \b
    Examples:
      mocapkit clean take.bvh --report report.json --plot mdm.png
      mocapkit clean take.bvh --context takes/ --out fixed.bvh --mdm mdm.npy
      mocapkit clean take.bvh --context takes/ --two-stage --threshold 0.6 --out fixed.bvh
    """
    outputs = [p for p in (out_path, report_path, mdm_path, plot_path) if p]
    for o in outputs:
        refuse_overwrite(o, [input_path])
    motion = load(input_path, lenient)
    ctx_paths = expand_inputs(contexts, exclude=[input_path])
    for o in outputs:
        refuse_overwrite(o, [str(p) for p in ctx_paths])
    context = _load_all(ctx_paths, lenient)
    contacts = [parse_contact(c, motion) for c in contact_specs]
    t0 = time.perf_counter()
    _, mdm, mask, segments, result = clean_take(
        motion, context, threshold, two_stage, baseline, show_progress=not quiet, contacts=contacts
    )
    elapsed = time.perf_counter() - t0
    names = list(motion.skeleton.names)
    report = {
        "input": str(input_path),
        "fps": motion.fps,
        "frames": motion.num_frames,
        "joints": names,
        "threshold": threshold,
        "method": f"baseline {baseline}" if baseline else "self-similarity",
        "two_stage": two_stage,
        "context": [str(p) for p in ctx_paths],
        "segments": segments,
        "flagged_cells": int(mask.sum()),
        "repaired_cells": int(result.written.sum()),
        "blend_margin_frames": result.margin,
        "analysis_seconds": round(elapsed, 3),
        "output": str(out_path) if out_path else None,
    }
    if out_path:
        write_motion(result.motion, out_path)
    if mdm_path:
        import io

        buf = io.BytesIO()
        np.save(buf, np.ascontiguousarray(mdm, dtype=np.float32))
        atomic_write_bytes(mdm_path, buf.getvalue())
    if plot_path:
        plot_mdm(mdm, names, segments, plot_path, motion.fps, title=Path(input_path).name)
    if report_path:
        atomic_write_text(report_path, json.dumps(report, indent=2) + "\n")
    if quiet:
        return
    click.echo(
        f"{input_path}: {motion.num_frames} frames at {motion.fps:g} fps, "
        f"{len(ctx_paths)} context take(s), {elapsed:.1f} s"
    )
    if not segments:
        click.echo("  no erroneous segment above the threshold")
    for s in segments[:50]:
        click.echo(
            f"  {s['joint']:>16s}  frames {s['start']:5d}-{s['end']:<5d}  peak {s['peak']:.2f}"
        )
    if len(segments) > 50:
        click.echo(f"  ... {len(segments) - 50} more (see --report)")
    for label, path in (
        ("repaired take", out_path),
        ("report", report_path),
        ("MDM", mdm_path),
        ("plot", plot_path),
    ):
        if path:
            click.echo(f"  wrote {label}: {path}")


@main.command("reconstruct")
@click.argument("sparse_path", metavar="SPARSE", type=click.Path(dir_okay=False, exists=True))
@click.option(
    "--database",
    "databases",
    multiple=True,
    required=True,
    metavar="FILE_OR_DIR",
    help="Complete takes (one skeleton) to take the missing joints from; repeatable.",
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

    refuse_overwrite(out_path, [sparse_path])
    sparse = load(sparse_path, lenient)
    db_paths = expand_inputs(databases, exclude=[sparse_path])
    if not db_paths:
        raise CLIError("the database is empty")
    db = _load_all(db_paths, lenient)
    known = [j.strip() for j in joints.split(",") if j.strip()] if joints else None
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
    from mocapkit.clean import inject
    from mocapkit.clean.evaluate import unit_matrix
    from mocapkit.clean.texture import rotating_joints

    walk = datasets.procedural_motion("walk", seconds=8.0, seed=3).motion
    ctx = datasets.procedural_motion("walk", seconds=8.0, seed=4).motion
    rng = np.random.default_rng(0)
    names = list(walk.skeleton.names)
    plan = [("spike", "LeftForeArm", 60), ("offset", "RightLeg", 130), ("flip", "Head", 190)]
    cur = walk
    truth = np.zeros((walk.num_frames, walk.num_joints), dtype=bool)
    for kind, joint, start in plan:
        inj = inject(cur, kind, names.index(joint), rng, start=start)
        cur = inj.motion
        truth[inj.frames, inj.joint] = True
        fr = np.flatnonzero(inj.frames)
        click.echo(f"  injected {kind} on {joint}, frames {fr.min()}-{fr.max()}")
    src = write_motion(cur, out / "humanoid_walk_corrupted.bvh")
    ctx_path = write_motion(ctx, out / "humanoid_walk_context.bvh")
    _, mdm, mask, segments, result = clean_take(cur, [ctx])
    click.echo(f"  [clean] {src} with context {ctx_path}:")
    for s in segments:
        click.echo(
            f"    flagged {s['joint']} frames {s['start']}-{s['end']} (peak {s['peak']:.2f})"
        )
    act = np.flatnonzero(rotating_joints(walk))
    t = unit_matrix(truth, walk.fps)[:, act]
    f = unit_matrix(mask, walk.fps)[:, act]
    tp = int((t & f).sum())
    click.echo(
        f"    detection: recall {tp / max(1, t.sum()):.2f}, precision {tp / max(1, f.sum()):.2f}"
    )
    fixed = write_motion(result.motion, out / "humanoid_walk_repaired.bvh")
    from mocapkit.core.rotations import quat_angle

    bad = truth.any(axis=1)
    before = np.degrees(quat_angle(walk.rotations[bad], cur.rotations[bad]).max())
    after = np.degrees(quat_angle(walk.rotations[bad], result.motion.rotations[bad]).max())
    click.echo(
        f"    repaired {int(result.written.sum())} cells -> {fixed} "
        f"(worst error on corrupted frames {before:.0f} deg -> {after:.0f} deg)"
    )
    png = plot_mdm(mdm, names, segments, out / "humanoid_walk_mdm.png", walk.fps, "demo walk")
    np.save(out / "humanoid_walk_mdm.npy", mdm)
    atomic_write_text(
        out / "humanoid_walk_clean_report.json",
        json.dumps({"segments": segments, "repaired_cells": int(result.written.sum())}, indent=2)
        + "\n",
    )
    click.echo(f"    plotted {png}")


DEMO_STEPS.append((30, "cleaning: detect, repair and plot injected errors", cleaning_step))
