"""Fuzz: damaged files and misused paths through every subcommand (issue 14).

Seeded and generated here from a small valid BVH (the procedural walk, 1 s) and a small ASF/AMC
pair (CMU subject 01's skeleton and the first frames of 01_01.amc from the shared data, or a
generated pair when that is absent). Each case runs in-process through click's ``CliRunner``
(the read-only-folder cases, when the tests run as root, in one subprocess under ``setpriv`` as
nobody, since root ignores permissions) and must end

* in a valid result: exit 0, every JSON output (stdout of ``--json``, written ``.json`` files,
  the data of a viewer page) parses with a strict parser (no NaN/Infinity), stderr holds only
  ``mocapkit: warning|repaired: ...`` lines; or
* in a one-line error: exit 2, stderr's content is one line ``mocapkit: error: ...`` that names
  one of the case's files, quotes at most a short bit of the input (quotes closed);

and in either case: no input byte changed, no temporary file left, nothing written after a
failure (the case folder is listed before and after), no output outside the declared ones.

Families: structural damage, numeric damage, ASF/AMC damage, path misuse; the number of cases
per family is printed (``pytest -s``) and checked by ``test_case_counts``.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import random
import re
import shutil
import stat
import subprocess
import sys
import tempfile
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from click.testing import CliRunner
from testsupport import shared_subpath

from mocapkit.cli import main

SEED = 14
PREFIX = "mocapkit: error: "
MAX_MESSAGE = 300
"""Characters an error line may have besides the file names it holds (the parser quotes at
most ~80 characters of offending text)."""

TMP_FILE = re.compile(r"^\..*\.tmp$")
VIEW_DATA = re.compile(rb'<script type="application/json" id="mocapkit-data">(.*?)</script>', re.S)


# ------------------------------------------------------------------------------ base inputs
@functools.cache
def base_bvh(seed: int = 0) -> bytes:
    from mocapkit import datasets
    from mocapkit.io import write_bvh

    motion = datasets.procedural_motion("walk", seconds=1, seed=seed).motion
    with tempfile.TemporaryDirectory() as d:
        return write_bvh(motion, Path(d) / "walk.bvh").read_bytes()


_GENERATED_ASF = """\
# generated: a root and a three-bone leg
:version 1.10
:name fuzz
:units
  mass 1.0
  length 0.45
  angle deg
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name lfemur
     direction 0 -1 0
     length 7.0
     axis 0 0 0  XYZ
    dof rx ry rz
    limits (-160.0 20.0)
           (-70.0 70.0)
           (-60.0 70.0)
  end
  begin
     id 2
     name ltibia
     direction 0 -1 0
     length 7.0
     axis 0 0 0  XYZ
    dof rx
    limits (-10.0 170.0)
  end
  begin
     id 3
     name lfoot
     direction 0 0 1
     length 2.0
     axis 0 0 0  XYZ
    dof rx rz
    limits (-45.0 90.0)
           (-70.0 20.0)
  end
:hierarchy
  begin
    root lfemur
    lfemur ltibia
    ltibia lfoot
  end
"""


@functools.cache
def base_asfamc(frames: int = 40) -> tuple[bytes, bytes, str]:
    """(ASF, AMC of ``frames`` frames, where they come from)."""
    folder = shared_subpath("cmu-asfamc/01")
    asf, amc = folder / "01.asf", folder / "01_01.amc"
    if asf.is_file() and amc.is_file():
        lines = amc.read_bytes().splitlines(keepends=True)
        out, seen = [], 0
        for line in lines:
            if line.strip().isdigit():
                seen += 1
                if seen > frames:
                    break
            out.append(line)
        return asf.read_bytes(), b"".join(out), "shared cmu-asfamc/01"
    rng = random.Random(SEED)
    rows = [":FULLY-SPECIFIED", ":DEGREES"]
    for f in range(1, frames + 1):
        rows += [
            str(f),
            f"root {f * 0.1:.3f} 17.5 0 {rng.uniform(-2, 2):.4f} 0 0",
            f"lfemur {rng.uniform(-30, 10):.4f} 0 0",
            f"ltibia {rng.uniform(0, 60):.4f}",
            f"lfoot {rng.uniform(-10, 10):.4f} 0",
        ]
    return _GENERATED_ASF.encode(), ("\n".join(rows) + "\n").encode(), "generated"


# ------------------------------------------------------------------------------------ cases
@dataclass(frozen=True)
class Case:
    family: str
    name: str
    args: tuple[str, ...]
    files: tuple[tuple[str, bytes], ...] = ()  # relative path, content
    folders: tuple[str, ...] = ()  # extra (empty) folders
    symlinks: tuple[tuple[str, str], ...] = ()  # link, target (relative to the link's folder)
    hardlinks: tuple[tuple[str, str], ...] = ()  # new name, existing file
    outputs: tuple[str, ...] = ()  # what the command may write on success
    readonly: tuple[str, ...] = ()  # folders made read-only (needs a non-root user)
    cwd: str = "."
    expect: str = "any"  # "ok", "error" or "any"
    checks: tuple[str, ...] = ()  # "no_fffd": joint names decoded without U+FFFD
    culprits: tuple[str, ...] = ()  # more names the error may give (an option, an output)
    marks: tuple = field(default=(), compare=False)

    @property
    def id(self) -> str:
        return f"{self.family}-{self.name}"


def _cmds_bvh(take: str, other: str) -> list[tuple[str, tuple[str, ...], tuple[str, ...]]]:
    """(label, args, outputs) of every subcommand on a damaged ``take`` (``other``: valid)."""
    return [
        ("info", ("info", take), ()),
        ("info-json", ("info", "--json", take), ()),
        ("convert", ("convert", take, "out.bvh"), ("out.bvh",)),
        (  # a 1 s take finds like motion words only in a context
            "clean",
            ("clean", take, "--context", other, "--quiet", "--report", "r.json", "--out", "f.bvh"),
            ("r.json", "f.bvh"),
        ),
        (
            "stitch",
            ("stitch", take, other, "--takeoff", "15", "--json", "stitch.json", "--out", "st.bvh"),
            ("stitch.json", "st.bvh", "st.bvh.provenance.json"),
        ),
        (
            "graph",
            ("graph", "build", take, other, "--out", "graph.json", "--quiet"),
            ("graph.json",),
        ),
        ("view", ("view", take, "--out", "view.html"), ("view.html",)),
        (
            "edit",
            ("edit", take, "e.bvh", "--trim", "0:10", "--mirror", "--in-place", "--speed", "1.5"),
            ("e.bvh", "e.bvh.provenance.json"),
        ),
    ]


LIGHT = ("info", "info-json", "convert", "view")
"""The subcommands big inputs (deep nesting, huge lines) go through."""


def _bvh_cases(
    family: str,
    name: str,
    data: bytes,
    only: tuple[str, ...] | None = None,
    checks: tuple[str, ...] = (),
    expect: str = "any",
) -> list[Case]:
    other = base_bvh(1)
    out = []
    for label, args, outputs in _cmds_bvh("take.bvh", "other.bvh"):
        if only is not None and label not in only:
            continue
        out.append(
            Case(
                family,
                f"{name}-{label}",
                args,
                files=(("take.bvh", data), ("other.bvh", other)),
                outputs=outputs,
                checks=checks if label == "info-json" else (),
                expect=expect,
            )
        )
    return out


def _lines(data: bytes) -> list[bytes]:
    return data.split(b"\n")


def _motion_start(data: bytes) -> int:
    return data.index(b"MOTION")


def _deep_bvh(depth: int = 1500) -> bytes:
    parts = ["HIERARCHY\nROOT j0\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition "
             "Zrotation Xrotation Yrotation\n"]  # fmt: skip
    for j in range(1, depth):
        parts.append(f"JOINT j{j}\n{{\nOFFSET 0 0.01 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n")
    parts.append("End Site\n{\nOFFSET 0 0.01 0\n}\n")
    parts.append("}\n" * depth)
    channels = 6 + 3 * (depth - 1)
    row = " ".join(["0"] * channels)
    parts.append(f"MOTION\nFrames: 2\nFrame Time: 0.0333333\n{row}\n{row}\n")
    return "".join(parts).encode()


def structural_cases(rng: random.Random) -> list[Case]:
    base = base_bvh()
    cases: list[Case] = []
    m0 = _motion_start(base)
    # truncation at random byte offsets: half in the hierarchy, half anywhere
    cuts = sorted({rng.randrange(1, m0 + 30) for _ in range(10)} | {
        rng.randrange(m0, len(base) - 1) for _ in range(6)})  # fmt: skip
    for c in cuts:
        cases += _bvh_cases("structural", f"truncate{c}", base[:c])
    cases += _bvh_cases(
        "structural", "intact", base, expect="ok"
    )  # the control: every command succeeds
    cases += _bvh_cases("structural", "empty", b"")
    cases += _bvh_cases("structural", "only-HIERARCHY", b"HIERARCHY\n")
    # unbalanced braces
    lines = _lines(base)
    closes = [i for i, ln in enumerate(lines) if ln.strip() == b"}"]
    opens = [i for i, ln in enumerate(lines) if ln.strip() == b"{"]
    for k in rng.sample(closes, 3):
        cases += _bvh_cases("structural", f"drop-close{k}", b"\n".join(lines[:k] + lines[k + 1 :]))
    for k in rng.sample(opens, 2):
        cases += _bvh_cases(
            "structural", f"extra-open{k}", b"\n".join([*lines[:k], b"{", *lines[k:]])
        )
    k = rng.choice(closes[:5])
    cases += _bvh_cases("structural", f"extra-close{k}", b"\n".join([*lines[:k], b"}", *lines[k:]]))
    # swapped lines: in the hierarchy, across MOTION, in the frames
    hier = [i for i, ln in enumerate(lines) if i < base[:m0].count(b"\n")]
    frames = list(range(base[:m0].count(b"\n") + 3, len(lines) - 1))
    for a, b in [tuple(rng.sample(hier, 2)) for _ in range(4)] + [
        (rng.choice(hier), rng.choice(frames)),
        tuple(rng.sample(frames, 2)),
    ]:
        ls = list(lines)
        ls[a], ls[b] = ls[b], ls[a]
        cases += _bvh_cases("structural", f"swap{a}-{b}", b"\n".join(ls))
    # byte flips
    for i in range(8):
        data = bytearray(base)
        where = rng.randrange(0, m0 if i % 2 == 0 else len(base))
        data[where] ^= rng.randrange(1, 256)
        cases += _bvh_cases("structural", f"flip{where}", bytes(data))
    # BOM, CR, CRLF
    cases += _bvh_cases("structural", "utf8-bom", b"\xef\xbb\xbf" + base)
    cases += _bvh_cases("structural", "utf16-bom", base.decode().encode("utf-16"))
    cases += _bvh_cases("structural", "crlf", base.replace(b"\n", b"\r\n"))
    cases += _bvh_cases("structural", "cr", base.replace(b"\n", b"\r"))
    cases += _bvh_cases("structural", "mixed-eol", base.replace(b"\n", b"\r\n", 40))
    # NUL bytes
    for where in (rng.randrange(0, m0), rng.randrange(m0, len(base))):
        cases += _bvh_cases("structural", f"nul{where}", base[:where] + b"\0" + base[where:])
    cases += _bvh_cases("structural", "nul-padding", base + b"\0" * 16384)
    cases += _bvh_cases("structural", "nul-middle-block", base[:m0] + b"\0" * 4096 + base[m0:])
    cases += _bvh_cases("structural", "all-nul", b"\0" * 4096)
    # non-UTF-8 bytes: latin-1 and Shift-JIS joint names (decoded with a stated fallback),
    # stray bytes in the hierarchy and in the frames
    latin1 = base.replace(b"LeftArm", "LeftArmHüfte".encode("latin-1"))
    cases += _bvh_cases("structural", "latin1-name", latin1, checks=("no_fffd",))
    sjis = base.replace(b"Spine", "Spine腰".encode("shift_jis"))
    cases += _bvh_cases("structural", "shiftjis-name", sjis, checks=("no_fffd",))
    w = rng.randrange(0, m0)
    cases += _bvh_cases("structural", f"byte-ff{w}", base[:w] + b"\xff\xfe" + base[w:])
    w = rng.randrange(m0, len(base))
    cases += _bvh_cases("structural", f"byte-c3{w}", base[:w] + b"\xc3" + base[w:])
    # huge lines: a 2 MB joint name, a 2 MB motion row, a 1 MB blank line
    cases += _bvh_cases(
        "structural", "huge-name", base.replace(b"JOINT Spine", b"JOINT " + b"S" * 2_000_000, 1),
        only=LIGHT,
    )  # fmt: skip
    row_start = base.index(b"\n", base.index(b"Frame Time")) + 1
    cases += _bvh_cases(
        "structural", "huge-row", base[:row_start] + b"0 " * 1_000_000 + base[row_start:],
        only=LIGHT,
    )  # fmt: skip
    cases += _bvh_cases(
        "structural", "huge-blank", base[:m0] + b" " * 1_000_000 + b"\n" + base[m0:], only=LIGHT
    )
    # deep nesting: 1,500 joints
    cases += _bvh_cases("structural", "deep1500", _deep_bvh(1500), only=LIGHT)
    return cases


NUMERIC_TOKENS = {
    "overflow": "1e309",
    "neg-overflow": "-1e309",
    "400-digits": "9" * 400,
    "400-digit-fraction": "1" + "0" * 399 + ".5",
    "nan": "nan",
    "NaN": "NaN",
    "inf": "inf",
    "neg-inf": "-inf",
    "Infinity": "Infinity",
    "hex": "0x1A",
    "two-dots": "1.0.0",
    "bare-e": "1e",
    "double-sign": "--1",
    "underscore": "1_000",
}


def numeric_cases(rng: random.Random) -> list[Case]:
    base = base_bvh()
    text = base.decode()
    m0 = text.index("MOTION")
    rows_at = text.index("\n", text.index("Frame Time")) + 1
    cases: list[Case] = []

    def number_spans(lo: int, hi: int) -> list[tuple[int, int]]:
        return [
            (m.start() + lo, m.end() + lo)
            for m in re.finditer(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", text[lo:hi])
        ]

    motion_spans = number_spans(rows_at, len(text))
    offset_spans = [(m.start(1), m.end(1)) for m in re.finditer(r"OFFSET (\S+) \S+ \S+", text[:m0])]
    for label, tok in NUMERIC_TOKENS.items():
        a, b = rng.choice(motion_spans)
        cases += _bvh_cases("numeric", f"motion-{label}", (text[:a] + tok + text[b:]).encode())
        a, b = rng.choice(offset_spans[1:])
        cases += _bvh_cases("numeric", f"offset-{label}", (text[:a] + tok + text[b:]).encode())
    ft = re.search(r"Frame Time: (\S+)", text)
    fc = re.search(r"Frames: (\S+)", text)
    for label in ("overflow", "nan", "inf", "hex", "two-dots", "400-digits"):
        tok = NUMERIC_TOKENS[label]
        data = text[: ft.start(1)] + tok + text[ft.end(1) :]
        cases += _bvh_cases("numeric", f"frametime-{label}", data.encode())
        data = text[: fc.start(1)] + tok + text[fc.end(1) :]
        cases += _bvh_cases("numeric", f"frames-{label}", data.encode())
    for label, tok in (("zero", "0"), ("negative", "-0.0333333")):
        data = text[: ft.start(1)] + tok + text[ft.end(1) :]
        cases += _bvh_cases("numeric", f"frametime-{label}", data.encode())
    # extreme but finite: positions overflow to inf in the bounding box
    data = re.sub(r"OFFSET 0 0\.\d+ 0", "OFFSET 0 1e308 0", text, count=3)
    cases += _bvh_cases("numeric", "offset-1e308", data.encode())
    return cases


def _asf_amc_cases(name: str, asf: bytes, amc: bytes, expect: str = "any") -> list[Case]:
    good_amc = base_asfamc()[1]
    files = (("01.asf", asf), ("01_01.amc", amc), ("01_02.amc", good_amc))
    cmds = [
        ("info", ("info", "01_01.amc"), ()),
        ("info-json", ("info", "--json", "01_01.amc"), ()),
        ("convert", ("convert", "01.asf", "01_01.amc", "out.bvh"), ("out.bvh",)),
        ("convert-npz", ("convert", "01_01.amc", "out.npz"), ("out.npz",)),
        (
            "stitch",
            ("stitch", "01_01.amc", "01_02.amc", "--takeoff", "15", "--json", "stitch.json"),
            ("stitch.json",),
        ),
        (
            "edit",
            ("edit", "01_01.amc", "e.bvh", "--trim", "0.05s:", "--mirror", "--extract-root"),
            ("e.bvh", "e.bvh.provenance.json"),
        ),
        (
            "graph",
            ("graph", "build", "01_01.amc", "01_02.amc", "--out", "graph.json", "--quiet"),
            ("graph.json",),
        ),
        ("view", ("view", "01_01.amc", "--out", "view.html"), ("view.html",)),
    ]
    return [
        Case("asfamc", f"{name}-{label}", args, files=files, outputs=outputs, expect=expect)
        for label, args, outputs in cmds
    ]


def asfamc_cases(rng: random.Random) -> list[Case]:
    asf, amc, _ = base_asfamc()
    cases: list[Case] = []
    eol = "\r\n" if b"\r\n" in asf else "\n"  # CMU's files have CRLF line ends

    def enc(text: str) -> bytes:
        return text.replace("\n", eol).encode()

    atext, mtext = asf.decode().replace("\r\n", "\n"), amc.decode().replace("\r\n", "\n")
    cases += _asf_amc_cases("intact", asf, amc, expect="ok")  # the control
    for c in sorted({rng.randrange(1, len(asf)) for _ in range(5)}):
        cases += _asf_amc_cases(f"asf-truncate{c}", asf[:c], amc)
    for c in sorted({rng.randrange(1, len(amc)) for _ in range(4)}):
        cases += _asf_amc_cases(f"amc-truncate{c}", asf, amc[:c])
    # units
    for label, new in (
        ("length-abc", "length abc"),
        ("length-zero", "length 0"),
        ("length-overflow", "length 1e309"),
        ("angle-grad", None),
    ):
        if new is None:
            data = atext.replace("angle deg", "angle grad")
        else:
            data = re.sub(r"length [\d.]+\n", new + "\n", atext, count=1)
        cases += _asf_amc_cases(f"units-{label}", enc(data), amc)
    # missing bones: a bone block out of the ASF, a bone out of the hierarchy, a bone line out
    # of an AMC frame
    blocks = list(re.finditer(r"  begin\n(?:(?!  end\n).)*?name (\w+)\n.*?  end\n", atext, re.S))
    blk = blocks[1]
    cases += _asf_amc_cases(
        f"asf-no-{blk.group(1)}", enc(atext[: blk.start()] + atext[blk.end() :]), amc
    )
    hier = atext.index(":hierarchy")
    cut = atext.index("\n", atext.index("\n", atext.index("begin", hier)) + 1)
    line_end = atext.index("\n", cut + 1)
    cases += _asf_amc_cases("hierarchy-line-dropped", enc(atext[:cut] + atext[line_end:]), amc)
    mlines = mtext.split("\n")
    bone_rows = [i for i, ln in enumerate(mlines) if ln[:1].isalpha()]
    k = rng.choice(bone_rows[5:])
    cases += _asf_amc_cases(
        "amc-bone-line-dropped", asf, enc("\n".join(mlines[:k] + mlines[k + 1 :]))
    )
    # bad dof counts: one value too many / too few on an AMC line, a dof without limits
    k = rng.choice(bone_rows[5:])
    ls = list(mlines)
    ls[k] += " 1.5"
    cases += _asf_amc_cases("amc-extra-value", asf, enc("\n".join(ls)))
    k = rng.choice([i for i in bone_rows[5:] if len(mlines[i].split()) > 2])
    ls = list(mlines)
    ls[k] = ls[k].rsplit(" ", 1)[0]
    cases += _asf_amc_cases("amc-missing-value", asf, enc("\n".join(ls)))
    data = atext.replace("dof rx ry rz", "dof rx ry rz rw", 1)
    cases += _asf_amc_cases("asf-bad-dof", enc(data), amc)
    # non-numeric values
    for label, tok in (("word", "abc"), ("two-dots", "1.0.0"), ("overflow", "1e309"),
                       ("nan", "nan")):  # fmt: skip
        k = rng.choice(bone_rows[5:])
        ls = list(mlines)
        parts = ls[k].split(" ")
        parts[1] = tok
        ls[k] = " ".join(parts)
        cases += _asf_amc_cases(f"amc-{label}", asf, enc("\n".join(ls)))
    data = re.sub(r"length ([\d.]+) *\n", "length xyz\n", atext.split(":bonedata")[1], count=1)
    cases += _asf_amc_cases(
        "asf-bone-length-word", enc(atext.split(":bonedata")[0] + ":bonedata" + data), amc
    )
    cases += _asf_amc_cases("asf-empty", b"", amc)
    cases += _asf_amc_cases("amc-empty", asf, b"")
    return cases


def path_cases() -> list[Case]:
    """Outputs that are inputs under other spellings or links, outputs under a file or over
    another input, folders as inputs, missing files, read-only folders."""
    take, other = base_bvh(), base_bvh(1)
    two = (("take.bvh", take), ("other.bvh", other))
    sub = (("clips/take.bvh", take), ("clips/other.bvh", other))
    cases: list[Case] = []

    def add(name: str, args: tuple[str, ...], expect: str = "error", **kw) -> None:
        kw.setdefault("files", two)
        cases.append(Case("path", name, args, expect=expect, **kw))

    spellings = {"plain": "take.bvh", "dot": "./take.bvh", "dotdot": "clips/../take.bvh",
                 "slashes": ".//take.bvh", "abs-like": "clips/./../take.bvh"}  # fmt: skip
    for label, out in spellings.items():
        add(f"convert-onto-input-{label}", ("convert", "take.bvh", out), folders=("clips",))
    add("convert-onto-symlink", ("convert", "take.bvh", "link.bvh"),
        symlinks=(("link.bvh", "take.bvh"),))  # fmt: skip
    add("convert-onto-hardlink", ("convert", "take.bvh", "hard.bvh"),
        hardlinks=(("hard.bvh", "take.bvh"),))  # fmt: skip
    add("convert-via-symlinked-folder", ("convert", "take.bvh", "ln/take.bvh"),
        symlinks=(("ln", "."),))  # fmt: skip
    add("convert-input-is-symlink", ("convert", "link.bvh", "take.bvh"),
        symlinks=(("link.bvh", "take.bvh"),))  # fmt: skip
    add("convert-under-a-file", ("convert", "take.bvh", "take.bvh/c.bvh"))
    add("convert-under-a-file-deeper", ("convert", "take.bvh", "other.bvh/x/c.bvh"))
    add("convert-onto-folder", ("convert", "take.bvh", "clips"), folders=("clips",))
    add("convert-bad-extension", ("convert", "take.bvh", "out.txt"))
    add("convert-folder-input", ("convert", "clips", "out.bvh"), files=sub)
    add("convert-missing-input", ("convert", "nope.bvh", "out.bvh"))
    add("convert-broken-symlink-input", ("convert", "gone.bvh", "out.bvh"),
        symlinks=(("gone.bvh", "nowhere.bvh"),))  # fmt: skip
    add("convert-ok-new-folder", ("convert", "take.bvh", "new/deeper/out.bvh"), expect="ok",
        outputs=("new", "new/deeper", "new/deeper/out.bvh"))  # fmt: skip
    add("info-missing", ("info", "nope.bvh"))
    add("info-json-missing", ("info", "--json", "nope.bvh"))
    add("info-empty-folder", ("info", "clips"), folders=("clips",))
    add("info-bracket-name", ("info", "[bold]walk.bvh"), expect="ok",
        files=(("[bold]walk.bvh", take),))  # fmt: skip
    add("info-json-bracket-name", ("info", "--json", "[x] take.bvh"), expect="ok",
        files=(("[x] take.bvh", take),))  # fmt: skip
    add("info-folder-of-two", ("info", "--json", "clips"), expect="ok", files=sub)
    add("info-bad-up", ("info", "--up", "W", "take.bvh"), culprits=("--up",))
    for label, args, outputs in (
        ("clean-report-onto-input", ("clean", "take.bvh", "--report", "./take.bvh"), ()),
        (
            "clean-out-onto-context",
            ("clean", "take.bvh", "--context", "clips", "--out", "clips/other.bvh"),
            (),
        ),
        ("clean-plot-onto-input", ("clean", "take.bvh", "--plot", "clips/../take.bvh"), ()),
        ("clean-mdm-under-file", ("clean", "take.bvh", "--mdm", "take.bvh/m.npy"), ()),
        (
            "clean-two-outputs-same",
            ("clean", "take.bvh", "--report", "r.json", "--mdm", "./r.json"),
            (),
        ),
        ("clean-folder-input", ("clean", "clips"), ()),
        ("clean-missing-input", ("clean", "nope.bvh"), ()),
        ("clean-missing-context", ("clean", "take.bvh", "--context", "nope/"), ()),
        (
            "stitch-json-onto-data",
            ("stitch", "take.bvh", "other.bvh", "--takeoff", "15", "--json", "other.bvh"),
            (),
        ),
        (
            "stitch-out-onto-query-symlink",
            ("stitch", "take.bvh", "other.bvh", "--takeoff", "15", "--out", "link.bvh"),
            (),
        ),
        (
            "stitch-plot-onto-data-dotdot",
            (
                "stitch",
                "take.bvh",
                "clips",
                "--takeoff",
                "15",
                "--plot",
                "clips/../clips/other.bvh",
            ),
            (),
        ),
        ("stitch-folder-query", ("stitch", "clips", "other.bvh", "--takeoff", "15"), ()),
        ("stitch-missing-data", ("stitch", "take.bvh", "nope.bvh", "--takeoff", "15"), ()),
        ("graph-out-onto-clip", ("graph", "build", "clips", "--out", "clips/take.bvh"), ()),
        (
            "graph-graphml-onto-clip",
            ("graph", "build", "clips", "--out", "g.json", "--graphml", "clips/other.bvh"),
            (),
        ),
        (
            "graph-plot-onto-clip",
            (
                "graph",
                "build",
                "clips",
                "--out",
                "g.json",
                "--plot",
                "clips/x.bvh",
                "--graphml",
                "./clips/take.bvh",
            ),
            (),
        ),
        (
            "graph-plot-onto-out",
            ("graph", "build", "clips", "--out", "g.json", "--plot", "./g.json"),
            (),
        ),
        ("graph-out-under-file", ("graph", "build", "clips", "--out", "clips/take.bvh/g.json"), ()),
        ("graph-empty-folder", ("graph", "build", "empty", "--out", "g.json"), ()),
        ("graph-missing", ("graph", "build", "nope", "--out", "g.json"), ()),
        ("view-out-onto-input", ("view", "take.bvh", "--out", "take.bvh"), ()),
        ("view-out-not-html", ("view", "take.bvh", "--out", "v.bvh"), ()),
        ("view-out-under-file", ("view", "take.bvh", "--out", "take.bvh/v.html"), ()),
        ("view-missing", ("view", "nope.bvh"), ()),
        ("view-empty-folder", ("view", "empty"), ()),
    ):
        add(label, args, files=two + sub, folders=("empty",), outputs=outputs,
            symlinks=(("link.bvh", "take.bvh"),))  # fmt: skip
    # outputs beside inputs: the default page goes into the current folder
    add("view-default-out-cwd", ("view", "clips/take.bvh"), expect="ok", files=sub,
        outputs=("take.html",))  # fmt: skip
    add("view-default-out-cwd-from-sub", ("view", "../clips/take.bvh"), expect="ok", files=sub,
        folders=("w",), cwd="w", outputs=("w/take.html",))  # fmt: skip
    add("graph-plot-named-like-a-clip", ("graph", "build", "clips", "--out", "g.json", "--plot",
                                          "clips/x.bvh"), files=sub)  # fmt: skip
    add("graph-plot-ok-then-nothing", ("graph", "build", "clips", "--out", "g.json", "--plot",
                                        "clips/take.bvh"), files=sub)  # fmt: skip
    return cases


def readonly_cases() -> list[Case]:
    """Outputs into a read-only folder (or a missing folder inside one), the default viewer
    page with a read-only current folder; inputs in a read-only folder are fine."""
    take, other = base_bvh(), base_bvh(1)
    files = (("ro/take.bvh", take), ("ro/other.bvh", other))
    cases = []

    def add(name: str, args: tuple[str, ...], expect: str = "error", **kw) -> None:
        kw.setdefault("files", files)
        cases.append(Case("path", f"readonly-{name}", args, expect=expect, readonly=("ro",),
                          **kw))  # fmt: skip

    add("convert", ("convert", "ro/take.bvh", "ro/out.bvh"))
    add("convert-npz-subfolder", ("convert", "ro/take.bvh", "ro/new/out.npz"))
    add("clean-report", ("clean", "ro/take.bvh", "--report", "ro/r.json", "--quiet"))
    add("clean-out-and-report", ("clean", "ro/take.bvh", "--report", "r.json", "--out",
                                 "ro/fixed.bvh", "--quiet"))  # fmt: skip
    add("stitch-json", ("stitch", "ro/take.bvh", "ro/other.bvh", "--takeoff", "15", "--json",
                        "ro/s.json"))  # fmt: skip
    add("stitch-out", ("stitch", "ro/take.bvh", "ro/other.bvh", "--takeoff", "15", "--out",
                       "ro/s.bvh"))  # fmt: skip
    add("graph-out", ("graph", "build", "ro", "--out", "ro/g.json", "--quiet"))
    add("graph-plot", ("graph", "build", "ro", "--out", "g.json", "--plot", "ro/g.png",
                       "--quiet"))  # fmt: skip
    add("view-out", ("view", "ro/take.bvh", "--out", "ro/v.html"))
    add("view-default-in-readonly-cwd", ("view", "take.bvh"), cwd="ro", culprits=("take.html",))
    add("convert-from-readonly-ok", ("convert", "ro/take.bvh", "out.bvh"), expect="ok",
        outputs=("out.bvh",))  # fmt: skip
    add("view-from-readonly-ok", ("view", "ro/take.bvh"), expect="ok", outputs=("take.html",))
    return cases


# Parser-side failures (src/mocapkit/io/bvh.py, _numparse.py, asfamc.py, errors.py are being
# fixed elsewhere): cases that still fail are listed here and expected to fail (not strictly).
PARSER_SIDE: dict[str, str] = {}  # cases the parser still fails (xfail): none now


def all_cases() -> list[Case]:
    rng = random.Random(SEED)
    cases = structural_cases(rng) + numeric_cases(rng) + asfamc_cases(rng) + path_cases()
    cases += readonly_cases()
    ids = [c.id for c in cases]
    assert len(ids) == len(set(ids)), [i for i, n in Counter(ids).items() if n > 1]
    return cases


CASES = all_cases()


def _params(cases: list[Case]) -> list:
    out = []
    for c in cases:
        marks = ()
        reason = next((r for k, r in PARSER_SIDE.items() if re.fullmatch(k, c.id)), None)
        if reason:
            marks = (pytest.mark.xfail(strict=False, reason=f"parser side: {reason}"),)
        out.append(pytest.param(c, id=c.id, marks=marks))
    return out


# ------------------------------------------------------------------------------- running
def _materialize(case: Case, root: Path) -> None:
    for f in case.folders:
        (root / f).mkdir(parents=True, exist_ok=True)
    for rel, data in case.files:
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    for link, target in case.symlinks:
        (root / link).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(target, root / link)
    for new, existing in case.hardlinks:
        os.link(root / existing, root / new)


def _snapshot(root: Path) -> dict[str, str]:
    """Every entry under ``root``: files by content hash, links by target, folders."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for n in dirnames + filenames:
            p = Path(dirpath) / n
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = "link:" + os.readlink(p)
            elif p.is_dir():
                out[rel] = "folder"
            else:
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


@dataclass
class Result:
    exit_code: int
    stdout: str
    stderr: str
    error: str | None  # an unexpected exception, with its traceback


def _invoke(args: tuple[str, ...], cwd: Path) -> Result:
    import traceback

    with contextlib.chdir(cwd):
        res = CliRunner().invoke(main, list(args))
    err = None
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        err = "".join(traceback.format_exception(*res.exc_info))
    return Result(res.exit_code, res.stdout, res.stderr, err)


def _strict_json(text: str | bytes, what: str):
    def refuse(token: str):
        raise AssertionError(f"{what}: not strict JSON ({token})")

    return json.loads(text, parse_constant=refuse)


OUTCOMES: Counter = Counter()
"""(family, "valid result" | "one-line error") of the cases run so far (for the summary)."""


def _check(case: Case, root: Path, before: dict[str, str], res: Result) -> None:
    __tracebackhide__ = True
    OUTCOMES[case.family, "valid result" if res.exit_code == 0 else "error"] += 1
    where = f"{case.id}: mocapkit {' '.join(a[:60] for a in case.args)}"
    assert res.error is None, f"{where}: unhandled exception\n{res.error}"
    after = _snapshot(root)
    for rel, digest in before.items():
        assert after.get(rel) == digest, f"{where}: input {rel} changed or removed"
    leftovers = [rel for rel in after if TMP_FILE.match(Path(rel).name)]
    assert not leftovers, f"{where}: temporary files left: {leftovers}"
    new = sorted(set(after) - set(before))
    if res.exit_code == 0:
        assert case.expect != "error", f"{where}: expected an error, got exit 0\n{res.stderr}"
        allowed = set(case.outputs)
        assert set(new) <= allowed, f"{where}: unexpected outputs {sorted(set(new) - allowed)}"
        for line in res.stderr.splitlines():
            assert line.startswith(("mocapkit: warning: ", "mocapkit: repaired: ")), (
                f"{where}: stray stderr line {line[:200]!r}"
            )
        if "--json" in case.args and case.args[0] == "info":
            data = _strict_json(res.stdout, f"{where}: stdout")
            if "no_fffd" in case.checks:
                names = data["joint_names"] if isinstance(data, dict) else []
                assert not any("\ufffd" in n for n in names), f"{where}: U+FFFD in names"
        for rel in new:
            p = root / rel
            if p.suffix == ".json":
                _strict_json(p.read_bytes(), f"{where}: {rel}")
            elif p.suffix == ".html":
                m = VIEW_DATA.search(p.read_bytes())
                assert m, f"{where}: no data in {rel}"
                _strict_json(m.group(1), f"{where}: {rel} data")
        return
    assert case.expect != "ok", f"{where}: expected success, got {res.exit_code}\n{res.stderr}"
    assert res.exit_code == 2, f"{where}: exit {res.exit_code}\n{res.stderr[-2000:]}"
    # a library job (graph build) goes past a bad file: its outputs from the others may stand
    partial = set(case.outputs) if case.args[:2] == ("graph", "build") else set()
    assert set(new) <= partial, f"{where}: wrote {sorted(set(new) - partial)} although it failed"
    text = res.stderr.strip()
    if partial:  # what it built from the others may carry its own warnings
        text = "\n".join(x for x in text.splitlines() if not x.startswith("mocapkit: warning: "))
    assert "\n" not in text, f"{where}: not one line:\n{text[:3000]}"
    assert text.startswith(PREFIX), f"{where}: {text[:300]!r}"
    names = {Path(rel).name for rel, _ in case.files} | {Path(a).name for a in case.args}
    names |= {Path(link).name for link, _ in case.symlinks} | {n for n, _ in case.hardlinks}
    names = {n for n in names if ("." in n and not n.startswith("-")) or n in FOLDERS}
    names |= set(case.culprits)
    assert any(n in text for n in names), f"{where}: the error names no file: {text[:300]!r}"
    rest = text
    for a in sorted({*case.args, *names}, key=len, reverse=True):
        if len(a) > 2:
            rest = rest.replace(a, "")
    assert len(rest) <= MAX_MESSAGE, f"{where}: {len(rest)}-character message: {text[:400]!r}..."
    quoted = re.findall(r"(?:got|read|value|token) '", rest)
    if quoted:
        assert rest.count("'") % 2 == 0, f"{where}: unclosed quote in {text[:300]!r}"
    if "--json" in case.args and res.stdout.strip():
        _strict_json(res.stdout, f"{where}: stdout")


FOLDERS = ("clips", "empty", "nope")

INPROCESS = [c for c in CASES if not c.readonly]
READONLY = [c for c in CASES if c.readonly]


@pytest.mark.parametrize("case", _params(INPROCESS))
def test_fuzz_case(case: Case, tmp_path: Path) -> None:
    _materialize(case, tmp_path)
    before = _snapshot(tmp_path)
    res = _invoke(case.args, tmp_path / case.cwd)
    _check(case, tmp_path, before, res)


# ------------------------------------------------------------ read-only folders, dropped privileges
_CHILD = r"""
import json, sys, traceback, contextlib
from click.testing import CliRunner
from mocapkit.cli import main
out = []
for job in json.load(open(sys.argv[1])):
    with contextlib.chdir(job["cwd"]):
        res = CliRunner().invoke(main, job["args"])
    err = None
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        err = "".join(traceback.format_exception(*res.exc_info))
    out.append({"exit_code": res.exit_code, "stdout": res.stdout, "stderr": res.stderr,
                "error": err})
json.dump(out, open(sys.argv[2], "w"))
"""


def _drop_privileges() -> list[str] | None:
    """The command prefix that runs as nobody (root ignores permissions), [] when not root,
    None when root and setpriv is missing."""
    if os.geteuid() != 0:
        return []
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        return None
    return [setpriv, "--reuid=65534", "--regid=65534", "--clear-groups"]


@pytest.fixture(scope="module")
def readonly_runs():
    """Run every read-only case once (in one subprocess as nobody when root): case id ->
    (case folder, snapshot before, Result)."""
    prefix = _drop_privileges()
    if prefix is None:
        pytest.skip("running as root and util-linux setpriv is missing: cannot drop privileges")
    if prefix:
        # can nobody reach the interpreter's packages and mocapkit's sources? (no import:
        # numba would want a cache folder first)
        code = "import click, importlib.util as u; open(u.find_spec('mocapkit').origin).read()"
        probe = subprocess.run([*prefix, sys.executable, "-c", code],
                               capture_output=True, text=True, timeout=120)  # fmt: skip
        if probe.returncode != 0:  # e.g. a checkout under a mode-700 folder (mktemp -d)
            pytest.skip(
                "user nobody cannot import mocapkit from this checkout (a folder above "
                f"it is not readable by others): {probe.stderr.strip()[-120:]}"
            )
    base = Path(tempfile.mkdtemp(prefix="mocapkit-fuzz-ro-"))
    os.chmod(base, 0o755)
    try:
        jobs, folders, befores = [], {}, {}
        for i, case in enumerate(READONLY):
            root = base / f"c{i}"
            root.mkdir()
            _materialize(case, root)
            for dirpath, _, filenames in os.walk(root):
                os.chmod(dirpath, 0o777)  # writable by nobody, but for the read-only ones
                for n in filenames:
                    os.chmod(Path(dirpath) / n, 0o644)
            for ro in case.readonly:
                os.chmod(root / ro, 0o555)
            folders[case.id], befores[case.id] = root, _snapshot(root)
            jobs.append({"args": list(case.args), "cwd": str(root / case.cwd)})
        job_file, result_file = base / "jobs.json", base / "results.json"
        job_file.write_text(json.dumps(jobs))
        child = base / "child.py"
        child.write_text(_CHILD)
        numba_cache = base / "numba-cache"
        numba_cache.mkdir()
        os.chmod(base, 0o777)
        os.chmod(numba_cache, 0o777)
        env = dict(os.environ, NUMBA_CACHE_DIR=str(numba_cache), HOME=str(base))
        proc = subprocess.run(
            [*prefix, sys.executable, str(child), str(job_file), str(result_file)],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert proc.returncode == 0, proc.stderr[-3000:]
        results = json.loads(result_file.read_text())
        yield {
            c.id: (folders[c.id], befores[c.id], Result(**r))
            for c, r in zip(READONLY, results, strict=True)
        }
    finally:
        for dirpath, _, _ in os.walk(base):
            with contextlib.suppress(OSError):
                os.chmod(dirpath, 0o755 | stat.S_IWUSR)
        shutil.rmtree(base, ignore_errors=True)


@pytest.mark.parametrize("case", _params(READONLY))
def test_fuzz_readonly_case(case: Case, readonly_runs) -> None:
    root, before, res = readonly_runs[case.id]
    _check(case, root, before, res)


# ------------------------------------------------------------------------------- counts
def test_case_counts() -> None:
    families = Counter(c.family for c in CASES)
    commands = Counter(" ".join(c.args[:2]) if c.args[0] in ("graph", "info") and c.args[1]
                       in ("build", "--json") else c.args[0] for c in CASES)  # fmt: skip
    print(f"\nfuzz cases ({len(CASES)}, ASF/AMC from {base_asfamc()[2]}):")
    for fam, n in sorted(families.items()):
        ran = ", ".join(f"{OUTCOMES[fam, k]} {k}" for k in ("valid result", "error"))
        print(
            f"  {fam:10s} {n:4d}"
            + (f"  (this run: {ran})" if ran != "0 valid result, 0 error" else "")
        )
    print("  by subcommand: " + ", ".join(f"{k} {v}" for k, v in sorted(commands.items())))
    assert len(CASES) >= 300
    assert {"structural", "numeric", "asfamc", "path"} <= set(families)
    assert all(n >= 30 for n in families.values()), families
    for cmd in ("info", "convert", "clean", "stitch", "graph", "view", "edit"):
        assert any(c.args[0] == cmd for c in CASES), cmd
    assert any(c.args[:2] == ("info", "--json") for c in CASES)
