"""Readable references for mocapkit.graph (never imported by the library).

``window_cost`` spells the aligned window cost out pair by pair: it builds both windows' point
clouds, their per-point weights ``W_k (s_p + f_{i+k,p} + f_{j+k,p})``, finds the rigid ground
transform with :func:`mocapkit.features.align_point_clouds_2d` (Kovar & Gleicher's closed form)
and sums the weighted squared distances. ``brute_force_theta`` does the same minimisation by a
dense search over the angle (translation optimal in closed form for each angle).
``local_minima`` marks the interior cells of a cost grid that are finite and <= their eight
neighbours, with array slices (the compiled kernel behind ``tiled_local_minima`` does it cell by
cell).
"""

from __future__ import annotations

import numpy as np

from mocapkit.features import align_point_clouds_2d


def _windows(db, i, j):
    k = np.arange(-db.half, db.half + 1)
    a = db.coords[i + k].reshape(-1, 3)
    b = db.coords[j + k].reshape(-1, 3)
    w = (
        db.window[:, None]
        * (db.point_static[None, :] + db.point_frame[i + k] + db.point_frame[j + k])
    ).reshape(-1)
    return a, b, w


def _to_xyz(p):
    # db.coords already hold (side, up, forward) = (x, y, z); embed as a Y-up cloud
    return p


def window_cost(db, i, j):
    """Aligned window cost of centre frames (i, j), one pair at a time."""
    a, b, w = _windows(db, i, j)
    T = align_point_clouds_2d(_to_xyz(a), _to_xyz(b), w, up="Y")
    tb = T.apply(b)
    return float(np.sum(w * np.sum((a - tb) ** 2, axis=1)))


def brute_force_theta(db, i, j, steps=20000):
    """min over a dense grid of angles of the window cost (translation optimal per angle)."""
    a, b, w = _windows(db, i, j)
    W = w.sum()
    th = np.linspace(-np.pi, np.pi, steps, endpoint=False)[:, None]
    c, s = np.cos(th), np.sin(th)
    # rotation about +Y by th: x' = c x + s z, z' = -s x + c z; all angles at once
    rx = c * b[:, 0] + s * b[:, 2]
    rz = -s * b[:, 0] + c * b[:, 2]
    tx = (w * (a[:, 0] - rx)).sum(1, keepdims=True) / W
    tz = (w * (a[:, 2] - rz)).sum(1, keepdims=True) / W
    d = (a[:, 0] - rx - tx) ** 2 + (a[:, 1] - b[:, 1]) ** 2 + (a[:, 2] - rz - tz) ** 2
    return float((w * d).sum(1).min())


def local_minima(t):
    """(n-2, m-2) bool: interior cells of ``t`` (n, m) that are finite and <= their 8 neighbours."""
    c = t[1:-1, 1:-1]
    ok = np.isfinite(c)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                ok &= c <= t[1 + di : t.shape[0] - 1 + di, 1 + dj : t.shape[1] - 1 + dj]
    return ok
