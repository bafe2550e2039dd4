"""Forward-kinematics throughput on one core: mocapkit side by side with upc-pymotion.

Usage::

    python bench/bench_fk.py [--data DIR] [--json] [--repeats N] [--files N]

Input: the shared bandai1 takes (22 joints, 6 channels on every joint), read once with mocapkit.
Both implementations get the same local quaternions (w,x,y,z) and local translations and return
global positions and rotations of every joint in every frame:

* ``mocapkit``      ``forward_kinematics(motion)``.
* ``upc-pymotion``  ``pymotion.ops.skeleton_np.fk_quat(rotations, root_positions, translations,
                    parents)`` (its quaternion FK; its matrix ``fk`` is timed too, for reference).

Two workloads: every take on its own (one call per take, the per-call overhead counts) and one long
clip, all takes concatenated (one call). Throughput is joint-frames per second (frames x joints /
seconds), best of ``--repeats`` passes after one untimed pass. Threads are pinned to 1 (OMP, BLAS,
MKL, numba) before numpy is imported, so the figures are for one core.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402  (the thread variables must be set before numpy is imported)
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parent.parent
TARGET = 5e6  # joint-frames per second


def default_data_dir() -> Path:
    """The shared bandai1 takes, found as the tests find shared data."""
    env = os.environ.get("MOCAPKIT_SHARED")
    root = Path(env).expanduser() if env else REPO_ROOT.parent / "shared"
    return root / "data" / "bandai1" / "data"


def _import_mocapkit() -> Any:
    try:
        import mocapkit  # noqa: F401
    except ImportError:  # run from a checkout without installing: use src/
        sys.path.insert(0, str(REPO_ROOT / "src"))
    from mocapkit.core import kinematics, motion
    from mocapkit.io import bvh

    return kinematics, motion, bvh


def best_of(fn: Callable[[Any], object], items: list[Any], repeats: int) -> float:
    """Seconds for the fastest of ``repeats`` passes over ``items`` (after one untimed pass)."""
    for item in items:
        fn(item)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        for item in items:
            fn(item)
        best = min(best, time.perf_counter() - t0)
    return best


def run(data: Path, repeats: int, max_files: int | None, log: Callable[[str], None]) -> dict:
    kinematics, motion_mod, bvh = _import_mocapkit()
    from pymotion.ops import skeleton_np

    files = sorted(data.glob("*.bvh"))[:max_files]
    if not files:
        raise SystemExit(f"no .bvh files in {data} (use --data DIR, or set MOCAPKIT_SHARED)")
    log(f"reading {len(files)} takes from {data}")
    motions = [bvh.read_bvh(f) for f in files]
    J = motions[0].num_joints
    # One long clip: the takes end to end. Their skeletons differ in a few OFFSETs, but every
    # Bandai joint animates its translation, so the local translations carry all of it and the
    # first take's skeleton serves for the concatenated motion.
    first = motions[0]
    long_clip = motion_mod.Motion(
        first.skeleton,
        np.concatenate([m.rotations for m in motions]),
        np.concatenate([m.root_positions for m in motions]),
        first.frame_time,
        np.concatenate([m.local_translations() for m in motions]),
    )

    def pymotion_inputs(m: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        parents = m.skeleton.parents.copy()
        parents[0] = 0  # pymotion's convention: the root is its own parent
        t = m.local_translations()
        return m.rotations, t[:, 0], t, parents

    def mk(m: Any) -> object:
        return kinematics.forward_kinematics(m)

    def pm_quat(args: tuple) -> object:
        rot, root, trans, parents = args
        return skeleton_np.fk_quat(rot, root, trans, parents)

    def pm_mat(args: tuple) -> object:
        rot, root, trans, parents = args
        return skeleton_np.fk(rot, root, trans, parents)

    # Same answers before timing anything.
    p_mk, _ = kinematics.forward_kinematics(long_clip)
    p_pm, _ = skeleton_np.fk_quat(*pymotion_inputs(long_clip))
    agree = float(np.abs(p_mk - p_pm).max())
    log(f"  max |mocapkit - pymotion| on the long clip: {agree:.2e} units")

    per_take_in = [pymotion_inputs(m) for m in motions]
    long_in = [pymotion_inputs(long_clip)]
    jf_takes = sum(m.num_frames for m in motions) * J
    jf_long = long_clip.num_frames * J
    rows = []
    for workload, jf, mk_items, pm_items in (
        (f"{len(motions)} takes, one call each", jf_takes, motions, per_take_in),
        (f"long clip ({long_clip.num_frames} frames)", jf_long, [long_clip], long_in),
    ):
        timings = {
            "mocapkit": best_of(mk, mk_items, repeats),
            "upc-pymotion fk_quat": best_of(pm_quat, pm_items, repeats),
            "upc-pymotion fk (matrices)": best_of(pm_mat, pm_items, repeats),
        }
        for name, secs in timings.items():
            rows.append(
                {
                    "workload": workload,
                    "impl": name,
                    "joint_frames": jf,
                    "seconds": secs,
                    "joint_frames_per_s": jf / secs,
                }
            )
            log(f"  {workload}: {name}: {jf / secs / 1e6:.2f} M joint-frames/s")
    summary = []
    for workload in dict.fromkeys(r["workload"] for r in rows):
        mine = next(r for r in rows if r["workload"] == workload and r["impl"] == "mocapkit")
        peers = [r for r in rows if r["workload"] == workload and r["impl"] != "mocapkit"]
        fastest = max(peers, key=lambda r: r["joint_frames_per_s"])
        summary.append(
            {
                "workload": workload,
                "mocapkit_joint_frames_per_s": mine["joint_frames_per_s"],
                "fastest_peer": fastest["impl"],
                "ratio_vs_fastest_peer": mine["joint_frames_per_s"] / fastest["joint_frames_per_s"],
                "meets_target": mine["joint_frames_per_s"] >= TARGET,
            }
        )
    return {
        "data": str(data),
        "takes": len(motions),
        "joints": J,
        "threads": 1,
        "max_abs_position_difference": agree,
        "results": rows,
        "summary": summary,
        "target_joint_frames_per_s": TARGET,
    }


def format_table(report: dict) -> str:
    widths = (34, 28, 10, 9, 14)
    head = ("workload", "implementation", "M j-frames", "seconds", "M j-frames/s")

    def line(cells: tuple[str, ...]) -> str:
        return "  ".join(
            c.ljust(w) if i < 2 else c.rjust(w)
            for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        ).rstrip()

    out = [line(head), line(tuple("-" * w for w in widths))]
    for r in report["results"]:
        out.append(
            line(
                (
                    r["workload"],
                    r["impl"],
                    f"{r['joint_frames'] / 1e6:.2f}",
                    f"{r['seconds']:.4f}",
                    f"{r['joint_frames_per_s'] / 1e6:.2f}",
                )
            )
        )
    out.append("")
    for s in report["summary"]:
        flag = "meets" if s["meets_target"] else "BELOW"
        out.append(
            f"{s['workload']}: mocapkit {s['mocapkit_joint_frames_per_s'] / 1e6:.2f} M "
            f"joint-frames/s ({flag} the {report['target_joint_frames_per_s'] / 1e6:.0f} M "
            f"target); ratio vs fastest peer ({s['fastest_peer']}): "
            f"{s['ratio_vs_fastest_peer']:.1f}x"
        )
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--data",
        type=Path,
        default=None,
        help="folder of .bvh takes with one skeleton layout (default: shared bandai1)",
    )
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    ap.add_argument("--repeats", type=int, default=5, help="timed passes (best of)")
    ap.add_argument("--files", type=int, default=None, help="use only the first N takes")
    args = ap.parse_args(argv)
    data = args.data if args.data is not None else default_data_dir()

    def log(msg: str) -> None:
        print(msg, file=sys.stderr if args.json else sys.stdout, flush=True)

    report = run(data, max(1, args.repeats), args.files, log)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print()
        print(format_table(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
