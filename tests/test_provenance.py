"""Provenance sidecars: file paths stored relative to the sidecar, read back from anywhere."""

from __future__ import annotations

import json
import os
from pathlib import Path

from mocapkit.provenance import Provenance, Segment, TransitionTaken, find_provenance


def test_paths_are_relative_to_the_sidecar_and_read_back_from_any_folder(tmp_path, monkeypatch):
    work = tmp_path / "work"
    (work / "clips").mkdir(parents=True)
    (work / "out").mkdir()
    for n in ("a.bvh", "b.bvh"):
        (work / "clips" / n).write_text("x")
    monkeypatch.chdir(work)  # the tool ran here, with paths as the user typed them
    prov = Provenance(
        "stitch", "out/walk.bvh", 30.0, 20, ["clips/a.bvh", "clips/b.bvh", "api_clip"],
        {"library": ["clips/b.bvh"], "up": "Y", "blended_from": [{"source": "clips/b.bvh"}]},
        [Segment(0, 10, "clip", "clips/a.bvh", 0, 10), Segment(10, 20, "clip", "api_clip", 3, 13)],
        [TransitionTaken(10, "clips/a.bvh", 9, "api_clip", 3, 0.5)],
    )  # fmt: skip
    (work / "out" / "walk.bvh").write_text("x")
    side = prov.write("out/walk.bvh")
    data = json.loads(side.read_text())
    assert data["output"] == "./walk.bvh"
    assert data["inputs"] == ["../clips/a.bvh", "../clips/b.bvh", "api_clip"]  # a name stays
    assert data["segments"][0]["source"] == "../clips/a.bvh"
    assert data["transitions"][0]["source"] == "../clips/a.bvh"
    assert data["transitions"][0]["target"] == "api_clip"
    assert data["parameters"]["library"] == ["../clips/b.bvh"]
    assert data["parameters"]["blended_from"][0]["source"] == "../clips/b.bvh"
    assert data["parameters"]["up"] == "Y"
    # read from another folder: the paths lead to the same files
    monkeypatch.chdir(tmp_path)
    back = find_provenance(work / "out" / "walk.bvh")
    assert back is not None
    assert [Path(p).resolve() for p in back.inputs[:2]] == [
        (work / "clips" / n).resolve() for n in ("a.bvh", "b.bvh")
    ]
    assert back.inputs[2] == "api_clip" and back.transitions[0].target == "api_clip"
    assert Path(back.segments[0].source).resolve() == (work / "clips" / "a.bvh").resolve()
    assert os.path.exists(back.output) and not os.path.isabs(back.output)
    # a path the user gave absolute stays absolute
    monkeypatch.chdir(work)
    absolute = str((work / "clips" / "a.bvh").resolve())
    prov.inputs[0] = absolute
    data = json.loads(prov.write("out/walk.bvh").read_text())
    assert data["inputs"][0] == absolute and data["inputs"][1] == "../clips/b.bvh"


def test_keys_a_later_version_adds_are_ignored(tmp_path):
    side = tmp_path / "x.bvh.provenance.json"
    side.write_text(json.dumps({
        "format": "mocapkit-provenance-1", "tool": "inbetween", "output": "./x.bvh",
        "fps": 30.0, "frames": 10, "inputs": [], "parameters": {}, "future": 1,
        "segments": [{"output_start": 0, "output_stop": 10, "kind": "clip", "backwards": True}],
        "transitions": [{"output_frame": 5, "source": "a", "source_frame": 1, "target": "b",
                         "target_frame": 2, "cost": 1.0, "weight": 3}],
    }))  # fmt: skip
    (tmp_path / "x.bvh").write_text("x")
    prov = find_provenance(tmp_path / "x.bvh")
    assert prov is not None and prov.segments[0].kind == "clip"
    assert prov.transitions[0].cost == 1.0
