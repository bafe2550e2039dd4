"""BVH reader/writer: grammar quirks, exact frame time, errors with lines, round trips."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import end_site_positions, forward_kinematics
from mocapkit.io.bvh import format_bvh, parse_bvh, read_bvh, write_bvh
from mocapkit.io.errors import BVHError, RepairWarning

SMALL = """HIERARCHY
ROOT Hips
{
  OFFSET 0 90 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 20 0
    }
  }
  JOINT Leg
  {
    OFFSET 10 -5 0
    CHANNELS 3 Xrotation Yrotation Zrotation
    End Site
    {
      OFFSET 0 -40 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
1 90 2 10 20 30 0 0 45 90 0 0
1.5 91 2.5 -10 5e-1 3.0E+01 1 2 3 0 -90 0
"""


def test_small_file_values_and_fk() -> None:
    m = parse_bvh(SMALL)
    assert m.skeleton.names == ("Hips", "Spine", "Leg")
    assert list(m.skeleton.parents) == [-1, 0, 0]
    assert m.skeleton.rotation_orders == ("ZXY", "ZXY", "XYZ")
    assert m.frame_time == 0.0333333
    np.testing.assert_array_equal(m.root_positions, [[1, 90, 2], [1.5, 91, 2.5]])
    # rotation of Hips frame 1 = intrinsic ZXY (-10, 0.5, 30) degrees, checked with scipy
    ref = Rotation.from_euler("ZXY", [-10, 0.5, 30], degrees=True).as_quat(scalar_first=True)
    assert rot.quat_angle(m.rotations[1, 0], ref) < 1e-12
    # FK: Leg End Site at frame 0 = hips + R_hips (10,-5,0) + R_hips R_leg (0,-40,0)
    pos, grot = forward_kinematics(m)
    es = end_site_positions(m.skeleton, pos, grot)
    R0 = Rotation.from_euler("ZXY", [10, 20, 30], degrees=True)
    R1 = Rotation.from_euler("XYZ", [90, 0, 0], degrees=True)
    expect = np.array([1, 90, 2]) + R0.apply([10, -5, 0]) + (R0 * R1).apply([0, -40, 0])
    np.testing.assert_allclose(es[0, 1], expect, atol=1e-9)


def _tweak(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new, 1)


def test_whitespace_crlf_tabs_and_missing_final_newline() -> None:
    ref = parse_bvh(SMALL)
    crlf = SMALL.replace("\n", "\r\n")
    tabs = SMALL.replace("  ", "\t").replace("Frames: 2", "Frames:\t2").replace(" 2 10", "\t2 \t10")
    mixed = SMALL.replace("\n", "\r\n", 5)
    no_eol = SMALL.rstrip("\n")
    blank_hier = _tweak(SMALL, "JOINT Spine", "\n\nJOINT Spine")
    for text in (crlf, tabs, mixed, no_eol, blank_hier):
        assert parse_bvh(text).allclose(ref, rot_atol=1e-12, pos_atol=0)


def test_rotations_first_and_six_channel_children_and_zero_channel_root() -> None:
    text = _tweak(
        SMALL,
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
        "CHANNELS 6 Zrotation Xrotation Yrotation Xposition Yposition Zposition",
    )
    text = text.replace("1 90 2 10 20 30", "10 20 30 1 90 2").replace(
        "1.5 91 2.5 -10 5e-1 3.0E+01", "-10 5e-1 3.0E+01 1.5 91 2.5"
    )
    a, b = parse_bvh(text), parse_bvh(SMALL)
    assert a.skeleton.channels[0][0] == "Zrotation"
    np.testing.assert_array_equal(a.rotations, b.rotations)
    np.testing.assert_array_equal(a.root_positions, b.root_positions)
    assert parse_bvh(format_bvh(a)).skeleton.channels == a.skeleton.channels

    six = _tweak(
        SMALL,
        "CHANNELS 3 Zrotation Xrotation Yrotation",
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
    )
    six = six.replace("30 0 0 45", "30 0 7 0 0 0 45").replace(
        "30.0E+01 1 2 3", "30.0E+01 0 9 0 1 2 3"
    )
    six = six.replace("3.0E+01 1 2 3", "3.0E+01 0 9 0 1 2 3")
    m = parse_bvh(six)
    assert m.translations is not None
    np.testing.assert_array_equal(m.translations[:, 1], [[0, 7, 0], [0, 9, 0]])
    np.testing.assert_array_equal(m.translations[:, 2], [[10, -5, 0]] * 2)
    back = parse_bvh(format_bvh(m))
    assert back.allclose(m)

    zero_root = _tweak(
        SMALL,
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
        "CHANNELS 0",
    )
    zero_root = zero_root.replace("1 90 2 10 20 30 ", "").replace(
        "1.5 91 2.5 -10 5e-1 3.0E+01 ", ""
    )
    m0 = parse_bvh(zero_root)
    np.testing.assert_array_equal(m0.root_positions, [[0, 90, 0]] * 2)
    np.testing.assert_array_equal(m0.rotations[:, 0], [[1, 0, 0, 0]] * 2)
    assert parse_bvh(format_bvh(m0)).allclose(m0)


def test_end_site_variants_and_joint_without_end_site() -> None:
    named = SMALL.replace(
        "End Site\n    {\n      OFFSET 0 20 0", "End Site Head_end\n    {\n      OFFSET 0 20 0"
    )
    m = parse_bvh(named)
    assert m.skeleton.end_site_names[0] == "Head_end"
    assert "End Site Head_end" in format_bvh(m)
    glued = SMALL.replace(
        "End Site\n    {\n      OFFSET 0 20 0", "End Site4\n    {\n      OFFSET 0 20 0"
    )
    np.testing.assert_array_equal(parse_bvh(glued).skeleton.end_site_offsets[0], [0, 20, 0])
    bare = SMALL.replace("    End Site\n    {\n      OFFSET 0 20 0\n    }\n", "", 1)
    mb = parse_bvh(bare)
    assert len(mb.skeleton.end_site_parents) == 1
    assert parse_bvh(format_bvh(mb)).skeleton.allclose(mb.skeleton)


def test_zero_and_one_frame_files() -> None:
    head = SMALL.split("MOTION")[0]
    zero = parse_bvh(head + "MOTION\nFrames: 0\nFrame Time: 0.01\n")
    assert zero.num_frames == 0 and zero.rotations.shape == (0, 3, 4)
    assert parse_bvh(format_bvh(zero)).num_frames == 0
    one = parse_bvh(head + "MOTION\nFrames: 1\nFrame Time: 1\n" + "0 " * 12)
    assert one.num_frames == 1 and one.frame_time == 1.0


@pytest.mark.parametrize(
    "ft",
    [
        "0.0417083750417",
        ".0083333",
        "0.016666666666666666",
        "0.03333333333333333",
        "1.00000000",
        "8.333e-3",
        "0.008",
    ],
)
def test_frame_time_kept_exactly(ft: str, tmp_path) -> None:
    text = SMALL.replace("Frame Time: 0.0333333", f"Frame Time: {ft}")
    m = parse_bvh(text)
    assert m.frame_time == float(ft)
    p = write_bvh(m, tmp_path / "out.bvh")
    assert read_bvh(p).frame_time == float(ft)


MALFORMED = [
    (
        "missing closing brace",
        lambda s: s.replace("    }\n  }\n  JOINT Leg", "    }\n  JOINT Leg"),
        None,
    ),
    (
        "channel count",
        lambda s: s.replace(
            "CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 4 Zrotation Xrotation Yrotation"
        ),
        9,
    ),
    ("unknown channel", lambda s: s.replace("CHANNELS 3 Zrotation", "CHANNELS 3 Wrotation"), 9),
    ("short motion line", lambda s: s.replace("0 0 45 90 0 0", "0 0 45 90 0"), 28),
    ("long motion line", lambda s: s.replace("0 0 45 90 0 0", "0 0 45 90 0 0 7"), 28),
    ("not a number", lambda s: s.replace("0 0 45 90", "0 0 4x5 90"), 28),
    ("nan", lambda s: s.replace("0 0 45 90", "0 0 nan 90"), 28),
    ("inf", lambda s: s.replace("0 0 45 90", "0 0 -inf 90"), 28),
    ("duplicate names", lambda s: s.replace("JOINT Leg", "JOINT Spine"), 15),
    ("frames too many", lambda s: s.replace("Frames: 2", "Frames: 3"), 26),
    ("frames too few", lambda s: s.replace("Frames: 2", "Frames: 1"), 26),
    ("frames not a number", lambda s: s.replace("Frames: 2", "Frames: two"), 26),
    ("no MOTION", lambda s: s.split("MOTION")[0], None),
    ("no hierarchy", lambda s: s.split("MOTION")[1], 2),
    ("offset short", lambda s: s.replace("OFFSET 0 10 0", "OFFSET 0 10"), 8),
    ("offset nan", lambda s: s.replace("OFFSET 0 10 0", "OFFSET 0 nan 0"), 8),
    ("bad frame time", lambda s: s.replace("Frame Time: 0.0333333", "Frame Time: 0"), 27),
    ("empty", lambda s: "", None),
    ("blank line inside data", lambda s: s.replace("0 0\n1.5", "0 0\n\n1.5"), 29),
]


@pytest.mark.parametrize(("what", "edit", "line"), MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_input_names_file_and_line(what, edit, line) -> None:
    with pytest.raises(BVHError) as err:
        parse_bvh(edit(SMALL), source="bad.bvh")
    msg = str(err.value)
    assert msg.startswith("bad.bvh")
    if line is not None:
        assert err.value.line == line, msg
        assert msg.startswith(f"bad.bvh:{line}: ")


def test_lenient_repairs_and_says_so() -> None:
    extra_row = SMALL + "1 90 2 0 0 0 0 0 0 0 0 0\n"
    with pytest.warns(RepairWarning, match="Frames: 2' but 3 rows"):
        m = parse_bvh(extra_row, lenient=True)
    assert m.num_frames == 3
    truncated = SMALL + "1 90 2 0 0"
    with pytest.warns(RepairWarning, match="incomplete last row"):
        m = parse_bvh(truncated, lenient=True)
    assert m.num_frames == 2
    with pytest.raises(BVHError, match=r"--lenient, drops an incomplete last row"):
        parse_bvh(truncated)  # the strict error says what would repair it (newcomer)
    holes = SMALL.replace("-10 5e-1", "nan 5e-1")
    with pytest.warns(RepairWarning, match="filled from neighbouring frames"):
        m = parse_bvh(holes, lenient=True)
    assert np.all(np.isfinite(m.rotations))
    # the repair names the line the strict reading names, not the first row's (newcomer
    # report), blank lines before it counted
    with pytest.raises(BVHError) as strict:
        parse_bvh(holes)
    with pytest.warns(RepairWarning, match=rf":{strict.value.line}: 1 NaN/inf value in 1 row "):
        parse_bvh(holes, lenient=True)
    lines = holes.split("\n")
    at = next(i for i, x in enumerate(lines) if "nan" in x)
    blank = "\n".join([*lines[:at], "", *lines[at:]])
    with pytest.warns(RepairWarning, match=rf":{strict.value.line + 1}: 1 NaN/inf value in 1 "):
        parse_bvh(blank, lenient=True)
    # a non-number is never "safe" to repair
    with pytest.raises(BVHError):
        parse_bvh(SMALL.replace("0 0 45 90", "0 0 4x5 90"), lenient=True)
    # nor a short row inside the data: which channel is missing cannot be told; it says so
    rows = SMALL.rstrip("\n").split("\n")
    rows[-2] = " ".join(rows[-2].split()[:-1])
    with pytest.raises(BVHError, match="repairs only an incomplete last row"):
        parse_bvh("\n".join(rows) + "\n", lenient=True)


def test_the_frames_filled_and_the_strict_error_are_told_apart() -> None:
    """A caller about to replace the frames holding NaN (inbetween's gap) needs to know which
    they are, and that NaN, not another defect, is what a strict reading refused."""
    from mocapkit.io import FilledFramesWarning, NonFiniteError

    head = SMALL.split("MOTION")[0]
    rows = [f"0 90 0 {z} 0 0 0 0 0 0 0 0" for z in (0, "nan", "nan", 30, "inf", 10, 20, "nan")]
    text = head + "MOTION\nFrames: 8\nFrame Time: 0.1\n" + "\n".join(rows) + "\n"
    with pytest.raises(NonFiniteError):
        parse_bvh(text)
    with pytest.warns(FilledFramesWarning) as seen:
        parse_bvh(text, lenient=True)
    assert [w.message.frames for w in seen] == [[(1, 3), (4, 5), (7, 8)]]
    with pytest.raises(BVHError) as other:  # not a number: another defect
        parse_bvh(text.replace("nan", "n4n", 1))
    assert not isinstance(other.value, NonFiniteError)


def test_fill_from_neighbours_interpolates_between_valid_frames() -> None:
    head = SMALL.split("MOTION")[0]
    rows = [f"0 90 0 {z} 0 0 0 0 0 0 0 0" for z in (0, "nan", "nan", 30)]
    text = head + "MOTION\nFrames: 4\nFrame Time: 0.1\n" + "\n".join(rows) + "\n"
    with pytest.warns(RepairWarning):
        m = parse_bvh(text, lenient=True)
    angles = np.rad2deg(2 * np.arctan2(m.rotations[:, 0, 3], m.rotations[:, 0, 0]))
    np.testing.assert_allclose(angles, [0, 10, 20, 30], atol=1e-9)


def test_writer_order_conversion_preserves_pose(tmp_path) -> None:
    m = parse_bvh(SMALL)
    for order in ("ZYX", "XYZ", "YZX"):
        p = write_bvh(m, tmp_path / f"{order}.bvh", order=order)
        back = read_bvh(p)
        assert set(back.skeleton.rotation_orders) == {order}
        np.testing.assert_allclose(forward_kinematics(back)[0], forward_kinematics(m)[0], atol=1e-9)
    text = format_bvh(m)
    assert "-0 " not in text and " -0\n" not in text
    assert not [p for p in tmp_path.iterdir() if p.suffix == ".tmp"], "temp files left behind"


def test_writer_refuses_nan() -> None:
    m = parse_bvh(SMALL)
    m.rotations[0, 1, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite rotation at frame 0, joint 'Spine'"):
        format_bvh(m)


def test_root_gets_position_channels_when_it_moves() -> None:
    zero_root = (
        SMALL.replace(
            "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
            "CHANNELS 3 Zrotation Xrotation Yrotation",
        )
        .replace("1 90 2 10", "10")
        .replace("1.5 91 2.5 -10", "-10")
    )
    m = parse_bvh(zero_root)
    m.root_positions[:, 0] += np.array([0.0, 5.0])
    back = parse_bvh(format_bvh(m))
    assert back.skeleton.has_position[0]
    np.testing.assert_allclose(back.root_positions, m.root_positions)


# ---- fuzzing: every corruption ends in BVHError or a valid parse -----------------------------


@settings(
    max_examples=300, deadline=2000, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(cut=st.integers(0, len(SMALL)), lenient=st.booleans())
def test_fuzz_truncated(cut: int, lenient: bool) -> None:
    _parse_or_bvherror(SMALL[:cut], lenient)


@settings(
    max_examples=600, deadline=2000, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    edits=st.lists(
        st.tuples(
            st.integers(0, len(SMALL) - 1),
            st.integers(0, 4),
            st.sampled_from(
                [*list("{} \n\t-.eE0123456789xX:#"), "nan", "End", "JOINT", "\r", "\x00", "é"]
            ),
        ),
        min_size=1,
        max_size=6,
    ),
    lenient=st.booleans(),
)
def test_fuzz_corrupted(edits: list[tuple[int, int, str]], lenient: bool) -> None:
    text = SMALL
    for pos, dele, ins in edits:
        pos = min(pos, len(text))
        text = text[:pos] + ins + text[pos + dele :]
    _parse_or_bvherror(text, lenient)


def _parse_or_bvherror(text: str, lenient: bool) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RepairWarning)
        try:
            m = parse_bvh(text, source="fuzz.bvh", lenient=lenient)
        except BVHError as e:
            assert str(e).startswith("fuzz.bvh")
            return
    assert np.all(np.isfinite(m.rotations)) and np.all(np.isfinite(m.root_positions))
    np.testing.assert_allclose(np.linalg.norm(m.rotations, axis=-1), 1.0, atol=1e-9)


@pytest.mark.parametrize("order", ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"])
def test_fast_channel_conversion_matches_reference_euler(order: str) -> None:
    """The numba channels -> quaternion kernel against rotations.euler_to_quat."""
    from mocapkit.core.skeleton import Skeleton
    from mocapkit.io.bvh import channels_to_motion, motion_to_channels

    rng = np.random.default_rng(7)
    rot_ch = tuple(f"{a}rotation" for a in order)
    sk = Skeleton(
        ("a", "b", "c"),
        [-1, 0, 1],
        np.zeros((3, 3)),
        (("Xposition", "Yposition", "Zposition", *rot_ch), rot_ch[::-1], ()),
    )
    values = rng.uniform(-360, 360, size=(50, 9))
    values[:5, 4] = 90.0  # gimbal lock in the middle channel
    m = channels_to_motion(sk, values, 0.01)
    ref0 = rot.euler_to_quat(np.deg2rad(values[:, 3:6]), order)
    ref1 = rot.euler_to_quat(np.deg2rad(values[:, 6:9]), order[::-1])
    assert np.all(rot.quat_angle(m.rotations[:, 0], ref0) < 1e-12)
    assert np.all(rot.quat_angle(m.rotations[:, 1], ref1) < 1e-12)
    np.testing.assert_array_equal(m.rotations[:, 2], [[1, 0, 0, 0]] * 50)
    back = channels_to_motion(sk, motion_to_channels(m), 0.01)
    assert np.all(rot.quat_angle(back.rotations, m.rotations) < 1e-12)


def _both_hierarchy_parsers(text: str):
    from mocapkit.io.bvh import _fast_hierarchy, _Lines, _parse_hierarchy

    lx = _Lines(text.encode(), "x.bvh")
    fast = _fast_hierarchy(lx.header_lines)
    try:
        ref = _parse_hierarchy(lx, "x.bvh")
    except BVHError:
        ref = None
    return fast, ref


def _same_hierarchy(a, b) -> bool:
    keys = ("names", "parents", "offsets", "channels", "es_parents", "es_offsets", "es_names")
    return all(getattr(a, k) == getattr(b, k) for k in keys)


@settings(max_examples=400, deadline=2000, derandomize=True)
@given(
    edits=st.lists(
        st.tuples(
            st.integers(0, SMALL.index("MOTION")),
            st.integers(0, 3),
            st.sampled_from(
                [
                    "{",
                    "}",
                    " ",
                    "\n",
                    "x",
                    "0",
                    "End Site",
                    "JOINT",
                    "CHANNELS 3",
                    "MOTION",
                    "ROOT a",
                ]
            ),
        ),
        max_size=3,
    ),
)
def test_fast_hierarchy_parser_agrees_with_reference(edits) -> None:
    """Whenever the line-based fast path accepts a hierarchy, the token parser (the reference)
    accepts it too and builds the same one; otherwise the reference decides (and errors)."""
    text = SMALL
    for pos, dele, ins in edits:
        text = text[:pos] + ins + text[pos + dele :]
    fast, ref = _both_hierarchy_parsers(text)
    if fast is not None:
        assert ref is not None and _same_hierarchy(fast, ref)


def test_fast_hierarchy_parser_takes_the_common_files(shared_path) -> None:
    for f in sorted(shared_path("bvh-corpus").glob("*.bvh")):
        fast, ref = _both_hierarchy_parsers(f.read_bytes().decode("utf-8", "replace"))
        assert ref is not None, f.name
        if fast is not None:
            assert _same_hierarchy(fast, ref), f.name


def test_joint_rotating_without_rotation_channels_gets_them() -> None:
    text = SMALL.replace("CHANNELS 3 Xrotation Yrotation Zrotation", "CHANNELS 0")
    text = text.replace(" 90 0 0\n", "\n").replace(" 0 -90 0\n", "\n")
    m = parse_bvh(text)
    assert not m.skeleton.has_rotation[2]
    m.rotations[:, 2] = rot.euler_to_quat(np.array([0.3, 0.2, 0.1]), "XYZ")
    back = parse_bvh(format_bvh(m))
    assert back.skeleton.has_rotation[2]
    assert np.all(rot.quat_angle(back.rotations, m.rotations) < 1e-9)


def test_outputs_get_normal_file_permissions(tmp_path) -> None:
    import os
    import stat

    p = write_bvh(parse_bvh(SMALL), tmp_path / "perm.bvh")
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~umask


def test_an_unchanged_small_angle_is_written_as_the_file_had_it() -> None:
    """Newcomer report: read then written, a Bandai take's -5.69484e-05 became
    -5.69483999995e-05 (the quaternion round trip's ~1e-14 deg printed to 12 digits) on every
    row; rotation channels are written to 1e-12 deg, below the round trip's rounding."""
    text = SMALL.replace("1 2 3 0 -90 0", "-5.69484e-05 -9.11063e-06 123.456 0 -90 0")
    m = parse_bvh(text)
    rows = format_bvh(m).split("Frame Time:")[1].splitlines()[1:]
    assert [float(v) for v in rows[1].split()[6:9]] == [-5.69484e-05, -9.11063e-06, 123.456]

