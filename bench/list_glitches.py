"""The second, third and fourth signals of the blind glitch list of the raw CMU takes
(tests/clean/fixtures).

Runs ``find_excursions`` (bench/eval_clean.py: short out-and-back excursions of a joint off its
own running-median trajectory) on every raw CMU take and lists its events that do not overlap a
step-signal entry (same take and joint, overlapping frames) as ``"signal": "excursion"``
entries; and ``find_holds`` (dropouts: a joint's rotation repeated exactly for 50 ms or more)
as ``"signal": "hold"`` entries, all of them (a hold names the held frames, which the step
signal's entry for the jump out of a dropout does not); and ``find_jitter`` (a joint rough
off its own 10 Hz path, 2 deg RMS or more) as ``"signal": "jitter"`` entries, all of them (a
jitter entry names the whole rough stretch around the pops the other signals list). The
motion data and those signals only: nothing of mocapkit.clean is run, and no evaluation
output is read. An event already listed by an earlier run of this script keeps its eye
verdict (``inspected``, ``glitch``, ``seen``); a new one is listed as not inspected, and
events starting in the first 20 s of their take (for the jitter signal, of the takes
bench/eval_clean.py analyses: ``EVAL_TAKES``) must then be judged by eye before the list is
committed (tests/clean/test_glitch_list.py checks it).

    PYTHONPATH=src .venv/bin/python bench/list_glitches.py           # counts only
    PYTHONPATH=src .venv/bin/python bench/list_glitches.py --write   # rewrite their entries
"""

from __future__ import annotations

import argparse
import glob
import importlib.util
import json
import os
from pathlib import Path

from mocapkit.io import read_motion

ROOT = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("MOCAPKIT_SHARED", ROOT.parent / "shared")) / "data"
FIXTURE = ROOT / "tests" / "clean" / "fixtures" / "cmu_glitches.json"
EARLY_FRAMES = 2400  # the first 20 s at 120 fps: the part bench/eval_clean.py analyses
NOT_INSPECTED = "not inspected: listed by the signal alone"
# the CMU takes bench/eval_clean.py analyses by default (four per class spread over those of
# 5 s or more: 03 has two; tests/clean/test_glitch_list.py checks it): the jitter signal lists
# ~2,000 events in the first 20 s of all takes; those of these six were judged by eye
EVAL_TAKES = ("01_01", "01_05", "01_10", "01_14", "03_03", "03_04")
SIGNALS = {"excursion": "find_excursions", "hold": "find_holds", "jitter": "find_jitter"}


def _eval_clean():
    spec = importlib.util.spec_from_file_location("eval_clean", ROOT / "bench" / "eval_clean.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def overlaps(e: dict, g: dict) -> bool:
    return (
        e["joint"] == g["joint"]
        and g["frames"][0] <= e["frames"][1]
        and e["frames"][0] <= g["frames"][1]
    )


def signal_entries(doc: dict, takes: list[str], signal: str) -> list[dict]:
    """The entries of ``signal`` ("excursion": ``find_excursions``, not overlapping a
    step-signal entry; "hold": ``find_holds`` and "jitter": ``find_jitter``, all) for the CMU
    takes at ``takes`` (paths), with the measure the signal reports, eye verdicts carried over
    from ``doc``."""
    find = getattr(_eval_clean(), SIGNALS[signal])
    step = [g for g in doc["glitches"] if "signal" not in g]
    known = {
        (g["take"], g["joint"], tuple(g["frames"])): g
        for g in doc["glitches"]
        if g.get("signal") == signal
    }
    kw = {k: v for k, v in doc[f"criterion_{signal}"].items() if k != "signal"}
    out = []
    for path in takes:
        take = Path(path).stem
        listed = [g for g in step if g["take"] == take] if signal == "excursion" else []
        for e in find(read_motion(path), **kw):
            if any(overlaps(e, g) for g in listed):
                continue
            old = known.get((take, e["joint"], tuple(e["frames"])), {})
            measure = {k: v for k, v in e.items() if k not in ("joint", "frames")}
            out.append(
                {"take": take, "joint": e["joint"], "frames": e["frames"], "signal": signal,
                 **measure, "inspected": old.get("inspected", False),
                 "glitch": old.get("glitch", True), "seen": old.get("seen", NOT_INSPECTED)}
            )  # fmt: skip
    return out


def must_judge(g: dict) -> bool:
    """Whether an entry must carry an eye verdict: it starts in the first 20 s of its take
    (of a take bench/eval_clean.py analyses, for the jitter signal)."""
    early = g["frames"][0] < EARLY_FRAMES
    return early and (g.get("signal") != "jitter" or g["take"] in EVAL_TAKES)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="rewrite the entries of the later signals")
    args = ap.parse_args()
    doc = json.loads(FIXTURE.read_text())
    d = SHARED / "cmu-asfamc"
    takes = sorted(glob.glob(str(d / "01" / "*.amc"))) + sorted(glob.glob(str(d / "03" / "*.amc")))
    found = {name: signal_entries(doc, takes, name) for name in SIGNALS}
    for name, entries in found.items():
        for take in sorted({g["take"] for g in entries}):
            ev = [g for g in entries if g["take"] == take]
            early = [g for g in ev if must_judge(g)]
            print(
                f"{name} {take}: {len(ev)} events, {len(early)} in the first 20 s, "
                f"{sum(g['inspected'] for g in early)} inspected, "
                f"{sum(g['inspected'] and not g['glitch'] for g in ev)} rejected"
            )
        todo = [g for g in entries if must_judge(g) and not g["inspected"]]
        print(f"{len(entries)} {name} events; {len(todo)} early ones still to judge by eye")
    if args.write:
        doc["glitches"] = [g for g in doc["glitches"] if "signal" not in g] + [
            g for name in SIGNALS for g in found[name]
        ]
        FIXTURE.write_text(json.dumps(doc, indent=1))
        print(f"wrote {FIXTURE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
