"""How the reasons of cleaning flags (the ``name`` of each rule of
:data:`mocapkit.clean.detect.PIPELINE`) are shown: one colour and one short phrase each, shared
by the heat map's decision panel and the library overview page (no plotting import here)."""

from __future__ import annotations

__all__ = ["REASON_COLOURS", "REASON_TEXT", "reason_colour"]

REASON_COLOURS = {
    "mdm": "#d62728",
    "cancelling-jumps": "#ff7f0e",
    "spike": "#e377c2",
    "frozen": "#1f77b4",
    "noise": "#9467bd",
    "wrong-way-hinge": "#8c564b",
    "extend": "#f7b6d2",
    "bridge": "#17becf",  # not grey: the MDM below is in greys
}
"""Colour of each rule's cells (others: :data:`OTHER_COLOURS` in order of appearance)."""

OTHER_COLOURS = ("#bcbd22", "#2ca02c", "#7f7f7f", "#393b79")

REASON_TEXT = {
    "mdm": "moves unlike its nearest neighbours in the context (MDM above the threshold)",
    "cancelling-jumps": "jumps away and back (a pop)",
    "spike": "leaves its smooth path and comes back within 1/15 s (a spike)",
    "frozen": "holds still while the body moves",
    "noise": "a burst of jitter",
    "wrong-way-hinge": "a knee or elbow bent the wrong way",
    "extend": "widened to the step where the error starts",
    "bridge": "a hole of a frame or two between two flagged runs, closed",
}
"""What a flag of each rule means, in a few words (a legend line)."""


def reason_colour(reason: str, seen: list[str]) -> str:
    """The colour of ``reason``; a reason without its own colour takes the next of
    :data:`OTHER_COLOURS` (by its place in ``seen``, the reasons met so far, which it joins)."""
    if reason in REASON_COLOURS:
        return REASON_COLOURS[reason]
    if reason not in seen:
        seen.append(reason)
    return OTHER_COLOURS[seen.index(reason) % len(OTHER_COLOURS)]
