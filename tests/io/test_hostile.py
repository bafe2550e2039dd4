"""Hostile input to the readers: deep rigs, huge lines, overflowing numbers, NUL padding and
non-UTF-8 names get a bounded, one-line answer or a correct result."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from mocapkit.io import MocapFileError
from mocapkit.io.asfamc import parse_asf
from mocapkit.io.bvh import format_bvh, parse_bvh
from mocapkit.io.errors import DecodingWarning, quote


def _chain(n: int, frames: int = 2, inline_braces: bool = False) -> str:
    sep = " " if inline_braces else "\n"
    out = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0",
           "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]  # fmt: skip
    for i in range(1, n):
        out += [f"JOINT j{i}{sep}{{", "OFFSET 0 1 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    out += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * n
    out += ["MOTION", f"Frames: {frames}", "Frame Time: 0.033333"]
    out += [" ".join(["0.5"] * (6 + 3 * (n - 1)))] * frames
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("inline", [False, True])  # fast line parser, then the token parser
def test_deep_rigs_read_and_write_without_recursion(inline: bool) -> None:
    m = parse_bvh(_chain(3000, inline_braces=inline).encode())
    assert m.num_joints == 3000
    again = parse_bvh(format_bvh(m).encode())
    assert again.skeleton.allclose(m.skeleton)
    np.testing.assert_allclose(again.rotations, m.rotations, atol=1e-9)


def test_a_huge_line_gets_a_short_message() -> None:
    data = b"HIERARCHY\nROOT " + b"a " * 2_000_000 + b"\n{\n"
    with pytest.raises(MocapFileError) as e:
        parse_bvh(data, "big.bvh")
    msg = str(e.value)
    assert msg.startswith("big.bvh:2:") and len(msg) < 200


def test_nul_padding_is_quoted_briefly_with_a_closed_quote() -> None:
    data = b"HIERARCHY\nROOT Hips\n{\n" + b"\x00" * 16000 + b"\n"
    with pytest.raises(MocapFileError) as e:
        parse_bvh(data, "nul.bvh")
    msg = str(e.value)
    assert len(msg) < 200 and msg.rstrip().endswith("'")


@pytest.mark.parametrize("literal", ["1e309", "-1e400", "1" + "0" * 400])
def test_numbers_beyond_double_range_are_an_error(literal: str) -> None:
    text = _chain(2).replace("0.5 0.5 0.5 0.5", f"0.5 0.5 {literal} 0.5", 1)
    with pytest.raises(MocapFileError, match="beyond the range"):
        parse_bvh(text.encode(), "x.bvh")
    # lenient mode fills them like any other gap, and says so
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = parse_bvh(text.encode(), "x.bvh", lenient=True)
    assert np.all(np.isfinite(m.rotations)) and caught


def test_an_extreme_offset_is_read_exactly() -> None:
    text = _chain(2).replace("OFFSET 0 1 0", "OFFSET 0 1e308 0", 1)
    m = parse_bvh(text.encode())
    assert m.skeleton.offsets[1, 1] == 1e308


@pytest.mark.parametrize(("encoding", "name"), [("latin-1", "Épaule_G"), ("cp932", "左太もも")])
def test_non_utf8_names_are_decoded_with_a_stated_fallback(encoding: str, name: str) -> None:
    data = _chain(2).replace("j1", name).encode(encoding)
    with pytest.warns(DecodingWarning, match=encoding):
        m = parse_bvh(data, "names.bvh")
    assert m.skeleton.names[1] == name


def test_asf_with_latin1_bytes_is_decoded_with_a_warning() -> None:
    asf = (
        ":version 1.10\n:name caf\xe9\n:units\n  mass 1.0\n  length 0.45\n  angle deg\n"
        ":root\n  order TX TY TZ RX RY RZ\n  axis XYZ\n  position 0 0 0\n  orientation 0 0 0\n"
        ":bonedata\n  begin\n    id 1\n    name lfemur\n    direction 0 -1 0\n    length 7\n"
        "    axis 0 0 0 XYZ\n  end\n:hierarchy\n  begin\n    root lfemur\n  end\n"
    ).encode("latin-1")
    with pytest.warns(DecodingWarning, match="latin-1"):
        a = parse_asf(asf, "caf.asf")
    assert a.name == "café"


def test_quote_keeps_short_text_and_closes_long_text() -> None:
    assert quote("abc") == "'abc'"
    q = quote("x" * 500)
    assert len(q) <= 80 and q.startswith("'") and q.endswith("'")


def test_a_file_named_npz_that_is_not_one_says_so(tmp_path) -> None:
    """Newcomer report: a BVH renamed .npz gave numpy's message about pickled data and
    allow_pickle (no help, and unsafe advice)."""
    from mocapkit.io import MocapFileError, read_motion

    fake = tmp_path / "walk.npz"
    fake.write_text("HIERARCHY\nROOT Hips\n{\n")
    with pytest.raises(MocapFileError, match=r"walk\.npz: not an \.npz archive .*name it \.bvh"):
        read_motion(fake)
    (tmp_path / "junk.npz").write_bytes(b"\x00\x01junk")
    with pytest.raises(MocapFileError, match=r"not an \.npz archive") as e:
        read_motion(tmp_path / "junk.npz")
    assert "pickle" not in str(e.value)
