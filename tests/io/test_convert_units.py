"""convert --units: lengths rescaled from the unit the file states (ASF) or the guess."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from mocapkit.body import body_of
from mocapkit.cli import main
from mocapkit.io import read_motion


@pytest.mark.shared
@pytest.mark.parametrize(("units", "mpu"), [("cm", 0.01), ("m", 1.0), ("inch", 0.0254)])
def test_cmu_to_bvh_keeps_the_height(units, mpu, shared_path, tmp_path) -> None:
    amc = shared_path("cmu-asfamc/01/01_01.amc")
    out = tmp_path / f"cmu_{units}.bvh"
    r = CliRunner().invoke(main, ["convert", str(amc), str(out), "--units", units])
    assert r.exit_code == 0, r.output
    src = body_of(read_motion(amc))
    back = read_motion(out)
    assert back.skeleton.metres_per_unit is None  # BVH states no unit
    # the file's lengths are now in the chosen unit: its stature in that unit is the source's
    assert body_of(back).stature * mpu == pytest.approx(src.height_m, rel=1e-6)


@pytest.mark.shared
def test_cmu_to_bvh_without_units_warns_that_the_unit_is_lost(shared_path, tmp_path) -> None:
    amc = shared_path("cmu-asfamc/01/01_01.amc")
    r = CliRunner().invoke(main, ["convert", str(amc), str(tmp_path / "raw.bvh")])
    assert r.exit_code == 0
    assert "--units" in r.output
    # every command that writes the take as BVH says so (the writer warns), not convert alone
    r = CliRunner().invoke(main, ["edit", str(amc), str(tmp_path / "e.bvh"), "--trim", "0:20"])
    assert r.exit_code == 0 and "cannot be stated in a BVH file" in r.output, r.output
    # and a --json result says so too (newcomer report: on standard error only)
    r = CliRunner().invoke(
        main, ["edit", str(amc), str(tmp_path / "j.bvh"), "--trim", "0:20", "--json"]
    )
    assert r.exit_code == 0
    said = json.loads(r.stdout)["warnings"]
    assert any("cannot be stated in a BVH file" in w for w in said), said
    r = CliRunner().invoke(main, ["edit", str(amc), str(tmp_path / "e.npz"), "--trim", "0:20"])
    assert r.exit_code == 0 and "cannot be stated" not in r.output, r.output
    r = CliRunner().invoke(main, ["convert", str(amc), str(tmp_path / "cm.bvh"), "--units", "cm"])
    assert r.exit_code == 0 and "cannot be stated" not in r.output, r.output
    # a scale to centimetres typed by hand (seven digits) is centimetres
    r = CliRunner().invoke(
        main, ["convert", str(amc), str(tmp_path / "s.bvh"), "--scale", "5.644444"]
    )
    assert r.exit_code == 0 and "cannot be stated" not in r.output, r.output
    bad = CliRunner().invoke(
        main, ["convert", str(amc), str(tmp_path / "x.bvh"), "--units", "cm", "--scale", "2"]
    )
    assert bad.exit_code == 2 and "not both" in bad.output


@pytest.mark.shared
def test_bvh_in_cmu_units_is_guessed_back_at_its_height(shared_path, tmp_path) -> None:
    """A BVH kept in the CMU ASF unit (mocapkit's own convert without --units, and the BVH
    conversions of CMU takes in the wild) reads back at the person's height, not as inches."""
    from mocapkit.features import detect_units

    amc = shared_path("cmu-asfamc/01/01_01.amc")
    out = tmp_path / "raw.bvh"
    assert CliRunner().invoke(main, ["convert", str(amc), str(out)]).exit_code == 0
    src = body_of(read_motion(amc)).height_m
    for path in (out, shared_path("bvh-corpus/facebookresearch__fairmotion__01_01.bvh"),
                 shared_path("bvh-corpus/BartekkPL__bvh-parser__walk_01.bvh")):  # fmt: skip
        m = read_motion(path)
        name, _ = detect_units(m)
        assert name == "cmu", path
        assert 1.4 <= body_of(m).height_m <= 2.0, path
    assert body_of(read_motion(out)).height_m == pytest.approx(src, rel=1e-6)


@pytest.mark.shared
def test_folder_conversion_names_the_take_each_warning_is_about(shared_path, tmp_path) -> None:
    """Four CMU takes converted to BVH in folder mode: each output's lost unit is warned on its
    own line naming it (newcomer report: one line naming none of them), in-process and the
    same on a Dask cluster of one worker."""
    folder = shared_path("cmu-asfamc/03")
    takes = sorted(p.name for p in folder.glob("*.amc"))
    assert len(takes) == 4
    for extra in ([], ["--workers", "1"]):
        out = tmp_path / f"out{len(extra)}"
        r = CliRunner().invoke(main, ["convert", str(folder), "--out-dir", str(out), "--to",
                                      "bvh", *extra])  # fmt: skip
        assert r.exit_code == 0, r.output
        lines = [x for x in r.stderr.splitlines() if "cannot be stated in a BVH file" in x]
        assert len(lines) == 4, r.stderr
        for take, line in zip(takes, sorted(lines), strict=True):
            written = out / take.replace(".amc", ".bvh")
            assert line.startswith(f"mocapkit: warning: {written}: the take's unit"), line
