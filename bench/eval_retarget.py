"""Retargeting figures, CMU ASF/AMC <-> Bandai, on takes not used while tuning.

Tuning used CMU 03_01/03_02/01_01 and the Bandai walk_normal_001 takes (both sets), bandai2
wave-both-hands_normal_005 and bandai1 walk-right_normal_001; this script measures others.
Per take: foot slide during the source's detected contacts (mean / max, cm) for the source, the
output without IK and the output with IK; the IK's residual on fully locked frames (cm mean /
max); effector path error (% of limb length, pelvis-relative,
mean offset removed; and uncentred); knee/elbow frames bent backwards (source -> output); the
largest shortfall of an effector goal out of reach (cm).

    .venv/bin/python bench/eval_retarget.py
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from mocapkit.edit.retarget import read_target, retarget
from mocapkit.io import read_motion

SHARED = Path(os.environ.get("MOCAPKIT_SHARED", Path(__file__).resolve().parents[2] / "shared"))
DATA = SHARED / "data"
# the last two per direction were added later, picked before any run on them, and the two
# after those (01_04, 01_14; raise-up-right-hand_active_005, bye_happy_001) likewise, for the
# per-effector head/wrist work (tuned on 03_01/03_02/01_01 and the tuning Bandai takes)
CMU_TAKES = [
    "03/03_03.amc",
    "03/03_04.amc",
    "01/01_02.amc",
    "01/01_05.amc",
    "01/01_07.amc",
    "01/01_11.amc",
    "01/01_04.amc",
    "01/01_14.amc",
]
BANDAI_TAKES = [
    "bandai2/data/dataset-2_walk_active_005.bvh",
    "bandai2/data/dataset-2_walk_elderly_005.bvh",
    "bandai1/data/dataset-1_walk-left_active_001.bvh",
    "bandai1/data/dataset-1_run_normal_001.bvh",
    "bandai1/data/dataset-1_dash_happy_001.bvh",
    "bandai2/data/dataset-2_walk-turn-right_feminine_013.bvh",
    "bandai2/data/dataset-2_raise-up-right-hand_active_005.bvh",
    "bandai1/data/dataset-1_bye_happy_001.bvh",
]
BANDAI_RIG = "bandai2/data/dataset-2_walk_masculine_005.bvh"
CMU_RIG = "cmu-asfamc/03/03.asf"


def _row(direction: str, take: str, res, secs: float) -> str:
    j = res.to_json()
    fs = j["foot_slide_cm"]

    def mm(d):
        return "   n/a      " if d["mean"] is None else f"{d['mean']:5.2f}/{d['max']:5.2f}"

    e = j["effector_path_error_pct"]
    unc = sum(v["uncentred_mean"] for v in e["per_effector"].values()) / len(e["per_effector"])
    lim = j["joint_limits"]["per_joint"]
    src_v = sum(v["source_frames_bent_backwards"] for v in lim.values())
    out_v = sum(v["output_frames_bent_backwards"] for v in lim.values())
    res_ik = j["ik_residual_cm"] or {"mean": None}
    worst = max(e["per_effector"].items(), key=lambda kv: kv[1]["mean"])
    # the largest distance an effector goal (head, wrists) was out of reach
    short = max((v["max_shortfall_cm"] for v in j["effector_goals"]["clamped"].values()), default=0)
    return (
        f"{direction:12s} {take:44s} {mm(fs['source'])}  {mm(fs['output_without_ik'])}  "
        f"{mm(fs['output'])}  {mm(res_ik)}  {e['mean']:5.2f}  {worst[1]['mean']:5.2f} "
        f"{worst[0]:11s} {unc:5.1f}  {src_v:4d}->{out_v:<4d} {short:5.2f}  {secs:5.2f}"
    )


def main() -> None:
    print(
        f"{'direction':12s} {'take':44s} {'src slide':11s}  {'no-IK':11s}  {'IK':11s}  "
        f"{'IK resid':11s}  {'path%':5s}  {'worst effector %':17s} {'unc%':5s}  "
        f"{'bent-back':9s} {'short':5s}  {'s':>5s}"
    )
    print(f"{'':57s}(cm mean/max for the slides)")
    bandai = read_motion(DATA / BANDAI_RIG)
    for t in CMU_TAKES:
        src = read_motion(DATA / "cmu-asfamc" / t)
        t0 = time.perf_counter()
        res = retarget(src, bandai)
        print(_row("CMU->Bandai", t, res, time.perf_counter() - t0))
    cmu = read_target(DATA / CMU_RIG)
    for t in BANDAI_TAKES:
        src = read_motion(DATA / t)
        t0 = time.perf_counter()
        res = retarget(src, cmu)
        print(_row("Bandai->CMU", Path(t).name, res, time.perf_counter() - t0))


if __name__ == "__main__":
    main()
