"""Provenance sidecars: what made a generated motion, frame by frame.

One format for every output mocapkit generates (stitch, graph synth, and later clean and
in-betweening). ``walk.bvh`` gets ``walk.bvh.provenance.json`` beside it (sidecars of older
versions, ``walk.provenance.json``, are still read when they name ``walk.bvh``)::

    {
      "format": "mocapkit-provenance-1",
      "tool": "graph synth",                # the subcommand that wrote the output
      "mocapkit_version": "0.1.0",
      "output": "walk.bvh", "fps": 30.0, "frames": 600,
      "inputs": ["clips/a.bvh", ...],       # every file read, in the tool's order
      "parameters": {"seed": 1, ...},       # the options that shaped the result
      "segments": [                         # the output's frames, in order, without gaps
        {"output_start": 0, "output_stop": 41, "kind": "clip",
         "source": "clips/a.bvh", "source_start": 12, "source_stop": 53},
        {"output_start": 41, "output_stop": 46, "kind": "transition", ...}, ...
      ],
      "transitions": [                      # graph synth and stitch: each transition taken
        {"output_frame": 41, "source": "clips/a.bvh", "source_frame": 53,
         "target": "clips/b.bvh", "target_frame": 7, "cost": 0.021}, ...
      ]
    }

File paths given relative (``output``, ``inputs``, ``source``, ``target``, and any parameter
that names a file) are written relative to the sidecar's own folder, starting ``./`` or
``../``, so the sidecar stays right wherever it is read from and when its folder moves with
the files; an absolute path stays absolute (and so does one that cannot be made relative:
another drive), and a name that is not a file (an API caller's clip name) is kept as it is.
:func:`read_provenance` turns them back into paths from the reader's working folder.

Frames are 0-based, ``*_stop`` excluded. Segment kinds: ``"clip"`` (frames copied from
``source``), ``"transition"`` (``source``'s frames blended with the clip the walk came from, which
the matching ``transitions`` entry names), ``"generated"`` (frames made by mocapkit, e.g. a
stitch's injected frames), ``"inbetween"`` (frames of ``source``, time-warped and moved onto
the frames around a gap, their ends blended into them: ``mocapkit inbetween``; with
``"backwards": true`` when the source played in reverse; ``source`` is the best-scoring of the
library segments the fill combines, and ``parameters["blended_from"]`` lists it and every other
one whose share is not 0 to 4 decimals, with its share, which may be small or negative).
Readers ignore keys they do not know, so later tools may add some.

A motion made from a motion mocapkit made (a take filled twice) traces its copied frames back
through that input's sidecar (:meth:`Provenance.through`; ``mocapkit inbetween`` does): the
segments then name the original files, and ``parameters["earlier"]`` lists the earlier runs.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from importlib import metadata
from pathlib import Path
from typing import Any

from mocapkit.io.atomic import atomic_write_text, same_file

FORMAT = "mocapkit-provenance-1"
SUFFIX = ".provenance.json"


@dataclass(frozen=True)
class Segment:
    """A run of output frames and where they came from."""

    output_start: int
    output_stop: int
    kind: str
    source: str | None = None
    source_start: int | None = None
    source_stop: int | None = None
    backwards: bool = False
    """The source's frames play in reverse order (``source_stop - 1`` first; in-betweening
    from a clip played backwards). Written only when true."""

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        if not d["backwards"]:
            del d["backwards"]
        return d


@dataclass(frozen=True)
class TransitionTaken:
    """One transition of a generated motion: from ``source_frame`` of ``source`` to
    ``target_frame`` of ``target``, entered at ``output_frame``."""

    output_frame: int
    source: str
    source_frame: int
    target: str
    target_frame: int
    cost: float | None = None


@dataclass
class Provenance:
    """The sidecar's content (see the module notes)."""

    tool: str
    output: str
    fps: float
    frames: int
    inputs: list[str]
    parameters: dict[str, Any] = field(default_factory=dict)
    segments: list[Segment] = field(default_factory=list)
    transitions: list[TransitionTaken] = field(default_factory=list)

    def to_json(self, path: Callable[[str], str] = str) -> dict[str, Any]:
        """The sidecar's JSON, every file path passed through ``path``."""
        return {
            "format": FORMAT,
            "tool": self.tool,
            "mocapkit_version": _version(),
            "output": path(self.output),
            "fps": _nominal(self.fps),
            "frames": self.frames,
            "inputs": [path(x) for x in self.inputs],
            "parameters": _map_strings(dict(self.parameters), path),
            "segments": [_map_keys(s.to_json(), ("source",), path) for s in self.segments],
            "transitions": [
                _map_keys(asdict(t), ("source", "target"), path) for t in self.transitions
            ],
        }

    def made_frames(self) -> list[tuple[int, int]]:
        """``(start, stop)`` of the frames mocapkit made rather than took from a capture, in
        order: an in-betweening's fill, a transition's blend, and "generated" frames of no
        source (injected frames, a Kalman fill). "generated" frames of a source are that
        capture re-timed or retargeted (``edit --speed``, ``retarget``: reviewer, a whole take
        read as made), and "clip" frames are copied."""
        return [
            (s.output_start, s.output_stop)
            for s in self.segments
            if s.kind in ("inbetween", "transition") or (s.kind == "generated" and not s.source)
        ]

    def through(self, earlier: Provenance, file: str) -> Provenance:
        """This sidecar with the frames it copied from ``file`` traced back through
        ``earlier``, the sidecar of ``file`` (a motion mocapkit made: a take whose gap was
        filled, then filled again elsewhere): each "clip" segment of ``file`` becomes the
        segments of ``earlier`` it copied (clipped to its frames; a time-warped segment's
        source frames in proportion), ``earlier``'s transitions inside it come along, a
        transition's end on a copied frame names the clip it came from, as does a segment
        made from copied frames (:func:`_named_back`), ``earlier``'s inputs are added, and
        ``parameters["earlier"]`` lists the tools and parameters that made ``file``, oldest
        first. Unchanged when ``earlier`` is of another frame rate or shorter
        than the frames copied (then it is not this file's sidecar any more)."""
        copied = [s for s in self.segments if s.kind == "clip" and s.source is not None
                  and same_file(s.source, file)]  # fmt: skip
        if not copied or not _close(earlier.fps, self.fps):
            return self
        if any(s.backwards or (s.source_stop or 0) > earlier.frames for s in copied):
            return self
        segs: list[Segment] = []
        trans = [_traced_ends(t, earlier, file) for t in self.transitions]
        for s in self.segments:
            if s not in copied:
                segs.append(_named_back(s, earlier, file))
                continue
            s0, s1 = int(s.source_start or 0), int(s.source_stop or 0)
            shift = s.output_start - s0
            for x in earlier.segments:
                lo, hi = max(x.output_start, s0), min(x.output_stop, s1)
                if lo < hi:
                    segs.append(_clipped(x, lo, hi, shift))
            trans += [
                replace(t, output_frame=t.output_frame + shift)
                for t in earlier.transitions
                if s0 < t.output_frame < s1
            ]
        params = {k: v for k, v in earlier.parameters.items() if k != "earlier"}
        history = [*earlier.parameters.get("earlier", []), {"tool": earlier.tool, **params}]
        return replace(
            self,
            inputs=[*self.inputs, *(x for x in earlier.inputs if x not in self.inputs)],
            parameters={**self.parameters, "earlier": history},
            segments=sorted(segs, key=lambda x: x.output_start),
            transitions=sorted(trans, key=lambda t: t.output_frame),
        )

    def write(self, output: str | Path) -> Path:
        """Write the sidecar of ``output`` (:func:`sidecar_path`) atomically, file paths relative
        to its folder (module notes); returns its path."""
        from mocapkit.jsonio import to_json_text

        side = sidecar_path(output)
        folder = os.path.abspath(side.parent)
        data = self.to_json(lambda s: _from_folder(s, folder))
        data["output"] = os.path.join(".", Path(output).name)  # beside it, written or not yet
        return atomic_write_text(side, to_json_text(data) + "\n")


def _close(x: float, y: float) -> bool:
    return abs(x - y) <= 1e-6 * max(abs(x), abs(y))


def _named_back(s: Segment, earlier: Provenance, file: str) -> Segment:
    """``s`` (not a copy of ``file``'s frames: a fill made from them, say) naming the clip its
    source frames of ``file`` were copied from, where ``earlier`` says they all were copied
    from one (an in-betweening of a take filled before, from the take's own frames); else
    ``s`` as it is (it names ``file``, a file on disk with its own sidecar)."""
    if s.source is None or s.source_start is None or s.source_stop is None:
        return s
    if not same_file(s.source, file):
        return s
    for x in earlier.segments:
        if x.kind == "clip" and x.source_start is not None and x.output_start <= s.source_start \
                and s.source_stop <= x.output_stop:  # fmt: skip
            shift = x.source_start - x.output_start
            return replace(s, source=x.source, source_start=s.source_start + shift,
                           source_stop=s.source_stop + shift)  # fmt: skip
    return s


def _traced_ends(t: TransitionTaken, earlier: Provenance, file: str) -> TransitionTaken:
    """``t`` with an end at a frame of ``file`` that ``earlier`` says was copied from a clip
    named as that clip's frame."""

    def back(name: str, frame: int) -> tuple[str, int]:
        if same_file(name, file):
            for x in earlier.segments:
                if x.kind == "clip" and x.output_start <= frame < x.output_stop:
                    return str(x.source), frame - x.output_start + int(x.source_start or 0)
        return name, frame

    (src, sf), (tgt, tf) = back(t.source, t.source_frame), back(t.target, t.target_frame)
    return replace(t, source=src, source_frame=sf, target=tgt, target_frame=tf)


def _clipped(x: Segment, lo: int, hi: int, shift: int) -> Segment:
    """Output frames ``lo:hi`` of segment ``x``, moved by ``shift`` frames, with the source
    frames that play there (in proportion where the segment is time-warped; from the source's
    end where it plays backwards)."""
    if x.source_start is None or x.source_stop is None:
        return replace(x, output_start=lo + shift, output_stop=hi + shift)
    k = (x.source_stop - x.source_start) / (x.output_stop - x.output_start)
    d0 = round((lo - x.output_start) * k)
    d1 = max(round((hi - x.output_start) * k), d0 + 1)
    src = (
        (x.source_stop - d1, x.source_stop - d0)
        if x.backwards
        else (x.source_start + d0, x.source_start + d1)
    )
    return replace(x, output_start=lo + shift, output_stop=hi + shift, source_start=src[0],
                   source_stop=src[1])  # fmt: skip


def _from_folder(s: str, folder: str) -> str:
    """``s`` as a path from ``folder`` (``./`` or ``../`` first) when it is a relative path
    naming a file or a folder, else ``s`` (an absolute path stays as the user gave it);
    absolute where no relative path exists (another drive)."""
    if not s or os.path.isabs(s) or not os.path.exists(s):
        return s
    try:
        rel = os.path.relpath(os.path.abspath(s), folder)
    except ValueError:
        return os.path.abspath(s)
    return rel if rel.startswith("..") else os.path.join(".", rel)


def _to_reader(s: str, folder: str) -> str:
    """A path stored relative to the sidecar's ``folder`` as a path from the working folder."""
    if not s.startswith(("./", "../", ".\\", "..\\")):
        return s
    full = os.path.normpath(os.path.join(folder, s))
    try:
        rel = os.path.relpath(full)
    except ValueError:
        return full
    return full if rel.startswith("..") else rel


def _known(cls: type, d: dict) -> dict:
    """``d`` less the keys ``cls`` (a dataclass) does not know: readers ignore keys that later
    versions add (module notes)."""
    names = {f.name for f in fields(cls)}
    return {k: v for k, v in d.items() if k in names}


def _map_keys(d: dict, keys: tuple[str, ...], f: Callable[[str], str]) -> dict:
    for k in keys:
        if isinstance(d.get(k), str):
            d[k] = f(d[k])
    return d


def _map_strings(x: Any, f: Callable[[str], str]) -> Any:
    """``x`` (parameters: dicts, lists, scalars) with every string passed through ``f``."""
    if isinstance(x, str):
        return f(x)
    if isinstance(x, dict):
        return {k: _map_strings(v, f) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_map_strings(v, f) for v in x]
    return x


def sidecar_path(output: str | Path) -> Path:
    """``walk.bvh`` -> ``walk.bvh.provenance.json`` (beside it): the whole file name, so that
    ``walk.bvh`` and ``walk.glb`` written from different runs keep a sidecar each."""
    p = Path(output)
    return p.with_name(p.name + SUFFIX)


def existing_sidecar(output: str | Path) -> Path | None:
    """The sidecar of ``output`` that lies beside it: ``walk.bvh.provenance.json``, or one
    written before sidecars carried the extension (``walk.provenance.json``) if it says it is
    ``walk.bvh``'s; None when there is none."""
    p = Path(output)
    new = sidecar_path(p)
    if new.exists():
        return new
    old = p.with_name(p.stem + SUFFIX)
    if old.exists():
        try:
            said = json.loads(old.read_text(encoding="utf-8")).get("output")
        except (OSError, UnicodeDecodeError, json.JSONDecodeError, AttributeError):
            return None
        if isinstance(said, str) and Path(said).name == p.name:
            return old
    return None


def read_provenance(path: str | Path) -> Provenance:
    """Read a sidecar (ValueError naming the file when it is not one)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"{path}: not a readable provenance file ({e})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(f"{path}: not a mocapkit provenance file (expected format {FORMAT})")
    folder = os.path.abspath(path.parent)

    def f(s: str) -> str:
        return _to_reader(s, folder)

    try:
        return Provenance(
            tool=str(data["tool"]),
            output=f(str(data["output"])),
            fps=float(data["fps"]),
            frames=int(data["frames"]),
            inputs=[f(str(x)) for x in data.get("inputs", [])],
            parameters=_map_strings(dict(data.get("parameters", {})), f),
            segments=[
                Segment(**_known(Segment, _map_keys(s, ("source",), f)))
                for s in data.get("segments", [])
            ],
            transitions=[
                TransitionTaken(**_known(TransitionTaken, _map_keys(t, ("source", "target"), f)))
                for t in data.get("transitions", [])
            ],
        )
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{path}: malformed provenance file ({e})") from None


def find_provenance(output: str | Path) -> Provenance | None:
    """The sidecar of ``output`` if one lies beside it (:func:`existing_sidecar`), else None."""
    p = existing_sidecar(output)
    return None if p is None else read_provenance(p)


def _version() -> str:
    try:
        return metadata.version("mocapkit")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def _nominal(fps: float) -> float:
    """``fps`` as ``mocapkit info`` gives it (30, not 30.00003 for a frame time of 0.0333333)."""
    from mocapkit.summary import nominal_fps  # summary reads files; this module is below io

    return nominal_fps(1.0 / fps) if fps > 0 else fps


def shares_by_take(blended: Sequence[dict[str, Any]]) -> list[tuple[str, float]]:
    """(take, summed weight) of each library file in ``blended`` (an in-betweening's
    ``blended_from``: its result's or its sidecar's ``parameters``), largest share first:
    twelve segments read as a few takes (the report, the demo and the viewer print these). A
    take is named by its file name, or by its path where another file has the same name."""
    shares: dict[str, float] = {}
    for x in blended:
        shares[str(x["source"])] = shares.get(str(x["source"]), 0.0) + float(x["weight"])
    names = [Path(k).name for k in shares]
    shown = [k if names.count(Path(k).name) > 1 else Path(k).name for k in shares]
    return sorted(zip(shown, shares.values(), strict=True), key=lambda kv: -kv[1])


def whole_percent(share: float) -> str:
    """A share as a whole percentage, never "-0%"."""
    text = f"{share:.0%}"
    return "0%" if text == "-0%" else text


def weighing_takes(blended: Sequence[dict[str, Any]]) -> tuple[list[tuple[str, float]], int]:
    """:func:`shares_by_take` less the takes whose segments together read 0% as a whole
    percentage (:func:`whole_percent`), and how many those are: the report, the demo and the
    viewer count them apart (newcomer: takes listed at 0% read as used)."""
    takes = shares_by_take(blended)
    weighing = [(name, share) for name, share in takes if whole_percent(share) != "0%"]
    return weighing, len(takes) - len(weighing)
