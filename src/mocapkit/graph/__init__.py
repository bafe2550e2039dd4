"""Motion graphs (Kovar, Gleicher & Pighin 2002) with the dynamics-based comparison metric of
Matsunaga & Zordan, "A Dynamics-based Comparison Metric for Motion Graphs".

Modules (data flows down the list):

* :mod:`~mocapkit.graph.pointcloud` body parts and their representative points;
* :mod:`~mocapkit.graph.weights` de Leva masses, contacts -> supporting bodies, the three
  weightings ("dynamics", "uniform" = Heuristic 1, "torso" = Heuristic 2);
* :mod:`~mocapkit.graph.distance` the aligned windowed cost: exact per pair, and tiled (BLAS)
  local minima over all frame pairs without holding the N x N matrix;
* :mod:`~mocapkit.graph.select` merging, the knee rule for T, refinement;
* :mod:`~mocapkit.graph.graph` the graph, pruning to the largest strongly connected component,
  JSON / GraphML, its report, synthesis entry point and the two-metric cost comparison;
* :mod:`~mocapkit.graph.synth` random and path-following walks, blended rendering;
* :mod:`~mocapkit.graph.skate` foot skate of the transitions;
* the cost-matrix and rank-curve figures: :mod:`mocapkit.viz.figures.graph`.

Quick start::

    from mocapkit.graph import build_graph, random_walk, transition_skate
    g, db, _ = build_graph(motions, "dynamics", paths=paths)   # T by the knee rule
    g.save("graph.json")
    out = random_walk(g, motions, seconds=30, seed=1)
    print(transition_skate(g, motions).summary())
"""

from mocapkit.graph.distance import (
    CostDatabase,
    build_database,
    cost_matrix,
    cost_tile,
    pair_alignment,
    pair_costs,
    tiled_local_minima,
    window_weights,
)
from mocapkit.graph.graph import (
    CostComparison,
    GraphReport,
    MotionGraph,
    Synthesis,
    build_graph,
    compare_metrics,
    cost_comparison,
    load_graph,
    synthesize,
)
from mocapkit.graph.pointcloud import BodyParts, body_parts, point_cloud
from mocapkit.graph.select import knee_rank, select_transitions
from mocapkit.graph.skate import SkateReport, transition_skate
from mocapkit.graph.synth import Synthesizer, follow_path, random_walk, render
from mocapkit.graph.weights import METRICS, metric_weights, part_masses

__all__ = [
    "METRICS",
    "BodyParts",
    "CostComparison",
    "CostDatabase",
    "GraphReport",
    "MotionGraph",
    "SkateReport",
    "Synthesis",
    "Synthesizer",
    "body_parts",
    "build_database",
    "build_graph",
    "compare_metrics",
    "cost_comparison",
    "cost_matrix",
    "cost_tile",
    "follow_path",
    "knee_rank",
    "load_graph",
    "metric_weights",
    "pair_alignment",
    "pair_costs",
    "part_masses",
    "point_cloud",
    "random_walk",
    "render",
    "select_transitions",
    "synthesize",
    "tiled_local_minima",
    "transition_skate",
    "window_weights",
]
