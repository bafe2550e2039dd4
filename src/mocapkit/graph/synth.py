"""Synthesis from a motion graph: seeded random walks, path-following walks (bounded search),
and rendering a walk into one continuous motion.

A walk is a list of edges of the pruned graph (:meth:`MotionGraph.scc`): continuations play clip
frames ``[f0, f1)``; transitions play ``blend`` frames. At a transition ``(A, i) -> (B, j)`` clip B
is aligned to A by the best rigid ground transform of the two blend windows' joint positions
(Kovar & Gleicher's closed form, :func:`mocapkit.features.align_point_clouds_2d`); where a foot
is planted at both ``A[i]`` and ``B[j]``, the transform's translation is then moved so that B's
planted feet lie on A's (on average over the blend), since a planted foot does not move and
the fit's residual there would otherwise become foot skate over the blend. Then either

* ``"crossfade"`` (Kovar et al.): frame k of the blend slerps every local rotation (and lerps
  the root and joint translations) from ``A[i+k]`` to the aligned ``B[j+k]`` with the ease-in /
  ease-out weight ``3 a^2 - 2 a^3``, ``a = (k + 1) / (blend + 1)``; or
* ``"inertialize"``: B plays from frame j at once and the difference ``A[i] - B[j]`` (rotation
  offsets per joint, translation offsets) is added and decays to zero over the blend with the
  same smooth weight, so the output starts where A would have been.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mocapkit.body import body_of
from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.features import (
    FootContacts,
    GroundTransform,
    align_point_clouds_2d,
    apply_ground_transform,
    detect_up_axis,
    find_feet,
    foot_contacts,
    ground_root_on_path,
    heading_angles,
    metres_per_unit,
    root_trajectory,
)
from mocapkit.graph.graph import MotionGraph
from mocapkit.ik import lock_feet

__all__ = [
    "BLENDS",
    "FOLLOW_TOLERANCE_M",
    "PathError",
    "PathNotFollowedWarning",
    "Step",
    "Synthesizer",
    "follow_path",
    "path_error",
    "random_walk",
    "render",
]

BLENDS = ("crossfade", "inertialize")

#: A walk "follows" a path when no pelvis frame is further than this from the path, no part of the
#: path further than this from the pelvis' ground track, and the walk ends this close to the
#: path's end: half a metre is about a stride, beyond which the character is visibly off its path.
FOLLOW_TOLERANCE_M = 0.5
#: Below this mean ground speed a clip stands (gestures, idles): pelvis sway is a few cm/s, the
#: slowest walks about 0.5 m/s.
STANDING_SPEED_MPS = 0.3
#: A random walk plays at least this much of a clip after arriving in it before it takes another
#: transition: about one gait cycle (a stride takes ~1 s walking, ~0.7 s running), so a clip is
#: seen as a motion and not as a blend of blends.
MIN_PLAY_S = 1.0
#: A random walk does not take a transition landing within the frames it played this recently
#: (while another way exists): a landing on just-played frames replays them, a visible loop.
RECENT_S = 4.0
#: The pelvis ground track a path is planned on is averaged over this window: the pelvis sways
#: to the stance foot's side every step, a motion with the period of a stride (~1 s walking).
SWAY_WINDOW_S = 1.0
#: A clip's direction of travel at a frame is its smoothed pelvis displacement over this long, a
#: stride: over a single step a side step or a turn does not point where the body goes.
TRAVEL_S = 1.0
#: Path-following looks this many metres of path ahead: a turning take walks a stride or two
#: (~2 m) into its turn and ~1.5 m out of it, and the search must see the turn completed to
#: prefer it to walking straight on.
HORIZON_M = 4.0
#: Path-following keeps this much of each best walk before it searches again: one stride, so the
#: plan is corrected every stride while a search still sees its whole horizon.
COMMIT_S = 1.0
#: After each commit the arc length walked is re-read as the pelvis' projection on the path within
#: this distance of it: a turning clip cuts a corner by tens of cm (a ~1 m turning radius), which
#: by arc length alone would ask the walk to be that far ahead for the rest of the path; a metre
#: keeps the projection off other parts of a path that come back near it.
RESYNC_M = 1.0
#: Path-following tries this many start nodes (drawn with the seed) and keeps the best: a
#: library's walks enter its turns at a few frames only, so where the walk starts decides where
#: it can turn.
START_NODES = 200


class PathNotFollowedWarning(UserWarning):
    """A synthesised walk stays further than :data:`FOLLOW_TOLERANCE_M` from its path."""


@dataclass(frozen=True)
class PathError:
    """How far a walk's pelvis ground track is from the path it was asked to follow, in file
    units (``*_cm``: in centimetres).

    ``mean``/``max``: distance of each output frame's pelvis from the path (polyline);
    ``miss``: the largest distance of a point of the path from the pelvis track (a walk that
    stays at the path's start is near the path but misses most of it); ``end``: the last frame's
    distance from the path's end. ``followed``: all of ``max``, ``miss`` and ``end`` within
    ``tolerance_m`` metres."""

    mean: float
    max: float
    miss: float
    end: float
    cm_per_unit: float
    tolerance_m: float = FOLLOW_TOLERANCE_M

    @property
    def followed(self) -> bool:
        worst = max(self.max, self.miss, self.end) * self.cm_per_unit / 100.0
        return bool(worst <= self.tolerance_m)

    def to_json(self) -> dict:
        c = self.cm_per_unit
        return {
            "mean": self.mean, "max": self.max, "miss": self.miss, "end": self.end,
            "mean_cm": self.mean * c, "max_cm": self.max * c, "miss_cm": self.miss * c,
            "end_cm": self.end * c, "tolerance_m": self.tolerance_m, "followed": self.followed,
        }  # fmt: skip

    def line(self) -> str:
        c = self.cm_per_unit
        return (
            f"path error: mean {self.mean * c:.0f} cm, max {self.max * c:.0f} cm, path missed by "
            f"up to {self.miss * c:.0f} cm, ends {self.end * c:.0f} cm from the path's end"
        )

    def warning(self) -> str | None:
        """A one-line warning when the walk did not follow its path, else None."""
        if self.followed:
            return None
        worst = max(self.max, self.miss, self.end) * self.cm_per_unit
        return (
            f"the walk does not follow the path ({worst:.0f} cm off it > {self.tolerance_m:g} m):"
            " the graph may lack the clips that travel, or the turns, this path needs"
        )


def _polyline_distance(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(N,) distance of each 2-D point from the polyline ``line`` (M, 2)."""
    a, d = line[:-1], np.diff(line, axis=0)
    dd = np.maximum((d * d).sum(-1), 1e-300)
    t = np.clip(((points[:, None] - a[None]) * d[None]).sum(-1) / dd[None], 0.0, 1.0)
    q = a[None] + t[..., None] * d[None]
    return np.linalg.norm(points[:, None] - q, axis=-1).min(axis=1)


def path_error(
    motion: Motion,
    path: np.ndarray,
    up: str | None = None,
    units: str | float | None = None,
    tolerance_m: float = FOLLOW_TOLERANCE_M,
) -> PathError:
    """:class:`PathError` of ``motion``'s pelvis ground track against the 2-D ground ``path``
    (M, 2) (file units; ``units``: the file's, guessed from the body's height when None)."""
    path = np.asarray(path, dtype=np.float64)
    track = root_trajectory(motion, up)
    if len(track) == 0:
        raise ValueError("the motion has no frames")
    dev = _polyline_distance(track, path)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    s = np.linspace(0.0, arc[-1], 200)
    samples = np.stack([np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])], 1)
    miss = (
        _polyline_distance(samples, track)
        if len(track) > 1
        else np.linalg.norm(samples - track[0], axis=1)
    )
    return PathError(
        float(dev.mean()), float(dev.max()), float(miss.max()),
        float(np.linalg.norm(track[-1] - path[-1])),
        100.0 * metres_per_unit(motion, units), float(tolerance_m),
    )  # fmt: skip


@dataclass(frozen=True)
class Step:
    """One edge of a walk: ``kind`` "clip" (play ``clip`` frames ``[start, stop)``) or
    "transition" (``index``: row of the graph's transitions)."""

    kind: str
    clip: int
    start: int
    stop: int
    index: int = -1

    @property
    def frames(self) -> int:
        return self.stop - self.start


def _ease(a: np.ndarray) -> np.ndarray:
    return 3.0 * a * a - 2.0 * a * a * a


class Synthesizer:
    """A motion graph with its clips loaded, ready to walk and render.

    Args:
        graph: the graph (its pruned strongly connected component is used).
        motions: the clips, in the graph's order.
        up: the up axis (detected when None).
        walks: prepare the pruned graph for walks (False: only render single transitions).
    """

    def __init__(
        self,
        graph: MotionGraph,
        motions: Sequence[Motion],
        up: str | None = None,
        walks: bool = True,
    ):
        if len(motions) != len(graph.clips):
            raise ValueError(f"the graph has {len(graph.clips)} clips, got {len(motions)}")
        for c, (m, info) in enumerate(zip(motions, graph.clips, strict=True)):
            if m.num_frames != info.frames:
                raise ValueError(
                    f"clip {c} ({info.path}) has {m.num_frames} frames, the graph expects "
                    f"{info.frames}"
                )
        self.graph = graph
        self.motions = list(motions)
        self.up = up or detect_up_axis(motions[0])
        self.nodes, self.edges = graph.scc() if walks else ([], [])
        if walks and not self.edges:
            raise ValueError(
                "the motion graph has no strongly connected component with a transition; "
                "build it with more transitions (--transitions / --threshold)"
            )
        self.out: list[list[dict]] = [[] for _ in self.nodes]
        for e in self.edges:
            self.out[e["u"]].append(e)
        self._align: dict[int, GroundTransform] = {}
        self._traj = [root_trajectory(m, self.up) for m in self.motions]
        self._head = [heading_angles(m, self.up) for m in self.motions]
        self._pos: dict[int, np.ndarray] = {}
        self._fk: dict[int, np.ndarray] = {}
        self._contacts: dict[int, FootContacts] = {}
        ankle: dict[str, int] = {}
        for side, j in find_feet(motions[0].skeleton, motions[0], self.up):
            ankle.setdefault(side or f"s{len(ankle)}", j)
        # per column of FootContacts.by_side (left, right): the ankle the skate is measured at
        self._ankles = list(ankle.values())[:2]
        self.start_transform: GroundTransform | None = None  # set by follow_path
        self._pieces: dict[int, tuple] = {}
        self._smooth: dict[int, np.ndarray] = {}
        self._move_cache: dict[int, list] = {}

    # ---- pieces --------------------------------------------------------------------------
    def _positions(self, c: int) -> np.ndarray:
        """(F, B, 3) world positions of the body's joints (the pelvis and below) of clip ``c``:
        a ground root above the pelvis (Bandai's joint_Root, fixed at the origin while the
        body travels) would pull the alignment towards turning the clip around it."""
        if c not in self._pos:
            m = self.motions[c]
            body = np.flatnonzero(m.skeleton.subtree_mask(body_of(m.skeleton).pelvis))
            self._pos[c] = self._world(c)[:, body]
        return self._pos[c]

    def _world(self, c: int) -> np.ndarray:
        """(F, J, 3) world joint positions of clip ``c``."""
        if c not in self._fk:
            self._fk[c] = forward_kinematics(self.motions[c])[0]
        return self._fk[c]

    def foot_contacts(self, c: int) -> FootContacts:
        """The foot contacts of clip ``c`` (:func:`mocapkit.features.foot_contacts`)."""
        if c not in self._contacts:
            self._contacts[c] = foot_contacts(self.motions[c], up=self.up)
        return self._contacts[c]

    def contacts(self, c: int) -> np.ndarray:
        """(F, 2) the feet of clip ``c`` planted (left, right; :meth:`FootContacts.by_side`)."""
        return self.foot_contacts(c).by_side()

    def alignment(self, t: int) -> GroundTransform:
        """Ground transform that moves clip B of transition t onto clip A over the blend."""
        if t not in self._align:
            g = self.graph
            n = g.blend
            a = self._positions(int(g.src_clip[t]))[g.src_frame[t] : g.src_frame[t] + n]
            b = self._positions(int(g.dst_clip[t]))[g.dst_frame[t] : g.dst_frame[t] + n]
            T = align_point_clouds_2d(a.reshape(-1, 3), b.reshape(-1, 3), up=self.up)
            self._align[t] = self._anchor_feet(t, T)
        return self._align[t]

    def _anchor_feet(self, t: int, T: GroundTransform) -> GroundTransform:
        """``T`` with its translation moved so that the feet planted at both ends of transition
        ``t`` (source and landing frame) coincide, on average over the blend."""
        g = self.graph
        ca, cb = int(g.src_clip[t]), int(g.dst_clip[t])
        i, j, n = int(g.src_frame[t]), int(g.dst_frame[t]), g.blend
        both = self.contacts(ca)[i] & self.contacts(cb)[j]
        feet = [a for k, a in enumerate(self._ankles) if both[k]]
        if not feet:
            return T
        pa = self._world(ca)[i : i + n, feet]
        pb = T.apply(self._world(cb)[j : j + n, feet])
        shift = (pa - pb).reshape(-1, 3).mean(axis=0)
        return GroundTransform(T.angle, T.translation + shift, self.up)

    def step_of(self, e: dict) -> Step:
        c0, f0 = self.nodes[e["u"]]
        c1, f1 = self.nodes[e["v"]]
        if e["kind"] == "clip":
            return Step("clip", c0, f0, f1)
        return Step("transition", c1, f1 - self.graph.blend, f1, int(e["index"]))

    def _chain(self) -> list[int]:
        """Joints from joint 0 down to the pelvis: blended as global transforms (a static
        ground root such as Bandai-Namco's ``joint_Root`` must not swing the pelvis)."""
        sk = self.motions[0].skeleton
        pelvis = body_of(sk).pelvis
        return [*reversed(sk.ancestors(pelvis)), pelvis]

    # ---- walks ---------------------------------------------------------------------------
    def random_walk(
        self,
        seconds: float,
        seed: int = 0,
        start: int | None = None,
        min_play: float = MIN_PLAY_S,
        recent: float = RECENT_S,
    ) -> list[Step]:
        """A seeded random walk of at least ``seconds`` that wanders the library.

        At each node of the pruned graph the next edge is drawn (``numpy`` generator seeded by
        ``seed``: the same graph, clips and arguments give the same walk) under three rules:

        * **dwell**: after arriving in a clip (a transition's landing, or the start) its own
          continuation is taken until ``min_play`` seconds of it have played (where the clip
          goes on): a motion is recognised over about a gait cycle, and a walk that hops every
          few frames is a chain of blends (:data:`MIN_PLAY_S`);
        * **no return**: a transition whose landing (its blend, then ``min_play`` seconds) falls
          on frames of the same clip played in the last ``recent`` seconds is not taken while
          another way out exists: it would replay them, a visible loop (:data:`RECENT_S`); nor
          is the clip's own continuation when every way out further along it returns so;
        * **choice**: the remaining edges are weighted ``exp(-cost / median cost)`` (a
          transition's cost is the pose difference its blend must hide; the graph's median
          transition is the reference, a continuation costs 0) times ``1 / (1 + t)``, ``t`` the
          seconds already played of the clip the edge leads into, so the walk drifts towards the
          clips it has seen least.
        """
        if not seconds > 0:
            raise ValueError(f"seconds must be > 0, got {seconds}")
        if not (min_play >= 0 and recent >= 0):
            raise ValueError(f"min_play and recent must be >= 0, got {min_play}, {recent}")
        rng = np.random.default_rng(seed)
        fps = self.motions[0].fps
        need = math.ceil(seconds * fps)
        dwell = round(min_play * fps)
        window = round(recent * fps)
        g = self.graph
        scc_costs = [float(g.cost[e["index"]]) for e in self.edges if e["kind"] != "clip"]
        ref = max(float(np.median(scc_costs)), 1e-300) if scc_costs else 1.0
        node = int(rng.integers(len(self.nodes))) if start is None else int(start)
        if not 0 <= node < len(self.nodes):
            raise ValueError(
                f"start node {node} is not in the pruned graph (0..{len(self.nodes) - 1})"
            )
        played = np.zeros(len(self.motions))  # frames played per clip
        history: list[tuple[int, int, int, int]] = []  # (clip, first, stop, output frame at stop)
        steps: list[Step] = []
        total = since = 0  # output frames; frames since arriving in the current clip

        def returns(e: dict) -> bool:
            c1, f1 = self.nodes[e["v"]]
            lo, hi = f1 - g.blend, f1 + dwell
            return any(
                c == c1 and a < hi and lo < b and total - end < window for c, a, b, end in history
            )

        def trapped(e: dict) -> bool:
            """Playing on along the clip reaches only transitions that return (the clip's end
            leads back into frames just played): take another way out while there is one."""
            v = e["v"]
            for _ in range(len(self.nodes)):
                out = self.out[v]
                if any(x["kind"] != "clip" and not returns(x) for x in out):
                    return False
                on = [x for x in out if x["kind"] == "clip"]
                if not on:
                    return True
                v = on[0]["v"]
            return False

        while total < need:
            choices = self.out[node]
            if not choices:  # cannot happen inside a strongly connected component
                raise RuntimeError(f"dead end at node {self.nodes[node]}")
            onward = [e for e in choices if e["kind"] == "clip"]
            if onward and since < dwell and not trapped(onward[0]):
                e = onward[0]
            else:
                allowed = (
                    [e for e in choices if not (returns(e) if e["kind"] != "clip" else trapped(e))]
                    or [e for e in choices if e["kind"] == "clip" or not returns(e)]
                    or choices
                )
                w = np.array([
                    (1.0 if e["kind"] == "clip" else math.exp(-float(g.cost[e["index"]]) / ref))
                    / (1.0 + played[self.nodes[e["v"]][0]] / fps)
                    for e in allowed
                ])  # fmt: skip
                w = w / w.sum() if w.sum() > 0 else np.full(len(allowed), 1.0 / len(allowed))
                e = allowed[int(rng.choice(len(allowed), p=w))]
            s = self.step_of(e)
            steps.append(s)
            total += s.frames
            since = since + s.frames if s.kind == "clip" else s.frames
            played[s.clip] += s.frames
            history.append((s.clip, s.start, s.stop, total))
            node = e["v"]
        return steps

    def _edge_piece(self, e: dict) -> tuple[np.ndarray, tuple[float, float, float] | None]:
        """Smoothed pelvis ground points (n, 2) an edge plays (:meth:`plan_track`), in its clip's
        frame, and the transform (angle, tx, tz) a transition applies first (None for a
        continuation)."""
        key = id(e)
        if key not in self._pieces:
            s = self.step_of(e)
            T = None
            if s.kind == "transition":
                A = self.alignment(s.index)
                T = (A.angle, *(float(v) for v in A.translation_2d))
            self._pieces[key] = (self.plan_track(s.clip)[s.start : s.stop], T)
        return self._pieces[key]

    def plan_track(self, c: int) -> np.ndarray:
        """(F, 2) the pelvis ground track of clip ``c`` averaged over :data:`SWAY_WINDOW_S`: the
        pelvis swings a few cm to the side of the stance foot every step, a motion with the
        period of a stride, so the average over a stride is where the body goes. The ends are
        padded by point reflection (``2 p[0] - p[k]``), which keeps a steady walk straight up
        to the clip's first and last frames."""
        if c not in self._smooth:
            p = self._traj[c]
            h = min(round(SWAY_WINDOW_S * self.motions[0].fps) // 2, len(p) - 1)
            if h < 1:
                self._smooth[c] = p.copy()
            else:
                pad = np.concatenate([2 * p[0] - p[h:0:-1], p, 2 * p[-1] - p[-2 : -h - 2 : -1]])
                k = np.ones(2 * h + 1) / (2 * h + 1)
                self._smooth[c] = np.stack([np.convolve(pad[:, i], k, "valid") for i in (0, 1)], 1)
        return self._smooth[c]

    def _moves(self, n: int) -> list[tuple]:
        """The ways on from node ``n``: each out edge, followed on through the nodes that have a
        single way on until :data:`COMMIT_S` seconds have played (a choice-less chain is one
        move of the search). Each move: (edges, end node, smoothed pelvis points (k, 2) and the
        transform (angle, tx, tz) after it, both relative to the frame before its first edge)."""
        if n not in self._move_cache:
            cap = max(1, round(COMMIT_S * self.motions[0].fps))
            moves = []
            for e in self.out[n]:
                chain, pts, G, frames = [e], [], (0.0, 0.0, 0.0), 0
                while True:
                    p, T = self._edge_piece(chain[-1])
                    if T is not None:
                        G = _compose(G, T)
                    pts.append(_apply2(G, p))
                    frames += len(p)
                    on = self.out[chain[-1]["v"]]
                    if len(on) != 1 or frames >= cap:
                        break
                    chain.append(on[0])
                moves.append((chain, chain[-1]["v"], np.concatenate(pts), G))
            self._move_cache[n] = moves
        return self._move_cache[n]

    def nominal_speed(self) -> float:
        """Ground speed (file units / s) a path-following walk is asked to keep: half the median
        mean pelvis speed of the clips that travel (mean speed above
        :data:`STANDING_SPEED_MPS`); half, so that turning and slow walks still qualify."""
        fps = self.motions[0].fps
        speeds = np.array([
            np.linalg.norm(np.diff(t, axis=0), axis=1).sum() / max(len(t) - 1, 1) * fps
            for t in self._traj
        ])  # fmt: skip
        mpu = metres_per_unit(self.motions[0], None)
        moving = speeds[speeds * mpu > STANDING_SPEED_MPS]
        if len(moving) == 0:
            raise ValueError(
                f"no clip of the graph travels (every mean pelvis speed is under "
                f"{STANDING_SPEED_MPS} m/s): a path needs walking or running clips"
            )
        return 0.5 * float(np.median(moving))

    def follow_path(
        self,
        path: np.ndarray,
        seed: int = 0,
        horizon: float = HORIZON_M,
        beam: int = 64,
        max_seconds: float | None = None,
        starts: int = START_NODES,
    ) -> list[Step]:
        """A walk whose pelvis follows the ground path (M, 2): ground coordinates
        ``(side, forward)`` in file units, ``(x, z)`` for Y-up (:func:`root_trajectory`).

        Path synthesis after Kovar et al. 2002 (section 5): a search over graph walks whose
        cost is the deviation of the pelvis from the path parametrised by arc length, repeated
        from the end of the part it commits, until the walk has reached the path's end (or
        ``max_seconds``, default 3 x the path's length at :meth:`nominal_speed`, at least 10 s).

        * **track**: the pelvis ground track averaged over a stride (:meth:`plan_track`), whose
          arc length is the distance the body travelled (the raw track's side-to-side sway
          would add ~5 % and run the correspondence ahead of the body).
        * **cost** of a walk from arc length ``s0``: the mean over its frames of the squared
          distance between the pelvis after travelling arc length ``s`` and the path's point at
          ``s`` (clamped to the path's end, so walking past it costs), plus the square of its
          shortfall from :meth:`nominal_speed` x its duration in arc length (capped by what is
          left of the path): standing still at the path's start would otherwise cost nothing.
        * **horizon** in metres of path, not seconds: a walk is scored once it has travelled
          ``horizon`` metres (or the path's end; or twice that at the nominal speed in time).
          Turning is done by the library's turning clips, which walk a stride or two before and
          after they turn; the search must see the turn completed to prefer it to walking on,
          whatever the walking speed (:data:`HORIZON_M`).
        * **search**: a beam search in time: every ``0.5 s`` the ``beam`` best partial walks by
          the same cost are kept (one per node and 20 cm place), each grown by every way on
          (a move follows nodes with a single way on, :meth:`_moves`).
        * **commit**: the first :data:`COMMIT_S` seconds of the best walk are kept and the
          search starts again from there (all of it once it reaches the path's end). The arc
          length done is then re-read as the pelvis' projection on the path within
          :data:`RESYNC_M`: a turning clip cuts the path's corner, and by arc length alone the
          walk would be asked to be ahead of where it is for the rest of the path.
        * **start**: up to ``starts`` nodes of clips that travel (drawn with ``seed``), each
          placed at the path's first point with its direction of travel over the next
          :data:`TRAVEL_S` (not its body's facing, which a side step or a turn does not go
          along) along the path's first segment; the search picks among them.
        * **end**: the walk is cut at the frame of its last plan closest to the path's end.

        Render it with ``start=self.start_transform``; :func:`path_error` measures the result."""
        path = np.asarray(path, dtype=np.float64)
        if path.ndim != 2 or path.shape[1] != 2 or len(path) < 2:
            raise ValueError("path must be (M >= 2, 2) ground points")
        if not np.isfinite(path).all():
            raise ValueError("the path has non-finite points")
        if not (horizon > 0 and beam >= 1 and starts >= 1):
            raise ValueError("horizon, beam and starts must be positive")
        seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
        keep = np.concatenate([[True], seg > 0])
        path, arc = path[keep], np.concatenate([[0.0], np.cumsum(seg[seg > 0])])
        L = float(arc[-1])
        if not L > 0:
            raise ValueError("the path has zero length")
        fps = self.motions[0].fps
        mpu = metres_per_unit(self.motions[0], None)
        v = self.nominal_speed() / fps  # file units per frame
        limit = max_seconds if max_seconds is not None else max(10.0, 3.0 * L / (v * fps))
        H = horizon / mpu  # file units of path
        slice_f = max(1, round(0.5 * fps))
        cell = 0.2 / mpu
        commit_f = max(1, round(COMMIT_S * fps))
        rng = np.random.default_rng(seed)

        def at(s: np.ndarray) -> np.ndarray:
            s = np.clip(s, 0.0, L)
            return np.stack([np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])], 1)

        def cost(st: tuple, s0: float) -> float:
            shortfall = max(0.0, min(v * st[4], L - s0) - (st[3] - s0))
            return st[5] / max(st[4], 1) + shortfall * shortfall

        def grow(st: tuple, move: tuple) -> tuple:
            """State (node, G, last point, arc length, frames, squared error, plan) after move."""
            _n, g, last, s, fr, err, plan = st
            _edges, end, mp, mT = move
            p = _apply2(g, mp)
            d = np.linalg.norm(np.diff(np.concatenate([last[None], p]), axis=0), axis=1)
            sa = s + np.cumsum(d)
            err2 = err + float(np.sum((p - at(sa)) ** 2))
            return (end, _compose(g, mT), p[-1], float(sa[-1]), fr + len(p), err2, (move, p, plan))

        # start candidates: nodes of clips travelling there, placed and turned onto the path
        travel = max(1, round(TRAVEL_S * fps))
        pool = []
        for n, (c, f) in enumerate(self.nodes):
            tr = self.plan_track(c)
            d = tr[min(f + travel, len(tr) - 1)] - tr[f]
            if np.linalg.norm(d) * mpu / TRAVEL_S > STANDING_SPEED_MPS and self.out[n]:
                pool.append((n, math.atan2(d[0], d[1])))
        if not pool:
            pool = [(n, float(self._head[c][f])) for n, (c, f) in enumerate(self.nodes)]
        pick = rng.permutation(len(pool))[:starts]
        d0 = path[1] - path[0]
        roots = []
        for k in sorted(int(i) for i in pick):
            n, heading = pool[k]
            c, f = self.nodes[n]
            ang = math.atan2(d0[0], d0[1]) - heading
            R = _apply2((ang, 0.0, 0.0), self._traj[c][f : f + 1])[0]
            g = (ang, path[0, 0] - R[0], path[0, 1] - R[1])
            first = _apply2(g, self.plan_track(c)[f : f + 1])[0]
            roots.append((n, g, first, 0.0, 0, 0.0, len(roots)))  # plan: the root's index

        steps: list[Step] = []
        frames = 0
        s_done = 0.0
        state = None
        final: list[np.ndarray] = []
        while s_done < L - 1e-9 and frames < limit * fps:
            base = roots if state is None else [state]
            target = min(L, s_done + H)
            cap = max(slice_f, round((target - s_done) / v))
            frontier = [(st[0], st[1], st[2], s_done, 0, 0.0, None) if state else st for st in base]
            done: list[tuple] = []
            t = 0
            while frontier:
                t += slice_f
                stack, waiting = list(frontier), []
                while stack:
                    st = stack.pop()
                    if st[4] >= t:
                        waiting.append(st)
                        continue
                    for mv in self._moves(st[0]):
                        ch = grow(st, mv)
                        (done if ch[3] >= target or ch[4] >= cap else stack).append(ch)
                best_of: dict = {}
                for st in waiting:
                    key = (st[0], round(st[2][0] / cell), round(st[2][1] / cell))
                    sc = cost(st, s_done)
                    if key not in best_of or sc < best_of[key][0]:
                        best_of[key] = (sc, st)
                frontier = [st for _, st in sorted(best_of.values(), key=lambda x: x[0])[:beam]]
            if not done:
                raise RuntimeError("the path search found no walk (a node without a way on)")
            best = min(done, key=lambda st: cost(st, s_done))
            plan = []
            link = best[6]
            while isinstance(link, tuple):
                plan.append(link[:2])
                link = link[2]
            plan.reverse()
            if state is None:  # the start the best walk came from
                state = roots[link]
                g0 = state[1]
                self.start_transform = GroundTransform.from_2d(g0[0], g0[1:], self.up)
            used = 0
            for move, p in plan:
                for e in move[0]:
                    steps.append(self.step_of(e))
                    frames += steps[-1].frames
                state = grow(state, move)
                used += len(p)
                if s_done >= L - H:  # the final approach: where the walk may be cut
                    final.append(p)
                if used >= commit_f:
                    break
            s_done = state[3]
            # re-read the arc length as the projection of where the pelvis is
            lo, hi = max(0.0, s_done - RESYNC_M / mpu), min(L, s_done + RESYNC_M / mpu)
            ss = np.linspace(lo, hi, 41)
            s_done = float(ss[np.argmin(np.linalg.norm(at(ss) - state[2], axis=1))])
            state = (*state[:3], s_done, *state[4:])
        return _cut_at_end(steps, np.concatenate(final) if final else None, path[-1])

    # ---- rendering -----------------------------------------------------------------------
    def render(
        self,
        steps: Sequence[Step],
        blend: str = "crossfade",
        start: GroundTransform | None = None,
        max_frames: int | None = None,
        foot_lock: bool = True,
    ) -> Motion:
        """One continuous Motion from a walk (see the module doc for the blends).

        ``foot_lock``: hold planted feet still over each contact run of the output (Kovar et
        al.'s footskate clean-up, by :func:`mocapkit.ik.lock_feet`): the contacts are the
        clips' own, and across a blend those of the clip whose weight dominates, since a
        blend of two planted feet a few centimetres apart slides between them."""
        if blend not in BLENDS:
            raise ValueError(f"unknown blend {blend!r}; expected one of {', '.join(BLENDS)}")
        if not steps:
            raise ValueError("empty walk")
        g = self.graph
        G = start or GroundTransform(0.0, np.zeros(3), self.up)
        rots: list[np.ndarray] = []
        trans: list[np.ndarray] = []
        flags: list[np.ndarray] = []
        for _k, s in enumerate(steps):
            if s.kind == "clip":
                m = apply_ground_transform(self.motions[s.clip][s.start : s.stop], G)
                rots.append(m.rotations)
                trans.append(m.local_translations())
                flags.append(self.foot_contacts(s.clip).contacts[s.start : s.stop])
                continue
            t = s.index
            n = g.blend
            A = self.motions[int(g.src_clip[t])]
            B = self.motions[int(g.dst_clip[t])]
            i, j = int(g.src_frame[t]), int(g.dst_frame[t])
            Gb = G.compose(self.alignment(t))
            a = apply_ground_transform(A[i : i + n], G)
            b = apply_ground_transform(B[j : j + n], Gb)
            chain = self._chain()
            ra, ta = _to_rep(a.rotations, a.local_translations(), chain)
            rb, tb = _to_rep(b.rotations, b.local_translations(), chain)
            w = _ease(np.arange(1, n + 1) / (n + 1.0))
            fa = self.foot_contacts(int(g.src_clip[t])).contacts[i : i + n]
            fb = self.foot_contacts(int(g.dst_clip[t])).contacts[j : j + n]
            flags.append(np.where((w < 0.5)[:, None], fa, fb))
            if blend == "crossfade":
                r = rot.quat_slerp(ra, rb, w[:, None])
                tr = ta + (tb - ta) * w[:, None, None]
            else:
                q_off = rot.quat_mul(ra[:1], rot.quat_inv(rot.quat_fix_hemisphere(rb[:1], ra[:1])))
                decay = 1.0 - _ease(np.arange(n) / float(n))
                ident = np.broadcast_to(rot.quat_identity(), (n, *q_off.shape[1:]))
                off = rot.quat_slerp(ident, q_off, decay[:, None])
                r = rot.quat_mul(off, rb)
                tr = tb + (ta[:1] - tb[:1]) * decay[:, None, None]
                # chain joints are global: offset positions rotate with them about the pelvis
            r, tr = _from_rep(r, tr, chain, self.motions[0].skeleton)
            rots.append(r)
            trans.append(tr)
            G = Gb
        R = rot.quat_normalize(np.concatenate(rots))
        Tr = np.concatenate(trans)
        K = np.concatenate(flags)
        if max_frames is not None:
            R, Tr, K = R[:max_frames], Tr[:max_frames], K[:max_frames]
        first = self.motions[0]
        sk = first.skeleton
        needs = sk.has_position.copy()
        needs[0] = False
        translations = (
            Tr if needs.any() or any(m.translations is not None for m in self.motions) else None
        )
        out = Motion(sk, R, Tr[:, 0].copy(), first.frame_time, translations)
        if foot_lock and K.shape[1] and K.any():
            fc = self.foot_contacts(0)
            out = lock_feet(out, replace(fc, contacts=K)).motion
        # a ground root (Bandai's joint_Root) follows the walk's ground path and heading
        return ground_root_on_path(out)


def _to_rep(lrot: np.ndarray, ltrans: np.ndarray, chain: list[int]):
    """Local rotations/translations with the chain joints (0 .. pelvis) made global."""
    r = lrot.copy()
    t = ltrans.copy()
    for k in range(1, len(chain)):
        p, j = chain[k - 1], chain[k]
        r[:, j] = rot.quat_mul(r[:, p], lrot[:, j])
        t[:, j] = t[:, p] + rot.quat_apply(r[:, p], ltrans[:, j])
    return r, t


def _from_rep(r: np.ndarray, t: np.ndarray, chain: list[int], sk) -> tuple:
    """Inverse of :func:`_to_rep` (chain translations of joints without position channels
    are reset to their offsets)."""
    lr = r.copy()
    lt = t.copy()
    for k in range(len(chain) - 1, 0, -1):
        p, j = chain[k - 1], chain[k]
        inv = rot.quat_inv(r[:, p])
        lr[:, j] = rot.quat_mul(inv, r[:, j])
        if sk.has_position[j]:
            lt[:, j] = rot.quat_apply(inv, t[:, j] - t[:, p])
        else:
            lt[:, j] = sk.offsets[j]
    return rot.quat_normalize(lr), lt


def _compose(g1: tuple[float, float, float], g2: tuple[float, float, float]):
    """2-D ground transform ``g1 after g2`` (angle, tx, tz); R(x, z) = (x c + z s, -x s + z c)."""
    a1, x1, z1 = g1
    a2, x2, z2 = g2
    c, s = math.cos(a1), math.sin(a1)
    return (a1 + a2, x2 * c + z2 * s + x1, -x2 * s + z2 * c + z1)


def _apply2(g: tuple[float, float, float], p: np.ndarray) -> np.ndarray:
    a, tx, tz = g
    c, s = math.cos(a), math.sin(a)
    return np.stack([p[:, 0] * c + p[:, 1] * s + tx, -p[:, 0] * s + p[:, 1] * c + tz], axis=1)


def _cut_at_end(steps: list[Step], last: np.ndarray | None, end: np.ndarray) -> list[Step]:
    """``steps`` cut after the frame, among the walk's last ``len(last)`` frames (planned pelvis
    points ``last``), closest to the path's ``end``; a transition's blend is kept whole."""
    if last is None or len(last) == 0:
        return steps
    cut = len(last) - 1 - int(np.argmin(np.linalg.norm(last - end, axis=1)))
    out = list(steps)
    while cut > 0 and len(out) > 1:
        s = out[-1]
        if s.frames <= cut:
            out.pop()
            cut -= s.frames
        else:
            if s.kind == "clip":
                out[-1] = replace(s, stop=s.stop - cut)
            break
    return out


def load_clips(graph: MotionGraph, base: Path | None = None) -> list[Motion]:
    """Read the graph's clips from their paths (relative ones against ``base``)."""
    from mocapkit.io import read_motion

    return [read_motion(p) for p in graph.clip_paths(base)]


def random_walk(
    graph: MotionGraph,
    motions: Sequence[Motion],
    seconds: float,
    seed: int = 0,
    blend: str = "crossfade",
) -> Motion:
    """A seeded random walk of ``seconds``, rendered (exactly ``seconds`` long, rounded)."""
    syn = Synthesizer(graph, motions)
    steps = syn.random_walk(seconds, seed)
    return syn.render(steps, blend, max_frames=max(1, round(seconds * motions[0].fps)))


def follow_path(
    graph: MotionGraph,
    motions: Sequence[Motion],
    path: np.ndarray,
    seed: int = 0,
    blend: str = "crossfade",
    horizon: float = 2.0,
) -> Motion:
    """A rendered walk following the 2-D ground path (see :meth:`Synthesizer.follow_path`);
    warns (:class:`PathNotFollowedWarning`) when :func:`path_error` says it did not follow."""
    syn = Synthesizer(graph, motions)
    steps = syn.follow_path(path, seed, horizon)
    m = syn.render(steps, blend, start=syn.start_transform)
    msg = path_error(m, path, syn.up).warning()
    if msg:
        warnings.warn(msg, PathNotFollowedWarning, stacklevel=2)
    return m


def render(
    graph: MotionGraph, motions: Sequence[Motion], steps: Sequence[Step], blend: str = "crossfade"
) -> Motion:
    """Render a walk (see :meth:`Synthesizer.render`)."""
    return Synthesizer(graph, motions).render(steps, blend)
