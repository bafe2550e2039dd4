"""Motion graphs (Kovar, Gleicher & Pighin 2002) built with a chosen comparison metric.

Nodes are instants ``(clip, frame)``: clip starts and ends, transition sources and transition
landing frames. Edges are continuations (play a clip from one node to the next node of that
clip) and transitions. A transition ``(A, i) -> (B, j)`` plays ``blend`` frames that blend
``A[i + k]`` into the aligned ``B[j + k]`` (k = 0..blend-1) and lands at node ``(B, j + blend)``.
The graph is pruned to its largest strongly connected component, so that a walk never dead-ends.
Frames are 0-based everywhere.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.graph.distance import (
    DEFAULT_WINDOW,
    CostDatabase,
    MinimaResult,
    build_database,
    cost_tile,
    tiled_local_minima,
)
from mocapkit.graph.select import (
    Candidates,
    find_overlaps,
    select_connected,
    select_transitions,
)
from mocapkit.provenance import Provenance, Segment, TransitionTaken

__all__ = [
    "COVERAGE_WARNING",
    "FORMAT",
    "ClipInfo",
    "CostComparison",
    "Coverage",
    "CoverageWarning",
    "GraphReport",
    "MotionGraph",
    "Synthesis",
    "build_graph",
    "compare_metrics",
    "cost_comparison",
    "default_stride",
    "load_graph",
    "load_path_csv",
    "sampled_cost_matrix",
    "synthesize",
]

FORMAT = "mocapkit-motion-graph"


@dataclass(frozen=True)
class ClipInfo:
    path: str
    frames: int
    fps: float


@dataclass(eq=False)
class MotionGraph:
    """Clips + selected transitions (+ what was learnt choosing them).

    Attributes:
        clips: path, frame count and fps of each clip (list order = clip index).
        src_clip, src_frame, dst_clip, dst_frame, cost: (T,) the transitions, 0-based, sorted
            by cost.
        in_scc: (T,) bool, the transition lies in the largest strongly connected component.
        metric, window (seconds), half (window half-width, frames), blend (frames), stride.
        ranked_costs: rank-ordered costs of all merged candidates (the curve of the knee rule).
        T: the number of transitions chosen (before refinement merged any).
        stats: timings and sizes; ``selection`` (the rule and how many transitions each step
            added), ``overlaps`` (duplicate or overlapping takes found).
        kind: (T,) why each transition was chosen ("knee", "end", "bridge"), or None (an
            explicit T or threshold, or a file without it).
    """

    clips: list[ClipInfo]
    src_clip: np.ndarray
    src_frame: np.ndarray
    dst_clip: np.ndarray
    dst_frame: np.ndarray
    cost: np.ndarray
    metric: str = "dynamics"
    window: float = DEFAULT_WINDOW
    half: int = 5
    blend: int = 5
    stride: int = 1
    ranked_costs: np.ndarray = field(default_factory=lambda: np.zeros(0))
    T: int = 0
    in_scc: np.ndarray | None = None
    stats: dict = field(default_factory=dict)
    kind: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("src_clip", "src_frame", "dst_clip", "dst_frame"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=np.int64).reshape(-1))
        self.cost = np.asarray(self.cost, dtype=np.float64).reshape(-1)
        n = len(self.cost)
        for name in ("src_clip", "src_frame", "dst_clip", "dst_frame"):
            if len(getattr(self, name)) != n:
                raise ValueError("transition arrays must have the same length")
        C = len(self.clips)
        if n and (
            self.src_clip.min() < 0
            or max(self.src_clip.max(), self.dst_clip.max()) >= C
            or self.dst_clip.min() < 0
        ):
            raise ValueError("transition clip index out of range")
        frames = np.array([c.frames for c in self.clips], dtype=np.int64)
        if n and (
            np.any(self.src_frame < 0)
            or np.any(self.src_frame + self.blend > frames[self.src_clip])
            or np.any(self.dst_frame < 0)
            or np.any(self.dst_frame + self.blend > frames[self.dst_clip] - 1)
        ):
            raise ValueError("a transition's frames (plus the blend) fall outside its clip")
        if self.in_scc is None:
            self.in_scc = self._scc_mask()
        self.in_scc = np.asarray(self.in_scc, dtype=bool)
        if self.kind is not None:
            self.kind = np.asarray(self.kind, dtype=str).reshape(-1)
            if len(self.kind) != n:
                raise ValueError("kind must give one entry per transition")

    # ---- structure -------------------------------------------------------------------------
    @property
    def num_transitions(self) -> int:
        return len(self.cost)

    def nodes_of_clip(self, c: int, only_scc: bool = False) -> np.ndarray:
        """Sorted node frames of clip c."""
        sel = self.in_scc if only_scc else np.ones(self.num_transitions, dtype=bool)
        f = [0, self.clips[c].frames - 1]
        f += self.src_frame[sel & (self.src_clip == c)].tolist()
        f += (self.dst_frame[sel & (self.dst_clip == c)] + self.blend).tolist()
        return np.unique(np.array(f, dtype=np.int64))

    def edges(self, only_scc: bool = False) -> tuple[list[tuple[int, int]], list[dict]]:
        """Nodes ``(clip, frame)`` (sorted) and edges as dicts: ``kind`` "clip" (``u``, ``v``,
        ``frames``) or "transition" (``u``, ``v``, ``cost``, ``index``: the transition's row);
        ``u``/``v`` index the node list. Duplicate transitions keep the cheapest."""
        sel = self.in_scc if only_scc else np.ones(self.num_transitions, dtype=bool)
        nodes: list[tuple[int, int]] = []
        for c in range(len(self.clips)):
            nodes += [(c, int(f)) for f in self.nodes_of_clip(c, only_scc)]
        where = {n: k for k, n in enumerate(nodes)}
        edges: list[dict] = []
        for k in range(len(nodes) - 1):
            (c0, f0), (c1, f1) = nodes[k], nodes[k + 1]
            if c0 == c1:
                edges.append({"u": k, "v": k + 1, "kind": "clip", "frames": f1 - f0})
        best: dict[tuple[int, int], int] = {}
        for t in np.flatnonzero(sel):
            u = where[(int(self.src_clip[t]), int(self.src_frame[t]))]
            v = where[(int(self.dst_clip[t]), int(self.dst_frame[t] + self.blend))]
            if (u, v) not in best or self.cost[t] < self.cost[best[(u, v)]]:
                best[(u, v)] = int(t)
        for (u, v), t in sorted(best.items()):
            edges.append(
                {"u": u, "v": v, "kind": "transition", "cost": float(self.cost[t]), "index": t}
            )
        return nodes, edges

    def _components(
        self, only_scc: bool = False
    ) -> tuple[list[tuple[int, int]], list[dict], np.ndarray]:
        """Nodes, edges and a bool mask of the nodes in the largest strongly connected
        component (scipy's Tarjan)."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        nodes, edges = self.edges(only_scc)
        n = len(nodes)
        u = np.array([e["u"] for e in edges], dtype=np.int64)
        v = np.array([e["v"] for e in edges], dtype=np.int64)
        adj = coo_matrix((np.ones(len(u)), (u, v)), shape=(n, n)).tocsr()
        _, labels = connected_components(adj, directed=True, connection="strong")
        sizes = np.bincount(labels)
        big = int(np.argmax(sizes))
        mask = labels == big if sizes[big] > 1 else np.zeros(n, dtype=bool)
        return nodes, edges, mask

    def _scc_mask(self) -> np.ndarray:
        n = self.num_transitions
        if n == 0:
            return np.zeros(0, dtype=bool)
        nodes, _, mask = self._components()
        comp = {nd for nd, m in zip(nodes, mask, strict=True) if m}
        out = np.zeros(n, dtype=bool)
        for t in range(n):
            u = (int(self.src_clip[t]), int(self.src_frame[t]))
            v = (int(self.dst_clip[t]), int(self.dst_frame[t] + self.blend))
            out[t] = u in comp and v in comp
        return out

    def scc(self) -> tuple[list[tuple[int, int]], list[dict]]:
        """The pruned graph: nodes and edges of the largest strongly connected component
        (edge ``u``/``v`` index the returned node list)."""
        nodes, edges, mask = self._components(only_scc=True)
        keep = np.flatnonzero(mask)
        remap = {int(k): n for n, k in enumerate(keep)}
        out = [
            dict(e, u=remap[e["u"]], v=remap[e["v"]])
            for e in edges
            if e["u"] in remap and e["v"] in remap
        ]
        return [nodes[k] for k in keep], out

    def scc_frames(self) -> int:
        """Number of clip frames covered by the continuation edges of the pruned graph."""
        _, edges = self.scc()
        return int(sum(e["frames"] for e in edges if e["kind"] == "clip"))

    def coverage(self) -> Coverage:
        """How much of each clip lies in the pruned graph (the frames a walk can play)."""
        nodes, edges = self.scc()
        per = np.zeros(len(self.clips), dtype=np.int64)
        for e in edges:
            if e["kind"] == "clip":
                per[nodes[e["u"]][0]] += e["frames"]
        return Coverage(
            tuple(c.path for c in self.clips),
            np.array([c.frames for c in self.clips], dtype=np.int64),
            per,
            tuple(dict(o) for o in self.stats.get("overlaps", [])),
        )

    # ---- files -----------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {
            "format": FORMAT,
            "version": 1,
            "metric": self.metric,
            "window_seconds": self.window,
            "window_half_frames": self.half,
            "blend_frames": self.blend,
            "stride": self.stride,
            "T": self.T,
            "clips": [{"path": c.path, "frames": c.frames, "fps": c.fps} for c in self.clips],
            "transitions": [
                {
                    "src_clip": int(self.src_clip[t]),
                    "src_frame": int(self.src_frame[t]),
                    "dst_clip": int(self.dst_clip[t]),
                    "dst_frame": int(self.dst_frame[t]),
                    "cost": float(self.cost[t]),
                    "in_scc": bool(self.in_scc[t]),
                    **({"kind": str(self.kind[t])} if self.kind is not None else {}),
                }
                for t in range(self.num_transitions)
            ],
            "ranked_costs": [float(c) for c in self.ranked_costs],
            "stats": self.stats,
        }

    def to_json(self) -> dict:
        """The graph file's content (:meth:`to_dict`), what ``mocapkit graph build`` writes."""
        return self.to_dict()

    def save(self, path: str | Path) -> Path:
        """Write the graph as strict JSON (atomically)."""
        from mocapkit.io.atomic import atomic_write_text
        from mocapkit.jsonio import to_json_text

        path = Path(path)
        atomic_write_text(path, to_json_text(self.to_dict(), indent=1) + "\n")
        return path

    def report(
        self, base: Path | None = None, motions: Sequence[Motion] | None = None
    ) -> GraphReport:
        """Transition count, the strongly connected component, its coverage of each clip
        (:meth:`coverage`) and the foot skate of the transitions, all and those in the
        component (:func:`mocapkit.graph.skate.transition_skate`) on ``motions``, or on the
        clips read from their paths (relative ones against ``base``, the graph file's folder);
        clips that cannot be read leave the skate out and say why."""
        from mocapkit.graph.skate import transition_skate
        from mocapkit.graph.synth import load_clips

        nodes, _edges = self.scc()
        skate = skate_scc = error = worst = None
        try:
            clips = list(motions) if motions is not None else load_clips(self, base)
        except (OSError, ValueError) as e:
            error = str(e)
        else:
            if self.num_transitions:
                sk = transition_skate(self, clips)
                skate = sk.summary()
                skate_scc = sk.subset(self.in_scc).summary()
                worst = self._worst_skate(sk)
        return GraphReport(
            clips=len(self.clips),
            frames=int(sum(c.frames for c in self.clips)),
            metric=self.metric,
            T=self.T,
            transitions=self.num_transitions,
            transitions_in_scc=int(self.in_scc.sum()),
            scc_nodes=len(nodes),
            scc_frames=self.scc_frames(),
            foot_skate=skate,
            foot_skate_error=error,
            coverage=self.coverage().to_json(),
            foot_skate_scc=skate_scc,
            selection=self.stats.get("selection"),
            worst_skate=worst,
        )

    def _worst_skate(self, sk: Any, most: int = 10) -> list[dict[str, Any]]:
        """The ``most`` supported transitions that skate most (start-to-end, cm), worst first:
        a mean or median over hundreds hides the few a walk should avoid."""
        v = np.where(sk.supported, sk.start_to_end, -np.inf)
        out = []
        for t in np.argsort(-v, kind="stable")[:most]:
            if not np.isfinite(v[t]):
                break
            out.append(
                {
                    "src": self.clips[int(self.src_clip[t])].path,
                    "src_frame": int(self.src_frame[t]),
                    "dst": self.clips[int(self.dst_clip[t])].path,
                    "dst_frame": int(self.dst_frame[t]),
                    "in_scc": bool(self.in_scc[t]),
                    "start_to_end_cm": float(sk.start_to_end[t]),
                    "arc_length_cm": float(sk.arc_length[t]),
                }
            )
        return out

    def save_graphml(self, path: str | Path) -> Path:
        """Write the (unpruned) graph as GraphML: nodes ``clip:frame`` with ``clip``, ``frame``,
        ``path``, ``in_scc``; edges with ``kind``, ``frames`` (continuations), ``cost``
        (transitions)."""
        import io

        from mocapkit._optional import require
        from mocapkit.io.atomic import atomic_write_bytes

        nx = require("networkx")
        nodes, edges = self.edges()
        scc_nodes = set(self.scc()[0])
        g = nx.MultiDiGraph(id="motion_graph")  # parallel edges stay distinct
        for c, f in nodes:
            g.add_node(
                f"{c}:{f}",
                clip=int(c),
                frame=int(f),
                path=self.clips[c].path,
                in_scc=(c, f) in scc_nodes,
            )
        for e in edges:
            (cu, fu), (cv, fv) = nodes[e["u"]], nodes[e["v"]]
            attrs = (
                {"frames": int(e["frames"])} if e["kind"] == "clip" else {"cost": float(e["cost"])}
            )
            g.add_edge(f"{cu}:{fu}", f"{cv}:{fv}", kind=e["kind"], **attrs)
        buf = io.BytesIO()
        nx.write_graphml(g, buf)
        return atomic_write_bytes(path, buf.getvalue())

    @classmethod
    def from_dict(cls, data: dict) -> MotionGraph:
        if not isinstance(data, dict):  # valid JSON of another shape (info --json's list)
            raise ValueError(
                f"not a motion graph file (a JSON {type(data).__name__}, not an object)"
            )
        if data.get("format") != FORMAT:
            raise ValueError(f"not a motion graph file (format {data.get('format')!r})")
        try:
            clips = [
                ClipInfo(str(c["path"]), int(c["frames"]), float(c["fps"])) for c in data["clips"]
            ]
            tr = data["transitions"]
            cols = {
                k: [t[k] for t in tr]
                for k in ("src_clip", "src_frame", "dst_clip", "dst_frame", "cost")
            }
            in_scc = [bool(t.get("in_scc", True)) for t in tr] if tr else None
            kind = [str(t["kind"]) for t in tr] if tr and all("kind" in t for t in tr) else None
        except (KeyError, TypeError) as e:
            raise ValueError(f"malformed motion graph file: missing {e}") from None
        return cls(
            clips,
            cols["src_clip"], cols["src_frame"], cols["dst_clip"], cols["dst_frame"],
            cols["cost"],
            metric=str(data.get("metric", "dynamics")),
            window=float(data.get("window_seconds", 1 / 3)),
            half=int(data.get("window_half_frames", 5)),
            blend=int(data.get("blend_frames", 5)),
            stride=int(data.get("stride", 1)),
            ranked_costs=np.asarray(data.get("ranked_costs", []), dtype=np.float64),
            T=int(data.get("T", len(tr))),
            in_scc=in_scc,
            stats=dict(data.get("stats", {})),
            kind=kind,
        )  # fmt: skip

    def clip_paths(self, base: Path | None = None) -> list[Path]:
        """Clip paths; relative ones are resolved against ``base`` (the graph file's folder)
        when they do not exist as given."""
        out = []
        for c in self.clips:
            p = Path(c.path)
            if not p.is_absolute() and not p.exists() and base is not None:
                p = base / p
            out.append(p)
        return out


#: Below this fraction of the library's frames in the largest strongly connected component,
#: :meth:`Coverage.warning` warns (and :func:`build_graph` issues a :class:`CoverageWarning`).
COVERAGE_WARNING = 0.5


class CoverageWarning(UserWarning):
    """Most of the library is unreachable in the graph just built (:meth:`Coverage.warning`)."""


@dataclass(frozen=True, eq=False)
class Coverage:
    """The part of each clip that lies in the pruned graph (:meth:`MotionGraph.coverage`).

    Attributes:
        paths: the clips' paths; frames: (C,) their frame counts; in_scc: (C,) the frames of
        each covered by the largest strongly connected component (what a walk can play);
        overlaps: the duplicate or overlapping takes the build found (JSON dicts).
    """

    paths: tuple[str, ...]
    frames: np.ndarray
    in_scc: np.ndarray
    overlaps: tuple[dict, ...] = ()

    @property
    def fraction(self) -> float:
        total = int(self.frames.sum())
        return float(self.in_scc.sum()) / total if total else 0.0

    @property
    def clips_reached(self) -> int:
        return int((self.in_scc > 0).sum())

    def warning(self) -> str | None:
        """A warning when most of the library is unreachable (None otherwise)."""
        if self.fraction >= COVERAGE_WARNING:
            return None
        return (
            f"only {100 * self.fraction:.1f}% of the frames ({self.clips_reached} of "
            f"{len(self.paths)} clips) lie in the largest strongly connected component; a walk "
            "never reaches the rest. Build with the default rule (no --transitions or "
            "--threshold, which keep only the cheapest transitions), or a larger --transitions "
            "or --threshold; clips reached by nothing may need takes that link them (their "
            "start and end poses differ from every other clip's)"
        )

    def summary(self) -> str:
        """One line: the share of frames and clips in the component, and the overlaps."""
        line = (
            f"coverage: {100 * self.fraction:.1f}% of the frames in the largest strongly "
            f"connected component ({self.clips_reached} of {len(self.paths)} clips reached, "
            f"{int((self.in_scc == 0).sum())} not at all)"
        )
        if self.overlaps:
            pairs = ", ".join(
                f"{Path(o.get('path_b', str(o['clip_b']))).name} frames "
                f"{o['b_frames'][0]}-{o['b_frames'][1]} = "
                f"{Path(o.get('path_a', str(o['clip_a']))).name} frames "
                f"{o['a_frames'][0]}-{o['a_frames'][1]}"
                for o in self.overlaps[:3]
            )
            more = f" and {len(self.overlaps) - 3} more" if len(self.overlaps) > 3 else ""
            line += f"; duplicate takes: {pairs}{more}"
        return line

    def clip_lines(self, most: int = 20) -> list[str]:
        """Per clip, least covered first: its share of frames in the component (at most
        ``most`` lines, then how many more; every clip is in :meth:`to_json`)."""
        frac = self.in_scc / np.maximum(self.frames, 1)
        order = np.lexsort((np.arange(len(frac)), frac))
        lines = [
            f"{100 * frac[c]:5.1f}%  {int(self.in_scc[c]):6d}/{int(self.frames[c]):<6d} "
            f"{self.paths[c]}"
            for c in order[:most]
        ]
        if len(order) > most:
            lines.append(f"... {len(order) - most} more clips (graph report --json lists all)")
        return lines

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Coverage:
        """Back from :meth:`to_json`."""
        clips = data.get("clips", [])
        return cls(
            tuple(str(c["path"]) for c in clips),
            np.array([int(c["frames"]) for c in clips], dtype=np.int64),
            np.array([int(c["frames_in_scc"]) for c in clips], dtype=np.int64),
            tuple(dict(o) for o in data.get("overlaps", [])),
        )

    def to_json(self) -> dict[str, Any]:
        return {
            "frames": int(self.frames.sum()),
            "frames_in_scc": int(self.in_scc.sum()),
            "fraction": self.fraction,
            "clips_reached": self.clips_reached,
            "clips": [
                {
                    "path": p,
                    "frames": int(f),
                    "frames_in_scc": int(c),
                    "fraction": float(c) / int(f) if f else 0.0,
                }
                for p, f, c in zip(self.paths, self.frames, self.in_scc, strict=True)
            ],
            "overlaps": list(self.overlaps),
            "warning": self.warning(),
        }


@dataclass(frozen=True)
class GraphReport:
    """What ``mocapkit graph report`` says about a graph (:meth:`MotionGraph.report`).

    ``foot_skate``: :meth:`~mocapkit.graph.skate.SkateReport.summary` (cm), None without
    transitions or when the clips could not be read (``foot_skate_error`` says why); over the
    component's transitions: ``foot_skate_scc``. ``coverage``: :meth:`Coverage.to_json` (per
    clip, the frames in the component; the overlaps found; a warning when most of the library
    is unreachable). ``selection``: the rule and what each step added.
    """

    clips: int
    frames: int
    metric: str
    T: int
    transitions: int
    transitions_in_scc: int
    scc_nodes: int
    scc_frames: int
    foot_skate: dict | None = None
    foot_skate_error: str | None = None
    coverage: dict | None = None
    foot_skate_scc: dict | None = None
    selection: dict | None = None
    worst_skate: list[dict] | None = None
    """The transitions that skate most (:meth:`MotionGraph._worst_skate`), worst first."""

    @property
    def warning(self) -> str | None:
        """The coverage warning (:meth:`Coverage.warning`), or None."""
        return self.coverage.get("warning") if self.coverage else None

    def coverage_summary(self) -> str | None:
        """The coverage line (:meth:`Coverage.summary`), or None."""
        return Coverage.from_json(self.coverage).summary() if self.coverage else None

    def coverage_lines(self, most: int = 20) -> list[str]:
        """Per clip, least covered first (:meth:`Coverage.clip_lines`); empty without coverage."""
        return Coverage.from_json(self.coverage).clip_lines(most) if self.coverage else []

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "clips": self.clips,
            "frames": self.frames,
            "metric": self.metric,
            "T": self.T,
            "transitions": self.transitions,
            "transitions_in_scc": self.transitions_in_scc,
            "scc_nodes": self.scc_nodes,
            "scc_frames": self.scc_frames,
            "foot_skate": self.foot_skate,
            "foot_skate_scc": self.foot_skate_scc,
            "coverage": self.coverage,
            "selection": self.selection,
            "worst_skate": self.worst_skate,
        }
        if self.foot_skate_error is not None:
            out["foot_skate_error"] = self.foot_skate_error
        return out


def default_stride(num_frames: int) -> int:
    """The grid stride :func:`build_graph` uses by default: 1 up to 20,000 frames, else 2."""
    return 1 if num_frames <= 20000 else 2


def load_graph(path: str | Path) -> MotionGraph:
    """Read a graph JSON written by :meth:`MotionGraph.save`."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: not valid JSON ({e})") from None
    g = MotionGraph.from_dict(data)
    g.stats.setdefault("graph_file", str(path))
    return g


def build_graph(
    motions: Sequence[Motion],
    metric: str = "dynamics",
    *,
    paths: Sequence[str] | None = None,
    transitions: int | None = None,
    threshold: float | None = None,
    window: float = DEFAULT_WINDOW,
    blend: int | None = None,
    stride: int | None = None,
    tile: int = 1024,
    dtype: type | None = None,
    masses: dict[str, float] | None = None,
    max_candidates: int = 200_000,
    progress: Callable[[int, int], None] | None = None,
    database: CostDatabase | None = None,
) -> tuple[MotionGraph, CostDatabase, MinimaResult]:
    """Build a motion graph: tiled local minima of the aligned window cost, merged and ranked
    candidates, and pruning to the largest strongly connected component.

    By default the transitions are the knee rule's T cheapest plus what makes the library
    walkable: every clip's best way out of its end and into its start, and bridges between
    components (:func:`mocapkit.graph.select.select_connected`); ``transitions`` (T) or
    ``threshold`` keep exactly the T cheapest, or those under the cost, instead. Duplicate or
    overlapping takes are found and reported in ``stats["overlaps"]``
    (:func:`mocapkit.graph.select.find_overlaps`); their zero-cost matches are never
    transitions. :meth:`MotionGraph.coverage` says how much of each clip a walk can reach; a
    :class:`CoverageWarning` says when most of the library is unreachable, and what to do.

    Args:
        motions: clips with one skeleton and frame rate.
        paths: their file paths (stored in the graph; default "clip0", ...).
        metric: "dynamics", "uniform" or "torso".
        transitions: T, the number of transitions to keep; threshold: a cost cut instead.
        window: comparison window in seconds.
        blend: blend length in frames (default: the window half-width, at least 1).
        stride: evaluate the cost on every stride-th frame of each clip and refine the chosen
            minima at full resolution (default 1 up to 20,000 frames, else 2).
        tile, dtype: tile size and precision of the matrix products (default float64 up to
            20,000 frames, else float32; candidates are re-scored exactly in float64).
        masses: joint name -> kg overrides.
        progress: ``progress(done, total)`` after each tile.
        database: a prebuilt :func:`build_database` result (reused, e.g. to compare metrics).
    """
    db = database or build_database(motions, metric, window, masses=masses)
    if stride is None:
        stride = default_stride(db.num_frames)
    if dtype is None:
        dtype = np.float64 if db.num_frames <= 20000 else np.float32
    blend = max(1, db.half) if blend is None else int(blend)
    if blend < 1 or blend > max(db.half, 1):
        raise ValueError(f"blend must be 1..{max(db.half, 1)} frames (the window half-width)")
    minima = tiled_local_minima(
        db, stride, tile, dtype, max_candidates=max_candidates, progress=progress
    )
    paths = list(paths) if paths is not None else [f"clip{c}" for c in range(len(motions))]
    selection: dict[str, Any]
    if transitions is None and threshold is None:
        sel = select_connected(db, minima, blend)
        chosen, merged, T, kind = sel.chosen, sel.merged, sel.T, sel.kind
        selection = {
            "rule": "connected",
            **sel.counts(),
            "components_bridged": sel.bridged,
            "components_left_out": sel.skipped,
        }
        overlaps = sel.overlaps
    else:
        chosen, merged, T = select_transitions(db, minima, transitions, threshold)
        chosen = _fit_blend(db, chosen, blend)
        kind = None
        selection = {"rule": "transitions" if transitions is not None else "threshold"}
        overlaps = find_overlaps(db, minima.i, minima.j, minima.cost, minima.stride)[0]
    cs, cd = db.clip_of(chosen.src), db.clip_of(chosen.dst)
    clips = [ClipInfo(str(p), m.num_frames, m.fps) for p, m in zip(paths, motions, strict=True)]
    g = MotionGraph(
        clips,
        cs, chosen.src - db.starts[cs], cd, chosen.dst - db.starts[cd], chosen.cost,
        metric=db.metric, window=window, half=db.half, blend=blend, stride=stride,
        ranked_costs=merged.cost, T=T, kind=kind,
        stats={
            "frames": db.num_frames,
            "pairs_evaluated": minima.pairs,
            "gflop": minima.flops / 1e9,
            "tile_seconds": minima.seconds,
            "candidates": len(merged),
            "selection": selection,
            "overlaps": [o.to_json([c.path for c in clips]) for o in overlaps],
        },
    )  # fmt: skip
    warning = g.coverage().warning()
    if warning is not None:
        warnings.warn(warning, CoverageWarning, stacklevel=2)
    return g, db, minima


def _fit_blend(db: CostDatabase, cand: Candidates, blend: int) -> Candidates:
    """Drop transitions whose blend (and landing frame) would leave the clip."""
    cd = db.clip_of(cand.dst)
    cs = db.clip_of(cand.src)
    ok = (cand.dst + blend <= db.starts[cd + 1] - 1) & (cand.src + blend <= db.starts[cs + 1])
    return cand.take(np.flatnonzero(ok))


# ------------------------------------------------------------------------------- synthesis


@dataclass(frozen=True, eq=False)
class Synthesis:
    """A synthesised motion and the walk through the graph that made it."""

    motion: Motion
    steps: list
    #: how far the walk is from the path it followed (:class:`~mocapkit.graph.synth.PathError`);
    #: None for a random walk
    path_error: Any = None

    @property
    def transitions(self) -> int:
        return sum(s.kind == "transition" for s in self.steps)

    def to_json(self) -> dict[str, Any]:
        out = {
            "frames": self.motion.num_frames,
            "seconds": self.motion.duration,
            "transitions": self.transitions,
        }
        if self.path_error is not None:
            out["path_error"] = self.path_error.to_json()
        return out

    def provenance(
        self,
        graph: MotionGraph,
        output: str,
        parameters: dict[str, Any] | None = None,
        clip_paths: Sequence[str] | None = None,
    ) -> Provenance:
        """The walk as a provenance sidecar (:mod:`mocapkit.provenance`): every output frame's
        clip and frame, and each transition taken (source clip and frame, target clip and
        frame, cost, the output frame where its blend starts). ``clip_paths``: the files the
        clips were read from (default: the paths stored in the graph)."""
        names = [c.path for c in graph.clips] if clip_paths is None else list(clip_paths)
        total = self.motion.num_frames
        segments: list[Segment] = []
        taken: list[TransitionTaken] = []
        at = 0
        for s in self.steps:
            if at >= total:
                break
            n = min(s.frames, total - at)
            if s.kind == "transition":
                t = s.index
                taken.append(TransitionTaken(
                    at, names[int(graph.src_clip[t])], int(graph.src_frame[t]),
                    names[int(graph.dst_clip[t])], int(graph.dst_frame[t]), float(graph.cost[t]),
                ))  # fmt: skip
            segments.append(
                Segment(at, at + n, s.kind, names[s.clip], int(s.start), int(s.start) + n)
            )
            at += n
        return Provenance(
            "graph synth",
            str(output),
            float(self.motion.fps),
            total,
            names,
            dict(parameters or {}),
            segments,
            taken,
        )


def synthesize(
    graph: MotionGraph,
    motions: Sequence[Motion],
    *,
    seconds: float | None = None,
    path: np.ndarray | None = None,
    seed: int = 0,
    blend: str = "crossfade",
) -> Synthesis:
    """A seeded random walk of ``seconds`` (exactly that long, rounded to frames), or a walk
    following the 2-D ground ``path`` ((n, 2) x, z points, file units;
    :meth:`~mocapkit.graph.synth.Synthesizer.follow_path`), rendered with ``blend``
    ("crossfade" or "inertialize"). A path walk carries its
    :func:`~mocapkit.graph.synth.path_error` and warns
    (:class:`~mocapkit.graph.synth.PathNotFollowedWarning`) when it did not follow the path."""
    from mocapkit.graph.synth import PathNotFollowedWarning, Synthesizer, path_error

    if (seconds is None) == (path is None):
        raise ValueError("give exactly one of --seconds or --path")
    syn = Synthesizer(graph, motions)
    if seconds is not None:
        if not seconds > 0:
            raise ValueError("--seconds must be positive")
        steps = syn.random_walk(seconds, seed)
        m = syn.render(steps, blend, max_frames=max(1, round(seconds * motions[0].fps)))
    else:
        pts = np.asarray(path, dtype=float)
        steps = syn.follow_path(pts, seed)
        m = syn.render(steps, blend, start=syn.start_transform)
        err = path_error(m, pts, syn.up)
        if err.warning():
            warnings.warn(err.warning(), PathNotFollowedWarning, stacklevel=2)
        return Synthesis(m, list(steps), err)
    return Synthesis(m, list(steps))


def load_path_csv(path: str | Path) -> np.ndarray:
    """A 2-D ground path from a CSV file: (n, 2) x, z points from the first two columns
    (commas, semicolons or tabs; a header line and ``#`` comments are skipped)."""
    rows = []
    for k, line in enumerate(Path(path).read_text().splitlines()):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        cells = [c for c in line.replace(";", ",").replace("\t", ",").split(",") if c.strip()]
        try:
            vals = [float(c) for c in cells]
        except ValueError:
            if not rows:
                continue  # header
            raise ValueError(f"{path}:{k + 1}: not a number in {line!r}") from None
        if len(vals) < 2:
            raise ValueError(f"{path}:{k + 1}: need two columns (x, z)")
        rows.append(vals[:2])
    if len(rows) < 2:
        raise ValueError(f"{path}: a path needs at least two points")
    return np.array(rows)


# ------------------------------------------------------------------------- metric comparison


def sampled_cost_matrix(db: CostDatabase, max_size: int = 1200) -> tuple[np.ndarray, np.ndarray]:
    """The cost matrix on every k-th frame (k chosen so that it is at most ``max_size``
    square), divided by its 95th percentile and clipped to [0, 1] (NaN where a frame has no
    full window); and the sampled frames."""
    N = db.num_frames
    k = max(1, -(-N // max_size))
    frames = np.arange(0, N, k)
    m = np.full((len(frames), len(frames)), np.nan)
    ok = db.valid_centres()[frames]
    f = frames[ok]
    if len(f):
        t = cost_tile(db, f, f)
        m[np.ix_(ok, ok)] = t
    fin = np.isfinite(m)
    if fin.any():
        # robust normalisation: a few extreme frames (a T-pose, a fall) would darken the rest
        scale = max(float(np.percentile(m[fin], 95.0)), 1e-300)
        m[fin] = np.minimum(m[fin] / scale, 1.0)
    return m, frames


@dataclass(frozen=True, eq=False)
class CostComparison:
    """Two metrics' normalised cost matrices on the same frames, and their transitions: the
    data of the paper's Figures 3 and 4 (:func:`mocapkit.viz.figures.graph.plot_cost_comparison`
    draws it).

    Attributes:
        metrics: the metric names (one or two).
        matrices: per metric, (n, n) normalised costs on the sampled frames (NaN: no window).
        frames: (n,) the sampled library frames (all clips one after the other).
        num_frames, fps: the library's length and frame rate.
        clip_starts: (C + 1,) first library frame of each clip, then num_frames.
        clip_names: the clips' names (file names).
        transitions: per metric, (T, 2) library frames (source, destination).
        shared: per metric, (T,) bool: within a quarter second of a transition of the other.
        ranked_costs: per metric, the rank-ordered candidate costs; T: per metric, the chosen T.
    """

    metrics: tuple[str, ...]
    matrices: dict[str, np.ndarray]
    frames: np.ndarray
    num_frames: int
    fps: float
    clip_starts: np.ndarray
    clip_names: tuple[str, ...]
    transitions: dict[str, np.ndarray]
    shared: dict[str, np.ndarray]
    ranked_costs: dict[str, np.ndarray]
    T: dict[str, int]


def cost_comparison(
    dbs: Mapping[str, CostDatabase], graphs: Mapping[str, MotionGraph], max_size: int = 1200
) -> CostComparison:
    """The :class:`CostComparison` of (up to) two metrics' databases and graphs (same clips)."""
    names = list(dbs)[:2]
    first = dbs[names[0]]
    mats, frames = {}, np.zeros(0, dtype=np.int64)
    for n in names:
        mats[n], frames = sampled_cost_matrix(dbs[n], max_size)
    pts = {}
    for n in names:
        g = graphs[n]
        pts[n] = np.stack(
            [first.starts[g.src_clip] + g.src_frame, first.starts[g.dst_clip] + g.dst_frame], 1
        ).reshape(-1, 2)
    q = max(1, round(0.25 * first.fps))

    def near(p: np.ndarray, others: np.ndarray) -> np.ndarray:
        if len(others) == 0 or len(p) == 0:
            return np.zeros(len(p), dtype=bool)
        d = np.abs(p[:, None, :] - others[None, :, :]).max(-1)
        return (d <= q).any(1)

    shared = {}
    for n in names:
        other = [m for m in names if m != n]
        shared[n] = near(pts[n], pts[other[0]]) if other else np.zeros(len(pts[n]), dtype=bool)
    g0 = graphs[names[0]]
    return CostComparison(
        metrics=tuple(names),
        matrices=mats,
        frames=frames,
        num_frames=first.num_frames,
        fps=float(first.fps),
        clip_starts=np.asarray(first.starts, dtype=np.int64),
        clip_names=tuple(Path(c.path).name for c in g0.clips),
        transitions=pts,
        shared=shared,
        ranked_costs={n: np.asarray(graphs[n].ranked_costs) for n in names},
        T={n: int(graphs[n].T) for n in names},
    )


def compare_metrics(
    motions: Sequence[Motion],
    graph: MotionGraph,
    database: CostDatabase,
    other: str | None = None,
    masses: dict[str, float] | None = None,
    max_size: int = 1200,
) -> CostComparison:
    """Build the graph of ``motions`` with another metric (``other``; default "uniform", or
    "dynamics" when ``graph`` is uniform) with the same T, window and stride, and compare it
    with ``graph`` (built on ``database``): :func:`cost_comparison`."""
    metric = graph.metric
    other = other or ("uniform" if metric != "uniform" else "dynamics")
    db2 = build_database(motions, other, graph.window, masses=masses)
    with warnings.catch_warnings():
        # the comparison graph keeps the same T, not the user's rule: its coverage says nothing
        warnings.simplefilter("ignore", CoverageWarning)
        g2, _, _ = build_graph(
            motions,
            other,
            paths=[c.path for c in graph.clips],
            transitions=graph.T,
            window=graph.window,
            stride=graph.stride,
            database=db2,
        )
    return cost_comparison({metric: database, other: db2}, {metric: graph, other: g2}, max_size)
