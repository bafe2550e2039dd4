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
    root_trajectory,
)
from mocapkit.graph.graph import MotionGraph
from mocapkit.ik import lock_feet

__all__ = [
    "BLENDS",
    "Step",
    "Synthesizer",
    "follow_path",
    "random_walk",
    "render",
]

BLENDS = ("crossfade", "inertialize")


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
    def random_walk(self, seconds: float, seed: int = 0, start: int | None = None) -> list[Step]:
        """A seeded random walk of at least ``seconds`` (uniform choice among out-edges)."""
        if not seconds > 0:
            raise ValueError(f"seconds must be > 0, got {seconds}")
        rng = np.random.default_rng(seed)
        fps = self.motions[0].fps
        need = math.ceil(seconds * fps)
        node = int(rng.integers(len(self.nodes))) if start is None else int(start)
        steps: list[Step] = []
        total = 0
        while total < need:
            choices = self.out[node]
            if not choices:  # cannot happen inside a strongly connected component
                raise RuntimeError(f"dead end at node {self.nodes[node]}")
            e = choices[int(rng.integers(len(choices)))]
            s = self.step_of(e)
            steps.append(s)
            total += s.frames
            node = e["v"]
        return steps

    def follow_path(
        self,
        path: np.ndarray,
        seed: int = 0,
        horizon: float = 2.0,
        max_branches: int = 3000,
        max_seconds: float | None = None,
    ) -> list[Step]:
        """A walk whose pelvis follows the ground path (M, 2) (ground coordinates, file units).

        Bounded search (Kovar et al. 2002): from the current node, every edge sequence up to
        ``horizon`` seconds (at most ``max_branches`` sequences) is scored by the summed squared
        distance between the character's pelvis after travelling arc length s and the path's
        point at arc length s; the first edge of the best sequence is taken, until the
        character has travelled the path's length (or ``max_seconds``, default 3 x the path's
        length at the clips' mean speed, at least 10 s). The walk starts at a seeded random node
        placed at the path's first point, facing along it: render it with
        ``start=self.start_transform``."""
        path = np.asarray(path, dtype=np.float64)
        if path.ndim != 2 or path.shape[1] != 2 or len(path) < 2:
            raise ValueError("path must be (M >= 2, 2) ground points")
        seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        L = float(arc[-1])
        if not L > 0:
            raise ValueError("the path has zero length")
        fps = self.motions[0].fps
        H = max(1, round(horizon * fps))
        speeds = [
            np.linalg.norm(np.diff(t, axis=0), axis=1).sum() / max(len(t) - 1, 1) * fps
            for t in self._traj
        ]
        mean_speed = max(float(np.mean(speeds)), 1e-9)
        limit = max_seconds if max_seconds is not None else max(10.0, 3.0 * L / mean_speed)
        rng = np.random.default_rng(seed)

        def at(s: np.ndarray) -> np.ndarray:
            s = np.clip(s, 0.0, L)
            return np.stack([np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])], 1)

        def piece(e: dict, G: tuple[float, float, float]):
            """Ground pelvis points of an edge under G=(angle, tx, tz), and the G after it."""
            s = self.step_of(e)
            if s.kind == "transition":
                T = self.alignment(s.index)
                G = _compose(G, (T.angle, *T.translation_2d))
            p = _apply2(G, self._traj[s.clip][s.start : s.stop])
            return p, G

        # start: a random node, placed at the path's start facing along it
        node = int(rng.integers(len(self.nodes)))
        c, f = self.nodes[node]
        d = path[1] - path[0]
        ang = math.atan2(d[0], d[1]) - float(self._head[c][f])
        R = _apply2((ang, 0.0, 0.0), self._traj[c][f : f + 1])[0]
        G = (ang, path[0, 0] - R[0], path[0, 1] - R[1])
        last = _apply2(G, self._traj[c][f : f + 1])[0]
        s_done = 0.0
        steps: list[Step] = []
        frames = 0
        while s_done < L - 1e-9 and frames < limit * fps:
            best = (np.inf, None)
            stack = [(node, G, last, s_done, 0, 0.0, None)]
            count = 0
            while stack:
                n, g, lp, sd, fr, err, first = stack.pop()
                outs = self.out[n]
                for e in outs:
                    count += 1
                    p, g2 = piece(e, g)
                    if len(p) == 0:
                        continue
                    pts = np.concatenate([lp[None], p])
                    sarr = sd + np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))
                    take = min(len(p), H - fr)
                    e_err = err + float(np.sum((p[:take] - at(sarr[:take])) ** 2))
                    f0 = first if first is not None else e
                    if fr + len(p) >= H or count >= max_branches or sarr[-1] >= L:
                        score = e_err / max(min(fr + len(p), H), 1)
                        if score < best[0]:
                            best = (score, f0)
                    else:
                        stack.append((e["v"], g2, p[-1], float(sarr[-1]), fr + len(p), e_err, f0))
                if count >= max_branches:
                    stack.clear()
            e = best[1] if best[1] is not None else self.out[node][0]
            p, G = piece(e, G)
            pts = np.concatenate([last[None], p])
            s_done += float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
            last = p[-1] if len(p) else last
            steps.append(self.step_of(e))
            frames += steps[-1].frames
            node = e["v"]
        self.start_transform = _start_transform(ang, path, self._traj[c][f], self.up)
        return steps

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


def _start_transform(angle: float, path: np.ndarray, pelvis: np.ndarray, up: str):
    R = _apply2((angle, 0.0, 0.0), pelvis[None])[0]
    return GroundTransform.from_2d(angle, (path[0, 0] - R[0], path[0, 1] - R[1]), up)


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
    """A rendered walk following the 2-D ground path (see :meth:`Synthesizer.follow_path`)."""
    syn = Synthesizer(graph, motions)
    steps = syn.follow_path(path, seed, horizon)
    return syn.render(steps, blend, start=syn.start_transform)


def render(
    graph: MotionGraph, motions: Sequence[Motion], steps: Sequence[Step], blend: str = "crossfade"
) -> Motion:
    """Render a walk (see :meth:`Synthesizer.render`)."""
    return Synthesizer(graph, motions).render(steps, blend)
