"""A real consumer reads mocapkit's output: Blender's own glTF and BVH importers.

One headless Blender process (Debian's ``blender`` 3.4) imports every file of the module and
writes the world position of every bone head at the frames asked for; the tests compare them
with mocapkit's forward kinematics, to 1e-4 of the character's height:

* Blender's glTF import of mocapkit's ``.glb`` vs FK in glTF's frame (metres, +Y up);
* Blender's BVH import of mocapkit's ``.bvh`` output vs FK, where only the root has position
  channels. Blender reads a non-root joint's position channels as a displacement added to its
  OFFSET (not as the offset itself), so for rigs that animate every joint's position (Bandai)
  Blender's import of mocapkit's BVH must agree with Blender's import of the source file.

Skipped with the reason when ``blender`` is not installed, unless MOCAPKIT_REQUIRE_BLENDER=1
(CI), where that fails.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from testsupport import require_tool

import mocapkit as mk
from mocapkit.body import body_of
from mocapkit.core.motion import Motion
from mocapkit.io import read_motion, write_bvh
from mocapkit.io.gltf import gltf_space, write_gltf

pytestmark = pytest.mark.shared

TOLERANCE = 1e-4
"""Of the character's height: what the checks allow (float32 in glTF, 6 decimals in BVH)."""

MAX_FRAMES = 240
"""Takes are cut to their first frames: Blender's importers key every frame in Python."""

CHECKED_FRAMES = 6
"""Frames compared per take, evenly spread, first and last included."""

# (case id, data set, file, its rotation order(s) as the manifest states them)
CASES = [
    ("bandai", "bandai1/data", "dataset-1_bow_active_001.bvh", "ZXY, 6 channels per joint"),
    ("cmu-asfamc", "cmu-asfamc/01", "01_02.amc", "ZYX (ASF rx ry rz)"),
    ("corpus-mixed", "bvh-corpus", "VictorS-67__pybvh__bvh_test1.bvh", "XZY/XYZ/YZX/ZYX, Z-up"),
    ("corpus-zxy", "bvh-corpus", "rmGinner__Bvh-Viewer__Male1_A13_Skipping.bvh", "ZXY"),
    ("corpus-yxz", "bvh-corpus", "GoldNotch__AxisNeuronFakeServer__test.bvh", "YXZ"),
    ("corpus-xyz", "bvh-corpus", "PeizhuoLi__ganimator__Baseball-Milling-Idle-edited-keyframes.bvh",
     "XYZ"),
]  # fmt: skip

# Run inside Blender: argv after "--" is the job file and the result file. Every job resets the
# scene, imports one file with Blender's own operator and reads pose-bone heads in world space.
BLENDER_SCRIPT = r"""
import builtins, json, math, sys
import bpy

job_path, out_path = sys.argv[sys.argv.index("--") + 1 :]
jobs = json.load(open(job_path))
import io_anim_bvh.import_bvh as import_bvh

# Debian's Blender 3.4 opens BVH files with mode "rU", which its Python 3.11 refuses
import_bvh.open = lambda f, mode="r", *a, **k: builtins.open(f, mode.replace("U", ""), *a, **k)
# ... and its glTF importer uses np.bool, which Debian's NumPy (>= 1.24) no longer has
import numpy
if "bool" not in numpy.__dict__:
    numpy.bool = numpy.bool_

results = {}
for job in jobs:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    if job["kind"] == "gltf":
        bpy.ops.import_scene.gltf(filepath=job["path"])
        fps = scene.render.fps  # the importer keys time t at frame t * fps
        frames = [t * fps for t in job["times"]]
    else:
        # forward Y, up Z: Blender's own axes, so world positions stay in the file's frame
        bpy.ops.import_anim.bvh(
            filepath=job["path"], axis_forward="Y", axis_up="Z", frame_start=1,
            use_fps_scale=False, rotate_mode="NATIVE",
        )
        frames = [1 + f for f in job["frames"]]
    arms = [o for o in scene.objects if o.type == "ARMATURE"]
    assert len(arms) == 1, [o.name for o in scene.objects]
    arm = arms[0]
    bones = {}
    for fr in frames:
        whole = math.floor(fr + 1e-6)
        scene.frame_set(whole, subframe=max(0.0, fr - whole))
        for pb in arm.pose.bones:
            head = arm.matrix_world @ pb.matrix.translation
            bones.setdefault(pb.name, []).append([head.x, head.y, head.z])
    results[job["id"]] = bones
json.dump(results, open(out_path, "w"))
"""


def find_blender() -> str | None:
    """``$MOCAPKIT_BLENDER`` if set, else ``blender`` on PATH; None when not installed."""
    return shutil.which(os.environ.get("MOCAPKIT_BLENDER") or "blender")


@dataclass
class Case:
    """One take: the motion checked, where its files went, and what Blender answered."""

    name: str
    source: Path
    orders: str
    motion: Motion
    frames: list[int]
    files: dict[str, Path] = field(default_factory=dict)
    blender: dict[str, dict[str, list[list[float]]]] = field(default_factory=dict)


def _load(source: Path) -> Motion:
    m = read_motion(source)
    return m[:MAX_FRAMES]


@pytest.fixture(scope="module")
def blender_cases(tmp_path_factory) -> dict[str, Case]:
    """Every case written (GLB, BVH) and imported by one Blender process."""
    blender = find_blender()
    require_tool(
        blender is not None,
        "MOCAPKIT_REQUIRE_BLENDER",
        "blender is not installed (apt-get install blender python3-numpy)",
    )
    from conftest import require_shared

    tmp = tmp_path_factory.mktemp("blender")
    cases: dict[str, Case] = {}
    jobs = []
    for name, dataset, file, orders in CASES:
        source = require_shared(dataset) / file
        m = _load(source)
        frames = np.linspace(0, m.num_frames - 1, CHECKED_FRAMES).round().astype(int)
        frames = sorted({int(f) for f in frames})
        case = Case(name, source, orders, m, frames)
        case.files["glb"] = write_gltf(m, tmp / f"{name}.glb")
        case.files["bvh"] = write_bvh(m, tmp / f"{name}.bvh")
        times = [float(np.float32(f * m.frame_time)) for f in frames]
        jobs.append({"id": f"{name}/glb", "kind": "gltf", "path": str(case.files["glb"]),
                     "times": times})  # fmt: skip
        jobs.append({"id": f"{name}/bvh", "kind": "bvh", "path": str(case.files["bvh"]),
                     "frames": frames})  # fmt: skip
        if source.suffix.lower() == ".bvh":
            jobs.append({"id": f"{name}/source", "kind": "bvh", "path": str(source),
                         "frames": frames})  # fmt: skip
        cases[name] = case
    (tmp / "jobs.json").write_text(json.dumps(jobs))
    (tmp / "script.py").write_text(BLENDER_SCRIPT)
    proc = subprocess.run(
        [blender, "-b", "--factory-startup", "--python", str(tmp / "script.py"), "--",
         str(tmp / "jobs.json"), str(tmp / "out.json")],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    if proc.returncode != 0 or not (tmp / "out.json").exists():
        tail = (proc.stdout + proc.stderr)[-3000:]
        pytest.fail(f"blender failed (exit {proc.returncode}):\n{tail}", pytrace=False)
    out = json.loads((tmp / "out.json").read_text())
    for name, case in cases.items():
        case.blender = {k.split("/", 1)[1]: v for k, v in out.items() if k.startswith(name + "/")}
    return cases


def _positions(case: Case, key: str) -> np.ndarray:
    """Blender's bone heads (frames, J, 3) in the order of the motion's joints."""
    bones = case.blender[key]
    names = case.motion.skeleton.names
    missing = [n for n in names if n not in bones]
    assert not missing, f"{case.name}/{key}: Blender has no bones {missing[:5]}"
    return np.array([bones[n] for n in names]).transpose(1, 0, 2)


def _worst(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b, axis=-1).max())


REPORT: dict[str, dict[str, float]] = {}


@pytest.mark.parametrize("name", [c[0] for c in CASES])
def test_blender_gltf_import_matches_fk(blender_cases, name):
    """Blender's glTF importer puts every bone head where mocapkit's FK does (in metres, +Y
    up: Blender's Z-up world turned back with (x, y, z) -> (x, z, -y))."""
    case = blender_cases[name]
    g, _, _ = gltf_space(case.motion)
    fk = mk.forward_kinematics(g)[0][case.frames]
    b = _positions(case, "glb")
    b = np.stack([b[..., 0], b[..., 2], -b[..., 1]], axis=-1)
    height = body_of(case.motion).height_m
    worst = _worst(b, fk)
    REPORT.setdefault(name, {})["glb"] = worst / height
    assert worst <= TOLERANCE * height, f"{name}: worst {worst:.3g} m of {height:.3g} m"
    # the pose moved between the frames compared: a rest pose would not pass by accident
    assert np.linalg.norm(fk[-1] - fk[0], axis=-1).max() > 10 * TOLERANCE * height


@pytest.mark.parametrize("name", [c[0] for c in CASES])
def test_blender_bvh_import_matches_fk(blender_cases, name):
    """Blender's BVH importer reads mocapkit's BVH output with every bone head where FK puts
    it; for rigs animating every joint's position, exactly as it reads the source file."""
    case = blender_cases[name]
    m = case.motion
    stature = body_of(m).stature  # file units
    b = _positions(case, "bvh")
    if np.any(m.skeleton.has_position[1:]):
        ref = _positions(case, "source")
        what = "Blender's import of the source"
    else:
        ref = mk.forward_kinematics(m)[0][case.frames]
        what = "mocapkit FK"
        if "source" in case.blender:
            src = _positions(case, "source")
            assert _worst(src, ref) <= TOLERANCE * stature, f"{name}: source vs FK"
    worst = _worst(b, ref)
    REPORT.setdefault(name, {})["bvh"] = worst / stature
    assert worst <= TOLERANCE * stature, f"{name}: worst {worst:.3g} vs {what} ({stature:.3g})"


def test_every_take_checked_by_both_importers(blender_cases, capsys):
    """Runs after the checks (file order): each take went through both importers; the worst
    differences per take are printed (a table, shown with ``pytest -s``)."""
    lines = [f"{'case':14} {'orders':32} {'frames':>6} {'glb/height':>11} {'bvh/height':>11}"]
    for name, case in blender_cases.items():
        r = REPORT.get(name, {})
        lines.append(
            f"{name:14} {case.orders:32} {len(case.frames):>6} "
            f"{r.get('glb', float('nan')):11.2e} {r.get('bvh', float('nan')):11.2e}"
        )
    with capsys.disabled():
        print("\n" + "\n".join(lines))
    unchecked = [n for n in blender_cases if set(REPORT.get(n, {})) != {"glb", "bvh"}]
    assert not unchecked, f"not checked by both importers: {unchecked}"
