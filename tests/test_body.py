"""The body model on real rigs: parts by name on ten and more conventions, the same parts by
structure once the names are scrambled, ground roots, up axes and statures in metres."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from mocapkit import datasets
from mocapkit.body import body_of, split_name
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton
from mocapkit.io import MocapFileError, read_motion

LIMB_PARTS = ("hip", "knee", "ankle", "shoulder", "elbow", "wrist")
KEYS = ("pelvis", "head", *(f"{s}_{p}" for s in ("left", "right") for p in LIMB_PARTS))

# rig -> file, and the expected joint of each part (left side; the right mirrors it by name)
RIGS: dict[str, tuple[str, dict[str, str]]] = {
    "bandai": ("bandai1/data/dataset-1_walk_normal_001.bvh", {
        "pelvis": "Hips", "head": "Head", "left_hip": "UpperLeg_L", "left_knee": "LowerLeg_L",
        "left_ankle": "Foot_L", "left_toe": "Toes_L", "left_clavicle": "Shoulder_L",
        "left_shoulder": "UpperArm_L", "left_elbow": "LowerArm_L", "left_wrist": "Hand_L"}),
    "cmu-asf": ("cmu-asfamc/01/01_01.amc", {
        "pelvis": "root", "neck": "lowerneck", "head": "head", "left_hip": "lfemur",
        "left_knee": "ltibia", "left_ankle": "lfoot", "left_toe": "ltoes",
        "left_clavicle": "lclavicle", "left_shoulder": "lhumerus", "left_elbow": "lradius",
        "left_wrist": "lwrist", "left_hand": "lhand"}),
    "mixamo-namespaced": ("bvh-corpus/PeizhuoLi__ganimator__Walk-In-Circle.bvh", {
        "pelvis": "mixamorig7:Hips", "head": "mixamorig7:Head", "left_hip": "mixamorig7:LeftUpLeg",
        "left_knee": "mixamorig7:LeftLeg", "left_ankle": "mixamorig7:LeftFoot",
        "left_toe": "mixamorig7:LeftToeBase", "left_clavicle": "mixamorig7:LeftShoulder",
        "left_shoulder": "mixamorig7:LeftArm", "left_elbow": "mixamorig7:LeftForeArm",
        "left_wrist": "mixamorig7:LeftHand"}),
    "biped": ("bvh-corpus/PeizhuoLi__ganimator__idle1.bvh", {
        "head": "Bip01_Head", "left_hip": "Bip01_L_Thigh", "left_knee": "Bip01_L_Calf",
        "left_ankle": "Bip01_L_Foot", "left_toe": "Bip01_L_Toe0",
        "left_clavicle": "Bip01_L_Clavicle", "left_shoulder": "Bip01_L_UpperArm",
        "left_elbow": "Bip01_L_Forearm", "left_wrist": "Bip01_L_Hand"}),
    "iclone": ("bvh-corpus/DragonForgedTheArtist__IClone-CMU-Mocap__002_03.bvh", {
        "pelvis": "CC_Base_Hip", "head": "CC_Base_Head", "left_hip": "CC_Base_L_Thigh",
        "left_knee": "CC_Base_L_Calf", "left_ankle": "CC_Base_L_Foot",
        "left_toe": "CC_Base_L_ToeBase", "left_clavicle": "CC_Base_L_Clavicle",
        "left_shoulder": "CC_Base_L_Upperarm", "left_elbow": "CC_Base_L_Forearm",
        "left_wrist": "CC_Base_L_Hand"}),
    "neuron": ("bvh-corpus/GoldNotch__AxisNeuronFakeServer__test.bvh", {
        "pelvis": "Hips", "head": "Head", "left_hip": "LeftUpLeg", "left_knee": "LeftLeg",
        "left_ankle": "LeftFoot", "left_clavicle": "LeftShoulder", "left_shoulder": "LeftArm",
        "left_elbow": "LeftForeArm", "left_wrist": "LeftHand"}),
    "smpl": ("bvh-corpus/iamthephd__WHAM__sample.bvh", {
        "pelvis": "pelvis", "head": "head", "left_hip": "left_hip", "left_knee": "left_knee",
        "left_ankle": "left_ankle", "left_toe": "left_foot", "left_clavicle": "left_collar",
        "left_shoulder": "left_shoulder", "left_elbow": "left_elbow",
        "left_wrist": "left_wrist"}),
    "smpl-palm": ("bvh-corpus/EricGuo5513__momask-codes__.bvh", {
        "pelvis": "Pelvis", "left_hip": "Left_hip", "left_ankle": "Left_ankle",
        "left_toe": "Left_foot", "left_shoulder": "Left_shoulder", "left_wrist": "Left_wrist",
        "left_hand": "Left_palm"}),
    "blender": ("bvh-corpus/Zju-George__video2bvh_hmr__result.bvh", {
        "pelvis": "hips", "head": "head", "left_hip": "thigh.L", "left_knee": "shin.L",
        "left_ankle": "foot.L", "left_clavicle": "shoulder.L", "left_shoulder": "upper_arm.L",
        "left_elbow": "forearm.L", "left_wrist": "hand.L"}),
    "unity-humanoid": ("bvh-corpus/guillefix__shadermotion-bvh-utils__test.bvh", {
        "pelvis": "Hips", "left_hip": "LeftUpperLeg", "left_knee": "LeftLowerLeg",
        "left_toe": "LeftToes", "left_shoulder": "LeftUpperArm", "left_elbow": "LeftLowerArm"}),
    "collar-elbow": ("bvh-corpus/nishiokozo__hv__test.bvh", {
        "left_hip": "LeftHip", "left_knee": "LeftKnee", "left_ankle": "LeftAnkle",
        "left_toe": "LeftToe", "left_clavicle": "LeftCollar", "left_shoulder": "LeftShoulder",
        "left_elbow": "LeftElbow", "left_wrist": "LeftWrist"}),
    "glued-sides": ("bvh-corpus/Woosub-Won__BVHViewer__Coda03(Woman).bvh", {
        "pelvis": "Center", "left_hip": "LHip", "left_knee": "LKnee", "left_ankle": "LAnkle",
        "left_clavicle": "LCollar", "left_shoulder": "LShoulder", "left_elbow": "LElbow",
        "left_wrist": "LWrist"}),
    "cmu-bvh": ("bvh-corpus/facebookresearch__fairmotion__01_01.bvh", {
        "pelvis": "Hips", "head": "Head", "left_hip": "LeftUpLeg", "left_knee": "LeftLeg",
        "left_clavicle": "LeftShoulder", "left_shoulder": "LeftArm", "left_wrist": "LeftHand"}),
}  # fmt: skip


def _read(path: Path) -> Motion:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_motion(path)


def _mirror(name: str) -> str:
    for a, b in (("Left", "Right"), ("left", "right"), ("_L_", "_R_"), ("_L", "_R"), (".L", ".R"),
                 ("mixamorig7:Left", "mixamorig7:Right")):  # fmt: skip
        if a in name:
            return name.replace(a, b, 1)
    if name[:1] in "lL" and len(name) > 1:
        return ("r" if name[0] == "l" else "R") + name[1:]
    return name


def _scrambled(m: Motion) -> Motion:
    sk = m.skeleton
    s2 = Skeleton(
        tuple(f"j{i}" for i in range(sk.num_joints)),
        sk.parents,
        sk.offsets,
        sk.channels,
        sk.end_site_parents,
        sk.end_site_offsets,
        sk.end_site_names,
        sk.metres_per_unit,
    )
    return Motion(s2, m.rotations, m.root_positions, m.frame_time, m.translations)


@pytest.mark.shared
@pytest.mark.parametrize("rig", sorted(RIGS))
def test_parts_by_name_on_real_rigs(rig: str, shared_path) -> None:
    rel, expected = RIGS[rig]
    m = _read(shared_path(rel))
    body = body_of(m)
    names = m.skeleton.names
    for key, joint in expected.items():
        assert body.joint(key) is not None, f"{rig}: no {key}"
        assert names[body.joint(key)] == joint, f"{rig}: {key}"
        assert body.part(key).source == "name" and body.part(key).confidence >= 0.9
        if key.startswith("left_"):
            right = body.joint("right_" + key[5:])
            assert right is not None and names[right] == _mirror(joint), f"{rig}: right {key}"


# Rigs whose structure tells every part and side (toes point forward); the others keep some
# limbs with an unknown side, which the last test checks.
STRUCTURE_RIGS = ("bandai", "cmu-asf", "mixamo-namespaced", "iclone", "smpl", "blender",
                  "unity-humanoid", "collar-elbow", "glued-sides", "cmu-bvh")  # fmt: skip


@pytest.mark.shared
@pytest.mark.parametrize("rig", STRUCTURE_RIGS)
def test_structure_finds_the_same_parts_without_names(rig: str, shared_path) -> None:
    rel, _ = RIGS[rig]
    m = _read(shared_path(rel))
    named, blind = body_of(m), body_of(_scrambled(m))
    assert blind.parts and all(p.source == "structure" for p in blind.parts)
    checked = 0
    for key in KEYS:
        if named.joint(key) is None:
            continue
        if key == "head" and rig in ("iclone", "mixamo-namespaced"):
            continue  # a face rig, or a HeadTop_End bone with its own End Site, tops the chain
        assert blind.joint(key) == named.joint(key), f"{rig}: {key}"
        checked += 1
    assert checked >= 12
    assert blind.up == named.up
    assert blind.pelvis == named.pelvis


@pytest.mark.shared
def test_no_geometric_cue_gives_an_unknown_side_never_a_guess(shared_path) -> None:
    # a rig without toes whose take holds its legs straight: nothing tells left from right
    m = _read(shared_path("bvh-corpus/BartekkPL__bvh-parser__simple.bvh"))
    blind = body_of(_scrambled(m))
    unknown = [p for p in blind.parts if p.side == "unknown"]
    assert unknown and all(p.confidence <= 0.2 for p in unknown)
    assert blind.pair("hip") is None  # no left/right pair is claimed
    assert len(blind.both("knee")) == 2  # but both knees are still found


@pytest.mark.shared
def test_every_corpus_bandai_and_cmu_file_gets_a_body(shared_path) -> None:
    paths = sorted(shared_path("bvh-corpus").glob("*.bvh"))
    paths += sorted(shared_path("bandai1/data").glob("*.bvh"))[::10]
    paths += sorted(shared_path("cmu-asfamc").glob("*/*.amc"))
    humans = 0
    for p in paths:
        try:
            m = _read(p)
        except MocapFileError:
            continue  # the corpus holds a few files that need --lenient
        body = body_of(m)
        assert 0 <= body.pelvis < m.num_joints
        assert body.up.lstrip("-") in ("X", "Y", "Z")
        assert np.isfinite(body.stature) and body.stature > 0
        if body.pair("hip") and body.head is not None:
            humans += 1
            # the canonical chain holds: hip above knee above ankle, shoulder above elbow
            for side in ("left", "right"):
                for upper, lower in (("hip", "knee"), ("knee", "ankle"), ("shoulder", "elbow")):
                    u, lo = body.joint(f"{side}_{upper}"), body.joint(f"{side}_{lower}")
                    if u is not None and lo is not None:
                        assert u in m.skeleton.ancestors(lo), (p.name, side, upper)
    assert humans >= 40


@pytest.mark.shared
def test_cmu_units_come_from_the_asf_and_give_a_human_height(shared_path) -> None:
    for p in sorted(shared_path("cmu-asfamc").glob("*/*.amc"))[::3]:
        body = body_of(_read(p))
        assert body.units_source == "file"
        assert body.metres_per_unit == pytest.approx(0.0254 / 0.45)
        assert 1.4 <= body.height_m <= 2.0, (p.name, body.height_m)


@pytest.mark.shared
def test_bandai_ground_root_and_height(shared_path) -> None:
    for p in sorted(shared_path("bandai1/data").glob("*.bvh"))[::25]:
        m = _read(p)
        body = body_of(m)
        assert body.ground_root == 0 and m.skeleton.names[0] == "joint_Root"
        assert body.pelvis == m.skeleton.index("Hips")
        assert body.units_source == "guess" and body.metres_per_unit == 0.01
        assert 1.4 <= body.height_m <= 2.0, (p.name, body.height_m)


def test_generated_humanoid_parts_and_no_ground_root() -> None:
    m = datasets.procedural_motion("walk", seconds=2.0, seed=0).motion
    body = body_of(m)
    assert body.ground_root is None
    assert body.sides_known
    names = m.skeleton.names
    assert names[body.joint("left_knee")] == "LeftLeg"
    blind = body_of(_scrambled(m))
    for key in KEYS:
        assert blind.joint(key) == body.joint(key), key
    # side_of follows the limbs; the spine and head are centre
    assert body.side_of(body.joint("left_wrist")) == "left"
    assert body.side_of(body.head) == "centre"


@pytest.mark.parametrize(
    ("name", "side", "base"),
    [
        ("mixamorig:LeftUpLeg", "left", "upleg"),
        ("Bip01 L Thigh", "left", "thigh"),
        ("CC_Base_R_Forearm", "right", "forearm"),
        ("upper_arm.L", "left", "upperarm"),
        ("lfemur", "left", "femur"),
        ("Left_palm", "left", "palm"),
        ("Hips", "", "hips"),
    ],
)
def test_split_name(name: str, side: str, base: str) -> None:
    assert split_name(name) == (side, base)


def test_joints_meant_reads_a_name_of_another_convention() -> None:
    """A joint typed in one convention names the rig's joint of that part (for suggestions):
    Bandai's Knee_L is Mixamo's LeftLeg; a side-less name means both sides."""
    from mocapkit import datasets

    sk = datasets.procedural_motion("walk", seconds=1.0, seed=0).motion.skeleton
    body = body_of(sk)
    names = list(sk.names)
    meant = {n: [names[j] for j in body.joints_meant(n)] for n in ("Knee_L", "lfemur", "knee")}
    assert meant == {
        "Knee_L": ["LeftLeg"], "lfemur": ["LeftUpLeg"], "knee": ["LeftLeg", "RightLeg"],
    }  # fmt: skip
    assert body.joints_meant("Banana") == []
