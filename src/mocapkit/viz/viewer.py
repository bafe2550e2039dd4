"""Build the self-contained HTML viewer page (three.js player + overlays, all inlined).

The page needs no server and no network: three.js (vendored, MIT, see ``static/README``), the
viewer script and style, and every motion's joint positions are written into one HTML file.

Positions are computed here by forward kinematics (End Sites included), turned to three.js'
Y-up frame from each motion's own detected (or given) up axis, scaled to metres by its own unit
(the file's statement, else a guess from the height, or given), and stored per motion as
uint16 quantised to the motion's bounding box (base64; < 0.2 mm error for a 10 m box).
Overlays (cleaning report + MDM, stitch result, motion graph transitions) are JSON.
"""

from __future__ import annotations

import base64
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.core.kinematics import end_site_positions, forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.provenance import Provenance, weighing_takes

__all__ = [
    "PALETTE",
    "ViewMotion",
    "build_page",
    "graph_overlay",
    "page_data",
    "sidecars_drawn",
    "to_y_up",
    "view_data",
    "view_files",
    "write_page",
    "write_page_data",
]

PALETTE = ("#4fc3f7", "#ff8a65", "#81c784", "#ba68c8", "#ffd54f", "#e57373")
"""Motion colours, in order (first motion light blue, second orange, ...)."""

_STATIC = ("three.min.js", "OrbitControls.js", "viewer.js", "viewer.css", "template.html")


@dataclass
class ViewMotion:
    """One motion to show: the motion, a label and (optional) colour."""

    motion: Motion
    name: str
    color: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    provenance: Provenance | None = None  # the sidecar of a generated motion, if any


def _static(name: str) -> str:
    return (
        resources.files("mocapkit.viz")
        .joinpath("static")
        .joinpath(name)
        .read_text(encoding="utf-8")
    )


def to_y_up(points: np.ndarray, up: str) -> np.ndarray:
    """Rotate (..., 3) points so that the axis ``up`` ("Y", "Z", "-X", ...) becomes +Y."""
    p = np.asarray(points, dtype=np.float64)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    up = up.strip().upper()
    maps = {
        "Y": (x, y, z),
        "-Y": (x, -y, -z),
        "Z": (x, z, -y),
        "-Z": (x, -z, y),
        "X": (-y, x, z),
        "-X": (y, -x, z),
    }
    if up not in maps:
        raise ValueError(f"unknown up axis {up!r}; expected X, Y, Z or their negations")
    return np.stack(maps[up], axis=-1)


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def _body_parts(m: Motion) -> tuple[int, int | None, float | None]:
    """``(pelvis, ground_root, stature in file units)`` of :func:`mocapkit.body.body_of`, or
    ``(0, None, None)`` for a skeleton it cannot read (the page then frames joint 0)."""
    from mocapkit.body import body_of

    try:
        b = body_of(m)
    except Exception:  # an unusual rig: the page still shows it, framed on joint 0
        return 0, None, None
    stature = float(b.stature) if np.isfinite(b.stature) and b.stature > 0 else None
    return int(b.pelvis), b.ground_root, stature


def _root_heading(m: Motion, gr: int, grot: np.ndarray, up: str) -> np.ndarray:
    """Per-frame heading of the ground root on the page's floor (radians about +Y, 0 = +Z):
    the root's own rotation applied to the root-local axis that best matches the body's facing
    (so the marker turns with the root and points where the body faces when they agree)."""
    from mocapkit.core.rotations import quat_apply, quat_inv
    from mocapkit.features import facing_directions

    q = grot[:, gr]
    try:
        face = facing_directions(m, up)
    except Exception:  # no facing found: heading 0 below
        face = np.zeros((m.num_frames, 3))
    a = quat_apply(quat_inv(q), face).mean(axis=0)
    if np.linalg.norm(a) > 1e-6:
        fwd = quat_apply(q, np.broadcast_to(a / np.linalg.norm(a), (*q.shape[:-1], 3)))
    else:
        fwd = face
    d = to_y_up(fwd, up)
    h = np.arctan2(d[:, 0], d[:, 2])
    return np.where(np.isfinite(h), h, 0.0)


def _motion_record(vm: ViewMotion, color: str, up: str, mpu: float) -> dict[str, Any]:
    m = vm.motion
    sk = m.skeleton
    if m.num_frames == 0:
        raise ValueError(f"{vm.name}: the motion has no frames")
    pelvis, gr, stature = _body_parts(m)
    gpos, grot = forward_kinematics(m)
    ends = end_site_positions(sk, gpos, grot)
    pos = np.concatenate([gpos, ends], axis=1) if ends.shape[1] else gpos
    pos = to_y_up(pos, up) * mpu
    bad = ~np.isfinite(pos)
    if bad.any():  # keep the page finite: a NaN joint is drawn at the origin
        pos = np.where(bad, 0.0, pos)
    lo = pos.reshape(-1, 3).min(axis=0)
    hi = pos.reshape(-1, 3).max(axis=0)
    step = np.maximum(hi - lo, 1e-9) / 65535.0
    q = np.clip(np.rint((pos - lo) / step), 0, 65535).astype("<u2")
    names = list(sk.names)
    parents = [int(p) for p in sk.parents]
    for e, p in enumerate(sk.end_site_parents):
        label = sk.end_site_names[e] if e < len(sk.end_site_names) else ""
        names.append(f"{names[int(p)]} End" + (f" ({label})" if label else ""))
        parents.append(int(p))
    body = pos if gr is None else np.delete(pos, gr, axis=1)  # the ground root is no body part
    ground = body[..., 1].min(axis=1)
    heights = body[..., 1].max(axis=1) - ground
    horiz = np.ptp(body[..., [0, 2]], axis=1).max(axis=1)
    extra: dict[str, Any] = {}
    floor = float(np.percentile(ground, 2))
    if gr is not None:  # the ground root is on the floor by definition
        floor = min(floor, float(np.percentile(pos[:, gr, 1], 2)))
        extra["rootHeading"] = _b64(_root_heading(m, gr, grot, up).astype("<f4"))
    return {
        "name": vm.name,
        "color": color,
        "frames": int(m.num_frames),
        "fps": float(m.fps),
        "numJoints": int(sk.num_joints),
        "names": names,
        "parents": parents,
        "lo": [float(v) for v in lo],
        "step": [float(v) for v in step],
        "pos": _b64(q),
        "ground": floor,
        "height": float(np.median(heights)),
        "width": float(np.median(horiz)),
        "stature": float(np.median(heights)) if stature is None else stature * mpu,
        "pelvis": pelvis,
        "groundRoot": gr,
        **extra,
        **vm.extra,
    }


def _match_motion(motions: Sequence[ViewMotion], path: str | None, frames: int | None) -> int:
    """Index of the motion an overlay belongs to: by file name, else by frame count, else 0."""
    if path:
        stem = Path(str(path)).name
        for i, vm in enumerate(motions):
            if Path(vm.name).name == stem:
                return i
        stem = Path(str(path)).stem
        for i, vm in enumerate(motions):
            if Path(vm.name).stem == stem:
                return i
    if frames is not None:
        for i, vm in enumerate(motions):
            if vm.motion.num_frames == frames:
                return i
    return 0


def clean_overlay(
    motions: Sequence[ViewMotion], report: dict[str, Any] | None, mdm: np.ndarray | None
) -> dict[str, Any] | None:
    """The cleaning overlay: MDM (frames x joints, quantised to uint8) and flagged segments."""
    if report is None and mdm is None:
        return None
    report = report or {}
    segs = list(report.get("segments") or [])
    frames = None if mdm is None else int(np.asarray(mdm).shape[0])
    if frames is None:
        frames = report.get("frames")
    idx = _match_motion(motions, report.get("input"), frames)
    m = motions[idx].motion
    names = list(m.skeleton.names)
    # a report of another take would mark joints and frames that are not this take's
    joints, n = report.get("joints"), report.get("frames")
    of = f"the clean report (of {report.get('input') or 'another take'})"
    if joints is not None and list(joints) != names:
        missing = [j for j in joints if j not in names][:3]
        raise ValueError(
            f"{of} names {len(joints)} joints, {motions[idx].name} has {len(names)}"
            + (f" (not in it: {', '.join(map(str, missing))})" if missing else "")
        )
    if n is not None and int(n) != m.num_frames:
        raise ValueError(f"{of} covers {n} frames, {motions[idx].name} has {m.num_frames}")
    out_segs = []
    for s in segs:
        j = s.get("joint_index")
        if j is None and s.get("joint") in names:
            j = names.index(s["joint"])
        if j is None:
            continue
        out_segs.append(
            {
                "joint": int(j),
                "name": s.get("joint", names[int(j)] if int(j) < len(names) else str(j)),
                "start": int(s["start"]),
                "end": int(s["end"]),
                "peak": float(s.get("peak", 1.0)),
            }
        )
    rec: dict[str, Any] = {
        "motion": idx,
        "segments": out_segs,
        "threshold": report.get("threshold"),
        "repairedCells": report.get("repaired_cells"),
    }
    if mdm is not None:
        a = np.asarray(mdm, dtype=np.float64)
        if a.ndim != 2:
            raise ValueError(f"the MDM must be a (frames, joints) array, got shape {a.shape}")
        if a.shape[1] != m.num_joints:
            raise ValueError(
                f"the MDM has {a.shape[1]} joints but {motions[idx].name} has {m.num_joints}"
            )
        a = np.clip(np.nan_to_num(a, nan=0.0), 0.0, 1.0)
        rec["frames"], rec["joints"] = int(a.shape[0]), int(a.shape[1])
        rec["mdm"] = _b64(np.rint(a * 255).astype(np.uint8))
    return rec


def _first_made_by(motions: Sequence[ViewMotion], tool: str) -> tuple[int, Provenance] | None:
    """The index and provenance sidecar of the first motion ``tool`` wrote, or None."""
    for i, vm in enumerate(motions):
        if vm.provenance is not None and vm.provenance.tool == tool:
            return i, vm.provenance
    return None


def stitch_overlay(motions: Sequence[ViewMotion], result: dict[str, Any] | None):
    """The stitch overlay: take-off, generated (injected) and landing output frames, L_k(k)."""
    if result is None:
        return None
    idx = _match_motion(motions, result.get("output"), result.get("frames"))
    gen = result.get("generated_frames")
    takeoff = int(result.get("takeoff", 0))
    k = int(result.get("k", 0))
    if not gen or len(gen) != 2:
        gen = [takeoff + 1, takeoff + 1 + k]
    landing = result.get("landing_output_frame")
    if landing is None:
        landing = int(gen[1])
    return {
        "motion": idx,
        "takeoff": takeoff,
        "generated": [int(gen[0]), int(gen[1])],
        "landing": int(landing),
        "landingData": result.get("landing"),
        "k": k,
        "lscore": result.get("lscore"),
        "lscoreByK": [float(x) for x in result.get("lscore_by_k") or []],
        "query": result.get("query"),
        "data": result.get("data"),
        "method": result.get("method"),
    }


def inbetween_overlay(motions: Sequence[ViewMotion]) -> dict[str, Any] | None:
    """The in-betweening overlay, read from the provenance sidecar ``mocapkit inbetween`` writes
    (:mod:`mocapkit.provenance`): drawn like a stitch (the filled frames yellow, the last context
    frame and the first frame after the gap marked), with the library clip and frames used;
    frames that earlier runs filled from a library on the same take (a sidecar traced through
    the take's own, :meth:`mocapkit.provenance.Provenance.through`) drawn yellow too."""
    found = _first_made_by(motions, "inbetween")
    if found is None:
        return None
    idx, plan = found
    # the newest fill (its gap, in the parameters); earlier runs' library fills are traced in
    # too, and only those are drawn as earlier fills: "generated" frames may be another tool's
    # (a stitch's injected frames, a retarget's resampled take)
    gap = plan.parameters.get("gap")
    fills = [s for s in plan.segments if s.kind in ("inbetween", "generated")]
    mid = next((s for s in fills if [s.output_start, s.output_stop] == gap), None)
    if mid is None:
        return None
    a, b = mid.output_start, mid.output_stop
    clip = plan.inputs[0] if plan.inputs else None
    before = a - 1 if a > 0 else None  # a gap at the clip's start or end: no frame there
    after = b if b < plan.frames else None
    weighing = weighing_takes(
        [x for x in plan.parameters.get("blended_from") or [] if "weight" in x]
    )
    return {
        "motion": idx,
        "sidecar": True,  # drawn from the motion's provenance sidecar
        "kind": "inbetween",
        "takeoff": before,
        "generated": [a, b],
        "landing": after,
        "landingData": after,
        "k": b - a,
        # the filled frames' two-sided L-score: the sum of the junctions' (sidecar costs; one
        # at a gap at the clip's start or end)
        "lscore": _junction_sum([t for t in plan.transitions if a <= t.output_frame <= b]),
        "lscoreByK": [],
        "query": clip,
        "data": mid.source,
        "sourceFrames": None if mid.source is None else [mid.source_start, mid.source_stop],
        "backwards": bool(plan.parameters.get("source_backwards", False)),
        "requested": plan.parameters.get("requested"),
        "blended": [
            {
                "data": x.get("source"),
                "frames": x.get("source_frames"),
                "backwards": bool(x.get("backwards")),
                "rate": x.get("rate"),
                "weight": x.get("weight"),
            }
            for x in plan.parameters.get("blended_from") or []
        ],
        # the segments' shares summed by take, largest first, and how many takes weigh
        # nothing (as the command's report)
        "takes": [{"name": name, "share": share} for name, share in weighing[0]],
        "takesAtZero": weighing[1],
        "method": plan.parameters.get("method"),
        "warning": plan.parameters.get("warning"),
        "feetWarning": plan.parameters.get("feet_warning"),  # measured on the frames written
        "motionKept": plan.parameters.get("motion_kept"),  # why one segment filled it alone
        # the share of the fill's pose that carries on the clip's own gait, and its half cycle
        "gaitShare": plan.parameters.get("gait_share"),
        "gaitHalfPeriod": plan.parameters.get("gait_half_period_s"),
        # the warning gave the gap to the Kalman transition (it is the reason, not a warning)
        "unlike": bool(plan.parameters.get("unlike")),
        "note": plan.parameters.get("note"),
        "earlier": [  # frames filled by earlier runs on the take this one filled
            {"generated": [s.output_start, s.output_stop], "data": s.source}
            for s in plan.segments
            if s.kind == "inbetween" and s is not mid
        ],
    }


def sidecar_stitch_overlay(motions: Sequence[ViewMotion]) -> dict[str, Any] | None:
    """The stitch overlay of a motion ``mocapkit stitch`` wrote, read from its provenance
    sidecar when no stitch result is given: the take-off, the generated frames and the landing
    (output frames), and the data clip's landing frame (its file's own)."""
    found = _first_made_by(motions, "stitch")
    if found is None:
        return None
    idx, plan = found
    if not plan.transitions:
        return None
    tr = plan.transitions[0]
    a = tr.output_frame  # the first generated (or blended) frame
    tail = [s for s in plan.segments if s.kind == "clip" and s.output_start >= a]
    b = tail[0].output_start if tail else a
    return {
        "motion": idx,
        "sidecar": True,
        "takeoff": a - 1,
        "generated": [a, b],
        "landing": b,
        # the data frame playing at the landing (a cross-fade's window holds the chosen one)
        "landingData": tail[0].source_start
        if tail and tail[0].source_start is not None
        else tr.target_frame,
        "k": int(plan.parameters.get("k", b - a)),
        "lscore": tr.cost,
        "lscoreByK": [],
        "query": tr.source,
        "data": tr.target,
        "method": plan.parameters.get("method"),
    }


def _junction_sum(transitions) -> float | None:
    """The sum of the transitions' costs, None unless every one has a finite cost."""
    costs = [t.cost for t in transitions]
    if not costs or any(c is None or not math.isfinite(c) for c in costs):
        return None
    return float(sum(costs))


def graph_overlay(
    motions: Sequence[ViewMotion], graph: dict[str, Any] | None = None
) -> dict[str, Any] | None:
    """The motion-graph overlay: the transitions a synthesised motion took, read from its plan
    (the provenance sidecar ``graph synth`` writes, :mod:`mocapkit.provenance`): the output frame
    where each blend starts and ends, the source and target clips and frames, and the cost.
    ``graph`` (the graph JSON, optional) only adds how many transitions the graph has."""
    found = _first_made_by(motions, "graph synth")
    if found is None:
        return None
    idx, plan = found
    names = [Path(p).name for p in plan.inputs]
    ends = {s.output_start: s.output_stop for s in plan.segments if s.kind == "transition"}
    trans = []
    for t in plan.transitions:
        src = plan.inputs.index(t.source) if t.source in plan.inputs else -1
        dst = plan.inputs.index(t.target) if t.target in plan.inputs else -1
        trans.append({
            "frame": t.output_frame, "end": ends.get(t.output_frame, t.output_frame),
            "src_clip": src, "src_frame": t.source_frame, "dst_clip": dst,
            "dst_frame": t.target_frame, "cost": t.cost,
            "src_name": Path(t.source).name, "dst_name": Path(t.target).name,
        })  # fmt: skip
    total = len(graph.get("transitions") or []) if graph else None
    return {
        "motion": idx,
        "sidecar": True,
        "clips": names,
        "missingClips": [],
        "numTransitions": total if total is not None else len(plan.transitions),
        "transitions": trans,
    }


def _scale_of(m: Motion, up: str | None, units: str | None) -> tuple[str, str, float, str]:
    """``(up axis, unit name, metres per unit, where the unit came from)`` of one motion: the
    given ``up``/``units``, else the file's statement (ASF ``:units``), else the guess."""
    from mocapkit.features import UNITS, detect_units, detect_up_axis

    up = up or detect_up_axis(m)
    if units is not None:
        return up, units, float(UNITS[units]), "given"
    name, mpu = detect_units(m)
    return up, name, float(mpu), "file" if m.skeleton.metres_per_unit is not None else "guessed"


def _shared(recs: Sequence[dict[str, Any]], key: str) -> Any:
    vals = {json.dumps(r[key]) for r in recs}
    return recs[0][key] if len(vals) == 1 else None


def page_data(
    motions: Sequence[ViewMotion],
    up: str | None = None,
    units: str | None = None,
    clean_report: dict[str, Any] | None = None,
    mdm: np.ndarray | None = None,
    stitch: dict[str, Any] | None = None,
    graph: dict[str, Any] | None = None,
    title: str | None = None,
) -> dict[str, Any]:
    """Everything the page shows, JSON-ready.

    Each motion is drawn in metres and Y up by its own file's scale and up axis (``units`` and
    ``up``, where given, apply to all): its record holds ``up``, ``units``, ``unitsSource``
    (``"file"``: stated by the file, ``"guessed"``: from the height, ``"given"``) and
    ``metresPerUnit``. The same top-level keys hold the value every motion shares, or None."""
    from mocapkit.features import UNITS

    if not motions:
        raise ValueError("nothing to view: give at least one motion")
    if units is not None and units not in UNITS:
        raise ValueError(f"unknown units {units!r}; expected one of {', '.join(UNITS)}")
    recs = []
    for i, vm in enumerate(motions):
        m_up, m_units, m_mpu, m_source = _scale_of(vm.motion, up, units)
        rec = _motion_record(vm, vm.color or PALETTE[i % len(PALETTE)], m_up, m_mpu)
        recs.append(
            {**rec, "up": m_up, "units": m_units, "unitsSource": m_source, "metresPerUnit": m_mpu}
        )
    return {
        "title": title or " vs ".join(Path(vm.name).name for vm in motions),
        # the value all motions share, else None (each motion has its own: see "motions")
        **{k: _shared(recs, k) for k in ("up", "units", "unitsSource", "metresPerUnit")},
        "motions": recs,
        "clean": clean_overlay(motions, clean_report, mdm),
        "stitch": stitch_overlay(motions, stitch)
        or inbetween_overlay(motions)
        or sidecar_stitch_overlay(motions),
        "graph": graph_overlay(motions, graph),
    }


_SCRIPT_JSON_ESCAPES = {
    ord("<"): "\\u003c",
    ord(">"): "\\u003e",
    ord("&"): "\\u0026",
    0x2028: "\\u2028",
    0x2029: "\\u2029",
}


def script_json(text: str) -> str:
    """JSON text safe to inline in a ``<script>`` element: ``<``, ``>``, ``&``, U+2028 and
    U+2029 as ``\\u`` escapes (they can only occur inside JSON strings, so the value is the
    same), so that no data (a joint named ``<!--<script>``, a path with ``</script>``) can end
    the element or change how the HTML parser reads it."""
    return text.translate(_SCRIPT_JSON_ESCAPES)


def _script(text: str) -> str:
    return text.replace("</script", "<\\/script")


def build_page(data: dict[str, Any]) -> str:
    """The HTML text of the page for :func:`page_data`'s result."""
    from mocapkit.jsonio import to_json_text

    blob = script_json(to_json_text(data, indent=None, separators=(",", ":")))
    html = _static("template.html")
    parts = {
        "{{TITLE}}": _html_escape(f"mocapkit view: {data['title']}"),
        "{{CSS}}": _static("viewer.css"),
        "{{THREE}}": _script(_static("three.min.js")),
        "{{ORBIT}}": _script(_static("OrbitControls.js")),
        "{{VIEWER}}": _script(_static("viewer.js")),
        "{{DATA}}": blob,
    }
    # substitute in one pass so that no inlined text is searched for placeholders again
    out, i = [], 0
    while True:
        j = html.find("{{", i)
        if j < 0:
            out.append(html[i:])
            break
        k = html.find("}}", j)
        key = html[j : k + 2]
        if key in parts:
            out.append(html[i:j])
            out.append(parts[key])
        else:
            out.append(html[i : k + 2])
        i = k + 2
    return "".join(out)


def _html_escape(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def sidecars_drawn(data: dict[str, Any]) -> list[int]:
    """The motions (indices into ``data["motions"]``) whose provenance sidecars the page
    draws: the first one ``inbetween`` or ``stitch`` wrote (none under a stitch result given),
    the first one ``graph synth`` wrote."""
    slots = (data.get("stitch"), data.get("graph"))
    return sorted({int(o["motion"]) for o in slots if o and o.get("sidecar")})


def write_page(path: str | Path, motions: Sequence[ViewMotion], **kwargs: Any) -> Path:
    """Write the viewer page for ``motions`` (keyword arguments: see :func:`page_data`)."""
    return write_page_data(path, page_data(motions, **kwargs))


def write_page_data(path: str | Path, data: dict[str, Any]) -> Path:
    """Write the viewer page of :func:`page_data`'s result ``data`` (atomically)."""
    from mocapkit.io.atomic import atomic_write_text

    p = Path(path)
    atomic_write_text(p, build_page(data))
    return p


OVERLAY_KEYS = {
    "stitch result": ("takeoff", "landing", "k"),
}
"""Keys an overlay file must have to be what its option says (a check, not a schema): an
in-betweening result given as a stitch result drew 'take-off 0, injected frames 1-0'."""


def read_overlay_json(path: str | Path, what: str) -> dict[str, Any]:
    """A JSON overlay file (cleaning report, stitch result, motion graph) as a dict;
    FileNotFoundError / ValueError with a one-line message naming ``what`` (also when it
    lacks the keys :data:`OVERLAY_KEYS` names for ``what``)."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FileNotFoundError(f"{what} not found: {path}") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"cannot read {what} {path}: {e}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{what} {path}: expected a JSON object")
    missing = [k for k in OVERLAY_KEYS.get(what, ()) if k not in data]
    if missing:
        hint = ""
        if "gap" in data and "blended_from" in data:
            hint = (
                " (it is an in-betweening result: `mocapkit view OUT.bvh` finds the "
                "in-betweened file's sidecar)"
            )
        raise ValueError(f"{path}: not a {what} (no {', '.join(missing)}){hint}")
    return data


def read_mdm(path: str | Path) -> np.ndarray:
    """An MDM ``.npy`` file (``mocapkit clean --mdm``)."""
    try:
        return np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise FileNotFoundError(f"MDM not found: {path}") from None
    except (OSError, ValueError) as e:
        raise ValueError(f"cannot read the MDM {path}: {e}") from None


def view_files(files: Sequence[str | Path], out: str | Path, *args: Any, **kwargs: Any) -> Path:
    """Read the motion files and the overlay files (arguments after ``out``: see
    :func:`view_data`) and write the viewer page (what ``mocapkit view`` does); returns its
    path."""
    return write_page_data(out, view_data(files, *args, **kwargs))


def view_data(
    files: Sequence[str | Path],
    clean_report: str | Path | None = None,
    mdm: str | Path | None = None,
    stitch: str | Path | None = None,
    graph: str | Path | None = None,
    lenient: bool = False,
    up: str | None = None,
    units: str | None = None,
    motions: Sequence[Motion] | None = None,
) -> dict[str, Any]:
    """The viewer page's data (:func:`page_data`) for the motion files (read unless
    ``motions`` holds them, already read), each with its provenance sidecar, and the overlay
    files."""
    from mocapkit.io import read_motion
    from mocapkit.provenance import find_provenance

    if motions is None:
        motions = [read_motion(f, lenient=lenient) for f in files]
    shown = [
        ViewMotion(m, str(f), provenance=find_provenance(f))
        for f, m in zip(files, motions, strict=True)
    ]
    return page_data(
        shown,
        up=up,
        units=units,
        clean_report=read_overlay_json(clean_report, "cleaning report") if clean_report else None,
        mdm=read_mdm(mdm) if mdm else None,
        stitch=read_overlay_json(stitch, "stitch result") if stitch else None,
        graph=read_overlay_json(graph, "motion graph") if graph else None,
    )
