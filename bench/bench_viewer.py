"""Viewer playback rate: a 10,000-frame x 60-joint motion played in headless Chromium.

Builds the page (timing FK + page writing), opens it in headless Chromium (DevTools protocol,
see mocapkit.viz.browser), starts playback and measures the requestAnimationFrame rate over a
few seconds of wall clock (every rAF callback updates the pose and renders; the motion is at
60 fps so the frame changes on every callback). Target: >= 30 fps.

    PYTHONPATH=src .venv/bin/python bench/bench_viewer.py [--frames 10000] [--joints 60]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.core.rotations import euler_to_quat
from mocapkit.core.skeleton import Skeleton


def synthetic_motion(frames: int, joints: int, fps: float = 60.0, seed: int = 0) -> Motion:
    """A walking-sized tree of ``joints`` joints (five chains from the root, cm units) with
    smooth random rotations and a root that walks forward."""
    rng = np.random.default_rng(seed)
    parents, offsets = [-1], [[0.0, 95.0, 0.0]]
    dirs = np.array([[0, 1, 0], [-1, 0.2, 0], [1, 0.2, 0], [-0.3, -1, 0], [0.3, -1, 0]], float)
    chains = np.array_split(np.arange(1, joints), 5)
    for c, idx in enumerate(chains):
        prev = 0
        for _ in idx:
            parents.append(prev)
            offsets.append((dirs[c] / np.linalg.norm(dirs[c]) * (90.0 / max(1, len(idx)))).tolist())
            prev = len(parents) - 1
    names = [f"j{j}" for j in range(joints)]
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")]
    channels += [("Zrotation", "Xrotation", "Yrotation")] * (joints - 1)
    sk = Skeleton(names, np.array(parents), np.array(offsets), tuple(channels))
    t = np.arange(frames) / fps
    amp = rng.uniform(5, 25, (1, joints, 3))
    freq = rng.uniform(0.5, 2.0, (1, joints, 3))
    phase = rng.uniform(0, 2 * np.pi, (1, joints, 3))
    angles = np.radians(amp * np.sin(2 * np.pi * freq * t[:, None, None] + phase))
    rot = euler_to_quat(angles, "ZXY")
    root = np.stack([np.zeros(frames), 95 + 2 * np.sin(4 * np.pi * t), 120.0 * t], axis=1)
    return Motion(sk, rot, root, 1.0 / fps)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--joints", type=int, default=60)
    ap.add_argument("--seconds", type=float, default=4.0, help="measurement window")
    ap.add_argument("--keep", help="also write the page here")
    ap.add_argument("--shot", help="save a screenshot (PNG) of the playing page here")
    ap.add_argument(
        "--no-mdm", action="store_true", help="without the cleaning overlay (MDM heat map)"
    )
    args = ap.parse_args(argv)

    from mocapkit.viz import ViewMotion, write_page
    from mocapkit.viz.browser import Browser, find_chromium

    m = synthetic_motion(args.frames, args.joints)
    with tempfile.TemporaryDirectory() as tmp:
        page = Path(args.keep) if args.keep else Path(tmp) / "bench_view.html"
        t0 = time.perf_counter()
        kw = {}
        if not args.no_mdm:  # the heaviest page: joints coloured by an MDM, heat map timeline
            rng = np.random.default_rng(1)
            mdm = np.clip(rng.normal(0.1, 0.05, (args.frames, args.joints)), 0, 1)
            segs = []
            for j, a in zip(
                rng.integers(1, args.joints, 20), rng.integers(0, args.frames - 50, 20), strict=True
            ):
                mdm[a : a + 40, j] = 1.0
                segs.append({"joint": f"j{j}", "start": int(a), "end": int(a) + 39, "peak": 1.0})
            kw = {"mdm": mdm.astype(np.float32), "clean_report": {"segments": segs}}
        write_page(page, [ViewMotion(m, "synthetic")], up="Y", units="cm", **kw)
        build_s = time.perf_counter() - t0
        size = page.stat().st_size / 1e6
        print(
            f"page: {args.frames} frames x {args.joints} joints"
            f"{'' if args.no_mdm else ' + MDM overlay'}, {size:.1f} MB, built in {build_s:.2f} s"
        )
        if not find_chromium():
            print("no Chromium found (install chromium or set MOCAPKIT_CHROMIUM)")
            return 2
        with Browser(width=1280, height=900) as b:
            t0 = time.perf_counter()
            b.open(page, ready="window.mocapkitViewer && window.mocapkitViewer.ready")
            print(f"load: {time.perf_counter() - t0:.2f} s")
            b.eval("mocapkitViewer.play()")
            b.sleep(1.0)  # warm-up
            f0 = b.eval("mocapkitViewer.frame")
            b.eval("mocapkitViewer.resetStats()")
            b.sleep(args.seconds)
            st = b.eval("mocapkitViewer.fpsStats()")
            if args.shot:
                Path(args.shot).write_bytes(b.screenshot())
            f1 = b.eval("mocapkitViewer.frame")
            renderer = b.eval(
                "(() => { const g = document.createElement('canvas').getContext('webgl');"
                " const e = g && g.getExtension('WEBGL_debug_renderer_info');"
                " return e ? g.getParameter(e.UNMASKED_RENDERER_WEBGL) : 'unknown'; })()"
            )
            errors = b.errors + b.eval("window.__mkErrors")
        print(f"renderer: {renderer}")
        print(
            f"playback: {st['fps']:.1f} fps (requestAnimationFrame, {st['frames']} callbacks in "
            f"{st['ms'] / 1000:.2f} s, worst gap {st['worstMs']:.0f} ms); motion advanced "
            f"{(f1 - f0) % args.frames} frames"
        )
        if errors:
            print("page errors:", *errors, sep="\n  ")
            return 1
        print("PASS (>= 30 fps)" if st["fps"] >= 30 else "BELOW TARGET (< 30 fps)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
