"""Body parts, masses and the three weightings."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mocapkit import datasets
from mocapkit.graph.pointcloud import body_parts, point_cloud
from mocapkit.graph.weights import (
    DE_LEVA_MALE,
    TORSO_EXTRA,
    load_masses,
    metric_weights,
    part_categories,
    part_masses,
    supporting_parts,
)


@pytest.fixture(scope="module")
def parts():
    return body_parts(datasets.humanoid_skeleton())


def test_de_leva_total_is_100_percent():
    limbs = ("upperarm", "forearm", "hand", "thigh", "shank", "foot")
    total = sum(v for k, v in DE_LEVA_MALE.items() if k not in limbs)
    total += 2 * sum(DE_LEVA_MALE[k] for k in limbs)
    assert total == pytest.approx(100.0, abs=1e-9)


def test_body_parts_and_points(parts):
    assert parts.names[0] == "Hips" and parts.parents[0] == -1
    assert parts.num_parts == 21
    assert parts.num_points == 21 + 5  # End Sites of head, hands, toes
    m = datasets.procedural_motion("walk", 1.0, seed=0).motion
    pc = point_cloud(m, parts)
    assert pc.shape == (m.num_frames, parts.num_points, 3)


def test_categories_and_masses(parts):
    cats = dict(zip(parts.names, part_categories(parts), strict=True))
    assert cats["LeftUpLeg"] == "thigh" and cats["LeftLeg"] == "shank"
    assert cats["LeftFoot"] == "foot" and cats["LeftToe"] == "foot"
    assert cats["LeftArm"] == "upperarm" and cats["LeftForeArm"] == "forearm"
    assert cats["Head"] == "head" and cats["Spine"] == "trunk"
    m = dict(zip(parts.names, part_masses(parts, 100.0), strict=True))
    assert sum(m.values()) == pytest.approx(100.0)
    assert m["LeftUpLeg"] == pytest.approx(14.16, rel=1e-9)
    assert m["LeftFoot"] + m["LeftToe"] == pytest.approx(1.37)
    assert m["Hips"] == pytest.approx(11.17)
    assert m["LeftUpLeg"] == pytest.approx(m["RightUpLeg"])


def test_mass_fallback_by_bone_length_and_overrides(tmp_path):
    from mocapkit.core.skeleton import Skeleton

    sk = Skeleton(
        ("root", "a", "b", "c"),
        np.array([-1, 0, 1, 0]),
        np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, -1, 0.0]]),
        (("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),)
        + (("Zrotation", "Xrotation", "Yrotation"),) * 3,
        np.array([2, 3]),
        np.array([[0, 3, 0], [0, -1, 0.0]]),
    )
    p = body_parts(sk)
    m = part_masses(p, 10.0)
    assert m.sum() == pytest.approx(10.0) and np.all(m > 0)
    f = tmp_path / "m.json"
    f.write_text(json.dumps({"b": 5.0}))
    m2 = part_masses(p, 10.0, overrides=load_masses(f))
    assert m2[p.names.index("b")] == 5.0
    with pytest.raises(KeyError):
        part_masses(p, overrides={"nope": 1.0})


def test_dynamics_weights(parts):
    F = 3
    cp = np.zeros((F, parts.num_parts), dtype=bool)
    lf = parts.names.index("LeftFoot")
    cp[1, lf] = True
    cp[2, parts.names.index("LeftToe")] = True
    cp[2, parts.names.index("RightToe")] = True
    masses = part_masses(parts)
    w = metric_weights("dynamics", parts, cp, masses)
    total = masses.sum()
    assert w.static[0] == pytest.approx(total)  # the root carries the whole body
    leg = [parts.names.index(n) for n in ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToe")]
    assert w.static[leg[0]] == pytest.approx(masses[leg].sum())
    assert np.all(w.frame[0] == 0)
    sup = supporting_parts(parts, cp)
    assert set(np.flatnonzero(sup[1])) == set(leg[:3])
    assert w.frame[1, lf] == pytest.approx(total - masses[leg[2:]].sum())
    assert w.frame[1, leg[0]] == pytest.approx(total - masses[leg].sum())
    assert w.frame[1, 0] == 0  # the pelvis is the root body, never supporting
    assert np.count_nonzero(w.frame[2]) == 8


def test_uniform_and_torso(parts):
    cp = np.zeros((2, parts.num_parts), dtype=bool)
    cp[1, parts.names.index("RightFoot")] = True
    u = metric_weights("uniform", parts, cp)
    assert np.all(u.static == 1) and np.all(u.frame == 0)
    t = metric_weights("torso", parts, cp)
    assert t.static[0] > t.static[parts.names.index("LeftArm")]
    assert t.frame[1, parts.names.index("RightFoot")] == TORSO_EXTRA
    assert np.count_nonzero(t.frame) == 1
    with pytest.raises(ValueError):
        metric_weights("nope", parts, cp)
