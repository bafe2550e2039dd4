"""ASF/AMC reader (Acclaim skeleton + motion, the CMU motion-capture database's native format).

The result is the same :class:`~mocapkit.core.motion.Motion` the BVH reader produces, so
:func:`mocapkit.io.bvh.write_bvh` can export it directly.

Conventions
-----------
Acclaim defines everything in one global frame:

* every bone has a ``direction`` (a unit vector in the global frame, used as written) and a
  ``length``; the bone vector is ``direction * length``; a bone starts where its parent ends
  (children of ``root`` start at the root position);
* a bone's ``axis ax ay az ORDER`` gives its local frame ``C`` as rotations about the *fixed*
  global axes, applied in the listed order: ``axis ax ay az XYZ`` is
  ``C = Rz(az) @ Ry(ay) @ Rx(ax)`` (column vectors); ``ORDER`` may be any permutation of XYZ;
* an AMC line gives a bone's values in the order of its ``dof`` list; the rotations are again about
  fixed axes (of the frame ``C``) applied in the listed order: ``dof rx ry rz`` gives
  ``M = Rz(rz) @ Ry(ry) @ Rx(rx)``; missing axes are zero;
* the world rotation of bone ``b`` is ``W_b = W_parent @ C_b @ M_b @ C_b^-1`` and its end is
  ``start_b + W_b @ (direction_b * length_b)``;
* the root: its AMC values follow the ``:root order`` line (e.g. ``TX TY TZ RX RY RZ``), the
  rotation tokens being applied about fixed axes in the listed order (``RX RY RZ`` gives
  ``Rz @ Ry @ Rx``). ``orientation`` (angles in the ``axis`` order, fixed axes) and ``position``
  are pre-set offsets: ``W_root = O @ M_root`` and root position ``= position + (TX, TY, TZ)``.
  (The spec is vague about how these offsets combine; CMU files always have them at zero.)

Mapping onto mocapkit's joint model (a joint at the *start* of each bone): every ASF bone becomes
a joint whose OFFSET is its parent bone's vector ``direction * length`` (zero for children of the
root) and whose local rotation is ``L_b = C_b @ M_b @ C_b^-1``, so that the joint's global rotation
equals ``W_b``; every leaf bone gets an End Site at ``direction * length``. Joints are ordered
depth-first from the root, children in ``:hierarchy`` order (the order a BVH written from the
result reads back in). The channels are ``Xposition Yposition Zposition Zrotation Yrotation
Xrotation`` for the root and ``Zrotation Yrotation Xrotation`` for the other joints (intrinsic ZYX
= fixed-axes XYZ, what CMU's own BVH conversions use); a bone with ``tx ty tz`` in its dof also
gets position channels: its translation, expressed in its axis frame ``C``, moves the bone's start
(``translation = parent bone vector + C @ t``), independent of where it appears in the dof list.
The ``l`` (length) dof is not supported and raises :class:`ASFAMCError`.

Units
-----
``:units angle deg|rad`` applies to the ASF's ``axis``, ``orientation`` and rotational ``limits``,
and to the AMC values unless the AMC itself says ``:DEGREES`` or ``:RADIANS``. Internally angles
are radians. Lengths stay in the file's units by default (offsets ``direction * length``, root and
bone translations as written). ``:units length`` is the scale the data were written with: by the
convention of the CMU database (``length 0.45``) a file unit is ``1 / length`` inches, so metres
are ``value * 0.0254 / length`` -- :attr:`AsfSkeleton.metres_per_unit`; pass
``scale=asf.metres_per_unit`` to the readers to get metres.

AMC files carry no frame time: ``fps`` (120 for the CMU database) sets ``frame_time = 1 / fps``.
Malformed input raises :class:`ASFAMCError` naming the file, the 1-based line and what was expected.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import POSITION_CHANNELS, Skeleton
from mocapkit.io.errors import ASFAMCError, RepairWarning, decode_text, quote

__all__ = [
    "AsfBone",
    "AsfSkeleton",
    "parse_amc",
    "parse_asf",
    "read_amc",
    "read_asf",
    "read_asfamc",
]

ROOT = "root"
BONE_CHANNELS = ("Zrotation", "Yrotation", "Xrotation")
ROOT_CHANNELS = POSITION_CHANNELS + BONE_CHANNELS
METRES_PER_INCH = 0.0254

_SEP = re.compile(r"[\s,()]+")
_AXIS = {"x": 0, "y": 1, "z": 2}
_ROT_DOFS = ("rx", "ry", "rz")
_TRANS_DOFS = ("tx", "ty", "tz")
_ANGLE_UNITS = {
    "deg": "deg", "degree": "deg", "degrees": "deg",
    "rad": "rad", "radian": "rad", "radians": "rad",
}  # fmt: skip


# ---------------------------------------------------------------------------------------------
# data


@dataclass(frozen=True, eq=False)
class AsfBone:
    """One ``:bonedata`` entry.

    Attributes:
        name: bone name.
        id: the optional numeric ``id`` (None when absent).
        direction: (3,) direction in the global frame, as written.
        length: bone length in file units.
        axis: (3,) axis-frame angles in radians, ``axis[i]`` about ``axis_order[i]``.
        axis_order: e.g. "XYZ": fixed-axes order, first letter applied first.
        dof: lowercase dof tokens in file order (AMC value order), from rx ry rz tx ty tz.
        limits: (len(dof), 2) lower/upper limits (radians for rotations, file units for
            translations; +-inf allowed), zeros-shaped (0, 2) when not given.
        line: 1-based line of the bone's ``begin``.
    """

    name: str
    id: int | None
    direction: np.ndarray
    length: float
    axis: np.ndarray
    axis_order: str
    dof: tuple[str, ...] = ()
    limits: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    line: int = 0

    @property
    def vector(self) -> np.ndarray:
        """``direction * length`` (file units)."""
        return self.direction * self.length

    @property
    def axis_quat(self) -> np.ndarray:
        """(4,) quaternion w,x,y,z of the axis frame ``C``."""
        return _fixed_axes_quat(self.axis, self.axis_order)

    @property
    def rotation_dofs(self) -> tuple[str, ...]:
        return tuple(d for d in self.dof if d in _ROT_DOFS)

    @property
    def translation_dofs(self) -> tuple[str, ...]:
        return tuple(d for d in self.dof if d in _TRANS_DOFS)


@dataclass(frozen=True, eq=False)
class AsfSkeleton:
    """A parsed ASF file (angles in radians, lengths in file units).

    Attributes:
        name: the ``:name`` (may be "").
        version: the ``:version`` (may be "").
        documentation: the ``:documentation`` text.
        mass, length: the ``:units`` factors (default 1.0).
        angle: "deg" or "rad", the ``:units angle`` (default "deg").
        root_order: upper-case root channel tokens in AMC order, e.g. ("TX", ..., "RZ").
        root_axis: e.g. "XYZ": the order of the ``orientation`` angles.
        root_position: (3,) pre-set root position (file units).
        root_orientation: (3,) pre-set root orientation (radians, in ``root_axis`` order).
        bones: the bones in file order.
        hierarchy: parent name -> child names, in file order.
        source: the file name used in errors.
    """

    name: str
    version: str
    documentation: str
    mass: float
    length: float
    angle: str
    root_order: tuple[str, ...]
    root_axis: str
    root_position: np.ndarray
    root_orientation: np.ndarray
    bones: tuple[AsfBone, ...]
    hierarchy: dict[str, tuple[str, ...]]
    source: str = "<string>"

    @property
    def metres_per_unit(self) -> float:
        """Metres per file length unit by the CMU convention: ``0.0254 / length``."""
        return METRES_PER_INCH / self.length

    def bone(self, name: str) -> AsfBone:
        for b in self.bones:
            if b.name == name:
                return b
        raise KeyError(f"no bone named {quote(name)}")

    def parent_of(self) -> dict[str, str]:
        """Bone name -> parent name ("root" for the root's children)."""
        return {c: p for p, kids in self.hierarchy.items() for c in kids}

    @property
    def joint_names(self) -> tuple[str, ...]:
        """ "root" then every bone, depth-first in ``:hierarchy`` order (the joint order)."""
        out: list[str] = []
        stack = [ROOT]
        while stack:
            n = stack.pop()
            out.append(n)
            stack.extend(reversed(self.hierarchy.get(n, ())))
        return tuple(out)

    def to_skeleton(self, scale: float = 1.0) -> Skeleton:
        """The mocapkit Skeleton (see the module docstring); lengths multiplied by ``scale``.

        The skeleton states its unit: ``metres_per_unit / scale`` metres (the CMU convention
        of ``:units length``, one inch where the file has none)."""
        names = self.joint_names
        index = {n: i for i, n in enumerate(names)}
        parent = self.parent_of()
        bones = {b.name: b for b in self.bones}
        parents = [-1]
        offsets = [self.root_position * scale]
        channels: list[tuple[str, ...]] = [ROOT_CHANNELS]
        es_parents, es_offsets = [], []
        for n in names[1:]:
            p = parent[n]
            parents.append(index[p])
            offsets.append(np.zeros(3) if p == ROOT else bones[p].vector * scale)
            b = bones[n]
            channels.append(
                POSITION_CHANNELS + BONE_CHANNELS if b.translation_dofs else BONE_CHANNELS
            )
            if not self.hierarchy.get(n):
                es_parents.append(index[n])
                es_offsets.append(b.vector * scale)
        return Skeleton(
            names,
            parents,
            offsets,
            channels,
            es_parents,
            np.reshape(es_offsets, (-1, 3)),
            metres_per_unit=self.metres_per_unit / scale,
        )


# ---------------------------------------------------------------------------------------------
# helpers


def _fixed_axes_quat(angles: np.ndarray, axes: str) -> np.ndarray:
    """Quaternion(s) (..., 4) of rotations about fixed axes applied in ``axes`` order.

    ``angles[..., i]`` (radians) is about ``axes[i]``; "XYZ" gives Rz @ Ry @ Rx. Any number of
    axes (0 gives the identity).
    """
    angles = np.asarray(angles, dtype=np.float64)
    q = rot.quat_identity(angles.shape[:-1])
    for i, a in enumerate(axes.lower()):
        half = 0.5 * angles[..., i]
        qi = np.zeros_like(q)
        qi[..., 0] = np.cos(half)
        qi[..., 1 + _AXIS[a]] = np.sin(half)
        q = rot.quat_mul(qi, q)
    return q


def _decode(data: bytes | str, source: str = "<string>") -> list[str]:
    if isinstance(data, bytes | bytearray | memoryview):
        data = decode_text(bytes(data), source)
    if data.startswith("\ufeff"):
        data = data[1:]
    return data.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def _tokens(text: str) -> list[str]:
    return [t for t in _SEP.split(text.split("#", 1)[0]) if t]


def _number(tok: str, source: str, line: int, what: str, allow_inf: bool = False) -> float:
    try:
        if "_" in tok:
            raise ValueError
        v = float(tok)
    except ValueError:
        raise ASFAMCError(
            source, line, f"expected a number for {what}, found {quote(tok)}"
        ) from None
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise ASFAMCError(source, line, f"{what} is {quote(tok)}; only finite numbers are allowed")
    return v


def _numbers(toks: list[str], n: int, source: str, line: int, what: str) -> np.ndarray:
    if len(toks) != n:
        raise ASFAMCError(
            source,
            line,
            f"{what} needs {n} number{'s' * (n != 1)}, found {len(toks)}: {quote(' '.join(toks))}",
        )
    return np.array([_number(t, source, line, what) for t in toks])


def _axis_order(tok: str, source: str, line: int, what: str) -> str:
    order = tok.upper()
    if sorted(order) != ["X", "Y", "Z"]:
        raise ASFAMCError(
            source,
            line,
            f"{what}: expected a rotation order such as XYZ "
            f"(a permutation of X, Y, Z), found {quote(tok)}",
        )
    return order


# ---------------------------------------------------------------------------------------------
# ASF


class _Section:
    def __init__(self, key: str, line: int, args: list[str]) -> None:
        self.key = key
        self.line = line
        self.args = args
        self.body: list[tuple[int, list[str]]] = []
        self.raw: list[str] = []


_KNOWN_SECTIONS = (
    ":version",
    ":name",
    ":units",
    ":documentation",
    ":root",
    ":bonedata",
    ":hierarchy",
)


def _split_sections(lines: list[str], source: str) -> dict[str, _Section]:
    sections: dict[str, _Section] = {}
    current: _Section | None = None
    for ln, text in enumerate(lines, 1):
        toks = _tokens(text)
        if toks and toks[0].startswith(":"):
            key = toks[0].lower()
            if key in sections and key in _KNOWN_SECTIONS:
                raise ASFAMCError(
                    source, ln, f"second {key} section (the first is on line {sections[key].line})"
                )
            current = _Section(key, ln, toks[1:])
            sections.setdefault(key, current)
            continue
        if current is None:
            if toks:
                raise ASFAMCError(
                    source,
                    ln,
                    f"expected a ':keyword' line such as ':version', found {quote(toks[0])}",
                )
            continue
        current.raw.append(text)
        if toks:
            current.body.append((ln, toks))
    return sections


def _parse_units(sec: _Section | None, source: str) -> tuple[float, float, str]:
    mass, length, angle = 1.0, 1.0, "deg"
    if sec is None:
        return mass, length, angle
    for ln, toks in sec.body:
        key = toks[0].lower()
        if key in ("mass", "length"):
            if len(toks) != 2:
                raise ASFAMCError(
                    source, ln, f":units {key} needs one number, found {quote(' '.join(toks[1:]))}"
                )
            v = _number(toks[1], source, ln, f":units {key}")
            if v <= 0:
                raise ASFAMCError(
                    source, ln, f":units {key} must be positive, found {quote(toks[1])}"
                )
            if key == "mass":
                mass = v
            else:
                length = v
        elif key == "angle":
            if len(toks) != 2 or toks[1].lower() not in _ANGLE_UNITS:
                raise ASFAMCError(
                    source,
                    ln,
                    f":units angle must be 'deg' or 'rad', found {quote(' '.join(toks[1:]))}",
                )
            angle = _ANGLE_UNITS[toks[1].lower()]
        # other unit keys (vendor extensions) do not affect the result
    return mass, length, angle


def _parse_root(
    sec: _Section, source: str, to_rad: float
) -> tuple[tuple[str, ...], str, np.ndarray, np.ndarray]:
    if sec.args:
        raise ASFAMCError(source, sec.line, f"unexpected text after :root: {quote(sec.args[0])}")
    order: tuple[str, ...] | None = None
    axis = "XYZ"
    position = np.zeros(3)
    orientation = np.zeros(3)
    for ln, toks in sec.body:
        key = toks[0].lower()
        if key == "order":
            order = tuple(t.upper() for t in toks[1:])
            bad = [t for t in order if t not in ("TX", "TY", "TZ", "RX", "RY", "RZ")]
            if bad or not order or len(set(order)) != len(order):
                raise ASFAMCError(
                    source,
                    ln,
                    "root order: expected distinct tokens from TX TY "
                    f"TZ RX RY RZ, found {quote(' '.join(toks[1:]))}",
                )
        elif key == "axis":
            if len(toks) != 2:
                raise ASFAMCError(source, ln, "root axis needs one rotation order such as XYZ")
            axis = _axis_order(toks[1], source, ln, "root axis")
        elif key == "position":
            position = _numbers(toks[1:], 3, source, ln, "root position")
        elif key == "orientation":
            orientation = _numbers(toks[1:], 3, source, ln, "root orientation") * to_rad
        else:
            raise ASFAMCError(
                source,
                ln,
                f"expected order, axis, position or orientation in :root, found {quote(toks[0])}",
            )
    if order is None:
        raise ASFAMCError(
            source,
            sec.line,
            ":root has no 'order' line (the root's AMC channels, e.g. 'order TX TY TZ RX RY RZ')",
        )
    return order, axis, position, orientation


_BONE_KEYS = ("name", "id", "direction", "length", "axis", "dof", "limits")


def _finite_vector(direction: np.ndarray, length: float) -> bool:
    """``direction * length`` has no overflow (Python floats overflow to inf silently)."""
    return all(math.isfinite(float(d) * length) for d in direction)


def _is_limit_token(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return "_" not in tok


def _parse_bone(
    body: list[tuple[int, list[str]]], begin_line: int, source: str, to_rad: float
) -> AsfBone:
    vals: dict[str, object] = {}
    limits: list[float] = []
    limits_line = 0
    expected = 0  # number of limit values (a pair per dof) once 'limits' is seen
    name = "?"

    def label() -> str:
        return f"bone {quote(name)}" if name != "?" else f"the bone starting on line {begin_line}"

    def too_few() -> ASFAMCError:
        return ASFAMCError(
            source,
            limits_line,
            f"limits of {label()}: expected {expected} "
            f"values (a pair per dof), found {len(limits)}",
        )

    def take_limits(toks: list[str], ln: int) -> None:
        for t in toks:
            if len(limits) == expected:
                raise ASFAMCError(
                    source, ln, f"limits of {label()}: more than {expected} values (a pair per dof)"
                )
            limits.append(_number(t, source, ln, f"limits of {label()}", allow_inf=True))

    for ln, toks in body:
        if len(limits) < expected:
            if not _is_limit_token(toks[0]):
                raise too_few()
            take_limits(toks, ln)
            continue
        key = toks[0].lower()
        if key in _BONE_KEYS and key in vals:
            raise ASFAMCError(source, ln, f"second '{key}' line in {label()}")
        if key == "name":
            if len(toks) != 2:
                raise ASFAMCError(source, ln, "name needs exactly one word")
            name = toks[1]
            vals["name"] = name
        elif key == "id":
            if len(toks) != 2 or not toks[1].lstrip("+-").isdigit():
                raise ASFAMCError(
                    source,
                    ln,
                    (
                        f"id of {label()}: expected one whole "
                        f"number, found {quote(' '.join(toks[1:]))}"
                    ),
                )
            vals["id"] = int(toks[1])
        elif key == "direction":
            vals["direction"] = _numbers(toks[1:], 3, source, ln, f"direction of {label()}")
        elif key == "length":
            v = float(_numbers(toks[1:], 1, source, ln, f"length of {label()}")[0])
            if v < 0:
                raise ASFAMCError(source, ln, f"length of {label()} is negative: {quote(toks[1])}")
            if "direction" in vals and not _finite_vector(vals["direction"], v):  # type: ignore[arg-type]
                raise ASFAMCError(source, ln, f"direction * length of {label()} overflows")
            vals["length"] = v
        elif key == "axis":
            if len(toks) != 5:
                raise ASFAMCError(
                    source,
                    ln,
                    f"axis of {label()}: expected 3 angles and a "
                    "rotation order (e.g. 'axis 0 0 20 XYZ'), found "
                    f"{quote(' '.join(toks[1:]))}",
                )
            angles = _numbers(toks[1:4], 3, source, ln, f"axis of {label()}") * to_rad
            vals["axis"] = (angles, _axis_order(toks[4], source, ln, f"axis of {label()}"))
        elif key == "dof":
            dof = tuple(t.lower() for t in toks[1:])
            if "l" in dof:
                raise ASFAMCError(source, ln, f"{label()}: the 'l' (length) dof is not supported")
            bad = [t for t in dof if t not in _ROT_DOFS + _TRANS_DOFS]
            if bad or len(set(dof)) != len(dof):
                raise ASFAMCError(
                    source,
                    ln,
                    f"dof of {label()}: expected distinct tokens from "
                    f"rx ry rz tx ty tz, found {quote(' '.join(toks[1:]))}",
                )
            vals["dof"] = dof
        elif key == "limits":
            if "dof" not in vals:
                raise ASFAMCError(source, ln, f"limits of {label()} come before its dof line")
            vals["limits"] = True
            limits_line = ln
            expected = 2 * len(vals["dof"])  # type: ignore[arg-type]
            take_limits(toks[1:], ln)
        elif _is_limit_token(toks[0]):
            raise ASFAMCError(
                source, ln, f"unexpected numbers in {label()}: {quote(' '.join(toks))}"
            )
        # other keys (bodymass, cofmass, ...) do not affect the result
    if len(limits) < expected:
        raise too_few()
    for key in ("name", "direction", "length", "axis"):
        if key not in vals:
            raise ASFAMCError(source, begin_line, f"{label()} has no '{key}' line")
    if not _finite_vector(vals["direction"], vals["length"]):  # type: ignore[arg-type]
        raise ASFAMCError(source, begin_line, f"direction * length of {label()} overflows")
    dof: tuple[str, ...] = vals.get("dof", ())  # type: ignore[assignment]
    lim = np.reshape(np.array(limits, dtype=np.float64), (-1, 2))
    if len(lim):
        lim = lim * np.array([to_rad if d in _ROT_DOFS else 1.0 for d in dof])[:, None]
    axis, axis_order = vals["axis"]  # type: ignore[misc]
    return AsfBone(
        name=name,
        id=vals.get("id"),  # type: ignore[arg-type]
        direction=vals["direction"],  # type: ignore[arg-type]
        length=vals["length"],  # type: ignore[arg-type]
        axis=axis,
        axis_order=axis_order,
        dof=dof,
        limits=lim,
        line=begin_line,
    )


def _parse_bonedata(sec: _Section, source: str, to_rad: float) -> list[AsfBone]:
    if sec.args:
        raise ASFAMCError(
            source, sec.line, f"unexpected text after :bonedata: {quote(sec.args[0])}"
        )
    bones: list[AsfBone] = []
    seen: dict[str, int] = {}
    body: list[tuple[int, list[str]]] | None = None
    begin_line = 0
    for ln, toks in sec.body:
        key = toks[0].lower()
        if body is None:
            if key != "begin" or len(toks) != 1:
                raise ASFAMCError(
                    source,
                    ln,
                    f"expected 'begin' (a new bone) in :bonedata, found {quote(' '.join(toks))}",
                )
            body, begin_line = [], ln
        elif key == "end" and len(toks) == 1:
            bone = _parse_bone(body, begin_line, source, to_rad)
            name_line = next(n for n, t in body if t[0].lower() == "name")
            if bone.name.lower() == ROOT:
                raise ASFAMCError(source, name_line, "a bone may not be called 'root'")
            if bone.name in seen:
                raise ASFAMCError(
                    source,
                    name_line,
                    (
                        f"duplicate bone name {quote(bone.name)} "
                        f"(first defined on line {seen[bone.name]})"
                    ),
                )
            seen[bone.name] = name_line
            bones.append(bone)
            body = None
        elif key == "begin":
            raise ASFAMCError(
                source,
                ln,
                f"'begin' inside the bone starting on line {begin_line}: expected 'end' first",
            )
        else:
            body.append((ln, toks))
    if body is not None:
        raise ASFAMCError(
            source, sec.body[-1][0], f"the bone starting on line {begin_line} has no 'end'"
        )
    return bones


def _parse_hierarchy(
    sec: _Section | None, bones: list[AsfBone], source: str, last_line: int
) -> dict[str, tuple[str, ...]]:
    if sec is None:
        if bones:
            raise ASFAMCError(
                source,
                last_line,
                "no :hierarchy section (expected ':hierarchy' "
                "with 'begin', lines 'parent child ...' and 'end')",
            )
        return {}
    if sec.args:
        raise ASFAMCError(
            source, sec.line, f"unexpected text after :hierarchy: {quote(sec.args[0])}"
        )
    names = {b.name for b in bones}
    kids: dict[str, list[str]] = {}
    parent_line: dict[str, tuple[str, int]] = {}
    state = "before"
    for ln, toks in sec.body:
        key = toks[0].lower()
        if state == "before":
            if key != "begin" or len(toks) != 1:
                raise ASFAMCError(
                    source, ln, f"expected 'begin' after :hierarchy, found {quote(' '.join(toks))}"
                )
            state = "in"
            continue
        if state == "after":
            raise ASFAMCError(
                source, ln, f"unexpected text after the hierarchy's 'end': {quote(' '.join(toks))}"
            )
        if key == "end" and len(toks) == 1:
            state = "after"
            continue
        parent = ROOT if toks[0].lower() == ROOT else toks[0]
        if parent != ROOT and parent not in names:
            raise ASFAMCError(
                source, ln, f"hierarchy names unknown bone {quote(parent)} (not in :bonedata)"
            )
        if len(toks) < 2:
            raise ASFAMCError(source, ln, f"hierarchy line for {quote(parent)} lists no children")
        for c in toks[1:]:
            if c.lower() == ROOT:
                raise ASFAMCError(source, ln, "the root cannot be a child")
            if c not in names:
                raise ASFAMCError(
                    source, ln, f"hierarchy names unknown bone {quote(c)} (not in :bonedata)"
                )
            if c in parent_line:
                p, pl = parent_line[c]
                raise ASFAMCError(
                    source, ln, f"bone {quote(c)} already has parent {quote(p)} (line {pl})"
                )
            parent_line[c] = (parent, ln)
            kids.setdefault(parent, []).append(c)
    if state == "before":
        raise ASFAMCError(
            source, sec.body[-1][0] if sec.body else sec.line, "expected 'begin' after :hierarchy"
        )
    if state == "in":
        raise ASFAMCError(source, sec.body[-1][0], "the :hierarchy has no 'end'")
    hierarchy = {p: tuple(c) for p, c in kids.items()}
    reached = {ROOT}
    stack = [ROOT]
    while stack:
        for c in hierarchy.get(stack.pop(), ()):
            reached.add(c)
            stack.append(c)
    for b in bones:
        if b.name not in reached:
            where = parent_line[b.name][1] if b.name in parent_line else b.line
            why = (
                "has no parent in :hierarchy"
                if b.name not in parent_line
                else "is not connected to the root (a cycle in :hierarchy)"
            )
            raise ASFAMCError(source, where, f"bone {quote(b.name)} {why}")
    return hierarchy


def parse_asf(data: bytes | str, source: str = "<string>") -> AsfSkeleton:
    """Parse ASF text (bytes or str); ``source`` names it in errors."""
    lines = _decode(data, source)
    sections = _split_sections(lines, source)
    last = max(1, len(lines) - (1 if lines and lines[-1] == "" else 0))
    mass, length, angle = _parse_units(sections.get(":units"), source)
    to_rad = math.pi / 180.0 if angle == "deg" else 1.0
    if ":root" not in sections:
        raise ASFAMCError(
            source,
            last,
            "no :root section (expected ':root' with 'order', "
            "'axis', 'position' and 'orientation')",
        )
    order, axis, position, orientation = _parse_root(sections[":root"], source, to_rad)
    if ":bonedata" not in sections:
        raise ASFAMCError(source, last, "no :bonedata section")
    bones = _parse_bonedata(sections[":bonedata"], source, to_rad)
    hierarchy = _parse_hierarchy(sections.get(":hierarchy"), bones, source, last)
    doc = sections.get(":documentation")
    return AsfSkeleton(
        name=" ".join(sections[":name"].args) if ":name" in sections else "",
        version=" ".join(sections[":version"].args) if ":version" in sections else "",
        documentation="\n".join(doc.raw).strip() if doc else "",
        mass=mass,
        length=length,
        angle=angle,
        root_order=order,
        root_axis=axis,
        root_position=position,
        root_orientation=orientation,
        bones=tuple(bones),
        hierarchy=hierarchy,
        source=source,
    )


def read_asf(path: str | Path) -> AsfSkeleton:
    """Read an ASF file. Raises :class:`ASFAMCError` (file, line, problem) on malformed input."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise ASFAMCError(path, None, f"cannot read file: {e.strerror or e}") from None
    return parse_asf(data, str(path))


# ---------------------------------------------------------------------------------------------
# AMC


def _parse_amc_values(
    data: bytes | str, asf: AsfSkeleton, source: str
) -> tuple[dict[str, np.ndarray], int, str | None]:
    """Per bone with dof ("root" included) its (F, ndof) raw values; F; the AMC's angle unit."""
    counts = {ROOT: len(asf.root_order)}
    counts.update({b.name: len(b.dof) for b in asf.bones})
    needed = [n for n, c in counts.items() if c]
    rows: dict[str, list[list[float]]] = {n: [] for n in needed}
    unit: str | None = None
    frame: int | None = None
    frame_line = 0
    nframes = 0
    seen: set[str] = set()
    isfinite = math.isfinite

    def check_frame() -> None:
        if frame is None:
            return
        for n in needed:
            if n not in seen:
                what = "the root" if n == ROOT else f"bone {quote(n)}"
                raise ASFAMCError(
                    source,
                    frame_line,
                    f"frame {frame} has no line for {what} "
                    "(every bone with dof needs one per frame)",
                )

    for ln, text in enumerate(_decode(data, source), 1):
        if "#" in text:
            text = text.split("#", 1)[0]
        if "," in text:
            text = text.replace(",", " ")
        toks = text.split()
        if not toks:
            continue
        head = toks[0]
        if head.startswith(":"):
            if frame is not None:
                raise ASFAMCError(source, ln, f"keyword {quote(head)} after the first frame")
            key = head.upper()
            if key in (":DEGREES", ":DEGREE"):
                unit = "deg"
            elif key in (":RADIANS", ":RADIAN"):
                unit = "rad"
            continue  # :FULLY-SPECIFIED and other flags change nothing
        if len(toks) == 1 and head.isdecimal():
            number = int(head)
            if frame is not None and number != frame + 1:
                raise ASFAMCError(
                    source,
                    ln,
                    f"frame {number} follows frame {frame}; AMC frames "
                    f"must be numbered consecutively (expected {frame + 1})",
                )
            check_frame()
            frame, frame_line = number, ln
            nframes += 1
            seen = set()
            continue
        if frame is None:
            raise ASFAMCError(
                source, ln, f"expected a frame number before the line of {quote(head)}"
            )
        name = ROOT if head.lower() == ROOT else head
        n = counts.get(name)
        if n is None:
            raise ASFAMCError(
                source, ln, f"unknown bone {quote(head)} (not in the ASF {asf.source})"
            )
        if name in seen:
            raise ASFAMCError(source, ln, f"second line for {quote(head)} in frame {frame}")
        seen.add(name)
        if len(toks) - 1 != n:
            what = (
                f"the root order {' '.join(asf.root_order)}"
                if name == ROOT
                else f"its dof {' '.join(asf.bone(name).dof) or '(none)'}"
            )
            raise ASFAMCError(
                source, ln, f"{quote(head)} has {len(toks) - 1} values; expected {n} for {what}"
            )
        if not n:
            continue
        try:
            row = [float(t) for t in toks[1:]]
            ok = all(map(isfinite, row)) and not ("_" in text and "_" in "".join(toks[1:]))
        except ValueError:
            ok = False
        if not ok:
            for i, t in enumerate(toks[1:], 1):
                _number(t, source, ln, f"value {i} of {quote(head)}")
        rows[name].append(row)
    check_frame()
    values = {
        n: np.asarray(r, dtype=np.float64).reshape(nframes, counts[n]) for n, r in rows.items()
    }
    return values, nframes, unit


def _amc_values(
    data: bytes | str, asf: AsfSkeleton, source: str, lenient: bool
) -> tuple[dict[str, np.ndarray], int, str | None]:
    """:func:`_parse_amc_values`, and with ``lenient`` the file less its last frame where the
    error lies in that frame (from its number line on): a truncated file."""
    try:
        return _parse_amc_values(data, asf, source)
    except ASFAMCError as e:
        if e.line is None:
            raise
        lines = _decode(data, source)
        heads = [i for i, t in enumerate(lines, 1) if t.split("#", 1)[0].strip().isdecimal()]
        filled = [i for i, t in enumerate(lines, 1) if t.split("#", 1)[0].strip()]
        # cut short: the last frame lacks bone lines, or its last line lacks values; anything
        # else wrong there (a NaN, a misnumbered frame) is an error like any other
        missing = e.line == heads[-1] if heads else False
        short = e.line == filled[-1] and bool(re.search(r"has \d+ values; expected", e.message))
        if (
            len(heads) < 2
            or e.line < heads[-1]
            or not ((missing and "has no line for" in e.message) or short)
        ):
            raise
        if not lenient:  # the last frame is cut short: say what would read it
            raise ASFAMCError(
                e.source, e.line, f"{e.message} (the last frame is cut short: --lenient drops it)"
            ) from None
        values = _parse_amc_values("\n".join(lines[: heads[-1] - 1]), asf, source)
        warnings.warn(
            f"{source}:{e.line}: dropped the incomplete last frame "
            f"{lines[heads[-1] - 1].strip()} ({e.message})",
            RepairWarning,
            stacklevel=3,
        )
        return values


def parse_amc(
    data: bytes | str,
    asf: AsfSkeleton,
    source: str = "<string>",
    fps: float = 120.0,
    scale: float = 1.0,
    lenient: bool = False,
) -> Motion:
    """Parse AMC text against a parsed ASF into a Motion (``frame_time = 1 / fps``).

    ``scale`` multiplies every length (offsets, translations): ``asf.metres_per_unit`` gives
    metres by the CMU convention. ``lenient``: a last frame cut short (a file truncated in
    the middle of its last frame) is dropped with a :class:`~mocapkit.io.RepairWarning`;
    anything else wrong is still an error.
    """
    fps = float(fps)
    if not math.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a positive number, got {quote(fps)}")
    scale = float(scale)
    if not math.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale must be a positive number, got {quote(scale)}")
    values, F, unit = _amc_values(data, asf, source, lenient)
    to_rad = math.pi / 180.0 if (unit or asf.angle) == "deg" else 1.0
    skeleton = asf.to_skeleton(scale)
    names = skeleton.names
    J = len(names)
    rotations = np.zeros((F, J, 4))
    rotations[..., 0] = 1.0

    # root: W_root = O @ M_root, position = pre-set position + T
    root_vals = values.get(ROOT, np.zeros((F, 0)))
    order = asf.root_order
    rot_idx = [i for i, t in enumerate(order) if t[0] == "R"]
    m_root = _fixed_axes_quat(root_vals[:, rot_idx] * to_rad, "".join(order[i][1] for i in rot_idx))
    o_root = _fixed_axes_quat(asf.root_orientation, asf.root_axis)
    rotations[:, 0] = rot.quat_normalize(rot.quat_mul(o_root, m_root))
    root_positions = np.broadcast_to(asf.root_position, (F, 3)).copy()
    for i, t in enumerate(order):
        if t[0] == "T":
            root_positions[:, _AXIS[t[1].lower()]] += root_vals[:, i]
    with np.errstate(over="ignore", invalid="ignore"):
        root_positions *= scale

    translations = None
    bones = {b.name: b for b in asf.bones}
    for j, n in enumerate(names[1:], 1):
        b = bones[n]
        if not b.dof:
            continue
        v = values[n]
        qc = b.axis_quat
        r_idx = [i for i, d in enumerate(b.dof) if d in _ROT_DOFS]
        if r_idx:
            qm = _fixed_axes_quat(v[:, r_idx] * to_rad, "".join(b.dof[i][1] for i in r_idx))
            local = rot.quat_mul(rot.quat_mul(qc, qm), rot.quat_conj(qc))
            rotations[:, j] = rot.quat_normalize(local)
        t_idx = [i for i, d in enumerate(b.dof) if d in _TRANS_DOFS]
        if t_idx:
            if translations is None:
                translations = np.broadcast_to(skeleton.offsets, (F, J, 3)).copy()
            t = np.zeros((F, 3))
            for i in t_idx:
                t[:, _AXIS[b.dof[i][1]]] = v[:, i]
            with np.errstate(over="ignore", invalid="ignore"):
                translations[:, j] += rot.quat_apply(qc, t) * scale
    if translations is not None:
        translations[:, 0] = root_positions
    for arr in (root_positions, translations):
        if arr is not None and not np.all(np.isfinite(arr)):
            raise ASFAMCError(source, None, "translations overflow (values too large)")
    return Motion(skeleton, rotations, root_positions, 1.0 / fps, translations)


def read_amc(
    path: str | Path,
    asf: AsfSkeleton,
    fps: float = 120.0,
    scale: float = 1.0,
    lenient: bool = False,
) -> Motion:
    """Read an AMC file for a parsed ASF (see :func:`parse_amc`)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise ASFAMCError(path, None, f"cannot read file: {e.strerror or e}") from None
    return parse_amc(data, asf, str(path), fps=fps, scale=scale, lenient=lenient)


def read_asfamc(
    asf_path: str | Path,
    amc_path: str | Path,
    fps: float = 120.0,
    scale: float = 1.0,
    lenient: bool = False,
) -> Motion:
    """Read an ASF skeleton and an AMC motion in one call (file units unless ``scale``)."""
    return read_amc(amc_path, read_asf(asf_path), fps=fps, scale=scale, lenient=lenient)
