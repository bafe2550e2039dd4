"""Foot skate of the transitions of a motion graph (the paper's Table 1).

For each transition the blended frames are rendered in isolation (clip B aligned to clip A, as
in synthesis). The supporting feet are the sides (:meth:`FootContacts.by_side`) in contact at
the source frame A[i] and at the target frame B[j] (if none is, those in contact at either).
For each such foot the ankle joint's ground-plane path over the blend gives the start-to-end
distance and the arc length; the transition's skate is the largest over its supporting feet, in
centimetres. Transitions with no supporting foot (both feet in the air) have no skate (NaN) and
are left out of the means.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mocapkit.core.kinematics import forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.features import find_feet, foot_contacts, ground_coordinates, metres_per_unit
from mocapkit.graph.graph import MotionGraph
from mocapkit.graph.synth import Step, Synthesizer

__all__ = ["SkateReport", "transition_skate"]


@dataclass(frozen=True, eq=False)
class SkateReport:
    """Per-transition foot skate (cm): ``start_to_end`` and ``arc_length`` (T,), NaN where no
    foot supports; ``supported`` (T,) bool."""

    start_to_end: np.ndarray
    arc_length: np.ndarray
    supported: np.ndarray

    def subset(self, mask: np.ndarray) -> SkateReport:
        """The report of the transitions selected by ``mask`` (bool, or indices)."""
        return SkateReport(self.start_to_end[mask], self.arc_length[mask], self.supported[mask])

    def summary(self) -> dict:
        s = self.supported

        def stats(v: np.ndarray) -> dict:
            v = v[s]
            if len(v) == 0:
                return {"mean": None, "median": None, "max": None}
            return {"mean": float(v.mean()), "median": float(np.median(v)), "max": float(v.max())}

        return {
            "transitions": len(s),
            "supported": int(s.sum()),
            "start_to_end_cm": stats(self.start_to_end),
            "arc_length_cm": stats(self.arc_length),
        }


def transition_skate(
    graph: MotionGraph,
    motions: Sequence[Motion],
    indices: np.ndarray | None = None,
    blend: str = "crossfade",
    units: str | float | None = None,
    foot_lock: bool = True,
) -> SkateReport:
    """Foot skate of the transitions ``indices`` (default: all) of ``graph``, rendered as
    synthesis renders them (``foot_lock``: with planted feet held, as by default)."""
    syn = Synthesizer(graph, motions, walks=False)
    idx = np.arange(graph.num_transitions) if indices is None else np.asarray(indices)
    sk = motions[0].skeleton
    up = syn.up
    cm = 100.0 * metres_per_unit(motions[0], units)
    feet = find_feet(sk, motions[0], up)
    ankle: dict[str, int] = {}
    for side, j in feet:
        ankle.setdefault(side or f"s{len(ankle)}", j)
    sides = list(ankle)[:2]
    contacts = {}
    for c in set(graph.src_clip[idx].tolist()) | set(graph.dst_clip[idx].tolist()):
        contacts[c] = foot_contacts(motions[c], up=up).by_side()
    ste = np.full(len(idx), np.nan)
    arc = np.full(len(idx), np.nan)
    sup = np.zeros(len(idx), dtype=bool)
    for n, t in enumerate(idx):
        ca, cb = int(graph.src_clip[t]), int(graph.dst_clip[t])
        fa, fb = int(graph.src_frame[t]), int(graph.dst_frame[t])
        ka, kb = contacts[ca][fa], contacts[cb][fb]
        use = ka & kb
        if not use.any():
            use = ka | kb
        if not use.any():
            continue
        m = syn.render([Step("transition", cb, fb, fb + graph.blend, int(t))], blend,
                       foot_lock=foot_lock)  # fmt: skip
        pos, _ = forward_kinematics(m)
        best_s = best_a = 0.0
        for k in np.flatnonzero(use[: len(sides)]):
            p = ground_coordinates(pos[:, ankle[sides[k]]], up)
            best_s = max(best_s, float(np.linalg.norm(p[-1] - p[0])))
            best_a = max(best_a, float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))))
        ste[n], arc[n], sup[n] = best_s * cm, best_a * cm, True
    return SkateReport(ste, arc, sup)
