"""A real consumer reads mocapkit's ``.glb``: three.js (r147, the viewer's version) with its own
``GLTFLoader`` (vendored beside three.min.js) in headless Chromium. Every bone's world position,
with the animation set to a frame's time, must match mocapkit's FK in glTF's frame (metres, +Y
up) to 1e-4 of the character's height.

Skips when no Chromium is found, unless MOCAPKIT_REQUIRE_BROWSER=1 (CI), where it fails.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
import pytest

import mocapkit as mk
from mocapkit.body import body_of
from mocapkit.io import read_motion
from mocapkit.io.gltf import gltf_space, write_gltf

pytestmark = pytest.mark.shared

STATIC = Path(mk.__file__).parent / "viz" / "static"
TOLERANCE = 1e-4  # of the character's height
MAX_FRAMES = 240
CHECKED_FRAMES = 6

CASES = [
    ("bandai", "bandai1/data", "dataset-1_bow_active_001.bvh"),
    ("cmu-asfamc", "cmu-asfamc/01", "01_02.amc"),
    ("corpus-mixed", "bvh-corpus", "VictorS-67__pybvh__bvh_test1.bvh"),
    ("corpus-zxy", "bvh-corpus", "rmGinner__Bvh-Viewer__Male1_A13_Skipping.bvh"),
    ("corpus-yxz", "bvh-corpus", "GoldNotch__AxisNeuronFakeServer__test.bvh"),
    ("corpus-xyz", "bvh-corpus",
     "PeizhuoLi__ganimator__Baseball-Milling-Idle-edited-keyframes.bvh"),
]  # fmt: skip

# poseAt(base64 GLB, times): the loader parses the file, an AnimationMixer plays its one clip
# (held at its end, not wrapped to the start), and each skin bone's world position is read.
PAGE = """<!doctype html><meta charset="utf-8"><body><script>{three}</script>
<script>{loader}</script><script>
async function poseAt(b64, times) {{
  const bin = atob(b64), buf = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) buf[i] = bin.charCodeAt(i);
  const gltf = await new Promise((ok, fail) =>
    new THREE.GLTFLoader().parse(buf.buffer, "", ok, fail));
  let skinned = null;
  gltf.scene.traverse(o => {{ if (o.isSkinnedMesh) skinned = o; }});
  const mixer = new THREE.AnimationMixer(gltf.scene);
  const action = mixer.clipAction(gltf.animations[0]);
  action.setLoop(THREE.LoopOnce, 1);
  action.clampWhenFinished = true;
  action.play();
  const v = new THREE.Vector3(), out = [];
  for (const t of times) {{
    mixer.setTime(t);
    gltf.scene.updateMatrixWorld(true);
    out.push(skinned.skeleton.bones.map(b => b.getWorldPosition(v).toArray()));
  }}
  return {{names: skinned.skeleton.bones.map(b => b.name), frames: out}};
}}
window.ready = true;
</script>"""


@pytest.fixture(scope="module")
def page_browser(tmp_path_factory):
    from testsupport import require_chromium

    from mocapkit.viz.browser import Browser, BrowserError

    require_chromium()
    page = tmp_path_factory.mktemp("threejs") / "gltf.html"
    page.write_text(
        PAGE.format(
            three=(STATIC / "three.min.js").read_text(),
            loader=(STATIC / "GLTFLoader.js").read_text(),
        )
    )
    try:
        b = Browser()
    except BrowserError as e:
        pytest.fail(f"Chromium did not start: {e}", pytrace=False)
    with b:
        b.open(page, ready="window.ready")
        yield b


@pytest.mark.parametrize("name,dataset,file", CASES, ids=[c[0] for c in CASES])
def test_threejs_pose_matches_fk(page_browser, shared_path, tmp_path, name, dataset, file):
    m = read_motion(shared_path(dataset) / file)[:MAX_FRAMES]
    frames = np.linspace(0, m.num_frames - 1, CHECKED_FRAMES).round().astype(int)
    frames = sorted({int(f) for f in frames})
    glb = write_gltf(m, tmp_path / f"{name}.glb")
    times = [float(np.float32(f * m.frame_time)) for f in frames]
    b64 = base64.b64encode(glb.read_bytes()).decode("ascii")
    res = page_browser.eval(f"poseAt({json.dumps(b64)}, {json.dumps(times)})", timeout=120)
    assert not page_browser.errors, page_browser.errors
    J = m.num_joints
    # the skin lists the joints first, in mocapkit's order (three.js strips ':' from names)
    assert len(res["names"]) >= J
    got = np.array(res["frames"])[:, :J]
    g, _, _ = gltf_space(m)
    fk = mk.forward_kinematics(g)[0][frames]
    height = body_of(m).height_m
    worst = float(np.linalg.norm(got - fk, axis=-1).max())
    print(f"\nthree.js {name}: {len(frames)} frames, worst {worst / height:.2e} of the height")
    assert worst <= TOLERANCE * height, f"{name}: worst {worst:.3g} m of {height:.3g} m"
    # the pose moved: a loader that ignored the animation would not pass by accident
    assert np.linalg.norm(fk[-1] - fk[0], axis=-1).max() > 10 * TOLERANCE * height
