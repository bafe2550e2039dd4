"""``mocapkit inbetween``: fill a gap of a clip with motion found in a library (registered on
import; see mocapkit.cli)."""

from __future__ import annotations

from pathlib import Path

import click

from mocapkit.cli.common import (
    LENIENT,
    MOTION_SUFFIXES,
    CLIError,
    JsonFile,
    check_input_file,
    data_output,
    echo_json,
    expand_library,
    friendly_errors,
    load,
    load_readable,
    main,
    naming,
    one_line,
    report_lines,
    up_option,
    warn_if_up_disagrees,
    warnings_so_far,
    write_json,
)
from mocapkit.cli.demo import DEMO_STEPS
from mocapkit.core.ranges import RangeError, RangeSpec
from mocapkit.io import WRITABLE, write_motion
from mocapkit.io.atomic import all_or_nothing, check_outputs, same_file
from mocapkit.provenance import Provenance, find_provenance, weighing_takes, whole_percent
from mocapkit.stitch.inbetween import (
    DEFAULT_CONFIG,
    KALMAN_FILLED,
    METHODS,
    kalman_max_frames,
)
from mocapkit.stitch.search import check_same_skeleton


@main.command("inbetween")
@click.argument("clip")
@click.option(
    "--gap",
    "gaps",
    required=True,
    multiple=True,
    help="Frames to replace: A:B for frames A..B-1 (B excluded), or 1.5s:2.5s in seconds; "
    "the frames before A and from B on are the context. :B and A: reach the clip's start "
    "and end. One gap per run.",
)
@click.option(
    "--library",
    "library",
    multiple=True,
    metavar="LIB",
    help="Library motion files or folders (their .bvh, .npz, .amc, .glb and .gltf files, "
    "sub-folders included); repeatable. Optional: CLIP's own frames beside the gap (each "
    "stretch of at least 1 s) are searched with or without it.",
)
@click.option(
    "--method",
    type=click.Choice(METHODS),
    default="auto",
    show_default=True,
    help="auto: the library, or the Kalman transition when there is nothing to search, the "
    "library holds nothing like the motion around the gap (the fit's warning) or the library "
    f"fill's two-sided L-score is more than {DEFAULT_CONFIG.fallback_margin:g}x the Kalman "
    "transition's; "
    "library: never fall back; kalman: the Kalman transition. The Kalman transition fills "
    f"gaps of up to {DEFAULT_CONFIG.kalman_max_seconds:g} s (it carries the motion's "
    "accelerations across the gap, and strays from the ground over a longer one).",
)
@up_option()
@click.option(
    "--out", "out_path", required=True, type=click.Path(dir_okay=False), help="Output motion."
)
@click.option(
    "--json",
    "json_path",
    type=JsonFile(),
    help="Write the result (-: print it, and the other lines go to standard error; a failure, "
    'a mistyped option too, prints {"error": LINE} there; a failed run writes no file).',
)
@LENIENT
@friendly_errors
def inbetween_cmd(
    clip: str,
    gaps: tuple[str, ...],
    library: tuple[str, ...],
    method: str,
    up: str | None,
    out_path: str,
    json_path: str | None,
    lenient: bool,
) -> None:
    """Replace frames A:B of CLIP (B excluded) by motion found in a library of clips, and in
    CLIP itself beside the gap.

    \b
    What it needs:
      - 3 frames of CLIP before the gap and 1 after it; or a gap at CLIP's start (:B, 3
        frames after it) or end (A:, 3 before it), filled from its one side, free at the
        other end.
      - a library (--library), or at least 1 s of CLIP before or after the gap: CLIP's own
        steps (its person's, style's and gait's) are searched with or without a library.
      - the same skeleton in CLIP and every library file (.bvh, .npz, .glb, .gltf, or CMU
        .amc with its subject's .asf beside it). One gap per run: run again on OUT for the
        next one.

    \b
    What it does:
      1. Search: every segment of every library clip (also played backwards) and of CLIP
         beside the gap, of the gap's length and of nearby lengths time-warped to fit
         (x0.8 to x1.25), is scored by how well its body-local poses match the two frames
         before the gap and the first after it, how its pelvis rises and falls with the
         steps just before the gap, and how it travels over the ground across the gap.
      2. Fit: the twelve best (fewer where the library holds fewer that do not overlap)
         are each moved over the ground onto both ends and their pose differences blended
         away, so each meets the context exactly; they are combined, the better-scored
         counting more (a segment scoring s weighs
         exp(-(s - best) / (best + 1))), the weights corrected so that what the segments
         share in missing the clip (all a little ahead in their step, say) is not carried
         into the fill (some weights are then negative). A gap over 1.5 s gets the best
         segment alone (combined segments drift out of step over a few strides), and so
         does a standing CLIP's gap (pelvis under 0.25 m/s) whose combination keeps under
         70% of the segments' own motion (a gesture's strokes out of step cancel: a wave
         would stand still).
         Where CLIP travels (pelvis 0.25 m/s or more) and the gap is 0.25 s or longer, 30%
         of the fill's pose carries on CLIP's own gait: its frames before the gap, mirrored
         every half gait cycle (read from the frame after the gap); less where the best
         segment arrives at that frame closer. The segments keep the path and planted feet.
      3. Feet: the legs are fitted by IK, planted feet held and raised onto CLIP's floor
         (the height at which CLIP's own frames plant them), swinging feet no lower than
         the segments lifted them, and no foot through the floor (as fast as the legs may
         turn, 360 deg/s: near the gap's ends a fill from an unlike library can leave a
         foot low).
      4. Fallback (--method auto): a gap of up to 0.3 s goes to stitching's Kalman
         transition instead, and the command says so, when the library fill's two-sided
         L-score (smoothness at both junctions, lower is better) is over 4x the Kalman
         transition's, or when nothing in the library is like the motion around the gap.

    \b
    What it tells you:
      - the best-scoring segment (file, frames, speed, how far its poses and path were off),
        the takes the fill was combined from and their shares, the share of CLIP's own gait
        carried on and its half cycle, and the L-scores of the
        filled frames and of the frames they replaced (about equal: as smooth at the
        junctions as the capture was).
      - a warning when the library holds nothing like the motion around the gap: the best
        segment's path over the ground off by more than 0.5 m (0.35 m per second of a gap
        over 1.4 s), or its poses beside the gap by more than 12 cm RMS per joint.
      - a warning, measured on the frames written, when a foot goes over 2 cm below CLIP's
        floor, or a foot slides near the floor over 2x as fast as either does in any stretch of
        CLIP's own frames of the gap's length.
      - OUT's provenance sidecar names the files searched, and the segments used: file,
        frames, speed, weight (mocapkit view OUT marks them). A CLIP filled before keeps
        its earlier fills marked, and they are not searched as its own, nor are its
        dropouts (a joint holding its value bit for bit for 1/3 s). --json writes the
        same, with the scores and every warning.
      - rows of a BVH CLIP holding NaN (a solver's dropout) are read when the gap covers
        them (said on standard error); elsewhere they need --lenient, which fills them from
        their neighbours and does not search them.
      - a library file that cannot be read, or has another skeleton, gets one error line
        and is left out; the gap is filled from the others (from CLIP's own frames if none
        is left), and the exit status is 2.

    \b
    Examples:
      mocapkit inbetween walk.bvh --gap 60:90 --library lib/ --out walk_filled.bvh
      mocapkit inbetween walk.bvh --gap 2.0s:3.0s --library a.bvh --library b.bvh --out o.bvh
      mocapkit inbetween take.bvh --gap :20 --library lib/ --out take_start_filled.bvh
      mocapkit inbetween long_take.bvh --gap 300:330 --out long_take_filled.bvh
    """
    from mocapkit.provenance import sidecar_path
    from mocapkit.stitch.inbetween import check_gap, inbetween

    say = report_lines(json_path)

    if len(gaps) > 1:  # click keeps the last of a repeated option: said, not dropped (newcomer)
        raise CLIError(
            f"--gap given {len(gaps)} times ({', '.join(gaps)}); inbetween fills one gap per "
            "run: fill one, then run again on its output for each other one (a take filled "
            "before keeps its earlier fills marked, and they are not searched)"
        )
    gap = gaps[0]
    try:
        spec = RangeSpec.parse(gap, "--gap")
    except RangeError as e:
        raise CLIError(str(e)) from None
    check_input_file(clip)
    lib_paths, unnamed = expand_library(library, MOTION_SUFFIXES)
    others = [p for p in lib_paths if not same_file(p, clip)]
    # library items given, none of them usable (the clip itself alone is not a failure: its
    # own frames beside the gap are searched anyway)
    # a library job goes on past a bad --library item, one line each (below, with the files
    # left out: where nothing fills the gap the error line names the first, not said twice)
    left_out = [f"--library: {why}" for why in unnamed]
    if len(others) < len(lib_paths):
        click.echo(
            f"mocapkit: note: {clip} is the clip: not searched as a library file (its frames "
            "beside the gap are searched anyway)",
            err=True,
        )
        lib_paths = others
    check_outputs(
        [(out_path, WRITABLE), sidecar_path(out_path), data_output(json_path, "result", ".json")],
        [clip, *lib_paths],
    )
    q, nan_frames, strict = _load_clip(clip, lenient)
    warn_if_up_disagrees(q, up, clip)
    with naming(clip):
        try:  # the take's bound is the gap's own rule (check_gap), said in full
            a, b = spec.frames(q.fps, q.num_frames if spec.stop is None else None)
            check_gap(gap, q.num_frames, clip, q.fps)
        except RangeError as e:
            raise CLIError(f"{clip}: {e}") from None
    if nan_frames and strict is not None:
        spans = ", ".join(f"{x}:{y}" for x, y in nan_frames)
        if any(x < a or y > b for x, y in nan_frames):
            raise CLIError(
                f"{one_line(strict)}; the frames holding such values ({spans}) are not all in "
                f"the gap {a}:{b}, which would replace them"
            )
        click.echo(f"mocapkit: note: {clip}: frames {spans} hold NaN or infinite values; "
                   f"the gap {a}:{b} replaces them", err=True)  # fmt: skip
    if method == "kalman" and (lib_paths or left_out):  # nothing is searched: not read either
        click.echo("mocapkit: note: --method kalman: the library is not searched", err=True)
        lib_paths, left_out, unnamed = [], [], []
    # as every library job: a file that cannot be read, or has another skeleton, is left out
    # (one error line each, exit status 2 at the end) and the others go on
    lib_paths, lib, skipped = load_readable(lib_paths, lenient)
    kept = []
    for p, m in zip(lib_paths, lib, strict=True):
        try:
            check_same_skeleton(m, q, str(p), clip)
            if m.num_frames == 0:
                raise ValueError(f"{p}: it has no frames")
            kept.append((p, m))
        except ValueError as e:
            skipped.append(one_line(e))
    # none kept: the clip's own frames beside the gap may still fill it, as with no --library
    left_out += [f"left out of the library: {why}" for why in skipped]
    none_kept = bool(left_out) and not kept and method != "kalman"

    def say_left_out(lines: list[str]) -> None:
        for line in lines:
            click.echo(f"mocapkit: error: {line}", err=True)

    if not none_kept:
        say_left_out(left_out)
    lib_paths, lib = [p for p, _ in kept], [m for _, m in kept]
    earlier = _earlier(clip, q.num_frames)
    with naming(clip, *lib_paths):
        try:  # an earlier run's fills are not the take's capture: not searched as its own
            res = inbetween(
                q, (a, b), lib, library_names=[str(p) for p in lib_paths], method=method, up=up,
                clip_name=clip, output=out_path,
                # nor are frames a lenient reading filled (NaN in the file)
                not_captured=[*(earlier.made_frames() if earlier else ()), *nan_frames],
            )  # fmt: skip
        except ValueError as e:
            if not none_kept:
                raise
            say_left_out(left_out[1:])
            more = f"; {len(left_out) - 1} more above" if len(left_out) > 1 else ""
            raise CLIError(
                f"--library: no library motion with {clip}'s skeleton could be read "
                f"({left_out[0].removeprefix('--library: ')}{more}), and {one_line(e)}"
            ) from None
    if none_kept:  # said last, where it is read: the fill owes nothing to the library asked for
        say_left_out(left_out)
        n = len(left_out)
        say_left_out([f"--library: {'its one item was' if n == 1 else f'all {n} items were'} "
                      "left out; the gap is filled from the clip's own frames alone"])  # fmt: skip
    c = res.candidate
    if c is not None and res.source_frames is not None:
        s0, s1 = res.source_frames
        ends = "after" if a == 0 else "before" if b == q.num_frames else ""
        where = f"the two frames {ends} the gap" if ends else "the gap's ends"
        path = "ground path (from its start velocity over the gap)" if ends else "ground path"
        mixed = len(res.blended_from) > 1
        weight = f", weight {whole_percent(res.blended_from[0]['weight'])}" if mixed else ""
        own = res.source == str(clip)  # the clip's frames beside the gap, not the library's
        what, mark = ("segment", " (the clip's own frames)") if own else ("library segment", "")
        say(  # the best-scoring one, whatever its share of the fill (the next line's)
            f"best-scoring {what}: {res.source}{mark} frames {s0}:{s1}"
            f"{' played backwards' if res.backwards else ''} (speed x{c.rate:g}): poses "
            f"{res.pose_rms_m * 100:.1f} cm RMS per joint off at {where}, {path} "
            f"{res.path_miss_m:.2f} m off; score {c.score:.4g}"
            f"{weight}; {res.candidates} candidates in {res.search_seconds:.2f} s"
        )
    kept = res.motion_kept
    long_gap = (b - a) * res.motion.frame_time > DEFAULT_CONFIG.average_max_seconds
    if res.method == "library" and len(res.blended_from) == 1 and long_gap and 0 < a < b < (
        res.motion.num_frames
    ):  # why one segment (newcomer: said for a standing take, not for a long gap)
        say(
            f"the best-scoring segment fills the gap alone: a gap over "
            f"{DEFAULT_CONFIG.average_max_seconds:g} s (combined segments drift out of step "
            "over a few strides)"
        )
    if len(res.blended_from) == 1 and kept == kept and kept < DEFAULT_CONFIG.average_min_motion:
        say(  # why one segment (newcomer: a wave combined out of step kept half its motion)
            f"the best-scoring segment fills the gap alone: combined, the best segments would "
            f"keep {kept:.0%} of their own motion, under {DEFAULT_CONFIG.average_min_motion:.0%} "
            "(a standing take's strokes out of step cancel)"
        )
    weighing, shown = _takes_shown(res.blended_from, 4)
    if len(res.blended_from) > 1:
        negative = sum(x["weight"] < -0.0005 for x in res.blended_from)
        main = res.largest
        say(
            f"the fill combines {len(res.blended_from)} segments of {weighing} take(s), by "
            f"take: {shown} (the weights follow how well each segment matches, corrected "
            "for what the segments share in missing the clip beside the gap"
            f"{f', {negative} of them subtracted' if negative else ''}; each segment's frames, "
            "speed and weight: --json or the sidecar, whose filled frames name the segment "
            f"weighing most, {Path(main['source']).name} frames {main['source_frames'][0]}:"
            f"{main['source_frames'][1]}{' played backwards' if main['backwards'] else ''} "
            f"({whole_percent(main['weight'])}))"
        )
    if res.gait_share > 0:  # the part of the fill that is not the segments'
        share = f"{res.gait_share:.0%}" if res.gait_share >= 0.005 else "under 1%"
        them = "segment gives" if len(res.blended_from) == 1 else "segments give"
        say(
            f"{share} of the fill's pose carries on the clip's own gait: its frames before the "
            f"gap, mirrored every half cycle (fitted: {res.gait_half_period_s:.2f} s, the one "
            f"that best carries them on to frame {b}); the {them} the rest, the ground path "
            "and the planted feet"
        )
    fit_warning = None  # said on standard error, and in the JSON's warnings
    if res.warning and res.method == "library":  # (a Kalman fill is not the library's)
        a, b = res.gap
        hint = (
            " (--method kalman fills it with the smoother's transition instead)"
            if b - a <= kalman_max_frames(res.motion) and a > 0 and b < q.num_frames
            else ""
        )
        fit_warning = f"warning: {clip}: {res.warning}{hint}"
        click.echo(f"mocapkit: {fit_warning}", err=True)
    feet_warning = None  # measured on the frames written, whatever filled them
    if res.feet_warning:
        feet_warning = f"warning: {clip}: {res.feet_warning}"
        click.echo(f"mocapkit: {feet_warning}", err=True)
    margin = DEFAULT_CONFIG.fallback_margin
    # the frames replaced, scored alike: the scale an L-score reads on (lower is smoother);
    # frames that held NaN have no score of their own (newcomer: their filling was scored)
    held_nan = any(x < b and y > a for x, y in nan_frames)
    was = (
        ", the frames replaced held NaN: no score"
        if held_nan
        else f", the frames replaced {res.replaced_lscore:.6g}"
    )
    scores = (
        f"two-sided L-score of the filled frames {res.library_lscore:.6g} from the library, "
        f"{res.kalman_lscore:.6g} from the Kalman transition{was}"
    )
    if res.method == "kalman":
        if method == "kalman":
            why = "--method kalman"
        elif res.note:
            why = res.note
        elif res.unlike:
            why = res.warning.removesuffix(KALMAN_FILLED)
        else:
            why = f"the library fill's L-score is over {margin:g}x the Kalman's: {scores}"
        tail = f": {why}" if res.unlike else f" ({why})"
        say(f"filled frames {a}:{b} with the Kalman transition{tail}")
    elif a == 0 or b == res.motion.num_frames:  # one junction, no Kalman transition to weigh
        at = b if a == 0 else a
        say(
            f"filled frames {a}:{b} from {res.source} (L-score of its junction with the clip at "
            f"frame {at}: {res.library_lscore:.6g}{was}; a gap at the clip's "
            f"{'start' if a == 0 else 'end'} is filled from its one side by the best segment, "
            f"free at the {'first' if a == 0 else 'last'} frame)"
        )
    else:
        n = len(res.blended_from)
        what = res.source if n == 1 else f"{n} segments of {weighing} take(s)"
        within = ""
        if b - a > kalman_max_frames(res.motion):  # no Kalman transition to weigh it against
            scores = f"two-sided L-score of the filled frames {res.library_lscore:.6g}{was}"
            if method == "auto":
                within = (
                    f"; a gap over {DEFAULT_CONFIG.kalman_max_seconds:g} s is not given to the "
                    "Kalman transition"
                )
        elif method == "auto":
            within = f"; the library fill is kept: its L-score is not over {margin:g}x the Kalman's"
        say(f"filled frames {a}:{b} from {what} ({scores}{within})")
    wrote = []
    with naming(clip, *lib_paths), all_or_nothing():
        write_motion(res.motion, out_path)
        side = _traced(res.provenance(out_path, {"gap_spec": gap}), clip, earlier)
        side = side.write(out_path)
        wrote.append(f"wrote {out_path} ({res.motion.num_frames} frames) and {side}")
        # what standard error will say too (the writer's: a unit BVH cannot state)
        said = [w for w in (fit_warning, feet_warning) if w]
        result = {**res.to_json(), "skipped": [*unnamed, *skipped],
                  "warnings": [*said, *warnings_so_far()]}  # fmt: skip
        if held_nan:  # a score of the frames a reading filled is not the capture's
            result["replaced_lscore"] = None
        if json_path and json_path != "-":
            write_json(json_path, result)
            wrote.append(f"wrote {json_path}")
    if json_path == "-":  # printed once the files are in place: a failure prints only its error
        echo_json(result)
        wrote.append("printed the JSON result")
    for line in wrote:
        say(line)
    if skipped or unnamed:  # the gap is filled from the others; the status says not all were
        raise click.exceptions.Exit(2)


def _load_clip(clip: str, lenient: bool):
    """``(motion, nan_frames, strict)``: the clip, read as ``lenient`` says or, where reading it
    strictly fails only on NaN or infinite values (a solver's dropout), with those frames
    filled from their neighbours; then ``nan_frames`` are their ``(start, stop)`` spans and
    ``strict`` the error a strict reading gave: the frames are fine only if the gap replaces
    them (a user fills a dropout by naming it as the gap; newcomer: that needed --lenient)."""
    import warnings

    from mocapkit.io import FilledFramesWarning, MocapFileError, NonFiniteError, RepairWarning

    strict = None
    if not lenient:
        try:
            return load(clip, False), [], None
        except NonFiniteError as e:
            strict = e
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        try:
            q = load(clip, True)
        except MocapFileError:
            if strict is None:
                raise
            raise strict from None  # more than NaN is wrong: the first defect, as read
    repairs = [w.message for w in seen if issubclass(w.category, RepairWarning)]
    others = [r for r in repairs if not isinstance(r, FilledFramesWarning)]
    if strict is not None and others:  # the gap may replace the NaN rows, not the rest
        raise CLIError(
            f"{one_line(strict)}; besides such rows it needs another repair, which --lenient "
            f"makes: {one_line(others[0])}"
        )
    if lenient:  # reported as every lenient reading's repairs are
        for w in seen:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    filled = [span for r in repairs if isinstance(r, FilledFramesWarning) for span in r.frames]
    return q, filled, strict


def _earlier(clip: str, frames: int) -> Provenance | None:
    """``clip``'s own sidecar, where it has one that still describes it (its frame count), or
    None; one that cannot be read is warned about once and left out."""
    try:
        earlier = find_provenance(clip)
    except ValueError as e:
        click.echo(f"mocapkit: warning: {one_line(e)}: its history is left out", err=True)
        return None
    return earlier if earlier is not None and earlier.frames == frames else None


def _traced(plan: Provenance, clip: str, earlier: Provenance | None) -> Provenance:
    """``plan`` with the frames it kept of ``clip`` traced back through ``clip``'s own sidecar
    ``earlier`` (:func:`_earlier`): a take whose gaps are filled one run at a time keeps every
    fill in the last sidecar (newcomer report: only the newest)."""
    return plan if earlier is None else plan.through(earlier, clip)


# ------------------------------------------------------------------------------------ demo
def inbetween_demo_step(out: Path) -> None:
    """Blank out a second of the procedural walk and fill it from a small generated library."""
    from mocapkit import datasets
    from mocapkit.stitch.inbetween import inbetween

    walk = datasets.procedural_motion("walk", 5.0, seed=11).motion
    lib = [datasets.procedural_motion(k, 6.0, seed=s).motion for k, s in
           (("walk", 1), ("walk", 2), ("run", 1), ("idle", 3))]  # fmt: skip
    # the clip and the library are written too, so the sidecar names files one can open
    original = write_motion(walk, out / "inbetween_walk_original.bvh")
    names = [str(write_motion(m, out / "inbetween_library" / f"{n}.bvh")) for m, n in
             zip(lib, ("walk_s1", "walk_s2", "run_s1", "idle_s3"), strict=True)]  # fmt: skip
    bvh = out / "inbetween_walk.bvh"
    a, b = 60, 90
    res = inbetween(
        walk, (a, b), lib, library_names=names, up="Y", clip_name=str(original),
        output=str(bvh),
    )  # fmt: skip
    write_motion(res.motion, bvh)
    side = res.provenance(bvh).write(bvh)
    err = res.difference_to(walk)
    _, used = _takes_shown(res.blended_from)
    gait = f", {res.gait_share:.0%} of its pose the walk's own gait carried on"
    click.echo(
        f"  gap {a}:{b} of the walk filled by {res.method}"
        f"{f' from {len(res.blended_from)} segments of {used}' if res.blended_from else ''}"
        f"{gait if res.gait_share >= 0.005 else ''}"
        f"; largest joint difference to the blanked frames {err * 100:.1f} cm"
    )
    click.echo(
        f"  wrote {bvh}, {side.name} and the clip and library it came from (mocapkit view "
        f"{bvh} marks the filled frames)"
    )
    res.motion.check_finite("demo: the in-betweened motion")


DEMO_STEPS.append(
    (15, "in-betweening: a blanked second filled from a library", inbetween_demo_step)
)


def _takes_shown(blended, most: int | None = None) -> tuple[int, str]:
    """How many takes the segments ``blended`` (an in-betweening's ``blended_from``) come from
    (those at 0% too: newcomer, "12 segments of 2 take(s)" then listed 5), and those takes with
    their shares, largest first (the first ``most``, the rest summed), then "N more take(s) at
    0%" (:func:`mocapkit.provenance.weighing_takes`)."""
    weighing, nothing = weighing_takes(blended)
    cut = len(weighing) if most is None else most
    shown = ", ".join(f"{name} {whole_percent(share)}" for name, share in weighing[:cut])
    if len(weighing) > cut:
        rest = sum(share for _, share in weighing[cut:])
        shown += f", {len(weighing) - cut} more take(s) {whole_percent(rest)}"
    return len(weighing) + nothing, shown + (f", {nothing} more take(s) at 0%" if nothing else "")
