"""The detection state the rules change: which cells are flagged, and which rule said so."""

from __future__ import annotations

import numpy as np


class Flags:
    """(F, J) flagged cells with their provenance.

    ``mask`` is the current decision. ``added[name]`` holds the cells rule ``name`` flagged
    (whether or not they were flagged already), ``removed[name]`` the flagged cells veto
    ``name`` cleared, ``judged[name]`` the decision that veto judged (the mask before it ran:
    ``--explain`` names the run a veto looked at). A cell's reasons are the rules whose flags
    on it stand (:meth:`live`: no veto cleared them after), in pipeline order.
    """

    def __init__(self, shape: tuple[int, int]) -> None:
        self.mask = np.zeros(shape, dtype=bool)
        self.added: dict[str, np.ndarray] = {}
        self.removed: dict[str, np.ndarray] = {}
        self.judged: dict[str, np.ndarray] = {}
        # every call in the order made: (rule, is a veto, the cells it flagged / cleared)
        self._events: list[tuple[str, bool, np.ndarray]] = []
        self._live: dict[str, np.ndarray] = {}  # live() per rule, until the next call

    def flag(self, rule: str, cells: np.ndarray) -> None:
        """Flag ``cells`` ((F, J) bool) on behalf of ``rule``."""
        cells = np.asarray(cells, dtype=bool)
        self._events.append((rule, False, cells.copy()))
        self._live.clear()
        prev = self.added.get(rule)
        self.added[rule] = cells.copy() if prev is None else (prev | cells)
        self.mask |= cells

    def veto(self, rule: str, cells: np.ndarray) -> None:
        """Clear ``cells`` ((F, J) bool) on behalf of the veto ``rule``."""
        cells = np.asarray(cells, dtype=bool)
        if rule not in self.judged:
            self.judged[rule] = self.mask.copy()
        gone = cells & self.mask
        self._events.append((rule, True, gone))
        self._live.clear()
        prev = self.removed.get(rule)
        self.removed[rule] = gone if prev is None else (prev | gone)
        self.mask &= ~cells

    def cells_of(self, rules: tuple[str, ...]) -> np.ndarray:
        """(F, J) bool: every cell any of ``rules`` flagged (a veto's ``spares``)."""
        out = np.zeros(self.mask.shape, dtype=bool)
        for rule in rules:
            if rule in self.added:
                out |= self.added[rule]
        return out

    def live(self, rule: str) -> np.ndarray:
        """(F, J) bool: the cells ``rule`` flagged that no veto running after it cleared (a
        cell cleared and flagged again by a later rule is that rule's, not this one's)."""
        cells = self._live.get(rule)
        if cells is None:  # once per rule: reasons_at asks for every segment
            cells = np.zeros(self.mask.shape, dtype=bool)
            for name, is_veto, changed in self._events:
                if is_veto:
                    cells &= ~changed
                elif name == rule:
                    cells |= changed
            cells.flags.writeable = False
            self._live[rule] = cells
        return cells

    def reasons_at(self, frames: slice | np.ndarray, joint: int) -> list[str]:
        """The rules whose flags on any of ``frames`` of ``joint`` stand (:meth:`live`), in
        the order they ran."""
        m = self.mask[frames, joint]
        return [r for r in self.added if (self.live(r)[frames, joint] & m).any()]

    def primary(self, order: list[str]) -> np.ndarray:
        """(F, J) int8: for each flagged cell the index in ``order`` of the first rule that
        flagged it (-1 where not flagged)."""
        out = np.full(self.mask.shape, -1, dtype=np.int8)
        for i, name in reversed(list(enumerate(order))):
            if name in self.added:
                out[self.live(name) & self.mask] = i
        return out
