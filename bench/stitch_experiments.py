"""The experiments of Li et al., "Laziness is a virtue" (Sec. 3), reproduced with mocapkit.stitch.

Usage::

    python bench/stitch_experiments.py [--out DIR] [--data DIR] [--clips N] [--json]

Prints two tables and writes PNG figures into ``--out`` (default: a folder under the system
temporary directory; nothing is written into the repository):

1. **Three-Circles** (Fig. 1 and 4). Query AB = the last 17 frames of the large circle (64
   frames per cycle, radius 20), take-off at B; data = the "forward" (centre (30, 10), clockwise)
   and "backward" (centre (30, -10), counter-clockwise) circles, one cycle each. The 2-D points
   are the features (m = 2); every landing frame and k = 0..30 are searched, w = 5. Reported per
   direction: landing, k_opt, L*, the windowed Euclidean distance of that window, and the best
   landing and distance when ranking by windowed Euclidean distance instead. The paper: the
   forward stitch scores lower and needs fewer injected frames (k = 3 vs 6), while Euclidean
   distance gives both the same cost. Figures: ``three_circles_lk.png`` (L_k vs k at the best
   landing of each, Fig. 4 left) and ``three_circles_paths.png`` (the transitions, Fig. 4 right).

2. **Blank-out** (Fig. 5, with the LaFAN1 in-betweening protocol). On bandai1 takes (waving
   "byebye"/"bye", walk, run, dash, guide...; 30 fps, cm), at three cut points per take (35 %,
   50 %, 65 % of its length), g = 2, 5, 11, 15, 30 frames after the take-off frame a are removed;
   the query is frames 0..a and the data clip frames a+g+1.., the landing frame (0 of the data
   clip, i.e. a+g+1 of the take) is given and k is searched in 0..30 (1 s). The two parts stay
   where they were recorded (no ground alignment: they are one take). Reported per g: k_opt
   (mean, median, range) and the mean joint-position error (cm, global positions by forward
   kinematics, the 21 body joints, averaged over the generated frames and the cases) of

   * ``L* (k_opt)``: the Kalman transition with the chosen k_opt; when k_opt != g its frames are
     resampled in time onto the g removed frames (positions, linearly, take-off and landing frames
     included as the ends) so that they can be compared;
   * ``Kalman (k=g)``: the same smoother given the true g;
   * ``slerp``: root lerp + quaternion slerp of every joint between frames a and a+g+1 (the
     LaFAN1 interpolation baseline); ``linear``: root lerp + component-wise linear interpolation
     of the quaternions (renormalised); both given the true g;
   * ``Kalman aligned``: as ``Kalman (k=g)`` but with the data clip re-placed by the stitcher's
     ground alignment (what a stitch of two different takes does), to show that heuristic's cost.

   The paper (2 waving circles, 93-D positions): k_opt = 2 for g = 2 and 14 for g = 11. Figure:
   ``blank_out.png`` (a right-hand coordinate around the gap for g = 2 and 11 on a waving take).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent
GAPS = (2, 5, 11, 15, 30)
CLIP_PATTERNS = (
    "byebye_normal",
    "bye_normal",
    "walk_normal",
    "run_normal",
    "dash_normal",
    "guide_normal",
    "byebye_happy",
    "walk_tired",
)


def _mocapkit():
    try:
        import mocapkit  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(REPO_ROOT / "src"))


def shared_root() -> Path:
    env = os.environ.get("MOCAPKIT_SHARED")
    return Path(env).expanduser() if env else REPO_ROOT.parent / "shared"


# ------------------------------------------------------------------------------ Three-Circles


def three_circles_experiment(out: Path) -> list[dict]:
    from mocapkit import datasets
    from mocapkit.stitch import elastic_lscore, search_features, sliding_windows
    from mocapkit.viz.figures import pyplot
    from mocapkit.viz.figures.stitch import plot_paths_2d

    tc = datasets.three_circles()
    rows, curves, lk = [], {}, {}
    for which, color in (("forward", "g"), ("backward", "m")):
        q, d = tc.pair(which)
        a = len(q) - 1
        r = search_features(q, a, d, k_max=30)
        e = search_features(q, a, d, k_max=30, score="euclidean")
        win = sliding_windows(q, a, d, 5, landings=[r.landing])[0]
        traj = elastic_lscore(win, k_max=30).trajectory
        rows.append(
            {
                "data": which,
                "landing": r.landing,
                "k_opt": r.k,
                "lstar": r.lscore,
                "euclidean_at_landing": r.euclidean,
                "euclid_best_landing": e.landing,
                "euclid_best": e.euclidean,
                "lstar_at_euclid_best": e.lscore,
                "point_distance": float(np.linalg.norm(q[-1] - d[0])),
            }
        )
        lk[which] = r.lscore_by_k
        curves[f"data {which}"] = (d, f"{color}.")
        curves[f"generated {which} (k={r.k})"] = (traj[5 : 5 + r.k], f"{color}^")
        curves[f"landing {which}"] = (d[r.landing : r.landing + 1], f"{color}o")
    curves = {"large circle": (tc.large, "k,"), "query AB": (tc.query, "kd"), **curves}
    curves["take-off B"] = (tc.query[-1:], "r^")
    plot_paths_2d(out / "three_circles_paths.png", curves, "Three-Circles: elastic L-score")
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    for which, L in lk.items():
        ax.plot(np.arange(len(L)), L, ".-", label=f"{which} (k_opt = {int(np.argmin(L))})")
    ax.set_xlabel("k (injected frames)")
    ax.set_ylabel("L_k at the best landing")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "three_circles_lk.png", dpi=110)
    plt.close(fig)
    return rows


def print_three_circles(rows: list[dict]) -> None:
    print("Three-Circles (64 frames/cycle, w = 5, k = 0..30, every landing searched)")
    print(
        "| data | landing | k_opt | L* | win. Euclid. (same window) | best by Euclid.: landing,"
        " distance, L* | |B - landing pt| |"
    )
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['data']} | {r['landing']} | {r['k_opt']} | {r['lstar']:.4f} | "
            f"{r['euclidean_at_landing']:.2f} | {r['euclid_best_landing']}, "
            f"{r['euclid_best']:.2f}, {r['lstar_at_euclid_best']:.4f} | "
            f"{r['point_distance']:.3f} |"
        )
    print()


# ------------------------------------------------------------------------------ blank-out


def _resample(pos: np.ndarray, k: int, g: int) -> np.ndarray:
    """Frames a..a+k+1 (k+2, J, 3) resampled at the g inner times of a..a+g+1 (linear)."""
    u_src = np.arange(k + 2) / (k + 1)
    u_dst = (np.arange(g) + 1.0) / (g + 1)
    flat = pos.reshape(k + 2, -1)
    out = np.stack([np.interp(u_dst, u_src, flat[:, c]) for c in range(flat.shape[1])], axis=1)
    return out.reshape(g, *pos.shape[1:])


def blank_out_experiment(folder: Path, n_clips: int, out: Path) -> tuple[list[dict], list[str]]:
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.io import read_motion
    from mocapkit.stitch import body_joints, find_transition, interpolate_gap, stitch_motions

    files = []
    for pat in CLIP_PATTERNS:
        files += sorted(folder.glob(f"*_{pat}_*.bvh"))[:1]
    files = files[:n_clips]
    if not files:
        raise SystemExit(f"no bandai1 takes found in {folder}")
    cases = []
    fig_data = {}
    for f in files:
        m = read_motion(f)
        P, _ = forward_kinematics(m)
        body = body_joints(m.skeleton)
        F = m.num_frames
        for frac in (0.35, 0.5, 0.65):
            a = round(frac * F)
            for g in GAPS:
                if a < 5 or a + 1 + g + 5 > F:
                    continue
                b = a + 1 + g
                q, d = m[: a + 1], m[b:]
                truth = P[a + 1 : b][:, body]
                tr = find_transition(q, a, d, landing=0, up="Y")
                err = {}
                s = stitch_motions(q, a, d, 0, tr.k, align=False, up="Y")
                Ps, _ = forward_kinematics(s.motion[a : a + tr.k + 2])
                err["lstar"] = np.linalg.norm(_resample(Ps, tr.k, g)[:, body] - truth, axis=-1)
                for key, res in (
                    ("kalman_g", stitch_motions(q, a, d, 0, g, align=False, up="Y")),
                    ("slerp", interpolate_gap(q, d, a, 0, g, "slerp", align=False, up="Y")),
                    ("linear", interpolate_gap(q, d, a, 0, g, "linear", align=False, up="Y")),
                    ("kalman_aligned", stitch_motions(q, a, d, 0, g, align=True, up="Y")),
                ):
                    Pg, _ = forward_kinematics(res.motion[res.generated])
                    err[key] = np.linalg.norm(Pg[:, body] - truth, axis=-1)
                    first = frac == 0.5 and g in (2, 11) and g not in fig_data
                    if key == "kalman_g" and first and "bye" in f.name:
                        fig_data[g] = (f.name, a, m, s, tr.k)
                cases.append(
                    {
                        "clip": f.name,
                        "a": a,
                        "g": g,
                        "k_opt": tr.k,
                        "lstar": tr.lscore,
                        **{f"err_{k}": float(v.mean()) for k, v in err.items()},
                    }
                )
    _blank_out_figure(fig_data, out)
    return cases, [f.name for f in files]


def _blank_out_figure(fig_data: dict, out: Path) -> None:
    if not fig_data:
        return
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.viz.figures import pyplot

    plt = pyplot()
    fig, axes = plt.subplots(1, len(fig_data), figsize=(6 * len(fig_data), 4), squeeze=False)
    for ax, (g, (name, a, m, s_opt, k)) in zip(axes[0], sorted(fig_data.items()), strict=True):
        lo, hi = a - 12, a + g + 14
        P, _ = forward_kinematics(m[lo:hi])
        # the joint coordinate that moves most over the gap (the waving hand, usually)
        ptp = np.ptp(P[12 : 12 + g + 2], axis=0)
        j, c = np.unravel_index(int(np.argmax(ptp)), ptp.shape)
        t = np.arange(lo, hi)
        Po, _ = forward_kinematics(s_opt.motion[lo : a + k + 2])
        ax.plot(t, P[:, j, c], "--", color="0.5", label="ground truth")
        ax.plot(np.arange(lo, a + k + 2), Po[:, j, c], "-", color="C0", lw=0.8, label="stitched")
        ax.plot(
            np.arange(a + 1, a + 1 + k),
            Po[a + 1 - lo :, j, c][:k],
            "rd",
            ms=4,
            label=f"generated (k_opt = {k})",
        )
        ax.plot([a], [P[a - lo, j, c]], "k^", label="take-off")
        ax.plot([a + g + 1], [P[a + g + 1 - lo, j, c]], "ko", mfc="none", label="landing")
        ax.set_title(f"{name}: {m.skeleton.names[j]} {'xyz'[c]}, g = {g} removed", fontsize=9)
        ax.set_xlabel("frame (take)")
        ax.set_ylabel("cm")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "blank_out.png", dpi=110)
    plt.close(fig)


def blank_out_table(cases: list[dict]) -> list[dict]:
    rows = []
    for g in GAPS:
        cs = [c for c in cases if c["g"] == g]
        if not cs:
            continue
        ks = np.array([c["k_opt"] for c in cs])
        wave = [c["k_opt"] for c in cs if "bye" in c["clip"]]
        row = {
            "g": g,
            "cases": len(cs),
            "k_opt_mean": float(ks.mean()),
            "k_opt_median": float(np.median(ks)),
            "k_opt_min": int(ks.min()),
            "k_opt_max": int(ks.max()),
            "k_opt_waving": wave,
        }
        for key in ("lstar", "kalman_g", "slerp", "linear", "kalman_aligned"):
            row[f"err_{key}"] = float(np.mean([c[f"err_{key}"] for c in cs]))
        rows.append(row)
    return rows


def print_blank_out(rows: list[dict], clips: list[str]) -> None:
    print(f"Blank-out on bandai1 ({len(clips)} takes: {', '.join(clips)}; 3 cut points each)")
    print("Mean joint-position error of the generated frames vs the removed ones (cm, 21 joints)")
    print(
        "| g | cases | k_opt mean / median [min-max] | k_opt on waving takes |"
        " L* (k_opt, resampled) | Kalman (k=g) |"
        " slerp (g) | linear (g) | Kalman aligned (k=g) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['g']} | {r['cases']} | {r['k_opt_mean']:.1f} / {r['k_opt_median']:.0f} "
            f"[{r['k_opt_min']}-{r['k_opt_max']}] | {r['k_opt_waving']} | {r['err_lstar']:.2f} | "
            f"{r['err_kalman_g']:.2f} | {r['err_slerp']:.2f} | {r['err_linear']:.2f} | "
            f"{r['err_kalman_aligned']:.2f} |"
        )
    print()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "mocapkit_stitch")
    ap.add_argument("--data", type=Path, default=None, help="bandai1 folder of BVH takes")
    ap.add_argument("--clips", type=int, default=len(CLIP_PATTERNS))
    ap.add_argument("--skip-blank-out", action="store_true")
    ap.add_argument("--json", action="store_true", help="print the tables as JSON")
    args = ap.parse_args(argv)
    _mocapkit()
    args.out.mkdir(parents=True, exist_ok=True)
    result: dict = {"three_circles": three_circles_experiment(args.out)}
    if not args.json:
        print_three_circles(result["three_circles"])
    if not args.skip_blank_out:
        folder = args.data or shared_root() / "data" / "bandai1" / "data"
        cases, clips = blank_out_experiment(folder, args.clips, args.out)
        result["blank_out"] = blank_out_table(cases)
        result["blank_out_cases"] = cases
        if not args.json:
            print_blank_out(result["blank_out"], clips)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(f"figures in {args.out}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
