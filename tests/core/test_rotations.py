"""Tests for mocapkit.core.rotations, cross-checked against scipy.spatial.transform."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation, Slerp

from mocapkit.core import rotations as rot

ORDERS = list(rot.VALID_ORDERS)
TAIT_BRYAN = [o for o in ORDERS if o[0] != o[2]]
PROPER = [o for o in ORDERS if o[0] == o[2]]
TOL = 1e-9

settings.register_profile("rotations", max_examples=60, deadline=None, derandomize=True)
settings.load_profile("rotations")


# --------------------------------------------------------------------------- helpers


def to_scipy(q: np.ndarray) -> Rotation:
    """Our (..., 4) wxyz -> scipy Rotation over the flattened batch (xyzw)."""
    return Rotation.from_quat(np.asarray(q).reshape(-1, 4)[:, [1, 2, 3, 0]])


def from_scipy(r: Rotation) -> np.ndarray:
    return np.atleast_2d(r.as_quat())[:, [3, 0, 1, 2]]


def random_quats(n: int | tuple[int, ...], seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    shape = (n,) if isinstance(n, int) else n
    q = rng.normal(size=(*shape, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def same_up_to_sign(a: np.ndarray, b: np.ndarray, tol: float = TOL) -> bool:
    d = np.minimum(np.abs(a - b).max(axis=-1), np.abs(a + b).max(axis=-1))
    return bool(np.all(d < tol))


def half_turns(n: int, seed: int = 1) -> np.ndarray:
    """Quaternions of exactly 180 deg rotations (w = 0), including coordinate axes."""
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(n, 3))
    axes = np.concatenate([axes, np.eye(3), -np.eye(3)])
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    return np.concatenate([np.zeros((len(axes), 1)), axes], axis=-1)


unit_quats = (
    arrays(np.float64, 4, elements=st.floats(-1.0, 1.0, allow_nan=False))
    .filter(lambda v: np.linalg.norm(v) > 0.1)
    .map(lambda v: v / np.linalg.norm(v))
)
euler_angles = arrays(np.float64, 3, elements=st.floats(-np.pi, np.pi, allow_nan=False))
vectors = arrays(np.float64, 3, elements=st.floats(-10.0, 10.0, allow_nan=False))


# --------------------------------------------------------------------------- orders


def test_validate_order() -> None:
    assert rot.validate_order("zxy") == "ZXY"
    assert rot.validate_order("XYX") == "XYX"
    for bad in ["XXY", "XY", "ABC", "XYZW", "", None, 3]:
        with pytest.raises(ValueError, match="invalid Euler order"):
            rot.validate_order(bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="'QQQ'"):
        rot.euler_to_quat(np.zeros(3), "QQQ")


def test_lowercase_order_accepted() -> None:
    a = np.array([0.1, 0.2, 0.3])
    np.testing.assert_array_equal(rot.euler_to_quat(a, "zxy"), rot.euler_to_quat(a, "ZXY"))


def test_bvh_intrinsic_convention() -> None:
    a = np.array([0.3, -0.5, 1.1])
    rz = rot.euler_to_matrix(np.array([a[0], 0, 0]), "ZXY")
    rx = rot.euler_to_matrix(np.array([0, a[1], 0]), "ZXY")
    ry = rot.euler_to_matrix(np.array([0, 0, a[2]]), "ZXY")
    np.testing.assert_allclose(rot.euler_to_matrix(a, "ZXY"), rz @ rx @ ry, atol=1e-15)


# --------------------------------------------------------------------------- Euler vs scipy


@pytest.mark.parametrize("order", ORDERS)
def test_euler_to_quat_matches_scipy(order: str) -> None:
    rng = np.random.default_rng(10)
    ang = rng.uniform(-np.pi, np.pi, size=(500, 3))
    q = rot.euler_to_quat(ang, order)
    assert same_up_to_sign(q, from_scipy(Rotation.from_euler(order, ang)))
    m = rot.euler_to_matrix(ang, order)
    np.testing.assert_allclose(m, Rotation.from_euler(order, ang).as_matrix(), atol=1e-12)


@pytest.mark.parametrize("order", ORDERS)
def test_quat_to_euler_round_trip(order: str) -> None:
    q = random_quats(1000, seed=11)
    ang = rot.quat_to_euler(q, order)
    assert np.all(rot.quat_angle(rot.euler_to_quat(ang, order), q) < TOL)
    m = rot.quat_to_matrix(q)
    ang_m = rot.matrix_to_euler(m, order)
    np.testing.assert_allclose(rot.euler_to_matrix(ang_m, order), m, atol=1e-12)
    # Away from gimbal lock the decomposition is unique: same angles as scipy.
    ang_s = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_euler(order)
    diff = np.angle(np.exp(1j * (ang - ang_s)))
    assert np.abs(diff).max() < 1e-9


@pytest.mark.parametrize("order", ORDERS)
def test_quat_to_euler_ranges(order: str) -> None:
    ang = rot.quat_to_euler(random_quats(500, seed=12), order)
    assert np.all(np.abs(ang[:, [0, 2]]) <= np.pi)
    if order[0] == order[2]:
        assert np.all((ang[:, 1] >= 0) & (ang[:, 1] <= np.pi))
    else:
        assert np.all(np.abs(ang[:, 1]) <= np.pi / 2 + 1e-15)


@settings(max_examples=40)
@given(ang=euler_angles, order=st.sampled_from(ORDERS))
def test_euler_round_trip_hypothesis(ang: np.ndarray, order: str) -> None:
    q = rot.euler_to_quat(ang, order)
    assert same_up_to_sign(q, from_scipy(Rotation.from_euler(order, ang))[0])
    back = rot.quat_to_euler(q, order)
    assert rot.quat_angle(rot.euler_to_quat(back, order), q) < TOL


def _gimbal_angles(order: str) -> np.ndarray:
    rng = np.random.default_rng(13)
    outer = rng.uniform(-np.pi, np.pi, size=(50, 2))
    mids = [np.pi / 2, -np.pi / 2] if order[0] != order[2] else [0.0, np.pi, -np.pi]
    rows = [np.column_stack([outer[:, 0], np.full(len(outer), m), outer[:, 1]]) for m in mids]
    # Also exact multiples of 90 deg on the outer axes and slightly-off-lock middles.
    special = [[np.pi / 2, m, -np.pi / 2] for m in mids]
    near = [[0.4, m + s * 1e-9, -1.3] for m in mids for s in (1, -1)]
    return np.concatenate([*rows, np.array(special), np.array(near)])


@pytest.mark.parametrize("order", ORDERS)
def test_gimbal_lock_round_trip(order: str) -> None:
    ang = _gimbal_angles(order)
    q = rot.euler_to_quat(ang, order)
    back = rot.quat_to_euler(q, order)
    assert np.all(np.isfinite(back))
    assert np.all(rot.quat_angle(rot.euler_to_quat(back, order), q) < TOL)
    m = rot.euler_to_matrix(ang, order)
    back_m = rot.matrix_to_euler(m, order)
    np.testing.assert_allclose(rot.euler_to_matrix(back_m, order), m, atol=1e-12)


# --------------------------------------------------------------------------- matrices


def test_matrix_quat_vs_scipy() -> None:
    q = np.concatenate([random_quats(500, seed=20), half_turns(50), rot.quat_identity((1,))])
    m = rot.quat_to_matrix(q)
    np.testing.assert_allclose(m, to_scipy(q).as_matrix(), atol=1e-14)
    q2 = rot.matrix_to_quat(m)
    assert np.all(q2[:, 0] >= 0)
    np.testing.assert_allclose(np.linalg.norm(q2, axis=-1), 1.0, atol=1e-15)
    assert same_up_to_sign(q2, q, tol=1e-14)
    assert same_up_to_sign(q2, from_scipy(Rotation.from_matrix(m)), tol=1e-14)


def test_matrix_to_quat_half_turns_about_axes() -> None:
    for axis in range(3):
        m = -np.eye(3)
        m[axis, axis] = 1.0
        q = rot.matrix_to_quat(m)
        expected = np.zeros(4)
        expected[1 + axis] = 1.0
        assert same_up_to_sign(q, expected, tol=1e-15)


def test_quat_to_matrix_orthonormal_for_non_unit() -> None:
    q = 3.0 * random_quats(100, seed=21)
    m = rot.quat_to_matrix(q)
    np.testing.assert_allclose(m @ np.swapaxes(m, -1, -2), np.broadcast_to(np.eye(3), m.shape),
                               atol=1e-14)  # fmt: skip
    np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-14)


@given(q=unit_quats)
def test_matrix_round_trip_hypothesis(q: np.ndarray) -> None:
    q2 = rot.matrix_to_quat(rot.quat_to_matrix(q))
    assert rot.quat_angle(q, q2) < TOL
    assert q2[0] >= 0


# --------------------------------------------------------------------------- products


def test_quat_mul_vs_scipy_composition() -> None:
    a, b = random_quats(300, seed=30), random_quats(300, seed=31)
    ab = rot.quat_mul(a, b)
    assert same_up_to_sign(ab, from_scipy(to_scipy(a) * to_scipy(b)), tol=1e-14)
    ma, mb = rot.quat_to_matrix(a), rot.quat_to_matrix(b)
    np.testing.assert_allclose(rot.quat_to_matrix(ab), ma @ mb, atol=1e-14)


def test_quat_apply_vs_scipy() -> None:
    q = random_quats(300, seed=32)
    v = np.random.default_rng(33).normal(size=(300, 3)) * 5
    np.testing.assert_allclose(rot.quat_apply(q, v), to_scipy(q).apply(v), atol=1e-13)
    np.testing.assert_allclose(
        rot.quat_apply(q, v), np.einsum("nij,nj->ni", rot.quat_to_matrix(q), v), atol=1e-13
    )


def test_inverse_and_conjugate() -> None:
    q = random_quats(100, seed=34)
    ident = rot.quat_identity(100)
    assert same_up_to_sign(rot.quat_mul(q, rot.quat_conj(q)), ident, tol=1e-15)
    s = 2.5 * q
    assert same_up_to_sign(rot.quat_mul(s, rot.quat_inv(s)), ident, tol=1e-14)
    np.testing.assert_allclose(rot.quat_inv(q), rot.quat_conj(q), atol=1e-15)


def test_identity_and_normalize() -> None:
    assert rot.quat_identity().shape == (4,)
    assert rot.quat_identity(3).shape == (3, 4)
    i = rot.quat_identity((2, 5))
    assert i.shape == (2, 5, 4)
    assert np.all(i == [1, 0, 0, 0])
    n = rot.quat_normalize(np.array([[0.0, 0, 0, 0], [2.0, 0, 0, 0], [1.0, 1, 1, 1]]))
    np.testing.assert_allclose(n, [[1, 0, 0, 0], [1, 0, 0, 0], [0.5, 0.5, 0.5, 0.5]])


# --------------------------------------------------------------------------- log / exp


def test_rotvec_vs_scipy() -> None:
    q = np.concatenate([random_quats(500, seed=40), half_turns(20), rot.quat_identity((1,))])
    rv = rot.quat_to_rotvec(q)
    np.testing.assert_allclose(np.linalg.norm(rv, axis=-1) <= np.pi + 1e-15, True)
    rv_s = to_scipy(q).as_rotvec()
    # At exactly 180 deg, v and -v are the same rotation.
    ok = (np.abs(rv - rv_s).max(axis=-1) < 1e-12) | (np.abs(rv + rv_s).max(axis=-1) < 1e-12)
    assert np.all(ok)
    q2 = rot.rotvec_to_quat(rv)
    assert same_up_to_sign(q2, from_scipy(Rotation.from_rotvec(rv)), tol=1e-14)
    assert np.all(rot.quat_angle(q2, q) < TOL)


def test_small_angle_rotvec_accuracy() -> None:
    rv = np.array([[1e-5, -2e-5, 3e-6], [1e-9, 0, 0], [3e-4, 1e-4, -2e-4], [0, 0, 1e-300]])
    q = rot.rotvec_to_quat(rv)
    assert same_up_to_sign(q, from_scipy(Rotation.from_rotvec(rv)), tol=1e-16)
    np.testing.assert_allclose(rot.quat_to_rotvec(q), rv, rtol=1e-12, atol=0)


def test_zero_angle_safety() -> None:
    with np.errstate(all="raise"):
        q = rot.rotvec_to_quat(np.zeros((3, 3)))
        np.testing.assert_array_equal(q, rot.quat_identity(3))
        np.testing.assert_array_equal(rot.quat_log(rot.quat_identity(3)), 0.0)
        np.testing.assert_array_equal(rot.quat_to_rotvec(rot.quat_identity()), 0.0)
        np.testing.assert_array_equal(rot.quat_exp(np.zeros(3)), [1, 0, 0, 0])
        assert rot.quat_angle(rot.quat_identity(), rot.quat_identity()) == 0.0
        i = rot.quat_identity(4)
        np.testing.assert_array_equal(rot.quat_slerp(i, i, np.linspace(0, 1, 4)), i)
        for order in ORDERS:
            assert np.all(rot.quat_to_euler(rot.quat_identity(), order) == 0.0)
        np.testing.assert_array_equal(rot.matrix_to_quat(np.eye(3)), [1, 0, 0, 0])
        np.testing.assert_array_equal(rot.quat_between([1.0, 0, 0], [2.0, 0, 0]), [1, 0, 0, 0])


@given(v=vectors)
def test_log_exp_inverse(v: np.ndarray) -> None:
    q = rot.quat_exp(v)
    assert abs(np.linalg.norm(q) - 1.0) < 1e-14
    assert rot.quat_angle(rot.quat_exp(rot.quat_log(q)), q) < TOL
    np.testing.assert_allclose(rot.quat_log(q), 0.5 * rot.quat_to_rotvec(q), atol=0)


@given(q=unit_quats)
def test_rotvec_round_trip_hypothesis(q: np.ndarray) -> None:
    rv = rot.quat_to_rotvec(q)
    assert np.linalg.norm(rv) <= np.pi + 1e-12
    assert rot.quat_angle(rot.rotvec_to_quat(rv), q) < TOL


# --------------------------------------------------------------------------- slerp / angle


def test_slerp_vs_scipy() -> None:
    a, b = random_quats(30, seed=50), random_quats(30, seed=51)
    ts = np.linspace(0.0, 1.0, 7)
    for qa, qb in zip(a, b, strict=True):
        ref = from_scipy(Slerp([0.0, 1.0], to_scipy(np.stack([qa, qb])))(ts))
        ours = rot.quat_slerp(qa, qb, ts)
        assert ours.shape == (7, 4)
        assert np.all(rot.quat_angle(ours, ref) < 1e-9)
    # Per-element t broadcasting against a batch.
    t = np.random.default_rng(52).uniform(size=30)
    out = rot.quat_slerp(a, b, t)
    assert out.shape == (30, 4)
    for k in range(30):
        ref = from_scipy(Slerp([0.0, 1.0], to_scipy(np.stack([a[k], b[k]])))([t[k]]))[0]
        assert rot.quat_angle(out[k], ref) < 1e-9


def test_slerp_endpoints_and_shorter_arc() -> None:
    a, b = random_quats(100, seed=53), random_quats(100, seed=54)
    assert np.all(rot.quat_angle(rot.quat_slerp(a, b, 0.0), a) < 1e-12)
    assert np.all(rot.quat_angle(rot.quat_slerp(a, b, 1.0), b) < 1e-12)
    # -b is the same rotation: the result must not depend on the sign.
    mid, mid_neg = rot.quat_slerp(a, b, 0.5), rot.quat_slerp(a, -b, 0.5)
    assert np.all(rot.quat_angle(mid, mid_neg) < 1e-12)
    np.testing.assert_allclose(rot.quat_angle(a, mid), 0.5 * rot.quat_angle(a, b), atol=1e-12)


def test_slerp_nearly_equal() -> None:
    a = random_quats(10, seed=55)
    b = rot.quat_mul(a, rot.rotvec_to_quat(np.array([1e-12, 0, 0])))
    for other in (a, b, -a):
        out = rot.quat_slerp(a, other, 0.3)
        assert np.all(np.isfinite(out))
        assert np.all(rot.quat_angle(out, a) < 1e-11)


def test_quat_angle_vs_scipy() -> None:
    a = np.concatenate([random_quats(300, seed=60), half_turns(5)])
    b = np.concatenate([random_quats(300, seed=61), rot.quat_identity((11,))])
    ang = rot.quat_angle(a, b)
    ref = (to_scipy(a).inv() * to_scipy(b)).magnitude()
    np.testing.assert_allclose(ang, ref, atol=1e-12)
    assert np.all((ang >= 0) & (ang <= np.pi))
    np.testing.assert_allclose(rot.quat_angle(a, -b), ang, atol=1e-15)


def test_quat_angle_tiny() -> None:
    a = random_quats(5, seed=62)
    b = rot.quat_mul(a, rot.rotvec_to_quat(np.array([0.0, 3e-10, 0.0])))
    np.testing.assert_allclose(rot.quat_angle(a, b), 3e-10, rtol=1e-5)


# --------------------------------------------------------------------------- hemisphere


def test_unroll() -> None:
    rng = np.random.default_rng(70)
    # Smooth motion (T=200, J=3) with random sign flips.
    rv = np.cumsum(rng.normal(scale=0.2, size=(200, 3, 3)), axis=0)
    q = rot.rotvec_to_quat(rv) * rng.choice([-1.0, 1.0], size=(200, 3, 1))
    u = rot.quat_unroll(q, axis=0)
    assert np.all(np.sum(u[1:] * u[:-1], axis=-1) >= 0)
    assert np.all(rot.quat_angle(u, q) < 1e-12)
    np.testing.assert_array_equal(u[0], q[0])
    # Time on another axis gives the same answer.
    u1 = rot.quat_unroll(np.swapaxes(q, 0, 1), axis=1)
    np.testing.assert_array_equal(np.swapaxes(u1, 0, 1), u)
    np.testing.assert_array_equal(rot.quat_unroll(np.swapaxes(q, 0, 1), axis=-2), u1)
    with pytest.raises(ValueError):
        rot.quat_unroll(q, axis=2)
    assert rot.quat_unroll(q[:1]).shape == (1, 3, 4)


def test_fix_hemisphere() -> None:
    q = random_quats((20, 4), seed=71)
    ref = random_quats(4, seed=72)
    f = rot.quat_fix_hemisphere(q, ref)
    assert f.shape == (20, 4, 4)
    assert np.all(np.sum(f * ref, axis=-1) >= 0)
    assert np.all(rot.quat_angle(f, q) < 1e-15)
    f2 = rot.quat_fix_hemisphere(ref, q)
    assert f2.shape == (20, 4, 4)
    assert np.all(np.sum(f2 * q, axis=-1) >= 0)


# --------------------------------------------------------------------------- quat_between


def test_quat_between() -> None:
    rng = np.random.default_rng(80)
    u = rng.normal(size=(300, 3)) * 3
    v = rng.normal(size=(300, 3))
    q = rot.quat_between(u, v)
    un = u / np.linalg.norm(u, axis=-1, keepdims=True)
    vn = v / np.linalg.norm(v, axis=-1, keepdims=True)
    np.testing.assert_allclose(rot.quat_apply(q, un), vn, atol=1e-14)
    # Shortest arc: rotation angle equals the angle between the directions.
    between = np.arccos(np.clip(np.sum(un * vn, axis=-1), -1, 1))
    np.testing.assert_allclose(rot.quat_angle(rot.quat_identity(), q), between, atol=1e-7)
    # Same as scipy's align_vectors for a single pair.
    r, _ = Rotation.align_vectors(vn[:1], un[:1])
    assert same_up_to_sign(q[:1], from_scipy(r), tol=1e-10)


def test_quat_between_opposite_and_parallel() -> None:
    rng = np.random.default_rng(81)
    u = np.concatenate([np.eye(3), -np.eye(3), rng.normal(size=(20, 3))])
    for v in (-u, -2.0 * u, u, 0.5 * u):
        q = rot.quat_between(u, v)
        assert np.all(np.isfinite(q))
        np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-15)
        un = u / np.linalg.norm(u, axis=-1, keepdims=True)
        vn = v / np.linalg.norm(v, axis=-1, keepdims=True)
        np.testing.assert_allclose(rot.quat_apply(q, un), vn, atol=1e-14)
    # Nearly opposite.
    eps = rot.rotvec_to_quat(np.array([0.0, 0.0, 1e-9]))
    w = -rot.quat_apply(eps, u)
    un = u / np.linalg.norm(u, axis=-1, keepdims=True)
    wn = w / np.linalg.norm(w, axis=-1, keepdims=True)
    np.testing.assert_allclose(rot.quat_apply(rot.quat_between(u, w), un), wn, atol=1e-12)


@given(u=vectors, v=vectors)
def test_quat_between_hypothesis(u: np.ndarray, v: np.ndarray) -> None:
    nu, nv = np.linalg.norm(u), np.linalg.norm(v)
    q = rot.quat_between(u, v)
    assert np.all(np.isfinite(q))
    if nu > 1e-3 and nv > 1e-3:
        np.testing.assert_allclose(rot.quat_apply(q, u / nu), v / nv, atol=1e-12)


# --------------------------------------------------------------------------- batching / purity


def test_batching_leading_axes() -> None:
    shape = (2, 3, 5)
    q = random_quats(shape, seed=90)
    assert q.shape == (2, 3, 5, 4)
    p = random_quats(shape, seed=91)
    v = np.random.default_rng(92).normal(size=(*shape, 3))
    flat = q.reshape(-1, 4)
    for order in ("ZXY", "YZY"):
        e = rot.quat_to_euler(q, order)
        assert e.shape == (*shape, 3)
        np.testing.assert_array_equal(e.reshape(-1, 3), rot.quat_to_euler(flat, order))
        assert rot.euler_to_quat(e, order).shape == (*shape, 4)
        assert rot.euler_to_matrix(e, order).shape == (*shape, 3, 3)
        assert rot.matrix_to_euler(rot.quat_to_matrix(q), order).shape == (*shape, 3)
    m = rot.quat_to_matrix(q)
    assert m.shape == (*shape, 3, 3)
    np.testing.assert_array_equal(rot.matrix_to_quat(m).reshape(-1, 4),
                                  rot.matrix_to_quat(m.reshape(-1, 3, 3)))  # fmt: skip
    assert rot.quat_mul(q, p).shape == (*shape, 4)
    assert rot.quat_mul(q, p[0, 0, 0]).shape == (*shape, 4)  # broadcasting
    assert rot.quat_apply(q, v).shape == (*shape, 3)
    assert rot.quat_apply(q[:, :, :1], v).shape == (*shape, 3)
    assert rot.quat_apply(q, v[0, 0, 0]).shape == (*shape, 3)
    assert rot.quat_to_rotvec(q).shape == (*shape, 3)
    assert rot.rotvec_to_quat(v).shape == (*shape, 4)
    assert rot.quat_log(q).shape == (*shape, 3)
    assert rot.quat_exp(v).shape == (*shape, 4)
    assert rot.quat_slerp(q, p, 0.3).shape == (*shape, 4)
    assert rot.quat_slerp(q, p, np.full(shape, 0.3)).shape == (*shape, 4)
    assert rot.quat_angle(q, p).shape == shape
    assert rot.quat_between(v, v[::-1]).shape == (*shape, 4)
    assert rot.quat_normalize(q).shape == (*shape, 4)
    assert rot.quat_inv(q).shape == (*shape, 4)
    np.testing.assert_allclose(
        rot.quat_apply(q, v).reshape(-1, 3), to_scipy(q).apply(v.reshape(-1, 3)), atol=1e-13
    )


def test_inputs_not_mutated() -> None:
    q = random_quats(10, seed=93)
    q[::2] *= -1.0  # mixed hemispheres so sign-flipping code paths run
    p = random_quats(10, seed=94)
    v = np.random.default_rng(95).normal(size=(10, 3))
    m = rot.quat_to_matrix(q)
    e = rot.quat_to_euler(q, "XYZ")
    t = np.linspace(0, 1, 10)
    copies = [x.copy() for x in (q, p, v, m, e, t)]
    outs = [
        rot.quat_normalize(q), rot.quat_conj(q), rot.quat_inv(q), rot.quat_mul(q, p),
        rot.quat_apply(q, v), rot.quat_to_matrix(q), rot.matrix_to_quat(m),
        rot.euler_to_quat(e, "XYZ"), rot.quat_to_euler(q, "XYZ"), rot.euler_to_matrix(e, "XYZ"),
        rot.matrix_to_euler(m, "XYZ"), rot.quat_to_rotvec(q), rot.rotvec_to_quat(v),
        rot.quat_log(q), rot.quat_exp(v), rot.quat_slerp(q, p, t), rot.quat_angle(q, p),
        rot.quat_unroll(q), rot.quat_fix_hemisphere(q, p), rot.quat_between(v, -v),
    ]  # fmt: skip
    for orig, now in zip(copies, (q, p, v, m, e, t), strict=True):
        np.testing.assert_array_equal(orig, now)
    # Outputs are fresh arrays, never views of the inputs.
    for out in outs:
        for x in (q, p, v, m, e, t):
            assert not np.shares_memory(out, x)


def test_shape_validation() -> None:
    with pytest.raises(ValueError):
        rot.quat_mul(np.zeros(3), np.zeros(4))
    with pytest.raises(ValueError):
        rot.quat_to_euler(np.zeros((2, 3)), "XYZ")
    with pytest.raises(ValueError):
        rot.matrix_to_quat(np.zeros((3, 4)))
