"""Resume for library jobs: a manifest entry per item records what went in (sha256 of the
item's file, of its context files, the job's configuration and the mocapkit version) and what
came out (each output's sha256). A rerun skips an item whose entry matches its inputs and whose
outputs are all present with the recorded hashes; anything else is redone.

Entries live in one folder (``<report dir>/.mocapkit-manifest/``), one small JSON file per
item, written atomically after the item's outputs: an item interrupted half-way has no entry
(or an old one whose hashes no longer match) and is redone.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["MANIFEST_DIR", "Manifest", "file_sha256", "input_key"]

MANIFEST_DIR = ".mocapkit-manifest"


def file_sha256(path: str | Path, chunk: int = 1 << 20) -> str:
    """sha256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while b := f.read(chunk):
            h.update(b)
    return h.hexdigest()


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True)


def input_key(
    item: str,
    item_hash: str,
    context: Sequence[tuple[str, str]],
    config: Mapping[str, Any],
    version: str | None = None,
) -> str:
    """The sha256 identifying one item's inputs: its name and file hash, its context files'
    names and hashes (in order), the configuration (canonical JSON) and the mocapkit
    version."""
    if version is None:
        from mocapkit import __version__ as version
    blob = _canonical(
        {
            "item": item,
            "sha256": item_hash,
            "context": [list(c) for c in context],
            "config": dict(config),
            "mocapkit": version,
        }
    )
    return hashlib.sha256(blob.encode()).hexdigest()


@dataclass(frozen=True)
class Manifest:
    """The entries of one job's output, kept in ``root/.mocapkit-manifest``."""

    root: Path

    @property
    def folder(self) -> Path:
        return Path(self.root) / MANIFEST_DIR

    def entry_path(self, item: str) -> Path:
        safe = item.replace("\\", "/").strip("/")
        return self.folder / f"{safe}.json"

    def _relative(self, path: str | Path) -> str:
        """An output's path relative to the manifest's folder (POSIX), so that an entry holds
        however the paths are spelled and from whichever folder the job is run."""
        return Path(os.path.relpath(Path(path).resolve(), Path(self.root).resolve())).as_posix()

    def _resolve(self, recorded: str) -> Path:
        return Path(self.root) / recorded

    def load(self, item: str) -> dict[str, Any] | None:
        try:
            return json.loads(self.entry_path(item).read_text())
        except (OSError, ValueError):
            return None

    def is_complete(self, item: str, key: str) -> dict[str, Any] | None:
        """The entry of ``item`` when its inputs key is ``key`` and every output it lists is
        present with its recorded sha256; else None (the item must be done again)."""
        entry = self.load(item)
        if entry is None or entry.get("key") != key:
            return None
        for path, digest in entry.get("outputs", {}).items():
            p = self._resolve(path)
            try:
                if not p.is_file() or file_sha256(p) != digest:
                    return None
            except OSError:
                return None
        return entry

    def outputs(self) -> set[Path]:
        """Every output the entries record (resolved paths): the files earlier runs of a job
        wrote here, which a later job over the folder must not take for inputs."""
        out: set[Path] = set()
        if not self.folder.is_dir():
            return out
        for entry in self.folder.rglob("*.json"):
            try:
                paths = json.loads(entry.read_text()).get("outputs", {})
            except (OSError, ValueError, AttributeError):
                continue
            out.update(self._resolve(p).resolve() for p in paths)
        return out

    def record(
        self, item: str, key: str, outputs: Sequence[str | Path], result: Any = None
    ) -> Path:
        """Write ``item``'s entry (atomically): its key, its outputs' hashes, and ``result``
        (what the job needs to rebuild its summary without redoing the item)."""
        from mocapkit.io.atomic import atomic_write_text

        entry = {
            "item": item,
            "key": key,
            "outputs": {self._relative(p): file_sha256(p) for p in outputs},
            "result": result,
        }
        # not key-sorted: ``result`` comes back with its keys in the order written
        text = json.dumps(entry, separators=(",", ":"), ensure_ascii=True)
        return atomic_write_text(self.entry_path(item), text + "\n")
