"""Library cleaning: every take of a folder cleaned against its related takes with
:func:`mocapkit.clean.run` (the function ``mocapkit clean`` calls for one take), one report per
take, and a library summary (``summary.json``: every take's flagged segments as the take's
report has them; ``overview.html``: takes ranked by flagged seconds with their worst joints and
a timeline each).

    from mocapkit.batch import Runner, clean_library
    with Runner(workers=4) as runner:
        res = clean_library("lib/", "fixed/", "reports/", runner=runner)
    res.summary_path, res.failed

Related takes (the context) are found by ``context_by``: ``"folder"`` (the takes of the same
folder: CMU's subject folders), ``"prefix"`` (the same folder and the longest name prefix, up
to a ``_``, that at least three other takes share: Bandai's ``content_style_NNN``, or every
style of the content when a style has fewer takes) or ``"all"``; of those, the ``context_max``
nearest in name order. Outputs (repaired take, report) are written atomically; each take's
manifest entry (:mod:`mocapkit.batch.manifest`) is written after them, so a rerun skips the
takes that are complete and unchanged. A take that cannot be read or cleaned is reported in
the summary and the others go on.
"""

from __future__ import annotations

import html
import json
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mocapkit.batch.manifest import Manifest, file_sha256, input_key
from mocapkit.batch.runner import Runner
from mocapkit.io import files_under
from mocapkit.summary import nominal_fps
from mocapkit.viz.reasons import REASON_TEXT, reason_colour

__all__ = [
    "CONTEXT_BY",
    "LibraryClean",
    "LibraryCleanConfig",
    "TakeTask",
    "clean_library",
    "clean_take",
    "context_of",
    "find_takes",
]

CONTEXT_BY = ("folder", "prefix", "all")
TAKE_SUFFIXES = (".bvh", ".npz", ".amc", ".glb", ".gltf")
#: report fields that change from run to run (wall time): left out of the written reports so
#: that a job's outputs are the same bytes wherever it runs
VOLATILE_REPORT_KEYS = ("analysis_seconds",)


@dataclass(frozen=True)
class LibraryCleanConfig:
    """The settings of a library clean (all of them go into each take's manifest key).

    Attributes:
        context_by: how related takes are found: "folder", "prefix" or "all".
        context_max: at most this many related takes per take (the nearest in name order).
        threshold, two_stage: :func:`mocapkit.clean.run`'s (None: its default threshold).
        lenient: read takes with the safe repairs of ``--lenient``.
    """

    context_by: str = "prefix"
    context_max: int = 8
    threshold: float | None = None
    two_stage: bool = False
    lenient: bool = False

    def __post_init__(self) -> None:
        if self.context_by not in CONTEXT_BY:
            raise ValueError(
                f"--context-by must be one of {', '.join(CONTEXT_BY)}, got {self.context_by!r}"
            )
        if self.context_max < 0:
            raise ValueError(f"--context-max must be >= 0, got {self.context_max}")

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def find_takes(library: str | Path) -> list[str]:
    """The takes of a library folder (its motion files, sub-folders included), as POSIX paths
    relative to it, sorted. Hidden files and folders are skipped."""
    root = Path(library)
    if not root.is_dir():
        raise ValueError(f"{root}: not a folder (library clean takes a folder of takes)")
    out = [p.relative_to(root).as_posix() for p in files_under(root, TAKE_SUFFIXES)]
    if not out:
        raise ValueError(
            f"{root}: no {'/'.join(TAKE_SUFFIXES)} files in this folder or its sub-folders"
        )
    return sorted(out)


MIN_RELATED = 3
"""``"prefix"`` widens a take's group until it holds this many other takes: the small-scale
context of the cleaning paper's evaluation (and ``bench/eval_clean.py``) is three takes."""


def _stem(rel: str) -> str:
    return rel.rpartition("/")[2].rsplit(".", 1)[0]


def _related(rel: str, groups: dict[str, list[str]], folder: list[str]) -> list[str]:
    """The takes of ``rel``'s folder (``folder``, ``rel`` among them) that share the longest
    name prefix (up to a ``_``, or the whole name) with it held by at least
    :data:`MIN_RELATED` others: Bandai's ``content_style_NNN`` first (the same content and
    style), then ``content`` (every style of it) when a style has one or two takes; the whole
    folder when no prefix gathers enough. ``groups``: :func:`_prefix_groups` of the folder."""
    parts = _stem(rel).split("_")
    for k in range(len(parts), 0, -1):
        members = groups.get("_".join(parts[:k]), [])
        if len(members) - 1 >= MIN_RELATED:
            return members
    return folder


def _prefix_groups(folder: Sequence[str]) -> dict[str, list[str]]:
    """Every name prefix up to a ``_`` (and every whole name) of the takes of one folder, with
    the takes that have it, in name order: one pass, not a scan of the folder per take."""
    groups: dict[str, list[str]] = {}
    for t in folder:
        parts = _stem(t).split("_")
        for k in range(1, len(parts) + 1):
            groups.setdefault("_".join(parts[:k]), []).append(t)
    return groups


def context_of(takes: Sequence[str], by: str, max_takes: int) -> dict[str, list[str]]:
    """Each take's context: the other takes related to it (``by``: its folder, the takes of its
    folder with the same name prefix (:func:`_related`), or all), the ``max_takes`` nearest to
    it in name order (ties: the earlier), listed in name order."""
    folders: dict[str, list[str]] = {}
    for t in sorted(takes):
        folders.setdefault("" if by == "all" else t.rpartition("/")[0], []).append(t)
    out: dict[str, list[str]] = {}
    for members in folders.values():
        groups = _prefix_groups(members) if by == "prefix" else {}
        for t in members:
            group = _related(t, groups, members) if by == "prefix" else members
            k = group.index(t)
            others = sorted(
                (i for i in range(len(group)) if i != k), key=lambda i: (abs(i - k), i)
            )[:max_takes]
            out[t] = [group[i] for i in sorted(others)]
    return out


@dataclass(frozen=True)
class TakeTask:
    """One take's work, as sent to a worker (paths as given to the job)."""

    name: str
    source: str
    context: tuple[str, ...]
    context_paths: tuple[str, ...]
    output: str
    report: str
    config: dict[str, Any] = field(hash=False)
    key: str = ""
    manifest_root: str = ""
    output_name: str = ""
    report_name: str = ""


def _error_line(name: str, e: BaseException) -> str:
    msg = str(e.args[0]) if isinstance(e, KeyError) and e.args else str(e)
    msg = " ".join(msg.split()) or type(e).__name__
    return msg if name in msg else f"{name}: {msg}"


def _record(report: Any, task: TakeTask) -> dict[str, Any]:
    """A take's line in the summary: its flagged segments as its report has them, flagged
    seconds (frames with any joint flagged), the worst joints and the flagged spans."""
    import numpy as np

    from mocapkit.core.runs import true_runs

    js = report.to_json()
    fps = float(report.fps)
    mask = np.asarray(report.mask, dtype=bool)
    any_f = mask.any(axis=1) if mask.size else np.zeros(report.frames, dtype=bool)
    per_joint = mask.sum(axis=0) if mask.size else np.zeros(0)
    worst = [
        {"joint": report.joints[j], "flagged_seconds": round(float(per_joint[j]) / fps, 4)}
        for j in sorted(np.flatnonzero(per_joint).tolist(), key=lambda j: (-per_joint[j], j))[:5]
    ]
    segments = js.get("segments", [])
    reasons: dict[str, int] = {}
    for seg in segments:
        for r in seg.get("reasons", ()):
            reasons[r] = reasons.get(r, 0) + 1
    return {
        "take": task.name,
        "frames": int(report.frames),
        "fps": nominal_fps(1.0 / fps),  # 30, as info and the take's report give it
        "seconds": round(report.frames / fps, 4),
        "flagged_seconds": round(float(any_f.sum()) / fps, 4),
        "flagged_cells": int(js.get("flagged_cells", int(mask.sum()))),
        "repaired_cells": js.get("repaired_cells"),
        "worst_joints": worst,
        # start:stop, stop excluded (the CLI's one range syntax, as segments' "stop")
        "flagged_spans": [[int(a), int(b) + 1] for a, b in true_runs(any_f)],
        "reasons": dict(sorted(reasons.items(), key=lambda kv: (-kv[1], kv[0]))),
        "segments": segments,
        "context": list(task.context),
        "report": task.report_name,
        "output": task.output_name or None,
    }


def clean_take(task: TakeTask) -> dict[str, Any]:
    """Clean one take (on whichever process runs it): read it and its context, run
    :func:`mocapkit.clean.run`, write the repaired take and its report atomically, then its
    manifest entry. Returns its summary record, or ``{"take", "error"}`` (one line) when the
    take cannot be read or cleaned. A context take that cannot be read is left out and named
    in ``context_skipped`` (in its record and its report). Its report carries ``warnings``:
    what reading, cleaning and writing it warned (a repaired row, a unit a BVH file cannot
    state), as a single take's report does, not what reading its context warned (the context
    takes' own reports carry that); all of them go on to the command. Collected per thread
    (:func:`mocapkit.core.thread_warnings.collected_warnings`): a worker may clean several
    takes at once."""
    from mocapkit.core.thread_warnings import collected_warnings

    with collected_warnings() as caught:
        return _clean_take(task, caught)


def _clean_take(task: TakeTask, caught: list[warnings.WarningMessage]) -> dict[str, Any]:
    from mocapkit import clean
    from mocapkit.core.thread_warnings import collected_warnings
    from mocapkit.io import MocapFileError, read_motion, write_motion
    from mocapkit.io.atomic import atomic_write_text
    from mocapkit.io.errors import warning_lines
    from mocapkit.jsonio import to_json_text

    cfg = task.config
    errors = (MocapFileError, ValueError, KeyError, OSError, IndexError, FloatingPointError)
    try:
        motion = read_motion(task.source, lenient=cfg["lenient"])
        context, names, skipped = [], [], []
        # what reading the context takes warns is theirs (their own reports carry it): passed
        # on to the command, left out of this take's report
        with collected_warnings() as theirs:
            for name, path in zip(task.context, task.context_paths, strict=True):
                try:
                    m = read_motion(path, lenient=cfg["lenient"])
                    if m.skeleton.names != motion.skeleton.names:
                        raise ValueError(f"{name}: a different skeleton from {task.name}")
                    context.append(m)
                    names.append(name)
                except errors as e:
                    skipped.append(_error_line(name, e))
        ids = {id(w) for w in theirs}
        caught[:] = [w for w in caught if id(w) not in ids]
        kwargs: dict[str, Any] = {"two_stage": cfg["two_stage"]}
        if cfg.get("threshold") is not None:
            kwargs["threshold"] = cfg["threshold"]
        report = clean.run(
            motion,
            context,
            source=task.name,
            context_names=names,
            output=task.output_name or None,
            **kwargs,
        )
        js = {k: v for k, v in report.to_json().items() if k not in VOLATILE_REPORT_KEYS}
        if task.output:  # no out_dir: the reports alone
            write_motion(report.motion, task.output)
        js["warnings"] = warning_lines(caught)
        js["context_skipped"] = skipped  # context takes it could not use (newcomer: say so)
        atomic_write_text(task.report, to_json_text(js) + "\n")
        record = _record(report, task)
        record["context"] = names
        if skipped:
            record["context_skipped"] = skipped
        outputs = [p for p in (task.output, task.report) if p]
    except errors as e:
        # no manifest entry: a failed take is tried again by the next run (its cause may lie
        # outside its file: an ASF put beside it, a worker that could not see the folder)
        return {"take": task.name, "error": _error_line(task.name, e)}
    if task.manifest_root:
        Manifest(Path(task.manifest_root)).record(task.name, task.key, outputs, record)
    return record


@dataclass(frozen=True)
class LibraryClean:
    """A library clean's outcome: every take's record (name order), the summary files, and
    how many takes were cleaned now and how many skipped as complete (``resumed``); the takes
    that failed are neither (a failed take is tried again by every run)."""

    records: tuple[dict[str, Any], ...]
    summary_path: Path
    overview_path: Path
    cleaned: int
    resumed: int

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.records if "error" in r]

    def to_json(self) -> dict[str, Any]:
        return {
            "takes": len(self.records),
            "cleaned": self.cleaned,
            "resumed": self.resumed,
            "failed": len(self.failed),
            "summary": str(self.summary_path),
            "overview": str(self.overview_path),
        }


def _inside(p: Path, root: Path) -> bool:
    try:
        p.resolve().relative_to(root.resolve())
        return True
    except ValueError:
        return False


def _with_suffix(rel: str, suffix: str) -> str:
    return rel.rsplit(".", 1)[0] + suffix


def clean_library(
    library: str | Path,
    out_dir: str | Path | None,
    report_dir: str | Path,
    config: LibraryCleanConfig | None = None,
    *,
    runner: Runner | None = None,
    progress: Callable[[int, int], None] | None = None,
    on_take: Callable[[dict[str, Any]], None] | None = None,
) -> LibraryClean:
    """Clean every take of ``library`` (see the module docstring): the repaired takes go to
    ``out_dir/<take>.bvh`` (None: no repaired takes, the reports alone), the reports to
    ``report_dir/takes/<take>.json`` (in reports and summary these are named relative to
    ``out_dir`` and ``report_dir``), the summary to
    ``report_dir/summary.json`` and ``report_dir/overview.html``. ``runner`` says where the
    takes are cleaned (default: in this process); ``progress(done, total)`` counts the takes
    to clean; ``on_take(record)`` is called with every take's record in name order."""
    from mocapkit.io.atomic import atomic_write_text, remove_stale_temporaries
    from mocapkit.jsonio import to_json_text

    config = config or LibraryCleanConfig()
    lib, rep = Path(library), Path(report_dir)
    out = None if out_dir is None else Path(out_dir)
    takes = find_takes(lib)
    for name, d in (("--out-dir", out), ("--report-dir", rep)):
        if d is not None and _inside(d, lib):
            raise ValueError(
                f"{d}: {name} is inside the library {lib}; its files would be read as takes "
                "by the next run (choose a folder outside it)"
            )
    hashes: dict[str, str] = {}
    for t in takes:
        try:
            hashes[t] = file_sha256(lib / t)
        except OSError as e:
            hashes[t] = f"unreadable: {e.strerror}"
    ctx = context_of(takes, config.context_by, config.context_max)
    # whether repaired takes are written is part of what a take's entry vouches for
    cfg = {**config.to_json(), "repaired_takes": out is not None}
    manifest = Manifest(rep)
    records: dict[str, dict[str, Any]] = {}
    tasks: list[TakeTask] = []
    owner: dict[str, str] = {}  # output name (no suffix) -> the take that writes it
    for t in takes:
        stem = _with_suffix(t, "")
        if stem in owner:  # 03_02.amc and 03_02.bvh: one would overwrite the other's outputs
            records[t] = {
                "take": t,
                "error": f"{t}: its repaired take and report would be those of {owner[stem]} "
                f"({_with_suffix(t, '.bvh')}, takes/{_with_suffix(t, '.json')}); rename one "
                "of them",
            }
            continue
        owner[stem] = t
        key = input_key(t, hashes[t], [(c, hashes[c]) for c in ctx[t]], cfg)
        entry = manifest.is_complete(t, key)
        result = None if entry is None else entry.get("result")
        if result is not None and "error" not in result:  # an older run recorded failures
            records[t] = result
            continue
        tasks.append(
            TakeTask(
                t, str(lib / t), tuple(ctx[t]), tuple(str(lib / c) for c in ctx[t]),
                "" if out is None else str(out / _with_suffix(t, ".bvh")),
                str(rep / "takes" / _with_suffix(t, ".json")), cfg, key, str(rep),
                "" if out is None else _with_suffix(t, ".bvh"), "takes/" + _with_suffix(t, ".json"),
            )
        )  # fmt: skip
    runner = runner or Runner()
    fresh = runner.imap(clean_take, tasks, progress=progress, name="clean-take")
    todo = {t.name for t in tasks}
    for t in takes:
        if t in todo:
            records[t] = next(fresh)
        if on_take is not None:
            on_take(records[t])
    # a worker killed mid-write leaves a temporary file; its task was rerun elsewhere
    remove_stale_temporaries(
        [p for t in tasks for p in (t.output, t.report, manifest.entry_path(t.name)) if p]
    )
    ordered = tuple(records[t] for t in takes)
    summary = library_summary(lib, config, ordered)
    summary_path = atomic_write_text(rep / "summary.json", to_json_text(summary) + "\n")
    overview_path = atomic_write_text(rep / "overview.html", overview_html(summary))
    ok = [t for t in takes if "error" not in records[t]]
    cleaned = sum(1 for t in ok if t in todo)
    return LibraryClean(ordered, summary_path, overview_path, cleaned, len(ok) - cleaned)


def library_summary(
    library: Path, config: LibraryCleanConfig, records: Sequence[dict[str, Any]]
) -> dict[str, Any]:
    """The library summary (``summary.json``): settings, totals, the ranking by flagged
    seconds (then name), the failed takes and every take's record. No timings: the same
    library and settings give the same bytes wherever and however often the job runs."""
    ok = [r for r in records if "error" not in r]
    ranked = sorted(ok, key=lambda r: (-r["flagged_seconds"], r["take"]))
    from mocapkit.clean import THRESHOLD

    shown = config.to_json()
    if shown["threshold"] is None:  # the default, said as the value it is
        shown["threshold"] = THRESHOLD
    return {
        "library": str(library),
        "config": shown,
        "takes": len(records),
        "failed": len(records) - len(ok),
        "flagged_takes": sum(1 for r in ok if r["flagged_seconds"] > 0),
        "seconds": round(sum(r["seconds"] for r in ok), 4),
        "flagged_seconds": round(sum(r["flagged_seconds"] for r in ok), 4),
        "ranking": [r["take"] for r in ranked],
        "errors": [{"take": r["take"], "error": r["error"]} for r in records if "error" in r],
        "records": list(records),
    }


def _first_reason(segment: dict[str, Any]) -> str:
    reasons = segment.get("reasons") or ["flagged"]
    return str(reasons[0])


def _timeline_svg(r: dict[str, Any], seen: list[str], width: int = 400, row: int = 12) -> str:
    """A take's timeline: one row for the whole body (frames with any joint flagged, dark),
    then one per worst joint (its segments, coloured by their first reason), time left to
    right; ``seen``: the reasons without a colour of their own met so far."""
    frames = max(int(r["frames"]), 1)
    joints = [w["joint"] for w in r["worst_joints"][:4]]
    rows = [("any joint", [(a, b, "") for a, b in r["flagged_spans"]])]
    for j in joints:
        rows.append(
            (j, [(s["start"], s["stop"], _first_reason(s)) for s in r["segments"]
                 if s.get("joint") == j])
        )  # fmt: skip
    label = 130
    h = row * len(rows) + 2
    parts = [f'<svg width="{label + width}" height="{h}" role="img">']
    for k, (name, spans) in enumerate(rows):
        y = 1 + k * row
        parts.append(
            f'<text x="{label - 4}" y="{y + row - 2}" text-anchor="end">{html.escape(name)}</text>'
            f'<rect x="{label}" y="{y}" width="{width}" height="{row - 2}" fill="#e8e8e8"/>'
        )
        for a, b, why in spans:  # frames a:b, b excluded
            x = label + width * a / frames
            w = max(1.0, width * (b - a) / frames)
            fill = reason_colour(why, seen) if why else "#333"
            tip = f"<title>{html.escape(why)}</title>" if why else ""
            parts.append(
                f'<rect x="{x:.1f}" y="{y}" width="{w:.1f}" height="{row - 2}" '
                f'fill="{fill}">{tip}</rect>'
            )
    parts.append("</svg>")
    return "".join(parts)


def overview_html(summary: dict[str, Any]) -> str:
    """The page a mocap lead reads at a glance: totals, the takes that failed, then every take
    ranked by flagged seconds with its worst joints and timeline (links to its report)."""
    by_name = {r["take"]: r for r in summary["records"]}
    esc = html.escape
    out = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<title>mocapkit clean: {esc(summary['library'])}</title>",
        "<style>body{font:13px sans-serif;margin:1.5em}table{border-collapse:collapse}"
        "td,th{padding:3px 8px;border-bottom:1px solid #ddd;text-align:left;vertical-align:top}"
        "svg text{font:10px sans-serif;fill:#333}.nw{white-space:nowrap}.err{color:#b00}"
        "</style></head><body>",
        f"<h1>Library clean: {esc(summary['library'])}</h1>",
        f"<p>{summary['takes']} takes, {summary['seconds']:.1f} s; "
        f"{summary['flagged_takes']} with flagged frames, {summary['flagged_seconds']:.1f} s "
        f"flagged in all; {summary['failed']} failed. Context: "
        f"{esc(summary['config']['context_by'])}, at most {summary['config']['context_max']} "
        "takes.</p>",
    ]
    if summary["errors"]:
        out.append("<h2>Takes that could not be cleaned</h2><ul>")
        out += [f"<li class='err'>{esc(e['error'])}</li>" for e in summary["errors"]]
        out.append("</ul>")
    seen: list[str] = []
    rows = []
    counts: dict[str, int] = {}
    for n, name in enumerate(summary["ranking"], 1):
        r = by_name[name]
        worst = ", ".join(
            f"{esc(w['joint'])} {w['flagged_seconds']:.2f}" for w in r["worst_joints"]
        )
        why = r.get("reasons", {})
        for k, v in why.items():
            counts[k] = counts.get(k, 0) + v
        reasons = "<br>".join(
            f"<span style='color:{reason_colour(k, seen)}'>&#9632;</span> {esc(k)} &times;{v}"
            for k, v in why.items()
        )
        rows.append(
            f"<tr><td>{n}</td><td><a href='{esc(_report_link(r, summary))}'>{esc(name)}</a></td>"
            f"<td class='nw'>{r['flagged_seconds']:.2f} s of {r['seconds']:.2f} s</td>"
            f"<td>{worst or '-'}</td><td class='nw'>{reasons or '-'}</td>"
            f"<td>{_timeline_svg(r, seen)}</td></tr>"
        )
    if counts:
        out.append("<h2>Why frames were flagged</h2><ul>")
        out += [
            f"<li><span style='color:{reason_colour(k, seen)}'>&#9632;</span> <b>{esc(k)}</b> "
            f"({v} segment{'s' if v != 1 else ''}): {esc(REASON_TEXT.get(k, k))}</li>"
            for k, v in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))
        ]
        out.append("</ul>")
    out.append(
        "<h2>Takes by flagged seconds</h2><table><tr><th>#</th><th>take</th><th>flagged</th>"
        "<th>worst joints (s)</th><th>reasons (segments)</th>"
        "<th>timeline (whole take, start to end)</th></tr>"
    )
    out += rows
    out.append("</table></body></html>\n")
    return "\n".join(out)


def _report_link(r: dict[str, Any], summary: dict[str, Any]) -> str:
    return str(r.get("report") or "takes/" + _with_suffix(r["take"], ".json"))


def read_summary(report_dir: str | Path) -> dict[str, Any]:
    """A library clean's ``summary.json``."""
    return json.loads((Path(report_dir) / "summary.json").read_text())
