"""``mocapkit view`` (registered on import; see mocapkit.cli)."""

from __future__ import annotations

import webbrowser
from pathlib import Path

import click

from mocapkit.cli.common import (
    LENIENT,
    MOTION_SUFFIXES,
    CLIError,
    expand_inputs,
    friendly_errors,
    load_readable,
    main,
    naming,
    up_option,
    warn_if_up_disagrees,
)
from mocapkit.cli.demo import DEMO_STEPS
from mocapkit.io.atomic import all_or_nothing, check_outputs
from mocapkit.viz.viewer import sidecars_drawn, view_data, view_files, write_page_data


@main.command("view")
@click.argument("files", nargs=-1, required=True, metavar="FILE_DIR_OR_GLOB...")
@click.option(
    "--clean-report",
    type=click.Path(dir_okay=False),
    help="Cleaning REPORT.json (mocapkit clean --report): flagged segments on the timeline.",
)
@click.option(
    "--mdm",
    type=click.Path(dir_okay=False),
    help="MDM.npy (mocapkit clean --mdm): joints coloured by it, heat map under the player.",
)
@click.option(
    "--stitch",
    "stitch_json",
    type=click.Path(dir_okay=False),
    help="Stitch RESULT.json (mocapkit stitch --json): take-off/injected/landing frames, L_k(k).",
)
@click.option(
    "--graph",
    "graph_json",
    type=click.Path(dir_okay=False),
    help="Motion graph GRAPH.json (optional): its transition count beside the transitions a "
    "synthesised FILE took, which view reads from FILE's plan (FILE.provenance.json).",
)
@click.option(
    "--out",
    "out_path",
    type=click.Path(dir_okay=False),
    help="The HTML page to write (default: the first FILE's name with .html, in the current "
    "folder, never beside the input).",
)
@click.option("--open", "open_page", is_flag=True, help="Open the page in the web browser.")
@up_option("Up axis (Y, Z, -Y, ...) of every FILE (default: detected for each FILE).")
@click.option(
    "--units",
    type=click.Choice(["m", "cm", "mm", "inch"]),
    help="Length unit of every FILE (default: each FILE's own: the unit its file states, as an "
    "ASF does, else guessed from the character's height).",
)
@LENIENT
@friendly_errors
def view_cmd(
    files: tuple[str, ...],
    clean_report: str | None,
    mdm: str | None,
    stitch_json: str | None,
    graph_json: str | None,
    out_path: str | None,
    open_page: bool,
    up: str | None,
    units: str | None,
    lenient: bool,
) -> None:
    """Write a self-contained HTML viewer (works offline) for one or more motions.

    Several FILEs are overlaid (two) or side by side (three or more; a checkbox switches).
    The page: orbit/zoom camera, play/pause, frame scrubber, speed, loop, frame and time
    readout, ground grid in metres on the skeleton's up axis; with overlays, a timeline under
    the player (click it to jump).

    \b
    Examples:
      mocapkit view walk.bvh
      mocapkit view take.bvh fixed.bvh --clean-report report.json --mdm mdm.npy --out v.html
      mocapkit view stitched.bvh --stitch best.json --open
      mocapkit view synth.bvh --graph graph.json
    """
    from mocapkit.provenance import existing_sidecar

    paths = expand_inputs(files, MOTION_SUFFIXES, unique=False)
    # data folders are often shared or read-only: the default page goes into the current folder
    # (named after the one folder or the first file given)
    first = Path(files[0])
    default = first.resolve().name + ".html" if first.is_dir() else paths[0].stem + ".html"
    out = Path(out_path) if out_path else Path(default)
    overlays = [p for p in (clean_report, mdm, stitch_json, graph_json) if p]
    plans = [x for x in map(existing_sidecar, paths) if x is not None]
    check_outputs([(out, (".html", ".htm"))], [*paths, *overlays, *plans])
    # as every job over several files: one that cannot be read is an error line, the page
    # shows the others, and the status says not all were shown
    kept, motions, bad = load_readable(paths, lenient, show=len(paths) > 1)
    if not kept:
        raise CLIError(bad[0] if len(bad) == 1 else "no FILE could be read:\n" + "\n".join(bad))
    for why in bad:
        click.echo(f"mocapkit: error: left out of the page: {why}", err=True)
    for p, m in zip(kept, motions, strict=True):
        warn_if_up_disagrees(m, up, p)
    with naming(*kept), all_or_nothing():
        data = view_data(
            kept, clean_report, mdm, stitch_json, graph_json, lenient, up, units, motions
        )
        page = write_page_data(out, data)
    # which sidecars the page drew (newcomer: nothing said that the filled frames are marked)
    drawn = [existing_sidecar(kept[i]) for i in sidecars_drawn(data)]
    names = [x.name for x in drawn if x is not None]
    verb = "names" if len(names) == 1 else "name"
    marks = f"; it marks what {', '.join(names)} {verb}" if names else ""
    click.echo(f"wrote {page} ({page.stat().st_size / 1e6:.1f} MB{marks})")
    if open_page:
        webbrowser.open(page.resolve().as_uri())
    if bad:
        raise click.exceptions.Exit(2)


# ------------------------------------------------------------------------------------ demo
def view_demo_step(out: Path) -> None:
    """A viewer page for each example the earlier demo steps wrote (missing ones skipped)."""
    examples: list[tuple[str, list[str], dict[str, str]]] = [
        ("view_humanoid_walk.html", ["humanoid_walk.bvh"], {}),
        (
            "view_cleaning.html",
            ["humanoid_walk_corrupted.bvh", "humanoid_walk_repaired.bvh"],
            {"clean_report": "humanoid_walk_clean_report.json", "mdm": "humanoid_walk_mdm.npy"},
        ),
        (
            "view_stitch.html",
            ["stitch_walk_idle.bvh"],
            {"stitch": "stitch_walk_idle.json"},
        ),
        ("view_graph.html", ["graph_random_walk.bvh"], {"graph": "humanoid_graph.json"}),
        ("view_inbetween.html", ["inbetween_walk.bvh"], {}),  # its sidecar marks the gap
    ]
    wrote = 0
    for name, files, overlays in examples:
        missing = [f for f in files if not (out / f).exists()]
        if missing:
            click.echo(f"  skipped {name}: {', '.join(missing)} not in {out}")
            continue
        kw = {k: str(out / v) for k, v in overlays.items() if (out / v).exists()}
        lost = sorted(set(overlays) - set(kw))
        try:
            page = view_files([str(out / f) for f in files], out / name, **kw)
        except (CLIError, ValueError, OSError) as e:
            click.echo(f"  skipped {name}: {getattr(e, 'message', e)}")
            continue
        note = f" (without {', '.join(lost)}: not found)" if lost else ""
        click.echo(f"  wrote {page}{note}")
        wrote += 1
    click.echo(f"  {wrote} viewer page(s); open them in any web browser (they work offline)")


DEMO_STEPS.append((90, "viewer: an offline HTML page for each example", view_demo_step))
