"""Readable reference of the IK hot loop (:func:`mocapkit.ik._solve_frames`): one frame at a
time, one joint at a time, plain loops and 3x3 algebra. The fast version is tested against it."""

from __future__ import annotations

import math

import numpy as np

from mocapkit.core import rotations as rot


def fk_frame(parents, lrot, ltrans):
    """Global positions and rotations of one frame."""
    J = len(parents)
    gpos = np.zeros((J, 3))
    grot = np.zeros((J, 4))
    for j in range(J):
        p = parents[j]
        if p < 0:
            gpos[j], grot[j] = ltrans[j], lrot[j]
        else:
            grot[j] = rot.quat_mul(grot[p], lrot[j])
            gpos[j] = gpos[p] + rot.quat_apply(grot[p], ltrans[j])
    return gpos, grot


def flex(gpos, grot, parents, j, axis_local, child):
    p = parents[j]
    u, v = gpos[j] - gpos[p], gpos[child] - gpos[j]
    a = rot.quat_apply(grot[p], axis_local)
    return math.atan2(float(np.cross(u, v) @ a), float(u @ v)), a


def solve_frame(parents, lrot, ltrans, chains, targets, min_flex, damping, tol, max_step, iters):
    """DLS on one frame. ``chains``: (joints, effectors, {hinge: axis}); ``min_flex``: per
    hinge in chain order, the lowest flexion allowed (radians)."""
    lrot = lrot.copy()
    effs = [e for c in chains for e in c[1]]
    # the pose closest to its targets met so far, per group of chains that move each other's
    # effectors (a chain with a joint above another's effector joins its group)
    starts = np.cumsum([0] + [len(c[1]) for c in chains])

    def ancestors(j):
        out = []
        while j >= 0:
            out.append(j)
            j = parents[j]
        return out

    n = len(chains)
    label = list(range(n))
    changed = True
    while changed:
        changed = False
        for i in range(n):
            for k in range(n):
                moves = any(j in ancestors(e) for e in chains[i][1] for j in chains[k][0])
                if i != k and moves and label[i] != label[k]:
                    low = min(label[i], label[k])
                    label = [low if x in (label[i], label[k]) else x for x in label]
                    changed = True
    groups = []
    for g in sorted(set(label)):
        members = [i for i in range(n) if label[i] == g]
        joints = sorted({j for i in members for j in chains[i][0]})
        cols = [c for i in members for c in range(starts[i], starts[i + 1])]
        groups.append((joints, cols))
    best = [lrot[joints].copy() for joints, _ in groups]
    best_err = [np.inf] * len(groups)

    def keep_best(err):
        for gi, (joints, cols) in enumerate(groups):
            e = np.linalg.norm(err[cols], axis=-1).max()
            if e < best_err[gi]:
                best[gi], best_err[gi] = lrot[joints].copy(), e

    for _ in range(iters):
        gpos, grot = fk_frame(parents, lrot, ltrans)
        err = targets - gpos[effs]
        keep_best(err)
        if np.linalg.norm(err, axis=-1).max() <= tol:
            break
        # Jacobian, one column per degree of freedom
        cols = []
        axes = {}
        flexes = {}
        row0 = 0
        rows = 3 * len(effs)
        for joints, ceffs, hinges in chains:
            for i, j in enumerate(joints):
                if j in hinges:
                    child = joints[i + 1] if i + 1 < len(joints) else ceffs[0]
                    flexes[j], axes[j] = flex(gpos, grot, parents, j, hinges[j], child)
                    dirs = [axes[j]]
                else:
                    dirs = [np.eye(3)[k] for k in range(3)]
                for d in dirs:
                    col = np.zeros(rows)
                    for e_i, e in enumerate(ceffs):
                        anc, k = [], e
                        while k >= 0:
                            anc.append(k)
                            k = parents[k]
                        if j in anc and j != e:
                            col[3 * (row0 + e_i) : 3 * (row0 + e_i) + 3] = np.cross(
                                d, gpos[e] - gpos[j]
                            )
                    cols.append(col)
            row0 += len(ceffs)
        J = np.stack(cols, axis=1)
        step = J.T @ np.linalg.solve(J @ J.T + damping**2 * np.eye(rows), err.reshape(-1))
        c = 0
        h = 0
        for ci, (joints, ceffs, hinges) in enumerate(chains):
            delta = np.array([1.0, 0, 0, 0])
            g_prev_new = None
            for i, j in enumerate(joints):
                if j in hinges:
                    ang = step[c]
                    # a straight hinge whose chain must shorten to reach its aim: bent 5 deg
                    reach = np.linalg.norm(gpos[ceffs[0]] - gpos[joints[0]])
                    aim = np.linalg.norm(targets[starts[ci]] - gpos[joints[0]])
                    if flexes[j] < math.radians(1.0) and aim < reach - tol:
                        ang = max(ang, math.radians(5.0) - flexes[j])
                    ang = max(ang, min_flex[h] - flexes[j])
                    h += 1
                    v = axes[j] * ang
                    c += 1
                else:
                    v = step[c : c + 3]
                    c += 3
                n = np.linalg.norm(v)
                if n > math.radians(max_step):
                    v = v * math.radians(max_step) / n
                delta = rot.quat_mul(rot.rotvec_to_quat(v), delta)
                g_new = rot.quat_mul(delta, grot[j])
                if i == 0:
                    p = parents[j]
                    g_par = grot[p] if p >= 0 else np.array([1.0, 0, 0, 0])
                    lrot[j] = rot.quat_normalize(rot.quat_mul(rot.quat_inv(g_par), g_new))
                else:
                    lrot[j] = rot.quat_normalize(rot.quat_mul(rot.quat_inv(g_prev_new), g_new))
                g_prev_new = g_new
    gpos, _ = fk_frame(parents, lrot, ltrans)
    keep_best(targets - gpos[effs])
    for gi, (joints, _) in enumerate(groups):
        lrot[joints] = best[gi]
    gpos, _ = fk_frame(parents, lrot, ltrans)
    return lrot, np.linalg.norm(targets - gpos[effs], axis=-1)
