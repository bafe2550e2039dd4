"""``mocapkit graph`` subcommands (registered on import; see mocapkit.cli): build, synth, report,
and the motion-graph step of ``mocapkit demo``."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import click

from mocapkit.cli.batch_commands import job_progress, job_runner, peak_memory_line, runner_options
from mocapkit.cli.common import (
    MOTION_SUFFIXES,
    CLIError,
    data_output,
    echo_json,
    expand_inputs,
    friendly_errors,
    load_all,
    load_readable,
    main,
    naming,
    plot_output,
    warnings_so_far,
)
from mocapkit.cli.demo import DEMO_STEPS
from mocapkit.graph.distance import DEFAULT_WINDOW
from mocapkit.io import WRITABLE
from mocapkit.io.atomic import all_or_nothing, check_outputs


@main.group()
def graph() -> None:
    """Motion graphs (Kovar et al.) with the dynamics-based comparison metric of Matsunaga &
    Zordan: build a graph from clips, synthesise new motion from it, report on it.

    \b
    Examples:
      mocapkit graph build clips/ --out graph.json --plot costs.png
      mocapkit graph synth graph.json --seconds 30 --out walk.bvh --seed 1
      mocapkit graph report graph.json
    """


def usable_clips(files: list[Path], motions: list) -> tuple[list[Path], list, list[str]]:
    """The clips a motion graph can be built of, as a library job takes them: those with
    frames and finite values, of the skeleton and frame rate most of the clips share (the
    first such clip in order names them). Returns the files and motions kept and one error
    line, naming the file, per clip left out."""
    import math
    from collections import Counter

    errors: list[str] = []
    ok: list[int] = []
    for i, (f, m) in enumerate(zip(files, motions, strict=True)):
        if m.num_frames == 0:
            errors.append(f"{f}: the motion has no frames (a motion graph needs frames)")
            continue
        try:
            m.check_finite(str(f))
        except ValueError as e:
            errors.append(str(e))
            continue
        ok.append(i)
    if not ok:
        return [], [], errors
    kinds = Counter((tuple(motions[i].skeleton.names), round(motions[i].fps, 6)) for i in ok)
    best = max(kinds.values())
    ref = next(i for i in ok if kinds[(tuple(motions[i].skeleton.names),
                                       round(motions[i].fps, 6))] == best)  # fmt: skip
    first, kept = motions[ref], []
    for i in ok:
        f, m = files[i], motions[i]
        if m.skeleton.names != first.skeleton.names:
            errors.append(
                f"{f}: a different skeleton from {files[ref]} and the other "
                f"{best - 1} clip(s) of its joints (all clips of a motion graph must have the "
                "same joints)"
            )
        elif not math.isclose(m.frame_time, first.frame_time, rel_tol=1e-6):
            errors.append(
                f"{f}: {m.fps:g} fps, but {files[ref]} is {first.fps:g} fps (all clips must "
                "share one frame rate; resample them first: mocapkit convert --fps)"
            )
        else:
            kept.append(i)
    return [files[i] for i in kept], [motions[i] for i in kept], errors


def _rel(path: Path, base: Path) -> str:
    # as the user named them (links not followed): lib/walk.bvh, not ../../data/walk.bvh
    try:
        return os.path.relpath(os.path.abspath(path), os.path.abspath(base))
    except ValueError:  # other drive (Windows)
        return os.path.abspath(path)


@graph.command("build")
@click.argument("inputs", nargs=-1, required=True, type=click.Path())
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(dir_okay=False),
    help="The graph file to write (JSON).",
)
@click.option(
    "--metric",
    type=click.Choice(["dynamics", "uniform", "torso"]),
    default="dynamics",
    show_default=True,
    help="Body-part weighting: dynamics (the paper's), uniform (Heuristic 1), torso (Heuristic 2).",
)
@click.option(
    "--transitions",
    "T",
    type=int,
    default=None,
    help="Keep the T best transitions (default: the knee of the rank-ordered costs).",
)
@click.option(
    "--threshold", type=float, default=None, help="Keep the transitions with cost <= X instead."
)
@click.option(
    "--window",
    type=float,
    default=DEFAULT_WINDOW,
    show_default="1/3",
    help="Comparison window in seconds.",
)
@click.option(
    "--stride",
    type=int,
    default=None,
    help="Evaluate every STRIDE-th frame, then refine (default: 1 up to 20,000 frames, else 2).",
)
@click.option(
    "--masses",
    type=click.Path(dir_okay=False, exists=True),
    default=None,
    help="JSON {joint name: kg} overriding the de Leva body-part masses.",
)
@click.option(
    "--plot",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the cost matrices (this metric vs the uniform one), their difference "
    "with the transitions marked, and the rank-ordered cost curve (PNG).",
)
@click.option(
    "--graphml",
    type=click.Path(dir_okay=False),
    default=None,
    help="Also write the graph as GraphML.",
)
@click.option("--quiet", is_flag=True, help="No progress bar.")
@runner_options
@friendly_errors
def build(
    inputs, out, metric, T, threshold, window, stride, masses, plot, graphml, quiet, workers,
    scheduler,
):  # fmt: skip
    """Build a motion graph from motion files and/or folders of them.

    Finds the local minima of the aligned window cost between every pair of frames (in tiles,
    never the whole matrix), merges those within a quarter second, keeps the T best (the knee
    of the rank-ordered curve unless --transitions/--threshold), refines them at full
    resolution and prunes the graph to its largest strongly connected component. Frames are
    0-based in the JSON.

    \b
    Examples:
      mocapkit graph build walk.bvh run.bvh --out graph.json
      mocapkit graph build clips/ --out graph.json --metric uniform --transitions 60
      mocapkit graph build clips/ --out graph.json --plot costs.png --graphml graph.graphml
      mocapkit graph build clips/ --out graph.json --workers 8     (tiles as Dask tasks)

    With --workers or --scheduler the frame-pair cost is cut into tiles that run as Dask tasks,
    each returning only its local minima; tiles, tasks and the merge order do not depend on the
    number of workers, so the graph is the same. The memory one worker needs is printed.
    """
    from mocapkit.graph.distance import build_database, plan_tiles, tile_runner
    from mocapkit.graph.graph import build_graph
    from mocapkit.graph.weights import load_masses

    if T is not None and threshold is not None:
        raise CLIError("give --transitions or --threshold, not both")
    files = expand_inputs(inputs, MOTION_SUFFIXES)
    outputs = [data_output(out, "graph", "graph.json"), data_output(graphml, "GraphML", ".graphml"),
               plot_output(plot)]  # fmt: skip
    check_outputs(outputs, [*files, *([masses] if masses else [])])
    files, motions, unreadable = load_readable(files, False, show=not quiet)
    files, motions, unusable = usable_clips(files, motions)
    unreadable += unusable
    if not motions:
        raise CLIError(unreadable[0] + (f" (and {len(unreadable) - 1} more)" if unreadable[1:]
                                        else ""))  # fmt: skip
    for line in unreadable:  # as every library job: the others go on
        click.echo(f"mocapkit: error: {line}", err=True)
    overrides = load_masses(masses) if masses else None
    outp = Path(out)
    with (
        naming(*files),
        all_or_nothing(),  # the graph, its GraphML and the plot: all of them or none
        job_runner(workers, scheduler) as runner,
        job_progress("comparing frames (tile tasks)", enabled=not quiet) as step,
    ):
        db = build_database(motions, metric, window, masses=overrides)
        plan = plan_tiles(db, stride, 1024, None)  # what build_graph will run
        with tile_runner(runner):
            g, db, _minima = build_graph(
                motions, metric, paths=[_rel(f, outp.parent) for f in files], transitions=T,
                threshold=threshold, window=window, stride=stride, masses=overrides,
                progress=step, database=db,
            )  # fmt: skip
        where = runner.describe()
        mem = peak_memory_line(runner)
        g.save(outp)
        wrote = [outp]
        if graphml:
            wrote.append(g.save_graphml(graphml))
        if plot:
            from mocapkit.graph.graph import compare_metrics
            from mocapkit.viz.figures.graph import plot_cost_comparison

            cmp = compare_metrics(motions, g, db, masses=overrides)
            wrote.append(
                plot_cost_comparison(
                    cmp, plot, title=f"{outp.name}: {' vs '.join(cmp.metrics)} metric, T = {g.T}"
                )
            )
    st = g.stats
    click.echo(
        f"{len(files)} clips, {db.num_frames} frames at {db.fps:g} fps; window "
        f"{len(db.window)} frames; {st['candidates']} candidate transitions "
        f"({st['gflop']:.1f} GFLOP in {st['tile_seconds']:.1f} s, stride {g.stride})"
    )
    rule = "--transitions" if T is not None else "--threshold" if threshold is not None else ""
    sel = st.get("selection") or {}
    if rule:
        kept = f"kept T = {g.T} ({rule}): {g.num_transitions} transitions"
    else:  # the knee's cheapest, then what connects the clips: say how the total is made
        kept = (
            f"kept the knee rule's T = {g.T} cheapest ({sel.get('knee', 0)} transitions at or "
            f"under its cost), {sel.get('end', 0)} more at clip ends and {sel.get('bridge', 0)} "
            f"bridging components: {g.num_transitions} transitions"
        )
    click.echo(
        f"{kept}, {int(g.in_scc.sum())} in the largest strongly connected component "
        f"({g.scc_frames()} frames)"
    )
    click.echo(
        f"tiles: {plan.num_tiles} in {len(plan.tasks)} tasks ({where}); memory per worker at "
        f"most {plan.memory_bytes(db) / 2**20:.0f} MB (estimate), {mem}"
    )
    cov = g.coverage()
    click.echo(cov.summary())
    click.echo("coverage per clip (least covered first):")
    for line in cov.clip_lines():
        click.echo(f"  {line}")
    for p in wrote:
        click.echo(f"wrote {p}")
    if unreadable:  # built from the others; the status says not all
        click.echo(f"left out {len(unreadable)} file(s) that could not be read or used")
        raise click.exceptions.Exit(2)


@graph.command("synth")
@click.argument("graph_file", type=click.Path(dir_okay=False, exists=True))
@click.option("--seconds", type=float, default=None, help="Random walk of this duration.")
@click.option(
    "--path",
    "path_csv",
    type=click.Path(dir_okay=False, exists=True),
    default=None,
    help="Follow this ground path instead: CSV of x,z points (file units; "
    "ground coordinates, x = side axis, z = forward axis).",
)
@click.option(
    "--out", "out", required=True, type=click.Path(dir_okay=False), help="The BVH to write."
)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option(
    "--blend",
    type=click.Choice(["crossfade", "inertialize"]),
    default="crossfade",
    show_default=True,
    help="How transitions are blended.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON (with the path error).")
@friendly_errors
def synth(graph_file, seconds, path_csv, out, seed, blend, as_json):
    """Synthesise a continuous BVH from a motion graph: a seeded random walk (--seconds) or a
    walk following a 2-D path (--path).

    \b
    Examples:
      mocapkit graph synth graph.json --seconds 30 --out walk.bvh --seed 7
      mocapkit graph synth graph.json --path path.csv --out follow.bvh
    """
    from mocapkit.graph.graph import load_graph, load_path_csv, synthesize
    from mocapkit.graph.synth import PathNotFollowedWarning
    from mocapkit.io import write_motion
    from mocapkit.provenance import sidecar_path

    if (seconds is None) == (path_csv is None):
        raise CLIError("give exactly one of --seconds or --path")
    with naming(graph_file):
        g = load_graph(graph_file)
    clip_paths = g.clip_paths(Path(graph_file).parent)
    for c, p in zip(g.clips, clip_paths, strict=True):
        if not p.exists():
            raise CLIError(
                f"{graph_file}: its clip {c.path} is not at {p} (a graph file names its clips "
                "relative to its own folder: keep it beside its library, or build it again)"
            )
    inputs = [graph_file, *clip_paths, *([path_csv] if path_csv else [])]
    check_outputs([(out, WRITABLE), sidecar_path(out)], inputs)
    motions = load_all(clip_paths, False)
    with naming(path_csv or graph_file):
        pts = load_path_csv(path_csv) if path_csv is not None else None
    with naming(graph_file, *clip_paths), all_or_nothing():  # the motion and its plan, or none
        with warnings.catch_warnings():  # reported below, once, as the CLI's warning line
            warnings.simplefilter("ignore", PathNotFollowedWarning)
            res = synthesize(g, motions, seconds=seconds, path=pts, seed=seed, blend=blend)
        params = {"graph": str(graph_file), "seconds": seconds, "path": path_csv, "seed": seed,
                  "blend": blend}  # fmt: skip
        plan = res.provenance(g, str(out), params, [str(p) for p in clip_paths])
        write_motion(res.motion, out)
        side = plan.write(out)
    m = res.motion
    err = res.path_error
    if as_json:
        echo_json(
            {**res.to_json(), "out": str(out), "plan": str(side), "warnings": warnings_so_far()}
        )
    else:
        click.echo(
            f"wrote {out} ({m.num_frames} frames, {m.duration:.1f} s, {res.transitions} "
            f"transitions) and its plan {side}"
        )
        if err is not None:
            click.echo(err.line())
    if err is not None and err.warning():
        click.echo(f"mocapkit: warning: {err.warning()}", err=True)


@graph.command("report")
@click.argument("graph_file", type=click.Path(dir_okay=False, exists=True))
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@friendly_errors
def report(graph_file, as_json):
    """Transition count, size of the strongly connected component and the foot skate of the
    transitions (start-to-end distance and arc length of the supporting foot, cm).

    \b
    Example:
      mocapkit graph report graph.json --json
    """
    from mocapkit.graph.graph import load_graph

    with naming(graph_file):
        rep = load_graph(graph_file).report(Path(graph_file).parent)
    r = rep.to_json()
    if as_json:
        echo_json(r)
        return
    click.echo(f"{graph_file}: {r['clips']} clips, {r['frames']} frames, metric {r['metric']}")
    click.echo(
        f"  transitions: {r['transitions']} (T = {r['T']}), "
        f"{r['transitions_in_scc']} in the largest strongly connected component"
    )
    click.echo(f"  component: {r['scc_nodes']} nodes, {r['scc_frames']} frames")
    fs = r.get("foot_skate")
    if fs:
        s, a = fs["start_to_end_cm"], fs["arc_length_cm"]
        if s["mean"] is None:
            click.echo("  foot skate: no transition has a supporting foot")
        else:
            click.echo(
                f"  foot skate over {fs['supported']}/{fs['transitions']} supported "
                f"transitions: start-to-end mean {s['mean']:.2f} cm (median "
                f"{s['median']:.2f}, max {s['max']:.2f}); arc length mean "
                f"{a['mean']:.2f} cm (median {a['median']:.2f}, max {a['max']:.2f})"
            )
            # the few a walk should avoid (over 1 cm: a visible slide)
            worst = [w for w in r.get("worst_skate") or [] if w["start_to_end_cm"] > 1.0][:5]
            if worst:
                click.echo("  transitions that skate over 1 cm, most first (start-to-end, cm):")
            for w in worst:
                click.echo(
                    f"    {w['start_to_end_cm']:6.2f}  {w['src']} frame {w['src_frame']} -> "
                    f"{w['dst']} frame {w['dst_frame']}"
                    f"{'' if w['in_scc'] else '  (outside the component)'}"
                )
    elif "foot_skate_error" in r:
        click.echo(f"  foot skate: clips not readable ({r['foot_skate_error']})")
    if rep.coverage:
        click.echo(f"  {rep.coverage_summary()}")
        click.echo("  coverage per clip (least covered first):")
        for line in rep.coverage_lines():
            click.echo(f"    {line}")
        if rep.warning:
            click.echo(f"mocapkit: warning: {rep.warning}", err=True)


def graph_step(out: Path) -> None:
    """Demo: a motion graph of the procedural humanoid, a random walk, the foot skate of its
    transitions and the cost matrices of two metrics."""
    from mocapkit import datasets
    from mocapkit.graph.graph import build_graph, compare_metrics, synthesize
    from mocapkit.io import write_motion
    from mocapkit.viz.figures.graph import plot_cost_comparison

    paths, motions = [], []
    for n, (kind, secs) in enumerate((("walk", 4.0), ("run", 3.0), ("walk", 4.0), ("idle", 3.0))):
        m = datasets.procedural_motion(kind, seconds=secs, seed=10 + n).motion
        p = out / f"graph_clip{n}_{kind}.bvh"
        write_motion(m, p)
        paths.append(p.name)
        motions.append(m)
    g, db, _ = build_graph(motions, "dynamics", paths=paths)  # the default rule
    gp = g.save(out / "humanoid_graph.json")
    r = g.report(motions=motions)
    click.echo(
        f"  {db.num_frames} frames -> {r.transitions} transitions, "
        f"{r.transitions_in_scc} in the strongly connected component; wrote {gp}"
    )
    click.echo(f"  {g.coverage().summary()}")
    walk = synthesize(g, motions, seconds=10.0, seed=0)
    wp = write_motion(walk.motion, out / "graph_random_walk.bvh")
    walk.provenance(g, str(wp), {"seconds": 10.0, "seed": 0}, [str(out / p) for p in paths]).write(
        wp
    )
    click.echo(
        f"  random walk: wrote {wp} and its plan "
        f"({walk.motion.num_frames} frames, {walk.transitions} transitions)"
    )
    fs = r.foot_skate
    if fs and fs["start_to_end_cm"]["mean"] is not None:
        click.echo(
            f"  foot skate of the transitions: {fs['start_to_end_cm']['mean']:.2f} cm "
            f"start-to-end, {fs['arc_length_cm']['mean']:.2f} cm arc length (mean)"
        )
    cmp = compare_metrics(motions, g, db)
    png = plot_cost_comparison(
        cmp, out / "humanoid_graph_costs.png", title="demo graph: dynamics vs uniform metric"
    )
    click.echo(f"  plotted {png}")


DEMO_STEPS.append((20, "motion graphs: build, walk, foot skate", graph_step))
