"""Readable references for mocapkit.core (never imported by the library).

``fk_reference`` is forward kinematics written out per frame and per joint with rotation
matrices (scipy): ``G[j] = G[parent] L[j]``, ``P[j] = P[parent] + G[parent] t[j]``; the numba
kernel behind :func:`mocapkit.core.kinematics.fk_arrays` is tested against it.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def fk_reference(parents, rotations, translations):
    """Readable reference: per frame, per joint, with rotation matrices."""
    F, J = rotations.shape[:2]
    translations = np.broadcast_to(translations, (F, J, 3))
    pos = np.zeros((F, J, 3))
    mats = np.zeros((F, J, 3, 3))
    for f in range(F):
        for j in range(J):
            local = Rotation.from_quat(rotations[f, j], scalar_first=True).as_matrix()
            p = parents[j]
            if p < 0:
                mats[f, j] = local
                pos[f, j] = translations[f, j]
            else:
                mats[f, j] = mats[f, p] @ local
                pos[f, j] = pos[f, p] + mats[f, p] @ translations[f, j]
    return pos, mats
