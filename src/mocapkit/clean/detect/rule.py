"""What every detection rule is: a frozen dataclass of its thresholds with one ``apply``."""

from __future__ import annotations

from typing import ClassVar, Protocol

from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags


class Rule(Protocol):
    """A detection rule.

    ``name``: its label in reports and ``--explain``; ``veto``: it only clears cells;
    ``signal``: it reads the rotations alone, so the KNN words lying on its cells may not speak
    for that joint (several errors on one joint would vouch for each other); ``glyph``: the
    mark of its cells in the heat map. ``from_config`` picks its thresholds from a
    :class:`DetectConfig`; ``apply`` changes ``flags``; ``cells`` (signal rules) gives what it
    would flag; ``describe`` says, in one line, what it measured at a cell. A veto may name in
    ``spares`` the rules whose cells it never clears (``--explain`` says so).
    """

    name: ClassVar[str]
    veto: ClassVar[bool]
    signal: ClassVar[bool]

    @classmethod
    def from_config(cls, config: DetectConfig) -> Rule: ...

    def apply(self, evidence: Evidence, flags: Flags) -> None: ...

    def describe(
        self, evidence: Evidence, frame: int, joint: int, flags: Flags | None = None
    ) -> str: ...
