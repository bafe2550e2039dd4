"""Joint names, End Site labels and file names are data, never markup: the inlined JSON escapes
``<``, ``>``, ``&``, U+2028 and U+2029, so no name can end the data ``<script>`` or open a
comment in it, and the page still loads (headless Chromium, when found)."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import pytest
from testsupport import require_chromium

from mocapkit.viz import ViewMotion, write_page
from mocapkit.viz.browser import Browser
from mocapkit.viz.viewer import script_json

from .helpers import random_motion

HOSTILE = (
    "<!--<script>",
    "</script><script>window.__pwned = 1</script>",
    "a&amp;b<b>",
    "line\u2028sep\u2029end",
    "]]>",
    "Head",
)
FILE_NAME = "[bold]</title><script>window.__pwned = 2</script>.bvh"


def _hostile_page(tmp_path: Path) -> Path:
    m = random_motion(40)
    sk = replace(m.skeleton, names=HOSTILE)
    motion = replace(m, skeleton=sk)
    return write_page(tmp_path / "hostile.html", [ViewMotion(motion, FILE_NAME)])


def _data_blob(html: str) -> str:
    m = re.search(r'<script type="application/json" id="mocapkit-data">(.*?)</script>', html, re.S)
    assert m, "no data script"
    return m.group(1)


def test_script_json_is_the_same_json() -> None:
    text = json.dumps({"n": list(HOSTILE)}, ensure_ascii=False)
    safe = script_json(text)
    assert not set("<>&\u2028\u2029") & set(safe)
    assert json.loads(safe) == json.loads(text)


def test_inline_data_cannot_end_its_script(tmp_path: Path) -> None:
    html = _hostile_page(tmp_path).read_text(encoding="utf-8")
    blob = _data_blob(html)
    assert "<" not in blob and ">" not in blob and "&" not in blob
    data = json.loads(blob)
    assert data["motions"][0]["names"][: len(HOSTILE)] == list(HOSTILE)
    assert data["motions"][0]["name"] == FILE_NAME
    title = re.search(r"<title>(.*?)</title>", html, re.S).group(1)
    assert "<" not in title  # the file name in the title is escaped too


@pytest.fixture(scope="module")
def browser():
    require_chromium()
    with Browser(width=900, height=700) as b:
        yield b


def test_page_with_hostile_names_loads(browser, tmp_path: Path) -> None:
    page = _hostile_page(tmp_path)
    browser.errors.clear()
    browser.open(page, ready="window.mocapkitViewer && window.mocapkitViewer.ready")
    assert browser.errors == []
    assert browser.eval("window.__mkErrors") == []
    assert browser.eval("typeof window.__pwned") == "undefined"
    names = browser.eval(
        "JSON.parse(document.getElementById('mocapkit-data').textContent).motions[0].names"
    )
    assert names[: len(HOSTILE)] == list(HOSTILE)
    assert browser.eval("document.title") == f"mocapkit view: {Path(FILE_NAME).name}"
