"""The aligned, windowed point-cloud cost of Kovar et al. with per-pair body-part weights, and
its tiled BLAS evaluation.

For centre frames i (of clip A) and j (of clip B) the cost is::

    C(i, j) = min_{theta, t} sum_{k=-h..h} sum_p w_kp(i, j) |a_{i+k,p} - R_theta b_{j+k,p} - t|^2
    w_kp(i, j) = W_k (s_p + f_{i+k,p} + f_{j+k,p})

with ``W_k`` the quadratic window weight (:func:`window_weights`), ``s_p`` / ``f_p`` the static
and per-frame weights of the part owning point p divided by its number of points
(:mod:`mocapkit.graph.weights`), ``R_theta`` a rotation about the up axis and ``t`` a
ground-plane translation (Kovar & Gleicher's closed form). Minimising over t and theta in closed
form leaves, with ``W = sum w``, ``A = sum w a_xz``, ``B = sum w b_xz``::

    C = sum w|a|^2 + sum w|b|^2 - 2 sum w y_a y_b - (|A|^2 + |B|^2) / W - 2 sqrt(num^2 + den^2)
    den = sum w (x_a x_b + z_a z_b) - A.B / W,   num = sum w (x_a z_b - z_a x_b) - A x B / W

Every sum is a correlation of per-frame window features of the two clips; since the weight is a
sum of a row term and a column term, each is one matrix product of (rows x window.points) by
(window.points x columns). :func:`cost_tile` evaluates a whole tile that way; :func:`pair_costs`
evaluates explicit pairs (float64, vectorised over pairs); tests/graph/naive.py holds the
readable per-pair reference.

Coordinates: ``x`` and ``z`` are ground coordinates (``p . side``, ``p . forward`` of
:func:`mocapkit.features.ground_frame`), ``y`` the height. Each window is centred on the ground
position of its centre frame's pelvis (the cost is invariant to that), which keeps float32 tiles
well conditioned.
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numba
import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.features import detect_up_axis, ground_frame, pelvis_index
from mocapkit.graph.pointcloud import BodyParts, body_parts, point_cloud
from mocapkit.graph.weights import (
    contact_parts_of,
    metric_weights,
    part_masses,
    support_mask,
)

__all__ = [
    "DEFAULT_BUCKET_SECONDS",
    "DEFAULT_PER_BUCKET",
    "DEFAULT_WINDOW",
    "TASK_SIDE",
    "CostDatabase",
    "MinimaReducer",
    "TileMinima",
    "TilePlan",
    "TileTask",
    "build_database",
    "cost_matrix",
    "cost_tile",
    "merge_tile_minima",
    "pair_alignment",
    "pair_costs",
    "plan_tiles",
    "tile_runner",
    "tile_task_minima",
    "tiled_local_minima",
    "window_weights",
]


#: Default comparison window (seconds): about a third of a second, as in Kovar et al.
DEFAULT_WINDOW = 1.0 / 3.0


def window_weights(half: int) -> np.ndarray:
    """(2 half + 1,) quadratic window weights ``1 - (k / (half + 1))^2``, largest at k = 0,
    normalised to sum 1."""
    if half < 0:
        raise ValueError(f"window half-width must be >= 0, got {half}")
    k = np.arange(-half, half + 1, dtype=np.float64)
    w = 1.0 - (k / (half + 1)) ** 2
    return w / w.sum()


@dataclass(eq=False)
class CostDatabase:
    """All clips' point clouds in one buffer (one array per quantity, clip ranges by offsets).

    Attributes:
        coords: (N, P, 3) float64 points as (x, y, z) = (side, up, forward) ground coordinates.
        centre: (N, 2) ground position (x, z) of each frame's pelvis.
        starts: (C + 1,) first frame of each clip in the buffer, then N.
        point_static: (P,) static weight of each point (part weight / points of the part).
        point_frame: (N, P) per-frame weight of each point.
        support: (Ps,) indices of the points whose per-frame weight can be non-zero.
        half: window half-width h (window = 2h + 1 frames).
        window: (2h + 1,) window weights.
        fps: frame rate (all clips share it).
        metric: the metric name.
        parts: the body parts.
        up: the up axis.
        foot_points: (S,) the point of each side's ankle (S <= 2, the feet of
            :func:`mocapkit.features.find_feet`, left first), the joint the foot skate measures.
        foot_contacts: (N, S) bool, that foot planted (:func:`mocapkit.features.foot_contacts`
            by side, or the given per-part contacts of its joints).
    """

    coords: np.ndarray
    centre: np.ndarray
    starts: np.ndarray
    point_static: np.ndarray
    point_frame: np.ndarray
    support: np.ndarray
    half: int
    window: np.ndarray
    fps: float
    metric: str
    parts: BodyParts
    up: str
    foot_points: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    foot_contacts: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), dtype=bool))

    @property
    def num_frames(self) -> int:
        return int(self.coords.shape[0])

    @property
    def num_clips(self) -> int:
        return len(self.starts) - 1

    def clip_of(self, frames: np.ndarray) -> np.ndarray:
        """Clip index of global frame indices."""
        return np.searchsorted(self.starts, np.asarray(frames), side="right") - 1

    def valid_centres(self) -> np.ndarray:
        """(N,) bool: frames whose whole window lies inside their clip."""
        ok = np.zeros(self.num_frames, dtype=bool)
        for a, b in zip(self.starts[:-1], self.starts[1:], strict=True):
            if b - a > 2 * self.half:
                ok[a + self.half : b - self.half] = True
        return ok

    def flops_per_pair(self) -> int:
        """Floating-point operations of the matrix products per evaluated pair."""
        K = len(self.window)
        P = self.coords.shape[1]
        Ps = len(self.support)
        inner = 3 * Ps + 3 * P + (P + Ps) + 2 * (2 * P + 2 * Ps)
        return 2 * K * inner


def build_database(
    motions: Sequence[Motion],
    metric: str = "dynamics",
    window: float = DEFAULT_WINDOW,
    *,
    masses: dict[str, float] | None = None,
    contacts: Sequence[np.ndarray] | None = None,
    up: str | None = None,
) -> CostDatabase:
    """Point clouds, weights and window of a set of clips (same skeleton and frame rate).

    Args:
        motions: the clips.
        metric: "dynamics", "uniform" or "torso".
        window: window length in seconds (rounded to an odd number of frames, at least 1).
        masses: joint name -> kg overrides of the de Leva masses.
        contacts: optional (F, B) bool per-part contacts per clip (default: foot contacts).
        up: the up axis (detected on the first clip when None).
    """
    if not motions:
        raise ValueError("need at least one clip")
    first = motions[0]
    for m in motions[1:]:
        if m.num_joints != first.num_joints or m.skeleton.names != first.skeleton.names:
            raise ValueError("all clips must share one skeleton (same joints)")
        if not np.isclose(m.frame_time, first.frame_time, rtol=1e-6, atol=0):
            raise ValueError(
                f"all clips must share one frame rate ({first.fps:g} vs {m.fps:g} fps); "
                "resample them first (mocapkit.features.resample)"
            )
    up = up or detect_up_axis(first)
    parts = body_parts(first.skeleton)
    mass = part_masses(parts, overrides=masses)
    half = max(0, round(window * first.fps / 2.0))
    side, u, fwd = ground_frame(up)
    basis = np.stack([side, u, fwd], axis=1)  # (3, 3): columns x, y, z
    pelvis = pelvis_index(first.skeleton)
    counts = parts.points_per_part().astype(np.float64)
    coords, centres, frames, sides = [], [], [], []
    foot_joints: set[int] = set()
    ankles = _side_ankles(first, parts, up)
    for c, m in enumerate(motions):
        if m.num_frames == 0:
            raise ValueError(f"clip {c} has no frames")
        m.check_finite(f"clip {c}")
        pc = point_cloud(m, parts) @ basis
        coords.append(pc)
        pel = (
            pc[:, parts.point_source.tolist().index(pelvis)]
            if pelvis in parts.point_source
            else pc[:, 0]
        )
        centres.append(pel[:, [0, 2]])
        if contacts is not None:
            cp = np.asarray(contacts[c], dtype=bool)
            side = np.stack(
                [cp[:, [int(parts.point_part[p]) for p in pts]].any(axis=1) for _, pts in ankles],
                axis=1,
            ).reshape(m.num_frames, len(ankles))
        else:
            from mocapkit.features import find_feet, foot_contacts

            foot_joints.update(j for _, j in find_feet(m.skeleton, m, up))
            fc = foot_contacts(m, up=up)
            cp = contact_parts_of(parts, fc, m.num_frames)
            side = fc.by_side()[:, : len(ankles)]
        sides.append(side)
        pw = metric_weights(metric, parts, cp, mass)
        frames.append(pw.frame)
        static = pw.static
    if contacts is not None:
        foot_joints.update(
            int(parts.joints[b])
            for cp in contacts
            for b in np.flatnonzero(np.asarray(cp).any(axis=0))
        )
    sup_parts = support_mask(metric, parts, sorted(foot_joints))
    frame_w = np.concatenate(frames)
    sup_parts |= (frame_w != 0).any(axis=0)
    point_static = static[parts.point_part] / counts[parts.point_part]
    point_frame = frame_w[:, parts.point_part] / counts[parts.point_part][None, :]
    support = np.flatnonzero(sup_parts[parts.point_part])
    starts = np.concatenate([[0], np.cumsum([m.num_frames for m in motions])]).astype(np.int64)
    return CostDatabase(
        np.ascontiguousarray(np.concatenate(coords)),
        np.ascontiguousarray(np.concatenate(centres)),
        starts,
        point_static,
        point_frame,
        support,
        int(half),
        window_weights(int(half)),
        float(first.fps),
        metric,
        parts,
        up,
        np.array([pts[0] for _, pts in ankles], dtype=np.int64),
        np.ascontiguousarray(np.concatenate(sides), dtype=bool),
    )


def _side_ankles(motion: Motion, parts: BodyParts, up: str) -> list[tuple[str, list[int]]]:
    """Per foot side (at most two, in :func:`~mocapkit.features.find_feet` order): the points
    of its joints, the ankle's first (the joint :mod:`mocapkit.graph.skate` measures)."""
    from mocapkit.features import find_feet

    src = parts.point_source.tolist()
    by: dict[str, list[int]] = {}
    for side, j in find_feet(motion.skeleton, motion, up):
        if j in src:
            by.setdefault(side or f"s{len(by)}", []).append(src.index(j))
    return list(by.items())[:2]


# ============================================================================================
# explicit pairs (float64)


@numba.njit(cache=True, nogil=True)
def _pair_sums_kernel(coords, centre, static, frame, window, half, ii, jj, out):  # pragma: no cover
    P = coords.shape[1]
    for n in range(ii.shape[0]):
        i = ii[n]
        j = jj[n]
        cxa = centre[i, 0]
        cza = centre[i, 1]
        cxb = centre[j, 0]
        czb = centre[j, 1]
        sw = ax = az = bx = bz = saa = sbb = syy = sdot = scrs = 0.0
        for k in range(-half, half + 1):
            wk = window[k + half]
            fa = i + k
            fb = j + k
            for p in range(P):
                w = wk * (static[p] + frame[fa, p] + frame[fb, p])
                xa = coords[fa, p, 0] - cxa
                ya = coords[fa, p, 1]
                za = coords[fa, p, 2] - cza
                xb = coords[fb, p, 0] - cxb
                yb = coords[fb, p, 1]
                zb = coords[fb, p, 2] - czb
                sw += w
                ax += w * xa
                az += w * za
                bx += w * xb
                bz += w * zb
                saa += w * (xa * xa + ya * ya + za * za)
                sbb += w * (xb * xb + yb * yb + zb * zb)
                syy += w * ya * yb
                sdot += w * (xa * xb + za * zb)
                scrs += w * (xa * zb - za * xb)
        out[n, 0] = sw
        out[n, 1] = ax
        out[n, 2] = az
        out[n, 3] = bx
        out[n, 4] = bz
        out[n, 5] = saa
        out[n, 6] = sbb
        out[n, 7] = syy
        out[n, 8] = sdot
        out[n, 9] = scrs


def _window_sums(db: CostDatabase, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, ...]:
    """The ten weighted sums for explicit pairs (compiled loop, float64)."""
    out = np.empty((len(i), 10))
    _pair_sums_kernel(
        db.coords, db.centre, db.point_static, db.point_frame, db.window, db.half,
        np.ascontiguousarray(i, dtype=np.int64), np.ascontiguousarray(j, dtype=np.int64), out,
    )  # fmt: skip
    return tuple(out[:, k] for k in range(10))


def _finish(sums: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """cost, num, den from the sums (works on arrays of any shape)."""
    Sw, Ax, Az, Bx, Bz, Saa, Sbb, Syy, Sdot, Scrs = sums
    inv = 1.0 / Sw
    num = Scrs - (Ax * Bz - Az * Bx) * inv
    den = Sdot - (Ax * Bx + Az * Bz) * inv
    cost = Saa + Sbb - 2.0 * Syy - (Ax * Ax + Az * Az + Bx * Bx + Bz * Bz) * inv
    cost -= 2.0 * np.sqrt(num * num + den * den)
    return np.maximum(cost, 0.0), num, den


def _check_centres(db: CostDatabase, idx: np.ndarray, name: str) -> np.ndarray:
    idx = np.asarray(idx, dtype=np.int64).reshape(-1)
    ok = db.valid_centres()
    if len(idx) and (idx.min() < 0 or idx.max() >= db.num_frames or not ok[idx].all()):
        bad = idx[(idx < 0) | (idx >= db.num_frames)]
        if len(bad) == 0:
            bad = idx[~ok[idx]]
        raise ValueError(
            f"{name}: frame {int(bad[0])} is not a valid window centre (the window of "
            f"{2 * db.half + 1} frames must lie inside one clip)"
        )
    return idx


def pair_costs(db: CostDatabase, i: np.ndarray, j: np.ndarray, chunk: int = 1 << 16) -> np.ndarray:
    """Exact aligned window costs (float64) of the pairs ``(i[n], j[n])`` of global frames."""
    i = _check_centres(db, i, "i")
    j = _check_centres(db, j, "j")
    if i.shape != j.shape:
        raise ValueError("i and j must have the same length")
    out = np.empty(len(i))
    for s in range(0, len(i), chunk):
        out[s : s + chunk] = _finish(_window_sums(db, i[s : s + chunk], j[s : s + chunk]))[0]
    return out


def pair_alignment(db: CostDatabase, i: int, j: int) -> tuple[float, np.ndarray]:
    """Optimal ground transform taking window j onto window i: ``(theta, t)`` with
    ``a ~ R_theta b + t`` in ground coordinates (x, z) of the original (uncentred) clouds,
    ``R_theta (x, z) = (x cos + z sin, -x sin + z cos)``."""
    i_arr = _check_centres(db, np.array([i]), "i")
    j_arr = _check_centres(db, np.array([j]), "j")
    sums = _window_sums(db, i_arr, j_arr)
    _, num, den = _finish(sums)
    theta = float(np.arctan2(num[0], den[0]))
    c, s = np.cos(theta), np.sin(theta)
    Sw, Ax, Az, Bx, Bz = (float(v[0]) for v in sums[:5])
    t = np.array([(Ax - c * Bx - s * Bz) / Sw, (Az + s * Bx - c * Bz) / Sw])
    gb = db.centre[j]
    t = t + db.centre[i] - np.array([c * gb[0] + s * gb[1], -s * gb[0] + c * gb[1]])
    return theta, t


# ============================================================================================
# tiles (BLAS)


@dataclass(eq=False)
class _Side:
    """Window features of a set of centre frames (rows or columns of a tile)."""

    x: np.ndarray  # (n, K*P)
    y: np.ndarray
    z: np.ndarray
    sq: np.ndarray  # |p|^2
    u: np.ndarray  # W_k (s_p + f_{i+k,p})
    f: np.ndarray  # W_k f_{i+k,p} on support points (n, K*Ps)
    xs: np.ndarray  # x on support points
    ys: np.ndarray
    zs: np.ndarray
    sqs: np.ndarray


def _side(db: CostDatabase, idx: np.ndarray, dtype: type) -> _Side:
    k = np.arange(-db.half, db.half + 1)
    win = np.clip(idx[:, None] + k, 0, db.num_frames - 1)  # invalid centres are masked later
    c = db.coords[win]  # (n, K, P, 3)
    x = c[..., 0] - db.centre[idx, 0][:, None, None]
    z = c[..., 2] - db.centre[idx, 1][:, None, None]
    y = c[..., 1]
    sq = x * x + y * y + z * z
    Wk = db.window[None, :, None]
    u = Wk * (db.point_static + db.point_frame[win])
    s = db.support
    f = Wk * db.point_frame[win][..., s]
    n = len(idx)

    def flat(v: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(v.reshape(n, -1), dtype=dtype)

    return _Side(
        flat(x), flat(y), flat(z), flat(sq), flat(u), flat(f),
        flat(x[..., s]), flat(y[..., s]), flat(z[..., s]), flat(sq[..., s]),
    )  # fmt: skip


@numba.njit(cache=True, nogil=True, fastmath=True, error_model="numpy", parallel=True)
def _finish_kernel(
    prod, pb, syy, pd, rw, rx, rz, raa, cw, cx, cz, cbb, has_s, out
):  # pragma: no cover
    """Cost of every cell from the products (one pass, float64 arithmetic): ``prod`` (n, 3m) =
    [Bx | Bz | Sbb] row parts, ``pb`` (3n, m) = [Ax; Az; Saa] column parts, ``syy`` (n, m),
    ``pd`` (n, 2m) = [Sdot | Scrs]; the r*/c* vectors are the row / column scalar terms."""
    n, m = out.shape
    for i in numba.prange(n):
        for j in range(m):
            W = rw[i] + cw[j]
            ax = rx[i]
            az = rz[i]
            saa = raa[i]
            if has_s:
                ax += pb[i, j]
                az += pb[n + i, j]
                saa += pb[2 * n + i, j]
            bx = prod[i, j] + cx[j]
            bz = prod[i, m + j] + cz[j]
            sbb = prod[i, 2 * m + j] + cbb[j]
            inv = 1.0 / W
            num = pd[i, m + j] - (ax * bz - az * bx) * inv
            den = pd[i, j] - (ax * bx + az * bz) * inv
            c = saa + sbb - 2.0 * syy[i, j] - (ax * ax + az * az + bx * bx + bz * bz) * inv
            c -= 2.0 * np.sqrt(num * num + den * den)
            out[i, j] = c if c > 0.0 else 0.0


@dataclass(eq=False)
class _RowPack:
    """Row-side matrices of a block, ready for the products of :func:`_tile_cost`."""

    u: np.ndarray  # (n, KP)
    ab: np.ndarray | None  # (3n, KPs): [W x; W z; W |a|^2] on support points
    y: np.ndarray  # (n, KP [+ KPs])
    d: np.ndarray  # (n, 2KP [+ 2KPs])
    rw: np.ndarray
    rx: np.ndarray
    rz: np.ndarray
    raa: np.ndarray


@dataclass(eq=False)
class _ColPack:
    """Column-side matrices of a block (transposed, so the products are plain ``A @ B``)."""

    b3: np.ndarray  # (KP, 3m): [x | z | |b|^2]
    beta: np.ndarray | None  # (KPs, m)
    y: np.ndarray  # (KP [+ KPs], m)
    d: np.ndarray  # (2KP [+ 2KPs], 2m): [dot | cross]
    cw: np.ndarray
    cx: np.ndarray
    cz: np.ndarray
    cbb: np.ndarray


def _row_pack(r: _Side, Wk_s: np.ndarray) -> _RowPack:
    f64 = np.float64
    ux, uz = r.u * r.x, r.u * r.z
    has_s = r.f.shape[1] > 0
    if has_s:
        ab = np.concatenate([Wk_s * r.xs, Wk_s * r.zs, Wk_s * r.sqs], axis=0)
        y = np.concatenate([r.u * r.y, Wk_s * r.ys], axis=1)
        d = np.concatenate([ux, uz, Wk_s * r.xs, Wk_s * r.zs], axis=1)
    else:
        ab = None
        y = r.u * r.y
        d = np.concatenate([ux, uz], axis=1)
    return _RowPack(
        r.u, ab, y, d,
        r.u.sum(1, dtype=f64), ux.sum(1, dtype=f64), uz.sum(1, dtype=f64),
        (r.u * r.sq).sum(1, dtype=f64),
    )  # fmt: skip


def _col_pack(c: _Side, Wk_s: np.ndarray) -> _ColPack:
    f64 = np.float64
    has_s = c.f.shape[1] > 0
    b3 = np.ascontiguousarray(np.concatenate([c.x, c.z, c.sq], axis=0).T)
    if has_s:
        beta = c.f / Wk_s  # beta_{j+k,p} (window weight divided back out)
        y = np.concatenate([c.y, beta * c.ys], axis=1)
        d = np.concatenate(
            [
                np.concatenate([c.x, c.z, beta * c.xs, beta * c.zs], axis=1),
                np.concatenate([c.z, -c.x, beta * c.zs, -beta * c.xs], axis=1),
            ],
            axis=0,
        )
        beta = np.ascontiguousarray(beta.T)
    else:
        beta = None
        y = c.y
        d = np.concatenate(
            [np.concatenate([c.x, c.z], axis=1), np.concatenate([c.z, -c.x], axis=1)], axis=0
        )
    return _ColPack(
        b3, beta, np.ascontiguousarray(y.T), np.ascontiguousarray(d.T),
        c.f.sum(1, dtype=f64), (c.f * c.xs).sum(1, dtype=f64), (c.f * c.zs).sum(1, dtype=f64),
        (c.f * c.sqs).sum(1, dtype=f64),
    )  # fmt: skip


def _tile_cost_packed(r: _RowPack, c: _ColPack, bufs: dict | None = None) -> np.ndarray:
    """Costs (n, m): four matrix products finished by one compiled pass. With ``bufs`` (a
    dict kept across tiles) the products and the result reuse its arrays (no fresh pages per
    tile; the result is overwritten by the next call)."""
    n, m = r.u.shape[0], c.b3.shape[1] // 3
    dt = np.result_type(r.u, c.b3)

    def buf(name: str, shape: tuple[int, int]) -> np.ndarray | None:
        if bufs is None:
            return None
        a = bufs.get(name)
        if a is None or a.shape != shape or a.dtype != dt:
            a = bufs[name] = np.empty(shape, dtype=dt)
        return a

    prod = np.matmul(r.u, c.b3, out=buf("prod", (n, 3 * m)))
    has_s = r.ab is not None and c.beta is not None
    pb = (
        np.matmul(r.ab, c.beta, out=buf("pb", (r.ab.shape[0], m)))
        if has_s
        else np.zeros((1, 1), dtype=prod.dtype)
    )
    syy = np.matmul(r.y, c.y, out=buf("syy", (n, m)))
    pd = np.matmul(r.d, c.d, out=buf("pd", (n, 2 * m)))
    out = buf("out", (n, m))
    if out is None:
        out = np.empty((n, m), dtype=prod.dtype)
    _finish_kernel(prod, pb, syy, pd, r.rw, r.rx, r.rz, r.raa, c.cw, c.cx, c.cz, c.cbb, has_s, out)
    return out


def _tile_cost(r: _Side, c: _Side, Wk_s: np.ndarray) -> np.ndarray:
    """Costs (n, m) of every (row, column) pair: the sums of the module docstring as four
    matrix products (:func:`_tile_cost_packed`)."""
    return _tile_cost_packed(_row_pack(r, Wk_s), _col_pack(c, Wk_s))


def _support_window(db: CostDatabase, dtype: type) -> np.ndarray:
    Ps = len(db.support)
    return np.ascontiguousarray(np.repeat(db.window, Ps)[None, :], dtype=dtype)


def _tile(db: CostDatabase, r: _Side, c: _Side, dtype: type) -> np.ndarray:
    return _tile_cost(r, c, _support_window(db, dtype))


def cost_tile(
    db: CostDatabase, rows: np.ndarray, cols: np.ndarray, dtype: type = np.float64
) -> np.ndarray:
    """Costs (len(rows), len(cols)) of every pair of the given centre frames, by matrix
    products in ``dtype`` (float64 or float32). Frames that are not valid centres give inf."""
    if dtype not in (np.float64, np.float32):
        raise ValueError("dtype must be numpy.float64 or numpy.float32")
    rows = np.asarray(rows, dtype=np.int64).reshape(-1)
    cols = np.asarray(cols, dtype=np.int64).reshape(-1)
    for name, idx in (("rows", rows), ("cols", cols)):
        if len(idx) and (idx.min() < 0 or idx.max() >= db.num_frames):
            raise ValueError(f"{name} must index frames 0..{db.num_frames - 1}")
    ok = db.valid_centres()
    out = _tile(db, _side(db, rows, dtype), _side(db, cols, dtype), dtype)
    out = np.array(out, dtype=np.float64)
    out[~ok[rows], :] = np.inf
    out[:, ~ok[cols]] = np.inf
    return out


def cost_matrix(db: CostDatabase, tile: int = 1024) -> np.ndarray:
    """The full (N, N) cost matrix (float64; for small databases and plots). inf where a frame
    is not a valid window centre."""
    N = db.num_frames
    if N > 20000:
        raise ValueError(f"cost_matrix holds N x N values; {N} frames is too many (use tiles)")
    out = np.empty((N, N))
    idx = np.arange(N)
    for a in range(0, N, tile):
        for b in range(a, N, tile):
            t = cost_tile(db, idx[a : a + tile], idx[b : b + tile])
            out[a : a + tile, b : b + tile] = t
            out[b : b + tile, a : a + tile] = t.T
    return out


# ============================================================================================
# tiled local minima


def candidate_grid(db: CostDatabase, stride: int = 1) -> np.ndarray:
    """Global centre frames on a stride grid per clip, with -1 separators before, between and
    after clips (so grid neighbours never cross a clip boundary)."""
    if stride < 1:
        raise ValueError(f"stride must be >= 1, got {stride}")
    ok = db.valid_centres()
    out: list[np.ndarray] = [np.array([-1])]
    for a, b in zip(db.starts[:-1], db.starts[1:], strict=True):
        v = np.flatnonzero(ok[a:b]) + a
        if len(v):
            out += [v[::stride], np.array([-1])]
    return np.concatenate(out).astype(np.int64)


@numba.njit(cache=True, nogil=True, parallel=True)
def _local_minima_kernel(t, out):  # pragma: no cover - compiled
    n, m = t.shape
    for i in numba.prange(1, n - 1):
        for j in range(1, m - 1):
            v = t[i, j]
            # most cells lose to a row neighbour: test those first and stop at the first loss
            ok = (
                v < np.inf
                and v <= t[i, j - 1]
                and v <= t[i, j + 1]
                and v <= t[i - 1, j]
                and v <= t[i + 1, j]
                and v <= t[i - 1, j - 1]
                and v <= t[i - 1, j + 1]
                and v <= t[i + 1, j - 1]
                and v <= t[i + 1, j + 1]
            )
            out[i - 1, j - 1] = ok


def _local_minima(t: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """(n-2, m-2) bool: interior cells <= their 8 neighbours and finite (compiled)."""
    shape = (t.shape[0] - 2, t.shape[1] - 2)
    if out is None or out.shape != shape:
        out = np.empty(shape, dtype=np.bool_)
    _local_minima_kernel(t, out)
    return out


@dataclass(frozen=True, eq=False)
class MinimaResult:
    """Local minima of the cost over the grid (each unordered pair once, i < j).

    Attributes:
        i, j: global centre frames; cost: their costs (in the tile dtype); stride; the number of
        evaluated cells (``pairs``), flops of the matrix products and seconds spent.
    """

    i: np.ndarray
    j: np.ndarray
    cost: np.ndarray
    stride: int
    pairs: int
    flops: float
    seconds: float
    dtype: str = "float64"


#: Default length (seconds) of the clip pieces that each keep their own best matches.
DEFAULT_BUCKET_SECONDS = 0.5
#: Default number of partner clips each piece keeps (its cheapest minimum with each).
DEFAULT_PER_BUCKET = 16


@numba.njit(cache=True, nogil=True)
def _bucket_insert(bucket, clip, fi, fj, cv, bc, bp, bi, bj, count):  # pragma: no cover
    """Offer each minimum (fi, fj, cv) to the buckets of both its frames: a bucket keeps its
    cheapest minimum with each partner clip, for its ``k`` cheapest partners (in place)."""
    k = bc.shape[1]
    for n in range(fi.shape[0]):
        for side in range(2):
            a = fi[n] if side == 0 else fj[n]
            o = fj[n] if side == 0 else fi[n]
            b = bucket[a]
            p = clip[o]
            c = cv[n]
            m = count[b]
            slot = -1
            worst = -1
            for s in range(m):
                if bp[b, s] == p:
                    slot = s
                    break
                if worst < 0 or bc[b, s] > bc[b, worst]:
                    worst = s
            if slot >= 0:
                if c < bc[b, slot]:
                    bc[b, slot] = c
                    bi[b, slot] = fi[n]
                    bj[b, slot] = fj[n]
                continue
            if m < k:
                slot = m
                count[b] = m + 1
            elif c < bc[b, worst]:
                slot = worst
            else:
                continue
            bc[b, slot] = c
            bp[b, slot] = p
            bi[b, slot] = fi[n]
            bj[b, slot] = fj[n]


class MinimaReducer:
    """The reduction behind :func:`tiled_local_minima`: tiles' local minima in, candidates out.

    Two parts, both exact under any order of tiles and mergeable (:meth:`merge`), so that tiles
    can be reduced on separate workers and the states combined:

    * the ``max_candidates`` cheapest minima of the whole library (as in Kovar et al.);
    * per *bucket* (each clip cut into pieces of ``bucket_frames``), the cheapest minimum with
      each partner clip, for its ``per_bucket`` cheapest partners. A motion's own cost scale
      (standing still is cheap, a run dear) would otherwise leave the global list to the
      cheapest motions, and most clips, their ends above all, without candidates.
    """

    def __init__(
        self,
        starts: np.ndarray,
        bucket_frames: int,
        per_bucket: int = DEFAULT_PER_BUCKET,
        max_candidates: int = 200_000,
    ):
        starts = np.asarray(starts, dtype=np.int64)
        N = int(starts[-1])
        bf = max(1, int(bucket_frames))
        lens = np.diff(starts)
        nb = -(-lens // bf)
        first = np.concatenate([[0], np.cumsum(nb)])
        clip = np.repeat(np.arange(len(lens)), lens)
        self.clip = clip.astype(np.int64)
        self.bucket = (first[clip] + (np.arange(N) - starts[clip]) // bf).astype(np.int64)
        B = int(first[-1])
        k = max(0, int(per_bucket))
        self.best_c = np.full((B, max(k, 1)), np.inf)
        self.best_p = np.full((B, max(k, 1)), -1, dtype=np.int64)
        self.best_i = np.zeros((B, max(k, 1)), dtype=np.int64)
        self.best_j = np.zeros((B, max(k, 1)), dtype=np.int64)
        self.count = np.zeros(B, dtype=np.int64)
        self.per_bucket = k
        self.max_candidates = int(max_candidates)
        self._i: list[np.ndarray] = []
        self._j: list[np.ndarray] = []
        self._c: list[np.ndarray] = []
        self._kept = 0

    def add(self, i: np.ndarray, j: np.ndarray, cost: np.ndarray, to_global: bool = True) -> None:
        """Offer minima (global frames, i < j, each pair once, and their costs)."""
        i = np.ascontiguousarray(i, dtype=np.int64)
        j = np.ascontiguousarray(j, dtype=np.int64)
        cost = np.ascontiguousarray(cost, dtype=np.float64)
        if self.per_bucket and len(cost):
            _bucket_insert(
                self.bucket, self.clip, i, j, cost,
                self.best_c, self.best_p, self.best_i, self.best_j, self.count,
            )  # fmt: skip
        if not to_global:
            return
        self._i.append(i)
        self._j.append(j)
        self._c.append(cost)
        self._kept += len(cost)
        if self._kept > 2 * self.max_candidates:
            self._compact()

    def _compact(self) -> None:
        if not self._i:
            return
        ci, cj, cc = (np.concatenate(v) for v in (self._i, self._j, self._c))
        if len(cc) > self.max_candidates:
            part = np.argpartition(cc, self.max_candidates)[: self.max_candidates]
            ci, cj, cc = ci[part], cj[part], cc[part]
        self._i, self._j, self._c = [ci], [cj], [cc]
        self._kept = len(cc)

    def merge(self, other: MinimaReducer) -> MinimaReducer:
        """Fold another reducer's state (same library and settings) into this one."""
        for name in ("bucket", "clip"):
            if not np.array_equal(getattr(self, name), getattr(other, name)):
                raise ValueError("reducers of different libraries or bucket sizes")
        sel = other.best_p >= 0
        self.add(other.best_i[sel], other.best_j[sel], other.best_c[sel], to_global=False)
        for v in zip(other._i, other._j, other._c, strict=True):
            self.add(*v)
        return self

    def result(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The union of both parts, each pair once, sorted by cost (then i, j)."""
        self._compact()
        sel = self.best_p >= 0
        ci = np.concatenate([self._i[0] if self._i else np.zeros(0, np.int64), self.best_i[sel]])
        cj = np.concatenate([self._j[0] if self._j else np.zeros(0, np.int64), self.best_j[sel]])
        cc = np.concatenate([self._c[0] if self._c else np.zeros(0), self.best_c[sel]])
        order = np.lexsort((cj, ci, cc))
        ci, cj, cc = ci[order], cj[order], cc[order]
        key = ci * (int(self.clip.shape[0]) + 1) + cj
        _, first = np.unique(key, return_index=True)
        first = np.sort(first)
        return ci[first].astype(np.int64), cj[first].astype(np.int64), cc[first]


#: A task of :func:`tiled_local_minima` is a square of TASK_SIDE x TASK_SIDE tiles (fewer on the
#: diagonal): its row and column features are built once for all its tiles (building them costs
#: about as much as the products of a tile or two). A fixed size, not a function of the number
#: of workers, so that the tasks, each task's reduction and the merge order (task order) are the
#: same wherever and on however many workers the tiles run.
TASK_SIDE = 8


@dataclass(frozen=True)
class TileTask:
    """One task of the tiled cost: a square block of tiles ``(row start, column start)``
    (positions in the plan's grid; upper triangle, row-major order within the block)."""

    index: int
    tiles: tuple[tuple[int, int], ...]


@dataclass(frozen=True, eq=False)
class TilePlan:
    """How :func:`tiled_local_minima` cuts the upper triangle of the grid's cost matrix into
    tiles and tasks, and the settings of the reduction; it depends on the library and the
    settings only."""

    grid: np.ndarray
    stride: int
    tile: int
    dtype: str
    gap: int
    bucket_frames: int
    per_bucket: int
    max_candidates: int
    tasks: tuple[TileTask, ...]
    task_side: int = TASK_SIDE

    @property
    def num_tiles(self) -> int:
        return sum(len(t.tiles) for t in self.tasks)

    def pairs(self) -> int:
        """Cells evaluated (halo included), over every tile."""
        G = len(self.grid)
        n = 0
        for t in self.tasks:
            for ra, ca in t.tiles:
                n += (min(ra + self.tile, G - 1) - ra + 2) * (min(ca + self.tile, G - 1) - ca + 2)
        return n

    def memory_bytes(self, db: CostDatabase) -> int:
        """An upper estimate of the memory one process needs to run a task (bytes): the
        database (every worker holds a copy; O(frames)), one tile's window features (rows and
        columns, with their float64 intermediates), one tile's products and its minima mask,
        and the task's reducer. Independent of the number of tiles: no process holds N x N."""
        item = np.dtype(self.dtype).itemsize
        K = len(db.window)
        P = db.coords.shape[1]
        n = self.tile + 2
        # a task keeps the packed features of its rows and columns (up to TASK_SIDE each)
        side = n * K * P * (11 * 8 + 20 * item) * max(1, self.task_side)
        tile = n * n * (8 * item + 1 + 8)
        buckets = -(-db.num_frames // max(1, self.bucket_frames)) + db.num_clips
        reducer = buckets * max(1, self.per_bucket) * 32 + db.num_frames * 16
        reducer += 2 * self.max_candidates * 24
        return int(_database_bytes(db) + 2 * side + tile + reducer + len(self.grid) * 32)


def _database_bytes(db: CostDatabase) -> int:
    arrays = (db.coords, db.centre, db.point_frame, db.point_static, db.starts, db.support,
              db.foot_contacts)  # fmt: skip
    return int(sum(a.nbytes for a in arrays))


def plan_tiles(
    db: CostDatabase,
    stride: int | None = 1,
    tile: int = 1024,
    dtype: type | None = np.float32,
    min_gap: int | None = None,
    max_candidates: int = 200_000,
    bucket_seconds: float = DEFAULT_BUCKET_SECONDS,
    per_bucket: int = DEFAULT_PER_BUCKET,
    task_side: int = TASK_SIDE,
) -> TilePlan:
    """The tiles and tasks of :func:`tiled_local_minima` (see its arguments); ``stride`` and
    ``dtype`` None: :func:`mocapkit.graph.build_graph`'s defaults. Tasks are squares of
    ``task_side`` x ``task_side`` tiles of the upper triangle, in row-major order of squares."""
    if stride is None:
        from mocapkit.graph.graph import default_stride

        stride = default_stride(db.num_frames)
    if dtype is None:
        dtype = np.float64 if db.num_frames <= 20000 else np.float32
    if tile < 8:
        raise ValueError("tile must be >= 8")
    if task_side < 1:
        raise ValueError(f"task_side must be >= 1, got {task_side}")
    if np.dtype(dtype) not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise ValueError("dtype must be numpy.float64 or numpy.float32")
    grid = candidate_grid(db, stride)
    G = len(grid)
    starts = list(range(1, G - 1, tile))
    blocks = [starts[a : a + task_side] for a in range(0, len(starts), task_side)]
    squares = [
        tuple((ra, ca) for ra in rows for ca in cols if ca >= ra)
        for r, rows in enumerate(blocks)
        for cols in blocks[r:]
    ]
    tasks = tuple(TileTask(k, sq) for k, sq in enumerate(squares))
    return TilePlan(
        grid,
        int(stride),
        int(tile),
        np.dtype(dtype).name,
        (2 * db.half + 1) if min_gap is None else int(min_gap),
        max(1, round(bucket_seconds * db.fps)),
        int(per_bucket),
        int(max_candidates),
        tasks,
        int(task_side),
    )


@dataclass(frozen=True, eq=False)
class TileMinima:
    """What one task returns: its tiles' local minima, reduced by its own
    :class:`MinimaReducer` (the global part ``i, j, cost`` and the per-bucket part ``bi, bj,
    bc``), the cells it evaluated and its seconds."""

    index: int
    i: np.ndarray
    j: np.ndarray
    cost: np.ndarray
    bi: np.ndarray
    bj: np.ndarray
    bc: np.ndarray
    pairs: int
    seconds: float


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """BLAS on one thread inside the block: a multi-threaded BLAS may sum a tile's products in
    another order (last-bit differences that move ties between local minima), so every tile is
    computed on one thread wherever it runs; parallelism comes from running tasks side by
    side."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def tile_task_minima(shared: tuple[CostDatabase, TilePlan], task: TileTask) -> TileMinima:
    """Run one task of a :class:`TilePlan` (``shared`` = the database and the plan, sent once to
    each worker): every tile's cost (BLAS on one thread), its local minima, reduced."""
    with one_blas_thread():
        return _tile_task_minima(shared, task)


def _tile_task_minima(shared: tuple[CostDatabase, TilePlan], task: TileTask) -> TileMinima:
    import time

    db, plan = shared
    t0 = time.perf_counter()
    dtype = np.dtype(plan.dtype).type
    grid = plan.grid
    G = len(grid)
    clip = db.clip_of(np.maximum(grid, 0))
    idx = np.maximum(grid, 0)
    sep = grid < 0
    Wk_s = _support_window(db, dtype)
    reducer = MinimaReducer(db.starts, plan.bucket_frames, plan.per_bucket, plan.max_candidates)
    bufs: dict[str, np.ndarray] = {}
    mins_buf: np.ndarray | None = None
    row_at = -1
    rpack = None
    cpacks: dict[int, _ColPack] = {}  # the square's columns, each built once
    pairs = 0
    for ra, ca in task.tiles:
        rb = min(ra + plan.tile, G - 1)
        rows = np.arange(ra - 1, rb + 1)
        if ra != row_at:
            rpack = _row_pack(_side(db, idx[rows], dtype), Wk_s)
            row_at = ra
        cb = min(ca + plan.tile, G - 1)
        cols = np.arange(ca - 1, cb + 1)
        if ca not in cpacks:
            cpacks[ca] = _col_pack(_side(db, idx[cols], dtype), Wk_s)
        t = _tile_cost_packed(rpack, cpacks[ca], bufs)
        t[sep[rows], :] = np.inf
        t[:, sep[cols]] = np.inf
        pairs += t.size
        mins = mins_buf = _local_minima(t, mins_buf)
        flat = np.flatnonzero(mins)
        mi, mj = np.divmod(flat, mins.shape[1])
        gi, gj = rows[mi + 1], cols[mj + 1]
        sel = gj > gi
        gi, gj = gi[sel], gj[sel]
        fi, fj = grid[gi], grid[gj]
        near = (clip[gi] == clip[gj]) & (np.abs(fj - fi) < plan.gap)
        fi, fj = fi[~near], fj[~near]
        cv = t[mi[sel][~near] + 1, mj[sel][~near] + 1].astype(np.float64)
        reducer.add(fi, fj, cv)
    reducer._compact()
    keep = reducer.best_p >= 0
    empty_i, empty_c = np.zeros(0, np.int64), np.zeros(0)
    return TileMinima(
        task.index,
        reducer._i[0] if reducer._i else empty_i,
        reducer._j[0] if reducer._j else empty_i,
        reducer._c[0] if reducer._c else empty_c,
        reducer.best_i[keep],
        reducer.best_j[keep],
        reducer.best_c[keep],
        pairs,
        time.perf_counter() - t0,
    )


class TileMapper:
    """What runs the tasks of :func:`tiled_local_minima`: anything with ``imap(fn, items, *,
    shared, progress)`` yielding ``fn(shared, item)`` in input order (e.g.
    :class:`mocapkit.batch.Runner`, in-process or on Dask)."""

    def imap(self, fn, items, *, shared=None, progress=None, name=None):  # pragma: no cover
        raise NotImplementedError


def _in_process_imap(fn, items, shared, progress):
    """``fn(shared, item)`` in input order, on one thread per core of this process (each task's
    BLAS on one thread: the same bits as on a Dask worker, and every core busy)."""
    from mocapkit.core.pool import cores, ordered_imap

    return ordered_imap(lambda item: fn(shared, item), items, cores(), progress)


def tiled_local_minima(
    db: CostDatabase,
    stride: int = 1,
    tile: int = 1024,
    dtype: type = np.float32,
    min_gap: int | None = None,
    max_candidates: int = 200_000,
    progress: Callable[[int, int], None] | None = None,
    bucket_seconds: float = DEFAULT_BUCKET_SECONDS,
    per_bucket: int = DEFAULT_PER_BUCKET,
    *,
    runner: TileMapper | None = None,
    task_side: int = TASK_SIDE,
) -> MinimaResult:
    """Local minima of the cost matrix over a stride grid, computed tile by tile (upper
    triangle; the cost is symmetric), never holding more than one tile (+ 1-cell halo).

    Pairs within one clip closer than ``min_gap`` frames (default: the window length) are
    dropped. The tiles' minima are reduced by a :class:`MinimaReducer`: the ``max_candidates``
    cheapest, plus, for every ``bucket_seconds`` piece of every clip, its cheapest minimum with
    each of its ``per_bucket`` cheapest partner clips (``per_bucket=0``: the global list only).

    The tiles are grouped into square tasks of ``task_side`` x ``task_side`` tiles
    (:func:`plan_tiles`); each task
    reduces its own tiles (:func:`tile_task_minima`) and the tasks' reductions are merged in
    task order, so the result is the same whether the tasks run here or on ``runner`` (e.g. a
    :class:`mocapkit.batch.Runner` on a Dask cluster), on any number of workers.
    ``progress(done, total)`` is called after each task.
    """
    import time

    t0 = time.perf_counter()
    plan = plan_tiles(db, stride, tile, dtype, min_gap, max_candidates, bucket_seconds,
                      per_bucket, task_side)  # fmt: skip
    with one_blas_thread():  # here too, for tasks run on this process's threads
        return merge_tile_minima(db, plan, _run_plan(db, plan, runner, progress), t0)


_TILE_RUNNER: contextvars.ContextVar[TileMapper | None] = contextvars.ContextVar(
    "mocapkit_tile_runner", default=None
)


@contextlib.contextmanager
def tile_runner(runner: TileMapper | None) -> Iterator[None]:
    """Inside the block, :func:`tiled_local_minima` calls that give no ``runner`` (e.g. through
    :func:`mocapkit.graph.build_graph`) run their tasks on ``runner``."""
    token = _TILE_RUNNER.set(runner)
    try:
        yield
    finally:
        _TILE_RUNNER.reset(token)


def _run_plan(db, plan, runner, progress):
    runner = runner if runner is not None else _TILE_RUNNER.get()
    if runner is None:
        return _in_process_imap(tile_task_minima, plan.tasks, (db, plan), progress)
    return runner.imap(
        tile_task_minima, plan.tasks, shared=(db, plan), progress=progress, name="graph-tiles"
    )


def merge_tile_minima(
    db: CostDatabase, plan: TilePlan, parts, t0: float | None = None
) -> MinimaResult:
    """Merge the tasks' :class:`TileMinima` (given in task order) into the
    :class:`MinimaResult` of :func:`tiled_local_minima`."""
    import time

    t0 = time.perf_counter() if t0 is None else t0
    reducer = MinimaReducer(db.starts, plan.bucket_frames, plan.per_bucket, plan.max_candidates)
    pairs = 0
    expect = 0
    for part in parts:
        if part.index != expect:
            raise ValueError(f"tile task {part.index} given where task {expect} was expected")
        expect += 1
        reducer.add(part.bi, part.bj, part.bc, to_global=False)
        reducer.add(part.i, part.j, part.cost)
        pairs += part.pairs
    if expect != len(plan.tasks):
        raise ValueError(f"{expect} of {len(plan.tasks)} tile tasks given")
    ci, cj, cc = reducer.result()
    return MinimaResult(
        ci,
        cj,
        cc,
        plan.stride,
        pairs,
        float(pairs) * db.flops_per_pair(),
        time.perf_counter() - t0,
        plan.dtype,
    )
