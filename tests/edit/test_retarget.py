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


def test_map_overrides_and_errors(pair):
    cmu, ban = pair
    res = retarget(cmu[:60], ban, joint_map={"Toes_L": None})
    assert "Toes_L" not in res.mapping
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
    assert out.exists() and (tmp_path / "walk_cmu.provenance.json").exists()
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
