"""Tests for mocapkit.io.asfamc: ASF/AMC written here from known values, FK checked against an
independent evaluation of the Acclaim definitions with scipy."""

from __future__ import annotations

import contextlib
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import end_site_positions, forward_kinematics
from mocapkit.io.asfamc import (
    AsfSkeleton,
    parse_amc,
    parse_asf,
    read_amc,
    read_asf,
    read_asfamc,
)
from mocapkit.io.bvh import read_bvh, write_bvh
from mocapkit.io.errors import ASFAMCError

TOL = 1e-9


def _unit(v: list[float]) -> list[float]:
    a = np.asarray(v, dtype=np.float64)
    return list(a / np.linalg.norm(a))


# A small skeleton: a spine chain with a branch, a leg chain behind a dof-less hip bone.
# Angles in degrees; each bone: (name, parent, direction, length, axis angles, axis order, dof).
BONES = [
    ("lowerback", "root", _unit([0.1, 1.0, 0.05]), 2.0, [10.0, -20.0, 30.0], "XYZ",
     ("rx", "ry", "rz")),
    ("upperback", "lowerback", _unit([0.0, 1.0, -0.2]), 1.5, [0.0, 40.0, 45.0], "ZYX",
     ("rz", "rx")),
    ("head", "upperback", _unit([0.05, 1.0, 0.1]), 1.2, [5.0, 15.0, -25.0], "YZX",
     ("ry", "rz", "rx")),
    ("rclavicle", "lowerback", _unit([-1.0, 0.3, 0.0]), 1.7, [30.0, 0.0, -10.0], "XZY",
     ("ry", "rz")),
    ("lhipjoint", "root", _unit([0.69, -0.65, 0.32]), 2.4, [0.0, 0.0, 0.0], "XYZ", ()),
    ("lfemur", "lhipjoint", _unit([0.342, -0.94, 0.0]), 7.1, [0.0, 0.0, 20.0], "XYZ",
     ("rx", "ry", "rz")),
    ("ltibia", "lfemur", _unit([0.342, -0.94, 0.0]), 7.4, [0.0, 0.0, 20.0], "XYZ", ("rx",)),
]
HIERARCHY = [
    ("root", ["lowerback", "lhipjoint"]),
    ("lowerback", ["upperback", "rclavicle"]),
    ("upperback", ["head"]),
    ("lhipjoint", ["lfemur"]),
    ("lfemur", ["ltibia"]),
]
PREORDER = ["root", "lowerback", "upperback", "head", "rclavicle", "lhipjoint", "lfemur", "ltibia"]
LEAVES = ["head", "rclavicle", "ltibia"]


def _fmt(x: float) -> str:
    return repr(float(x))


def make_asf(
    angle: str = "deg",
    length_unit: float = 1.0,
    root_order: str = "TX TY TZ RX RY RZ",
    root_axis: str = "XYZ",
    position: tuple[float, float, float] = (0.0, 0.0, 0.0),
    orientation: tuple[float, float, float] = (0.0, 0.0, 0.0),
    bones: list | None = None,
) -> str:
    """ASF text for BONES (angles written in ``angle`` units)."""
    conv = (lambda a: a) if angle == "deg" else math.radians
    out = [
        "# test skeleton",
        ":version 1.10",
        ":name test",
        ":units",
        "  mass 1.0",
        f"  length {_fmt(length_unit)}",
        f"  angle {angle}",
        ":documentation",
        "  written by test_asfamc",
        ":root",
        f"   order {root_order}",
        f"   axis {root_axis}",
        "   position " + " ".join(_fmt(v) for v in position),
        "   orientation " + " ".join(_fmt(conv(v)) for v in orientation),
        ":bonedata",
    ]
    for i, (name, _, d, length, axis, order, dof) in enumerate(bones or BONES, 1):
        out += [
            "  begin",
            f"     id {i}",
            f"     name {name}",
            "     direction " + " ".join(_fmt(v) for v in d),
            f"     length {_fmt(length)}",
            "     axis " + " ".join(_fmt(conv(a)) for a in axis) + f"  {order}",
        ]
        if dof:
            out.append("    dof " + " ".join(dof))
            lims = [f"({_fmt(conv(-170.0))} {_fmt(conv(170.0))})" for _ in dof]
            out.append("    limits " + lims[0])
            out += ["           " + lim for lim in lims[1:]]
        out.append("  end")
    out += [":hierarchy", "  begin"]
    out += [f"    {p} {' '.join(c)}" for p, c in HIERARCHY]
    out += ["  end", ""]
    return "\n".join(out)


def make_frames(n: int = 4, seed: int = 0, root_order: str = "TX TY TZ RX RY RZ") -> list[dict]:
    """Per frame: bone -> values in dof order (degrees / file units)."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(n):
        f = {"root": [float(rng.uniform(-10, 10)) if t[0] == "T" else float(rng.uniform(-90, 90))
                      for t in root_order.split()]}
        for name, _, _, _, _, _, dof in BONES:
            if dof:
                f[name] = [float(rng.uniform(-100, 100)) for _ in dof]
        frames.append(f)
    return frames


def make_amc(frames: list[dict], angle: str = "deg", header: str | None = ":DEGREES",
             root_order: str = "TX TY TZ RX RY RZ", first: int = 1) -> str:
    tokens = root_order.split()
    out = ["#!OML:ASF test.asf", ":FULLY-SPECIFIED"]
    if header:
        out.append(header)
    for k, f in enumerate(frames):
        out.append(str(first + k))
        for name, vals in f.items():
            if angle == "rad":
                if name == "root":
                    vals = [v if t[0] == "T" else math.radians(v)
                            for v, t in zip(vals, tokens, strict=True)]
                else:
                    vals = [math.radians(v) for v in vals]
            out.append(name + " " + " ".join(_fmt(v) for v in vals))
    return "\n".join(out) + "\n"


def acclaim_reference(
    frames: list[dict],
    bones: list | None = None,
    root_order: str = "TX TY TZ RX RY RZ",
    root_axis: str = "XYZ",
    position: tuple[float, float, float] = (0.0, 0.0, 0.0),
    orientation: tuple[float, float, float] = (0.0, 0.0, 0.0),
    translations: dict | None = None,
) -> tuple[dict, dict, dict]:
    """Independent evaluation of the Acclaim definitions with scipy (lowercase = fixed axes).

    W_root = O M_root, root at position + T; W_b = W_parent C_b M_b C_b^-1,
    start_b = end of the parent (root position for the root's children), plus W_parent C_b t_b
    for translation dofs; end_b = start_b + W_b (direction_b * length_b).
    Returns per-name lists over frames: world rotation matrices, bone starts, bone ends.
    """
    info = {b[0]: b for b in bones or BONES}
    W: dict[str, list] = {n: [] for n in PREORDER}
    start: dict[str, list] = {n: [] for n in PREORDER}
    end: dict[str, list] = {n: [] for n in PREORDER}
    tokens = root_order.split()
    for f in frames:
        rv = f["root"]
        rot_axes = "".join(t[1].lower() for t in tokens if t[0] == "R")
        rot_vals = [v for v, t in zip(rv, tokens, strict=True) if t[0] == "R"]
        T = np.array(position, dtype=np.float64)
        for v, t in zip(rv, tokens, strict=True):
            if t[0] == "T":
                T["XYZ".index(t[1])] += v
        O = Rotation.from_euler(root_axis.lower(), orientation, degrees=True)
        w = {"root": O * Rotation.from_euler(rot_axes, rot_vals, degrees=True)}
        s = {"root": T}
        e = {"root": T}
        for name in PREORDER[1:]:
            _, p, d, length, axis, order, dof = info[name]
            C = Rotation.from_euler(order.lower(), axis, degrees=True)
            rdof = [x for x in dof if x[0] == "r"]
            if rdof:
                vals = [v for v, x in zip(f[name], dof, strict=True) if x[0] == "r"]
                axes = "".join(x[1] for x in rdof)
                M = Rotation.from_euler(axes, vals[0] if len(vals) == 1 else vals, degrees=True)
            else:
                M = Rotation.identity()
            w[name] = w[p] * C * M * C.inv()
            s[name] = e[p].copy()
            if translations and name in translations:
                s[name] = s[name] + w[p].apply(C.apply(translations[name]))
            e[name] = s[name] + w[name].apply(np.asarray(d) * length)
        for n in PREORDER:
            W[n].append(w[n].as_matrix())
            start[n].append(s[n])
            end[n].append(e[n])
    return W, start, end


def check_fk(motion, W, start, end, atol=TOL, scale=1.0):
    sk = motion.skeleton
    assert list(sk.names) == PREORDER
    pos, grot = forward_kinematics(motion)
    es = end_site_positions(sk, pos, grot)
    for j, n in enumerate(PREORDER):
        np.testing.assert_allclose(pos[:, j], np.array(start[n]) * scale, rtol=0, atol=atol)
        np.testing.assert_allclose(rot.quat_to_matrix(grot[:, j]), np.array(W[n]), rtol=0,
                                   atol=atol)
    leaf_names = [sk.names[p] for p in sk.end_site_parents]
    assert sorted(leaf_names) == sorted(LEAVES)
    for e, n in enumerate(leaf_names):
        np.testing.assert_allclose(es[:, e], np.array(end[n]) * scale, rtol=0, atol=atol)


# ---------------------------------------------------------------------------------------------
# FK against the Acclaim definitions


@pytest.mark.parametrize("angle", ["deg", "rad"])
@pytest.mark.parametrize("length_unit", [1.0, 0.45])
def test_fk_matches_acclaim_definition(angle: str, length_unit: float) -> None:
    frames = make_frames(5, seed=1)
    asf = parse_asf(make_asf(angle=angle, length_unit=length_unit), "t.asf")
    header = ":DEGREES" if angle == "deg" else None  # rad: the ASF's unit applies
    motion = parse_amc(make_amc(frames, angle=angle, header=header), asf, "t.amc")
    assert motion.num_frames == 5
    W, start, end = acclaim_reference(frames)
    check_fk(motion, W, start, end)


def test_fk_root_offsets_and_order() -> None:
    order = "RZ TX RY TY RX TZ"
    pos, ori = (1.0, -2.0, 3.5), (15.0, -30.0, 50.0)
    frames = make_frames(3, seed=2, root_order=order)
    asf = parse_asf(make_asf(root_order=order, root_axis="ZXY", position=pos, orientation=ori))
    assert asf.root_order == tuple(order.split())
    assert asf.root_axis == "ZXY"
    motion = parse_amc(make_amc(frames, root_order=order), asf)
    W, start, end = acclaim_reference(frames, root_order=order, root_axis="ZXY",
                                      position=pos, orientation=ori)
    check_fk(motion, W, start, end)


def test_rest_pose_is_the_asf_pose() -> None:
    frames = [{"root": [0.0] * 6, **{b[0]: [0.0] * len(b[6]) for b in BONES if b[6]}}]
    asf = parse_asf(make_asf())
    motion = parse_amc(make_amc(frames), asf)
    np.testing.assert_allclose(motion.rotations[..., 0], 1.0, atol=1e-15)
    _, start, end = acclaim_reference(frames)
    check_fk(motion, *acclaim_reference(frames))
    # with no motion, each bone simply ends at its start + direction * length
    for name, _, d, length, *_ in BONES:
        np.testing.assert_allclose(end[name][0] - start[name][0], np.asarray(d) * length,
                                   atol=1e-12)


def test_knee_flexion_is_about_the_bone_axis() -> None:
    """A hand-checkable case: ltibia's axis is rotated 20 deg about z, so rx bends the shin
    about the axis Rz(20) x, not about global x."""
    frames = [{"root": [0.0] * 6, "lowerback": [0, 0, 0], "upperback": [0, 0], "head": [0, 0, 0],
               "rclavicle": [0, 0], "lfemur": [0, 0, 0], "ltibia": [90.0]}]
    motion = parse_amc(make_amc(frames), parse_asf(make_asf()))
    pos, grot = forward_kinematics(motion)
    es = end_site_positions(motion.skeleton, pos, grot)
    k = motion.skeleton.index("ltibia")
    shin = es[0, list(motion.skeleton.end_site_parents).index(k)] - pos[0, k]
    c, s = math.cos(math.radians(20)), math.sin(math.radians(20))
    bend_axis = np.array([c, s, 0.0])
    d = np.asarray(BONES[6][2]) * BONES[6][3]
    expected = Rotation.from_rotvec(bend_axis * math.pi / 2).apply(d)
    np.testing.assert_allclose(shin, expected, atol=1e-12)
    assert abs(np.dot(shin, bend_axis) - np.dot(d, bend_axis)) < 1e-12


# ---------------------------------------------------------------------------------------------
# units


def test_rad_and_deg_files_give_the_same_motion() -> None:
    frames = make_frames(3, seed=3)
    m_deg = parse_amc(make_amc(frames), parse_asf(make_asf(angle="deg")))
    m_rad = parse_amc(make_amc(frames, angle="rad", header=None),
                      parse_asf(make_asf(angle="rad")))
    assert m_deg.allclose(m_rad, rot_atol=1e-12, pos_atol=1e-12)
    asf = parse_asf(make_asf(angle="rad"))
    assert asf.angle == "rad"
    np.testing.assert_allclose(asf.bone("lfemur").limits,
                               np.radians([[-170.0, 170.0]] * 3), atol=1e-15)


def test_amc_header_overrides_asf_angle_unit() -> None:
    frames = make_frames(2, seed=4)
    ref = parse_amc(make_amc(frames), parse_asf(make_asf(angle="deg")))
    # degrees ASF, radian AMC values declared by :RADIANS
    m = parse_amc(make_amc(frames, angle="rad", header=":RADIANS"),
                  parse_asf(make_asf(angle="deg")))
    assert ref.allclose(m, rot_atol=1e-12, pos_atol=1e-12)
    # radians ASF, degree AMC values declared by :DEGREES
    m = parse_amc(make_amc(frames, header=":DEGREES"), parse_asf(make_asf(angle="rad")))
    assert ref.allclose(m, rot_atol=1e-12, pos_atol=1e-12)


def test_length_units_and_metres() -> None:
    frames = make_frames(3, seed=5)
    asf = parse_asf(make_asf(length_unit=0.45))
    assert asf.length == 0.45
    assert asf.metres_per_unit == pytest.approx(0.0254 / 0.45, rel=1e-15)
    # file units by default: offsets are direction * length as written
    m = parse_amc(make_amc(frames), asf)
    k = m.skeleton.index("ltibia")
    np.testing.assert_allclose(m.skeleton.offsets[k], np.asarray(BONES[5][2]) * BONES[5][3],
                               atol=1e-15)
    np.testing.assert_allclose(m.root_positions[0], frames[0]["root"][:3], atol=1e-15)
    # scale=metres_per_unit gives metres: every point scaled, rotations unchanged
    mm = parse_amc(make_amc(frames), asf, scale=asf.metres_per_unit)
    W, start, end = acclaim_reference(frames)
    check_fk(mm, W, start, end, scale=asf.metres_per_unit)
    np.testing.assert_allclose(mm.rotations, m.rotations, atol=0)
    with pytest.raises(ValueError):
        parse_amc(make_amc(frames), asf, scale=0.0)


# ---------------------------------------------------------------------------------------------
# files, BVH export


def test_files_and_fps(tmp_path) -> None:
    frames = make_frames(4, seed=6)
    (tmp_path / "a.asf").write_text(make_asf())
    (tmp_path / "a.amc").write_text(make_amc(frames))
    asf = read_asf(tmp_path / "a.asf")
    assert isinstance(asf, AsfSkeleton)
    assert asf.source == str(tmp_path / "a.asf")
    m1 = read_amc(tmp_path / "a.amc", asf)
    assert m1.frame_time == 1.0 / 120.0
    m2 = read_asfamc(tmp_path / "a.asf", tmp_path / "a.amc", fps=60)
    assert m2.frame_time == 1.0 / 60.0
    assert m2.num_frames == 4
    np.testing.assert_array_equal(m1.rotations, m2.rotations)
    with pytest.raises(ASFAMCError, match="cannot read"):
        read_asf(tmp_path / "missing.asf")
    with pytest.raises(ASFAMCError, match="cannot read"):
        read_amc(tmp_path / "missing.amc", asf)
    with pytest.raises(ValueError):
        parse_amc(make_amc(frames), asf, fps=0)


def test_bvh_round_trip(tmp_path) -> None:
    frames = make_frames(6, seed=7)
    motion = parse_amc(make_amc(frames), parse_asf(make_asf(length_unit=0.45)))
    sk = motion.skeleton
    assert sk.channels[0] == ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation",
                              "Xrotation")
    assert all(ch == ("Zrotation", "Yrotation", "Xrotation") for ch in sk.channels[1:])
    path = write_bvh(motion, tmp_path / "a.bvh")
    back = read_bvh(path)
    assert back.skeleton.allclose(sk, atol=1e-12)
    assert back.frame_time == motion.frame_time
    assert back.allclose(motion, rot_atol=1e-9, pos_atol=1e-9)
    p1, r1 = forward_kinematics(motion)
    p2, r2 = forward_kinematics(back)
    np.testing.assert_allclose(p2, p1, rtol=0, atol=1e-9)
    np.testing.assert_allclose(end_site_positions(back.skeleton, p2, r2),
                               end_site_positions(sk, p1, r1), rtol=0, atol=1e-9)


def test_translation_dof(tmp_path) -> None:
    bones = [list(b) for b in BONES]
    bones[3][6] = ("tx", "ry", "ty", "rz", "tz")  # rclavicle also slides, in its axis frame
    asf = parse_asf(make_asf(bones=bones))
    assert asf.bone("rclavicle").translation_dofs == ("tx", "ty", "tz")
    frames = make_frames(3, seed=8)
    rng = np.random.default_rng(9)
    trans = {}
    for f in frames:
        t = rng.uniform(-1, 1, 3)
        ry, rz = f["rclavicle"]
        f["rclavicle"] = [t[0], ry, t[1], rz, t[2]]
        trans.setdefault("rclavicle", []).append(t)
    motion = parse_amc(make_amc(frames), asf)
    assert motion.translations is not None
    k = motion.skeleton.index("rclavicle")
    assert motion.skeleton.channels[k][:3] == ("Xposition", "Yposition", "Zposition")
    # reference: rotation part from the rotational dofs only, start moved by W_parent C t
    ref_frames = [dict(f, rclavicle=[f["rclavicle"][1], f["rclavicle"][3]]) for f in frames]
    ref_bones = [tuple(b) for b in bones]
    ref_bones[3] = (*ref_bones[3][:6], ("ry", "rz"))
    out = [acclaim_reference([rf], ref_bones, translations={"rclavicle": t})
           for rf, t in zip(ref_frames, trans["rclavicle"], strict=True)]
    W = {n: [o[0][n][0] for o in out] for n in PREORDER}
    start = {n: [o[1][n][0] for o in out] for n in PREORDER}
    end = {n: [o[2][n][0] for o in out] for n in PREORDER}
    check_fk(motion, W, start, end)
    back = read_bvh(write_bvh(motion, tmp_path / "t.bvh"))
    assert back.allclose(motion, rot_atol=1e-9, pos_atol=1e-9)


# ---------------------------------------------------------------------------------------------
# parsed ASF contents


def test_asf_contents() -> None:
    asf = parse_asf(make_asf(length_unit=0.45), "t.asf")
    assert asf.name == "test"
    assert asf.version == "1.10"
    assert asf.documentation == "written by test_asfamc"
    assert (asf.mass, asf.length, asf.angle) == (1.0, 0.45, "deg")
    assert [b.name for b in asf.bones] == [b[0] for b in BONES]
    assert asf.joint_names == tuple(PREORDER)
    assert asf.hierarchy["lowerback"] == ("upperback", "rclavicle")
    assert asf.parent_of()["lfemur"] == "lhipjoint"
    fem = asf.bone("lfemur")
    assert fem.id == 6
    assert fem.dof == ("rx", "ry", "rz")
    assert fem.axis_order == "XYZ"
    np.testing.assert_allclose(fem.axis, np.radians([0, 0, 20]), atol=1e-15)
    np.testing.assert_allclose(fem.limits, np.radians([[-170, 170]] * 3), atol=1e-15)
    assert asf.bone("lhipjoint").dof == ()
    assert asf.bone("lhipjoint").limits.shape == (0, 2)
    with pytest.raises(KeyError):
        asf.bone("nope")


def test_dofless_and_partial_bones() -> None:
    frames = make_frames(2, seed=10)
    m = parse_amc(make_amc(frames), parse_asf(make_asf()))
    k = m.skeleton.index("lhipjoint")
    np.testing.assert_array_equal(m.rotations[:, k], [[1, 0, 0, 0]] * 2)


def test_cmu_style_text() -> None:
    """Tabs, CRLF, parenthesised limits on continuation lines, comments, mixed-case tokens."""
    asf = (
        "# AST/ASF file generated using VICON BodyLanguage\r\n"
        ":version 1.10\r\n:name VICON\r\n:units\r\n\tmass 1.0\r\n\tlength 0.45\r\n\tangle deg\r\n"
        ":documentation\r\n   .ast/.asf automatically generated\r\n"
        ":root\r\n   order TX TY TZ RX RY RZ\r\n   axis XYZ\r\n   position 0 0 0\r\n"
        "   orientation 0 0 0\r\n"
        ":bonedata\r\n  begin\r\n     id 1\r\n     name lfemur\r\n"
        "     direction 0.34202 -0.939693 0   \r\n     length 7.10592\r\n"
        "     axis 0 0 20  xyz\r\n    dof rx ry rz\r\n    limits (-160.0 20.0)\r\n"
        "           (-70.0 70.0)\r\n           (-60.0 inf)\r\n     bodymass 3.2\r\n  end\r\n"
        ":hierarchy\r\n  begin\r\n    root lfemur   # a comment\r\n  end\r\n"
    )
    a = parse_asf(asf)
    assert a.bone("lfemur").limits[2, 1] == np.inf
    amc = "#!OML:ASF x\r\n:FULLY-SPECIFIED\r\n:DEGREES\r\n1\r\nroot 1 2 3 4 5 6\r\n" \
          "lfemur -21.2 3.6 -10.5\r\n2\r\nroot 1 2 3 4 5 6\r\nlfemur 1e1 0 0\r\n"
    m = parse_amc(amc, a)
    assert m.num_frames == 2
    np.testing.assert_allclose(m.root_positions, [[1, 2, 3]] * 2)


def test_empty_amc() -> None:
    m = parse_amc("#!OML:ASF x\n:FULLY-SPECIFIED\n:DEGREES\n", parse_asf(make_asf()))
    assert m.num_frames == 0
    assert m.rotations.shape == (0, len(PREORDER), 4)


# ---------------------------------------------------------------------------------------------
# errors


def _line_of(text: str, snippet: str) -> int:
    idx = text.index(snippet)
    return text[:idx].count("\n") + 1


BASE_ASF = make_asf()
DIR_HEAD = next(ln for ln in BASE_ASF.split("\n") if "direction" in ln
                and ln.split()[1:] == [_fmt(v) for v in BONES[2][2]])
ASF_ERRORS = [
    # (old, new, snippet locating the expected line in the new text, message part)
    (":root", ":rot", None, "no :root section"),
    (":hierarchy", ":hierarchyy", None, "no :hierarchy section"),
    ("    lfemur ltibia", "    lfemur ltibiax", "lfemur ltibiax", "unknown bone 'ltibiax'"),
    ("    upperback head", "    upperbackx head", "upperbackx head", "unknown bone"),
    ("    lfemur ltibia", "    lfemur ltibia head", "lfemur ltibia head", "already has parent"),
    ("    upperback head", "    upperback head\n    head upperback", "head upperback",
     "already has parent"),
    ("    upperback head\n", "", None, "'head' has no parent"),
    ("    lfemur ltibia", "    lfemur ltibia\n    root lowerback", "LAST:root lowerback",
     "already has parent"),
    ("    upperback head\n", "", None, "'head' has no parent"),
    ("     length 7.4", "     length seven", "length seven", "expected a number"),
    ("     length 7.4", "     length 7.4 2", "length 7.4 2", "needs 1 number"),
    ("     length 7.4", "     length -7.4", "length -7.4", "negative"),
    ("     axis 0.0 0.0 20.0  XYZ\n    dof rx\n", "     axis 0.0 nan 20.0  XYZ\n    dof rx\n",
     "axis 0.0 nan", "only finite"),
    ("     axis 0.0 0.0 20.0  XYZ\n    dof rx\n", "     axis 0.0 0.0 20.0  XXY\n    dof rx\n",
     "XXY", "rotation order"),
    ("     axis 0.0 0.0 20.0  XYZ\n    dof rx\n", "     axis 0.0 0.0  XYZ\n    dof rx\n",
     "axis 0.0 0.0  XYZ", "3 angles"),
    ("    dof rx\n", "    dof rw\n", "dof rw", "expected distinct tokens"),
    ("    dof rx\n", "    dof rx l\n", "dof rx l", "'l' (length) dof is not supported"),
    ("    dof rx\n", "    dof rx rx\n", "dof rx rx", "distinct"),
    ("name ltibia", "name lfemur", "LAST:name lfemur", "duplicate bone name"),
    ("name ltibia", "name root", "name root", "may not be called 'root'"),
    ("    dof rx\n    limits (-170.0 170.0)\n", "    dof rx\n    limits (-170.0)\n",
     "limits (-170.0)\n", "expected 2 values"),
    ("    dof rx\n    limits (-170.0 170.0)\n", "    dof rx\n    limits (-170.0 170.0 1)\n",
     "limits (-170.0 170.0 1)", "more than 2"),
    ("   order TX TY TZ RX RY RZ", "   order TX TY TW RX RY RZ", "order TX", "root order"),
    ("   order TX TY TZ RX RY RZ", "   order TX TY TX RX RY RZ", "order TX", "root order"),
    ("   position 0.0 0.0 0.0", "   position 0.0 0.0", "position 0.0", "needs 3 numbers"),
    ("  angle deg", "  angle grad", "angle grad", "'deg' or 'rad'"),
    ("  length 1.0\n  angle", "  length 0\n  angle", "length 0\n", "must be positive"),
    (DIR_HEAD, "     direction 0.0 1.0", "direction 0.0 1.0\n", "needs 3 numbers"),
    ("     name head\n", "", None, "has no 'name'"),
    (":version 1.10", "hello\n:version 1.10", "hello", "expected a ':keyword'"),
    ("  end\n:hierarchy", ":hierarchy", None, "has no 'end'"),
    ("     name head\n", "     name head\n  begin\n", "  begin\n     direction", "'begin' inside"),
    ("  end\n", "", None, "the :hierarchy has no 'end'"),
    (":hierarchy\n  begin", ":hierarchy\n  start", "start", "expected 'begin'"),
    (":bonedata", ":bonedata\n:root", ":root\n  begin", "second :root"),
]


@pytest.mark.parametrize("old,new,snippet,message", ASF_ERRORS)
def test_asf_errors(old: str, new: str, snippet: str | None, message: str) -> None:
    if old == "  end\n":  # the last 'end' (the hierarchy's)
        idx = BASE_ASF.rindex(old)
        text = BASE_ASF[:idx] + BASE_ASF[idx + len(old):]
    elif old == "  end\n:hierarchy":
        text = BASE_ASF.replace(old, new, 1)
    else:
        assert old in BASE_ASF, old
        text = BASE_ASF.replace(old, new, 1)
    with pytest.raises(ASFAMCError) as info:
        parse_asf(text, "bad.asf")
    err = info.value
    assert message in err.message, err.message
    assert err.source == "bad.asf"
    assert isinstance(err.line, int) and 1 <= err.line <= text.count("\n") + 1
    if snippet is not None and snippet.startswith("LAST:"):
        idx = text.rindex(snippet[5:])
        assert err.line == text[:idx].count("\n") + 1, (err.line, str(err))
    elif snippet is not None:
        assert err.line == _line_of(text, snippet), (err.line, str(err))
    assert str(err).startswith(f"bad.asf:{err.line}: ")


GOOD_AMC = make_amc(make_frames(3, seed=11))
LTIBIA = next(ln for ln in GOOD_AMC.split("\n") if ln.startswith("ltibia "))
AMC_ERRORS = [
    ("\nlfemur ", "\nlfemurx ", "lfemurx", "unknown bone 'lfemurx'"),
    ("\nltibia ", "\nltibia 1.0 ", "ltibia 1.0", "has 2 values; expected 1"),
    ("\nroot ", "\nroot 1 ", "root 1 ", "has 7 values; expected 6"),
    (LTIBIA, "ltibia abc", "ltibia abc", "expected a number"),
    (LTIBIA, "ltibia nan", "ltibia nan", "only finite"),
    (LTIBIA, "ltibia inf", "ltibia inf", "only finite"),
    ("\n2\n", "\n3\n", "\n3\n", "numbered consecutively"),
    ("\n1\n", "\n", "\nroot", "expected a frame number"),
    ("\n2\n", "\n2\n:DEGREES\n", ":DEGREES\nroot", "after the first frame"),
    ("\nltibia ", "\nlfemur 1 2 3\nltibia ", "lfemur 1 2 3", "second line for 'lfemur'"),
]


@pytest.mark.parametrize("old,new,snippet,message", AMC_ERRORS)
def test_amc_errors(old: str, new: str, snippet: str, message: str) -> None:
    asf = parse_asf(BASE_ASF, "t.asf")
    assert old in GOOD_AMC
    text = GOOD_AMC.replace(old, new, 1)
    with pytest.raises(ASFAMCError) as info:
        parse_amc(text, asf, "bad.amc")
    err = info.value
    assert message in err.message, err.message
    assert err.source == "bad.amc"
    snippet_at = text.index(snippet) + (1 if snippet.startswith("\n") else 0)
    assert err.line == text[:snippet_at].count("\n") + 1, (err.line, str(err))


def test_amc_missing_bone_line() -> None:
    asf = parse_asf(BASE_ASF)
    lines = GOOD_AMC.split("\n")
    i = next(k for k, ln in enumerate(lines) if ln.startswith("head "))
    text = "\n".join(lines[:i] + lines[i + 1:])
    with pytest.raises(ASFAMCError, match="frame 1 has no line for bone 'head'") as info:
        parse_amc(text, asf, "bad.amc")
    assert info.value.line == lines.index("1") + 1


def test_garbage_only_raises_asfamc_error() -> None:
    """Truncations and token corruptions of valid files: parse, or raise ASFAMCError."""
    asf = parse_asf(BASE_ASF)
    rng = np.random.default_rng(12)
    junk = ["nan", "x", "(", "begin", "end", ":root", "-inf", "1e999", "", "root", "#", "1"]
    cases_asf = [BASE_ASF[:k] for k in range(0, len(BASE_ASF), 97)]
    cases_amc = [GOOD_AMC[:k] for k in range(0, len(GOOD_AMC), 53)]
    for _ in range(150):
        for base, out in ((BASE_ASF, cases_asf), (GOOD_AMC, cases_amc)):
            toks = base.split(" ")
            k = int(rng.integers(len(toks)))
            toks[k] = str(rng.choice(junk))
            out.append(" ".join(toks))
    for text in cases_asf:
        with contextlib.suppress(ASFAMCError):
            parse_amc(GOOD_AMC, parse_asf(text))
    for text in cases_amc:
        with contextlib.suppress(ASFAMCError):
            parse_amc(text, asf)


def test_overflow_is_an_asfamc_error() -> None:
    lines = BASE_ASF.split("\n")
    i = lines.index("     name lfemur")
    lines[i + 1:i + 3] = ["     direction 1e300 0 0", "     length 1e300"]
    with pytest.raises(ASFAMCError, match="overflows") as info:
        parse_asf("\n".join(lines))
    assert info.value.line == i + 3
    asf = parse_asf(BASE_ASF)
    text = GOOD_AMC.replace("\nroot ", "\nroot 1e308 ", 1)
    text = text.replace("\nroot ", "\nroot 1e308 ", 1)  # two frames
    fixed = []
    for ln in text.split("\n"):  # keep 6 values on the edited root lines
        toks = ln.split()
        fixed.append(" ".join(toks[:7]) if toks and toks[0] == "root" else ln)
    text = "\n".join(fixed)
    with pytest.raises(ASFAMCError, match="overflow"):
        parse_amc(text, asf, scale=10.0)


def test_a_truncated_last_frame_is_dropped_only_when_lenient() -> None:
    """Newcomer report: --lenient did not read an AMC cut short in its last frame, and the
    error did not say that it would."""
    import warnings

    from mocapkit.io import RepairWarning

    asf = parse_asf(BASE_ASF, "t.asf")
    cut = GOOD_AMC.rstrip("\n")
    cut = cut[: cut.rindex(" ")]  # the last value of the last line gone
    with pytest.raises(ASFAMCError, match="cut short: --lenient drops it"):
        parse_amc(cut, asf, "cut.amc")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = parse_amc(cut, asf, "cut.amc", lenient=True)
    full = parse_amc(GOOD_AMC, asf, "good.amc")
    assert m.num_frames == full.num_frames - 1
    np.testing.assert_array_equal(m.rotations, full.rotations[:-1])
    assert any(issubclass(w.category, RepairWarning) and "incomplete last frame 3" in
               str(w.message) for w in caught)  # fmt: skip
    # an error before the last frame is no truncation: still an error
    bad = GOOD_AMC.replace(LTIBIA, "ltibia abc", 1)
    with pytest.raises(ASFAMCError, match="expected a number"):
        parse_amc(bad, asf, "bad.amc", lenient=True)


def test_an_error_in_the_last_frame_that_is_no_truncation_stays_an_error() -> None:
    """Review: a NaN or a misnumbered last frame was dropped as 'incomplete' with --lenient."""
    asf = parse_asf(BASE_ASF, "t.asf")
    last = GOOD_AMC.rstrip("\n").split("\n")
    nan = "\n".join([*last[:-1], last[-1].split()[0] + " nan" * (len(last[-1].split()) - 1)])
    with pytest.raises(ASFAMCError, match="only finite") as e:
        parse_amc(nan, asf, "nan.amc", lenient=True)
    assert "cut short" not in str(e.value)
    renumbered = GOOD_AMC.replace("\n3\n", "\n5\n")
    with pytest.raises(ASFAMCError, match="numbered consecutively"):
        parse_amc(renumbered, asf, "n.amc", lenient=True)
    # the last frame's bone lines missing altogether is a truncation
    i = GOOD_AMC.index("\n3\n")
    cut = GOOD_AMC[: i + 3] + GOOD_AMC[i + 3 :].split("\n", 2)[0]
    assert parse_amc(cut, asf, "cut.amc", lenient=True).num_frames == 2


def test_a_linked_amc_finds_the_asf_beside_the_file_it_links_to(tmp_path) -> None:
    """Newcomer report: a library folder of links to CMU takes said "cannot find its ASF
    skeleton file" (it looked beside the link only). An ASF beside the link still wins."""
    from mocapkit.io import MocapFileError, find_asf, read_motion

    takes, lib = tmp_path / "03", tmp_path / "lib"
    takes.mkdir()
    lib.mkdir()
    (takes / "03.asf").write_text(make_asf())
    (takes / "03_02.amc").write_text(make_amc(make_frames(4, seed=6)))
    (lib / "03_02.amc").symlink_to(takes / "03_02.amc")
    assert find_asf(lib / "03_02.amc") == takes / "03.asf"
    assert read_motion(lib / "03_02.amc").num_frames == 4
    (lib / "03.asf").write_text(make_asf())
    assert find_asf(lib / "03_02.amc") == lib / "03.asf"
    (takes / "03.asf").unlink()
    (lib / "03.asf").unlink()
    with pytest.raises(MocapFileError, match=f"single .asf in {lib} and in {takes}"):
        find_asf(lib / "03_02.amc")
