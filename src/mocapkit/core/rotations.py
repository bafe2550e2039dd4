"""Vectorised rotation utilities: quaternions, matrices, Euler angles, rotation vectors.

Conventions
-----------
* Quaternions are unit quaternions stored as ``(..., 4)`` float64 arrays in
  **w, x, y, z** order (scalar first).  Note that scipy uses x, y, z, w.
* Angles are in radians everywhere (use ``np.deg2rad`` / ``np.rad2deg``).
* Rotation matrices are ``(..., 3, 3)`` and act on column vectors: ``v' = R @ v``.
* ``quat_mul(a, b)`` is the Hamilton product; it applies ``b`` first, then ``a``,
  so ``quat_to_matrix(quat_mul(a, b)) == quat_to_matrix(a) @ quat_to_matrix(b)``.
* Euler angles are ``(..., 3)``; ``angles[..., i]`` is the angle about axis
  ``order[i]``.  ``order`` is one of the 12 orders ``XYZ XZY YXZ YZX ZXY ZYX``
  (Tait-Bryan) or ``XYX XZX YXY YZY ZXZ ZYZ`` (proper Euler); lowercase is accepted.
  Rotations are **intrinsic** (as in BVH): for ``'ZXY'`` the matrix is
  ``Rz(a0) @ Rx(a1) @ Ry(a2)``, identical to scipy's
  ``Rotation.from_euler('ZXY', angles)`` (uppercase = intrinsic).
* Rotation vectors are ``axis * angle`` with angle in ``[0, pi]``.
* Every function is batched over arbitrary leading axes (with numpy
  broadcasting where two inputs are taken), never mutates its inputs, always
  returns new arrays and is safe at zero angle (no NaN).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "euler_to_matrix",
    "euler_to_quat",
    "matrix_to_euler",
    "matrix_to_quat",
    "quat_angle",
    "quat_apply",
    "quat_between",
    "quat_conj",
    "quat_exp",
    "quat_fix_hemisphere",
    "quat_identity",
    "quat_inv",
    "quat_log",
    "quat_mul",
    "quat_normalize",
    "quat_slerp",
    "quat_to_euler",
    "quat_to_matrix",
    "quat_to_rotvec",
    "quat_unroll",
    "rotvec_to_quat",
    "validate_order",
]

Array = NDArray[np.float64]

_AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}
VALID_ORDERS: tuple[str, ...] = (
    "XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX",
    "XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ",
)  # fmt: skip

# Within this distance of a singularity (middle angle 0 or pi in the Bernardes-Viollet
# parametrisation) the outer angles are reported with the gimbal-lock convention.  The
# general formula stays accurate right up to the singularity (errors in the split of the
# outer angles are damped by the tiny middle angle), so a tight threshold costs nothing
# and keeps the rotation error of the snap itself below ~1e-12.
_GIMBAL_EPS = 1e-12


# --------------------------------------------------------------------------- helpers


def _as_array(x: ArrayLike, last: int, name: str) -> Array:
    """``x`` as a float64 array (no copy if already one), checking the last dimension."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != last:
        raise ValueError(f"{name} must have shape (..., {last}), got {arr.shape}")
    return arr


def _as_matrix(m: ArrayLike) -> Array:
    arr = np.asarray(m, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(f"matrix must have shape (..., 3, 3), got {arr.shape}")
    return arr


def _norm(x: Array, keepdims: bool = False) -> Array:
    return np.sqrt(np.sum(x * x, axis=-1, keepdims=keepdims))


def _wrap_angle(a: Array) -> Array:
    """Wrap to [-pi, pi]; values already inside are left bit-identical."""
    return np.where(np.abs(a) > np.pi, np.mod(a + np.pi, 2.0 * np.pi) - np.pi, a)


def validate_order(order: str) -> str:
    """Return the upper-cased Euler order, or raise ``ValueError`` if it is not valid."""
    if isinstance(order, str) and order.upper() in VALID_ORDERS:
        return order.upper()
    raise ValueError(f"invalid Euler order {order!r}; expected one of {', '.join(VALID_ORDERS)}")


# --------------------------------------------------------------------------- basics


def quat_identity(shape: int | tuple[int, ...] = ()) -> Array:
    """Identity quaternions of shape ``shape + (4,)``."""
    shape = (shape,) if isinstance(shape, int | np.integer) else tuple(shape)
    q = np.zeros((*shape, 4))
    q[..., 0] = 1.0
    return q


def quat_normalize(q: ArrayLike) -> Array:
    """Unit quaternions ``(..., 4)``; zero-norm inputs become the identity."""
    q = _as_array(q, 4, "q")
    n = _norm(q, keepdims=True)
    safe = n > 0.0
    out = q / np.where(safe, n, 1.0)
    return np.where(safe, out, quat_identity())


def quat_conj(q: ArrayLike) -> Array:
    """Conjugate ``(w, -x, -y, -z)``; ``(..., 4) -> (..., 4)``."""
    q = _as_array(q, 4, "q")
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_inv(q: ArrayLike) -> Array:
    """Inverse ``conj(q) / |q|^2``; ``(..., 4) -> (..., 4)`` (equals conj for unit q)."""
    q = _as_array(q, 4, "q")
    return quat_conj(q) / np.sum(q * q, axis=-1, keepdims=True)


def quat_mul(a: ArrayLike, b: ArrayLike) -> Array:
    """Hamilton product ``a * b`` (apply b, then a); ``(..., 4) x (..., 4) -> (..., 4)``."""
    a = _as_array(a, 4, "a")
    b = _as_array(b, 4, "b")
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def quat_apply(q: ArrayLike, v: ArrayLike) -> Array:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)`` (broadcasting)."""
    q = _as_array(q, 4, "q")
    v = _as_array(v, 3, "v")
    w = q[..., :1]
    u = q[..., 1:]
    # v' = v + 2w (u x v) + 2 u x (u x v), written with one shared cross product.
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


# --------------------------------------------------------------------------- matrices


def quat_to_matrix(q: ArrayLike) -> Array:
    """Rotation matrices ``(..., 3, 3)`` from quaternions ``(..., 4)`` (normalised implicitly)."""
    q = _as_array(q, 4, "q")
    w, x, y, z = np.moveaxis(q, -1, 0)
    n2 = w * w + x * x + y * y + z * z
    # s = 2/|q|^2 makes the formula exact for non-unit quaternions too.
    s = np.where(n2 > 0.0, 2.0 / np.where(n2 > 0.0, n2, 1.0), 0.0)
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    m = np.stack(
        [
            1.0 - yy - zz, xy - wz, xz + wy,
            xy + wz, 1.0 - xx - zz, yz - wx,
            xz - wy, yz + wx, 1.0 - xx - yy,
        ],
        axis=-1,
    )  # fmt: skip
    return m.reshape((*q.shape[:-1], 3, 3))


def matrix_to_quat(m: ArrayLike) -> Array:
    """Quaternions ``(..., 4)`` with ``w >= 0`` from rotation matrices ``(..., 3, 3)``.

    Shepperd's method: of the four algebraically equivalent formulas, pick per
    element the one whose pivot (4w^2, 4x^2, 4y^2 or 4z^2) is largest, so there
    is never a division by a small number.  The result is renormalised, which
    also absorbs slight non-orthogonality of ``m``.
    """
    m = _as_matrix(m)
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    tr = m00 + m11 + m22
    # Each row is 4 * pivot_component * q for one branch (w, x, y, z pivots).
    cand = np.stack(
        [
            np.stack([1.0 + tr, m21 - m12, m02 - m20, m10 - m01], axis=-1),
            np.stack([m21 - m12, 1.0 + m00 - m11 - m22, m01 + m10, m02 + m20], axis=-1),
            np.stack([m02 - m20, m01 + m10, 1.0 - m00 + m11 - m22, m12 + m21], axis=-1),
            np.stack([m10 - m01, m02 + m20, m12 + m21, 1.0 - m00 - m11 + m22], axis=-1),
        ],
        axis=-2,
    )
    branch = np.argmax(np.stack([tr, m00, m11, m22], axis=-1), axis=-1)
    q = np.take_along_axis(cand, branch[..., None, None], axis=-2)[..., 0, :]
    q = q / _norm(q, keepdims=True)
    return np.where(q[..., :1] < 0.0, -q, q)


# --------------------------------------------------------------------------- Euler angles


def _axis_quat(axis: int, angle: Array) -> Array:
    q = np.zeros((*angle.shape, 4))
    q[..., 0] = np.cos(0.5 * angle)
    q[..., 1 + axis] = np.sin(0.5 * angle)
    return q


def _axis_matrix(axis: int, angle: Array) -> Array:
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3  # the plane rotated by this axis (right-handed)
    m = np.zeros((*angle.shape, 3, 3))
    m[..., axis, axis] = 1.0
    m[..., i, i] = c
    m[..., j, j] = c
    m[..., i, j] = -s
    m[..., j, i] = s
    return m


def euler_to_quat(angles: ArrayLike, order: str) -> Array:
    """Quaternions ``(..., 4)`` from intrinsic Euler ``angles (..., 3)`` in ``order``."""
    order = validate_order(order)
    angles = _as_array(angles, 3, "angles")
    q0, q1, q2 = (_axis_quat(_AXIS_INDEX[c], angles[..., n]) for n, c in enumerate(order))
    return quat_mul(quat_mul(q0, q1), q2)


def euler_to_matrix(angles: ArrayLike, order: str) -> Array:
    """Rotation matrices ``(..., 3, 3)`` from intrinsic Euler ``angles (..., 3)``."""
    order = validate_order(order)
    angles = _as_array(angles, 3, "angles")
    m0, m1, m2 = (_axis_matrix(_AXIS_INDEX[c], angles[..., n]) for n, c in enumerate(order))
    return m0 @ m1 @ m2


def quat_to_euler(q: ArrayLike, order: str) -> Array:
    """Intrinsic Euler angles ``(..., 3)`` in ``order`` from quaternions ``(..., 4)``.

    Direct method of Bernardes & Viollet (2022, PLoS ONE 17(11): e0276302).
    Ranges: first and third angles in [-pi, pi]; middle angle in [-pi/2, pi/2]
    (Tait-Bryan) or [0, pi] (proper Euler).  In gimbal lock the first angle is
    set to 0 and the third absorbs the whole remaining rotation (the middle
    angle is then exactly +-pi/2, or 0 / pi), so the angles always reproduce the
    input rotation.
    """
    order = validate_order(order)
    q = _as_array(q, 4, "q")
    # Intrinsic (o0, o1, o2) with angles (a, b, c) == extrinsic (o2, o1, o0) with (c, b, a):
    # solve the extrinsic problem, then reverse the angles.
    i, j, k = (_AXIS_INDEX[c] for c in order[::-1])
    proper = i == k
    if proper:
        k = 3 - i - j  # the axis not used
    sign = (i - j) * (j - k) * (k - i) // 2  # parity of the permutation (i, j, k): +-1

    w, qi, qj, qk = q[..., 0], q[..., 1 + i], q[..., 1 + j], q[..., 1 + k] * sign
    if proper:
        a, b, c, d = w, qi, qj, qk
    else:
        # Rotating the quaternion by 45 deg turns a Tait-Bryan problem into a proper one.
        a, b, c, d = w - qj, qi + qk, qj + w, qk - qi

    mid = 2.0 * np.arctan2(np.hypot(c, d), np.hypot(a, b))  # in [0, pi]
    half_sum = np.arctan2(b, a)
    half_diff = np.arctan2(d, c)
    first = half_sum - half_diff
    third = half_sum + half_diff

    # Gimbal lock: only the sum (mid ~ 0) or difference (mid ~ pi) of the outer angles is
    # defined; put it all on the first extrinsic angle (= last intrinsic one) and snap the
    # middle angle so that exact locks come out as exact +-pi/2 (or 0 / pi).
    at_zero = np.abs(mid) <= _GIMBAL_EPS
    at_pi = np.abs(mid - np.pi) <= _GIMBAL_EPS
    first = np.where(at_zero, 2.0 * half_sum, np.where(at_pi, -2.0 * half_diff, first))
    third = np.where(at_zero | at_pi, 0.0, third)
    mid = np.where(at_zero, 0.0, np.where(at_pi, np.pi, mid))

    if not proper:
        third = third * sign
        mid = mid - 0.5 * np.pi
    return np.stack([_wrap_angle(third), mid, _wrap_angle(first)], axis=-1)


def matrix_to_euler(m: ArrayLike, order: str) -> Array:
    """Intrinsic Euler angles ``(..., 3)`` from rotation matrices ``(..., 3, 3)``.

    Goes through :func:`matrix_to_quat`, which is robust, then :func:`quat_to_euler`.
    """
    return quat_to_euler(matrix_to_quat(m), order)


# --------------------------------------------------------------------------- log / exp


def quat_to_rotvec(q: ArrayLike) -> Array:
    """Rotation vectors ``(..., 3)`` (axis * angle, angle in [0, pi]) from quaternions."""
    q = quat_normalize(q)
    q = np.where(q[..., :1] < 0.0, -q, q)  # shortest rotation: angle <= pi
    w = q[..., 0]
    v = q[..., 1:]
    s = _norm(v)  # = sin(angle / 2)
    angle = 2.0 * np.arctan2(s, w)
    small = angle < 1e-4
    # angle / sin(angle/2), with its Taylor series near 0 to avoid 0/0.
    a2 = angle * angle
    series = 2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0
    scale = np.where(small, series, angle / np.where(small, 1.0, s))
    return v * scale[..., None]


def rotvec_to_quat(v: ArrayLike) -> Array:
    """Unit quaternions ``(..., 4)`` with ``w >= 0`` from rotation vectors ``(..., 3)``."""
    v = _as_array(v, 3, "v")
    angle = _norm(v)
    small = angle < 1e-4
    a2 = angle * angle
    # sin(angle/2) / angle, with its Taylor series near 0.
    scale = np.where(
        small, 0.5 - a2 / 48.0 + a2 * a2 / 3840.0, np.sin(0.5 * angle) / np.where(small, 1.0, angle)
    )
    q = np.concatenate([np.cos(0.5 * angle)[..., None], v * scale[..., None]], axis=-1)
    # Angles > pi (|v| > pi) would give w < 0; keep the w >= 0 convention.
    return np.where(q[..., :1] < 0.0, -q, q)


def quat_log(q: ArrayLike) -> Array:
    """Quaternion logarithm's vector part ``(..., 3)`` = ``quat_to_rotvec(q) / 2``."""
    return 0.5 * quat_to_rotvec(q)


def quat_exp(v: ArrayLike) -> Array:
    """Inverse of :func:`quat_log`: ``(..., 3) -> (..., 4)``, i.e. ``rotvec_to_quat(2 v)``."""
    return rotvec_to_quat(2.0 * _as_array(v, 3, "v"))


# --------------------------------------------------------------------------- slerp / metrics


def quat_slerp(a: ArrayLike, b: ArrayLike, t: ArrayLike) -> Array:
    """Spherical linear interpolation along the shorter arc.

    ``a``, ``b``: ``(..., 4)``; ``t``: scalar or array broadcasting against the
    batch shape ``(...)``.  Returns ``(..., 4)`` unit quaternions; ``t=0`` gives
    ``a`` and ``t=1`` gives ``b`` (up to sign).  Falls back to normalised lerp
    when ``a`` and ``b`` are (nearly) equal.
    """
    a = quat_normalize(a)
    b = quat_normalize(b)
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(a * b, axis=-1, keepdims=True)
    b = np.where(dot < 0.0, -b, b)  # shorter arc
    # Angle between the 4-vectors; atan2 form stays accurate when a ~ b.
    theta = 2.0 * np.arctan2(_norm(a - b, keepdims=True), _norm(a + b, keepdims=True))
    sin_theta = np.sin(theta)
    lerp = sin_theta < 1e-8
    safe = np.where(lerp, 1.0, sin_theta)
    wa = np.where(lerp, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    wb = np.where(lerp, t, np.sin(t * theta) / safe)
    return quat_normalize(wa * a + wb * b)


def quat_angle(a: ArrayLike, b: ArrayLike) -> Array:
    """Geodesic distance ``(...)`` in [0, pi] between rotations ``a`` and ``b`` (``(..., 4)``)."""
    rel = quat_mul(quat_conj(a), b)
    # |w| picks the shorter of q / -q; atan2 is accurate for both tiny and ~pi angles.
    return 2.0 * np.arctan2(_norm(rel[..., 1:]), np.abs(rel[..., 0]))


def quat_unroll(q: ArrayLike, axis: int = 0) -> Array:
    """Flip signs along ``axis`` (a time axis of ``q``, not the last one) for continuity.

    Returns ``(..., 4)`` with non-negative dot products between consecutive
    quaternions along ``axis``; the first one is kept as is.  Same rotations.
    """
    q = _as_array(q, 4, "q")
    ax = axis + q.ndim if axis < 0 else axis
    if not 0 <= ax < q.ndim - 1:
        raise ValueError(f"axis {axis} is not a batch axis of an array of shape {q.shape}")
    qt = np.moveaxis(q, ax, 0)
    if qt.shape[0] < 2:
        return q.copy()
    dots = np.sum(qt[1:] * qt[:-1], axis=-1)
    step = np.where(dots < 0.0, -1.0, 1.0)
    # s_t = s_{t-1} * sign(dot(q_{t-1}, q_t)) makes every consecutive dot |dot| >= 0.
    signs = np.concatenate([np.ones_like(step[:1]), np.cumprod(step, axis=0)], axis=0)
    return np.moveaxis(qt * signs[..., None], 0, ax)


def quat_fix_hemisphere(q: ArrayLike, ref: ArrayLike) -> Array:
    """Flip ``q`` to the hemisphere of ``ref`` (``dot(q, ref) >= 0``); broadcasting ``(..., 4)``."""
    q = _as_array(q, 4, "q")
    ref = _as_array(ref, 4, "ref")
    dot = np.sum(q * ref, axis=-1, keepdims=True)
    out = np.where(dot < 0.0, -q, q)
    return np.broadcast_to(out, np.broadcast_shapes(q.shape, ref.shape)).copy()


def quat_between(u: ArrayLike, v: ArrayLike) -> Array:
    """Shortest-arc rotation ``(..., 4)`` taking direction ``u`` to direction ``v`` (``(..., 3)``).

    For opposite directions the axis is undefined; a 180 deg rotation about an
    axis perpendicular to ``u`` is returned.  Zero vectors give the identity.
    """
    u = _as_array(u, 3, "u")
    v = _as_array(v, 3, "v")
    u = u / np.where((nu := _norm(u, keepdims=True)) > 0.0, nu, 1.0)
    v = v / np.where((nv := _norm(v, keepdims=True)) > 0.0, nv, 1.0)
    u, v = np.broadcast_arrays(u, v)
    cross = np.cross(u, v)
    sin_t = _norm(cross, keepdims=True)
    # atan2 keeps theta accurate near 0 and pi, where 1 + u.v would lose digits.
    theta = np.arctan2(sin_t, np.sum(u * v, axis=-1, keepdims=True))
    w = np.cos(0.5 * theta)
    # Axis = cross / |cross|.  For theta <= pi/2 use sin(theta/2)/sin(theta) = 1/(2w),
    # which is exact and has no 0/0 at theta = 0.
    near = theta <= 0.5 * np.pi
    vec_near = cross / (2.0 * np.where(near, w, 1.0))
    # Nearly opposite: when |cross| is at rounding level its direction is noise, so
    # use u x (basis vector least aligned with u), which is exactly perpendicular to u.
    e = np.zeros_like(u)
    np.put_along_axis(e, np.argmin(np.abs(u), axis=-1)[..., None], 1.0, axis=-1)
    perp = np.cross(u, e)
    perp = perp / np.where((n_p := _norm(perp, keepdims=True)) > 0.0, n_p, 1.0)
    # Otherwise make the axis exactly perpendicular to u: near pi, an axis tilted by eps
    # towards u would send u 2*eps away from -u.
    axis = cross - np.sum(cross * u, axis=-1, keepdims=True) * u
    n_a = _norm(axis, keepdims=True)
    degenerate = (sin_t < 1e-12) | (n_a == 0.0)
    axis = np.where(degenerate, perp, axis / np.where(degenerate, 1.0, n_a))
    vec = np.where(near, vec_near, np.sin(0.5 * theta) * axis)
    q = np.concatenate([w, vec], axis=-1)
    # Zero-length inputs have no direction: return the identity.
    zero = np.broadcast_to((nu == 0.0) | (nv == 0.0), w.shape)
    return np.where(zero, quat_identity(), q)
