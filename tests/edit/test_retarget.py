"""Retargeting between CMU ASF/AMC and Bandai rigs on the shared data (the issue's targets)."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from mocapkit.cli import main
from mocapkit.edit.retarget import retarget
from mocapkit.io import read_motion

CMU = "cmu-asfamc/03"
BANDAI = "bandai2/data"
WALK = "dataset-2_walk_normal_001.bvh"


@pytest.fixture(scope="module")
def pair(request):
    from conftest import require_shared

    cmu = read_motion(require_shared(CMU) / "03_01.amc")[::2]  # 60 fps, half the work
    ban = read_motion(require_shared(BANDAI) / WALK)
    return cmu, ban


def _check(res, src):
    j = res.to_json()
    fs = j["foot_slide_cm"]
    assert fs["output"]["contact_frames"] > 0
    assert fs["output"]["mean"] <= 1.0
    assert fs["output"]["mean"] < fs["output_without_ik"]["mean"]
    assert fs["output"]["max"] is not None and fs["source"]["max"] is not None
    assert j["effector_path_error_pct"]["mean"] <= 5.0
    for v in j["effector_path_error_pct"]["per_effector"].values():
        assert v["mean"] <= 5.0
    assert j["joint_limits"]["all_kept"]
    # the IK reaches the planted targets (cm), so the remaining slide is not a solver failure
    assert j["ik_residual_cm"]["max"] < 2.0
    # planted runs: frames where the source joint drifts beyond contact_drift left the run
    assert fs["source"]["max"] <= 2 * 100 * j["contacts"]["contact_drift_m"]
    assert j["contacts"]["frames"] <= j["contacts"]["detected_frames"]
    assert res.motion.frame_time == src.frame_time
    assert np.all(np.isfinite(res.motion.rotations))


def test_cmu_to_bandai(pair):
    cmu, ban = pair
    res = retarget(cmu, ban)
    _check(res, cmu)
    assert res.motion.skeleton is ban.skeleton
    assert 0.8 < res.scale < 1.25
    assert res.mapping["UpperLeg_L"] == "lfemur" and res.mapping["Hips"] == "root"


def test_bandai_to_cmu_asf(pair, shared_path):
    from mocapkit.edit.retarget import read_target

    _, ban = pair
    asf = read_target(shared_path(CMU) / "03.asf")
    res = retarget(ban, asf)
    _check(res, ban)
    assert res.mapping["lfemur"] == "UpperLeg_L"


def _limb(pos, body, side, U=None):
    """(shoulder -> wrist vector, reach as a fraction of upper + lower arm, elbow offset)."""
    from mocapkit.core import rotations as rot

    s, e, w = (body.joint(f"{side}_{k}") for k in ("shoulder", "elbow", "wrist"))
    r, u = pos[:, w] - pos[:, s], pos[:, e] - pos[:, s]
    if U is not None:
        r, u = rot.quat_apply(U, r), rot.quat_apply(U, u)
    length = np.linalg.norm(u, axis=-1) + np.linalg.norm(pos[:, w] - pos[:, e], axis=-1)
    return r, np.linalg.norm(r, axis=-1) / length, u


@pytest.mark.parametrize("direction", ["cmu_to_bandai", "bandai_to_cmu"])
def test_arms_match_source_reach_and_bend_side(pair, shared_path, direction):
    """Rigs split an arm differently (CMU upper arm / forearm 1.63, Bandai 1.09): the wrist
    keeps the source's direction from the shoulder and its reach as a fraction of the arm's
    length, and the elbow stays on the source's side of the shoulder-wrist line."""
    from mocapkit.body import body_of
    from mocapkit.core import rotations as rot
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.edit.retarget import RetargetConfig, read_target
    from mocapkit.features import ground_frame

    cmu, ban = pair
    if direction == "cmu_to_bandai":
        src, tgt = cmu, ban
    else:
        src, tgt = ban, read_target(shared_path(CMU) / "03.asf")
    res = retarget(src, tgt, RetargetConfig(effector_goals=()))  # the reach matching alone
    bS, bT = body_of(src), body_of(res.motion)
    U = rot.quat_between(ground_frame(bS.up)[1], ground_frame(bT.up)[1])
    posS, _ = forward_kinematics(src)
    posT, _ = forward_kinematics(res.without_ik)
    for side in ("left", "right"):
        rS, fS, uS = _limb(posS, bS, side, U)
        rT, fT, uT = _limb(posT, bT, side)
        np.testing.assert_allclose(fT, fS, atol=1e-6)
        cos = np.einsum("fi,fi->f", rS, rT) / (
            np.linalg.norm(rS, axis=-1) * np.linalg.norm(rT, axis=-1)
        )
        assert cos.min() > 1 - 1e-9
        # the elbow on the same side of the shoulder-wrist line (the bending plane's normal)
        nS, nT = np.cross(uS, rS), np.cross(uT, rT)
        bent = np.linalg.norm(nS, axis=-1) > 1e-3 * np.linalg.norm(rS, axis=-1) ** 2
        assert np.all(np.einsum("fi,fi->f", nS, nT)[bent] > 0)
    # copying bone directions alone leaves the wrists' paths further from the source's
    off = retarget(src, tgt, RetargetConfig(match_reach=False)).to_json()
    on = res.to_json()
    for side in ("left", "right"):
        k = f"{side}_wrist"
        err = on["effector_path_error_pct"]["per_effector"][k]["mean"]
        assert err < off["effector_path_error_pct"]["per_effector"][k]["mean"]


def test_planted_runs_hold_only_still_frames(pair):
    """A detected run keeps only the frames near its median position; every kept frame was
    detected, and a run whose joint wanders splits."""
    from dataclasses import replace

    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.core.runs import true_runs
    from mocapkit.edit.retarget import _planted
    from mocapkit.features import foot_contacts

    cmu, _ = pair
    body = body_of(cmu)
    det = foot_contacts(cmu)
    # a synthetic wandering contact: one run over the whole clip for the first foot joint
    flags = det.contacts.copy()
    flags[:, 0] = True
    wide = replace(det, contacts=flags)
    out = _planted(wide, cmu, body, 0.03)
    assert not np.any(out.contacts & ~wide.contacts)
    assert len(true_runs(out.contacts[:, 0])) >= 1
    assert out.contacts[:, 0].sum() < 0.5 * cmu.num_frames  # a walking foot is not planted
    pos, _ = forward_kinematics(cmu)
    j = det.joints[0]
    seg = pos[out.contacts[:, 0], j]
    dev = seg - np.median(pos[:, j], axis=0)
    dev[:, 1] = 0.0  # CMU is Y-up
    assert np.all(np.linalg.norm(dev, axis=-1) * body.metres_per_unit <= 0.03 + 1e-9)


def test_map_overrides_and_errors(pair):
    cmu, ban = pair
    res = retarget(cmu[:60], ban, joint_map={"Toes_L": None})
    assert "Toes_L" not in res.mapping
    # a joint mapped to null keeps its reference pose: the reach matching, the goals and the
    # foot lock moved a nulled thigh back onto the source's (newcomer report: no difference)
    from mocapkit.core import rotations as rot

    thigh = ban.skeleton.names.index("UpperLeg_L")
    auto = retarget(cmu[:60], ban).motion.rotations[:, thigh]
    kept = retarget(cmu[:60], ban, joint_map={"UpperLeg_L": None}).motion.rotations[:, thigh]
    assert np.degrees(rot.quat_angle(auto, auto[:1])).max() > 10.0
    assert np.degrees(rot.quat_angle(kept, kept[:1])).max() < 1e-6
    # nulling a joint the map leaves out anyway (the ground root) changes nothing, foot lock
    # included (review: the lock was dropped for any nulled ancestor of a foot)
    same = retarget(cmu[:60], ban, joint_map={"joint_Root": None}).motion
    np.testing.assert_array_equal(same.rotations, retarget(cmu[:60], ban).motion.rotations)
    with pytest.raises(ValueError, match="'Nope' is not in the target"):
        retarget(cmu[:30], ban, joint_map={"Nope": "root"})


def test_cli_retarget_and_bad_map(tmp_path, shared_path):
    src = shared_path(BANDAI) / WALK
    asf = shared_path(CMU) / "03.asf"
    out = tmp_path / "walk_cmu.bvh"
    r = CliRunner().invoke(
        main, ["retarget", str(src), "--to", str(asf), "--out", str(out), "--json"]
    )
    assert r.exit_code == 0, r.output
    assert out.exists() and (tmp_path / "walk_cmu.bvh.provenance.json").exists()
    back = read_motion(out)
    assert back.num_joints == 31
    bad = tmp_path / "map.json"
    bad.write_text('{"lfemur": 3}')
    out2 = tmp_path / "b.bvh"
    args = ["retarget", str(src), "--to", str(asf), "--out", str(out2), "--map", str(bad)]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2
    lines = [x for x in r.output.splitlines() if x.strip()]
    assert len(lines) == 1 and "map.json" in lines[0] and "'lfemur'" in lines[0]
    assert not out2.exists()
    bad.write_text("{oops")
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and "not valid JSON" in r.output and not out2.exists()
    # never over an input
    r = CliRunner().invoke(main, ["retarget", str(src), "--to", str(asf), "--out", str(src)])
    assert r.exit_code == 2


def test_retargeted_clip_in_bandai_graph_and_clean(pair, shared_path):
    from mocapkit.clean.run import run as clean_run
    from mocapkit.features import resample
    from mocapkit.graph.graph import build_graph

    cmu, ban = pair
    clip = resample(retarget(cmu, ban).motion, ban.fps)
    folder = shared_path(BANDAI)
    walks = [
        read_motion(folder / f"dataset-2_walk_{s}_001.bvh")
        for s in ("active", "elderly", "feminine")
    ]
    g, _, _ = build_graph([*walks, clip], "dynamics")  # the default connects every clip
    assert len(g.clips) == 4
    # the retargeted clip takes part in the graph: transitions into or out of it
    assert np.any((g.src_clip == 3) | (g.dst_clip == 3))
    # and serves as context for cleaning a Bandai take
    rep = clean_run(walks[0][:90], [clip[:150]])
    assert rep.to_json()


@pytest.mark.parametrize("direction", ["cmu_to_bandai", "bandai_to_cmu"])
def test_effector_goals_follow_source_paths(pair, shared_path, direction):
    """With the head and wrist goals, those effectors' pelvis-relative paths (scaled by limb
    length) follow the source's: each below 1 % here (without them the shoulders' and head's
    offsets from the pelvis turn with the torso and leave 1-2.5 %); elbows never bend
    backwards; reach shortfalls are reported."""
    from mocapkit.edit.retarget import RetargetConfig, read_target

    cmu, ban = pair
    if direction == "cmu_to_bandai":
        src, tgt = cmu, ban
    else:
        src, tgt = ban, read_target(shared_path(CMU) / "03.asf")
    on = retarget(src, tgt).to_json()
    off = retarget(src, tgt, RetargetConfig(effector_goals=())).to_json()
    e_on = on["effector_path_error_pct"]["per_effector"]
    e_off = off["effector_path_error_pct"]["per_effector"]
    for k in ("head", "left_wrist", "right_wrist"):
        assert e_on[k]["mean"] < 1.0
        assert e_on[k]["mean"] < e_off[k]["mean"]
    assert on["joint_limits"]["all_kept"]
    for v in on["joint_limits"]["per_joint"].values():
        assert v["output_frames_bent_backwards"] == 0
    cl = on["effector_goals"]["clamped"]
    assert set(cl) == {"head", "left_wrist", "right_wrist"}
    # the head is reached by bending the spine within a centimetre or two (its length is rigid)
    assert cl["head"]["max_shortfall_cm"] < 2.0
    # feet untouched by the goals: slide and IK residual as without them
    for key in ("foot_slide_cm", "ik_residual_cm"):
        assert on[key] == off[key]


def test_a_rig_without_legs_is_named_as_source_or_target(tmp_path):
    """The error names the file whose rig cannot be retargeted, the target as well as the
    source (a newcomer was told the source had no legs)."""
    from mocapkit import datasets
    from mocapkit.edit.joints import drop_joints
    from mocapkit.edit.retarget import RigError
    from mocapkit.io import write_motion

    walk = datasets.procedural_motion("walk", 2.0, seed=0).motion
    legless = drop_joints(walk, r".*(UpLeg|Leg|Foot|Toe)$")
    with pytest.raises(RigError) as e:
        retarget(walk, legless)
    assert e.value.role == "target"
    with pytest.raises(RigError) as e:
        retarget(legless, walk)
    assert e.value.role == "source"
    a, b = write_motion(walk, tmp_path / "walk.bvh"), write_motion(legless, tmp_path / "bust.bvh")
    r = CliRunner().invoke(main, ["retarget", str(a), "--to", str(b), "--out",
                                  str(tmp_path / "o.bvh")])  # fmt: skip
    assert r.exit_code == 2 and r.output.count("\n") == 1
    assert r.output.startswith(f"mocapkit: error: {b}: cannot retarget the target rig")
    assert not (tmp_path / "o.bvh").exists()


def _walk_and_a_level_rig():
    """A procedural walk, and the same walk on a rig whose trunk lies level over its legs (its
    Spine and everything above pitched forward by 90 degrees): a rig that never stands."""
    from dataclasses import replace

    from mocapkit import datasets
    from mocapkit.core import rotations as rot
    from mocapkit.core.motion import Motion

    walk = datasets.procedural_motion("walk", 2.0, seed=0).motion
    sk = walk.skeleton
    trunk = [sk.names.index("Spine")]  # the Spine joint and everything above it
    for j in range(sk.num_joints):
        if sk.parents[j] in trunk:
            trunk.append(j)
    pitch = rot.rotvec_to_quat(np.array([np.pi / 2, 0.0, 0.0]))  # forward, about the side axis
    offsets = sk.offsets.copy()
    offsets[trunk] = rot.quat_apply(pitch, offsets[trunk])
    level = Motion(replace(sk, offsets=offsets), walk.rotations, walk.root_positions,
                   walk.frame_time)  # fmt: skip
    return walk, level


def test_a_rig_that_never_stands_upright_is_warned_about():
    """A four-legged rig named like a biped (the corpus' Bip01 elephant) was retargeted onto a
    person without a word. A rig whose trunk lies level over its legs, in its rest pose and
    in every frame, is warned about as source or as target; a person walking is not."""
    walk, level = _walk_and_a_level_rig()
    assert retarget(walk, walk).figures["warnings"] == []
    src = retarget(level, walk).figures["warnings"]
    assert len(src) == 1 and src[0].startswith("the source never stands upright")
    tgt = retarget(walk, level).figures["warnings"]
    assert len(tgt) == 1 and tgt[0].startswith("the target never stands upright")


def test_cli_retarget_json_carries_what_standard_error_warns(tmp_path):
    """The command's --json holds the warnings standard error prints (each once), as the
    other commands' do: a script that reads only the JSON learns the rig is wrong."""
    import json

    from mocapkit.io import write_motion

    walk, level = _walk_and_a_level_rig()
    write_motion(level, tmp_path / "level.bvh")
    write_motion(walk, tmp_path / "walk.bvh")
    args = ["retarget", str(tmp_path / "level.bvh"), "--to", str(tmp_path / "walk.bvh")]
    r = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "o.bvh"), "--json"])
    assert r.exit_code == 0, r.output
    said = json.loads(r.stdout)["warnings"]
    assert any(w.startswith("warning: the source never stands upright") for w in said), said
    assert r.stderr.count("the source never stands upright") == 1, r.stderr
    r = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "p.bvh")])
    assert r.exit_code == 0 and r.stderr.count("never stands upright") == 1, r.output
    r = CliRunner().invoke(main, ["retarget", str(tmp_path / "walk.bvh"), "--to",
                                  str(tmp_path / "walk.bvh"), "--out", str(tmp_path / "q.bvh"),
                                  "--json"])  # fmt: skip
    assert r.exit_code == 0 and json.loads(r.stdout)["warnings"] == [], r.output
