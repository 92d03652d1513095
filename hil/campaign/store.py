"""The campaign folder: a manifest and one file per finished chunk, each written atomically.

Layout::

    FOLDER/campaign.json        what the campaign is (its identity) — a rerun must match it
    FOLDER/chunks/00012.npz     the arrays chunk 12 returned (temp file + rename: never partial)

A rerun with the same identity skips every chunk whose file exists; a rerun with another identity
is refused (one line naming the folder) so results of two campaigns are never mixed.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from hil.errors import InputError

MANIFEST = "campaign.json"


class CampaignStore:
    """Reads and writes the chunk files of one campaign folder."""

    def __init__(self, folder: str | Path, identity: dict[str, Any]) -> None:
        self.folder = Path(folder)
        self.identity = json.loads(json.dumps(identity, sort_keys=True, default=str))
        self.chunks_dir = self.folder / "chunks"

    def open(self) -> None:
        """Create the folder, or check that an existing one holds this same campaign."""
        manifest = self.folder / MANIFEST
        if manifest.exists():
            try:
                found = json.loads(manifest.read_text())
            except (OSError, ValueError) as exc:
                raise InputError(f"campaign folder {self.folder}: unreadable {MANIFEST} ({exc})") \
                    from None
            if found.get("identity") != self.identity:
                changed = sorted(k for k in set(found.get("identity", {})) | set(self.identity)
                                 if found.get("identity", {}).get(k) != self.identity.get(k))
                raise InputError(f"campaign folder {self.folder} holds another campaign "
                                 f"(differs in: {', '.join(changed) or 'format'}); "
                                 "use an empty folder")
        else:
            self.folder.mkdir(parents=True, exist_ok=True)
            write_atomic(manifest, json.dumps({"identity": self.identity}, indent=2).encode())
        self.chunks_dir.mkdir(exist_ok=True)

    def path(self, index: int) -> Path:
        return self.chunks_dir / f"{index:05d}.npz"

    def finished(self, count: int) -> set[int]:
        """Indices below ``count`` whose chunk file exists."""
        return {i for i in range(count) if self.path(i).exists()}

    def save(self, index: int, arrays: dict[str, np.ndarray]) -> None:
        """Write chunk ``index`` atomically (a crash leaves the old state, never half a file)."""
        if not isinstance(arrays, dict) or not arrays:
            raise TypeError(f"chunk {index}: a campaign task must return a non-empty dict of "
                            f"arrays, got {type(arrays).__name__}")
        fd, tmp = tempfile.mkstemp(dir=self.chunks_dir, prefix=f".{index:05d}-", suffix=".npz")
        try:
            with os.fdopen(fd, "wb") as handle:
                np.savez(handle, **{k: np.asarray(v) for k, v in arrays.items()})
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(tmp, self.path(index))
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

    def load(self, index: int) -> dict[str, np.ndarray]:
        with np.load(self.path(index), allow_pickle=False) as data:
            return {key: data[key] for key in data.files}


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temp file in the same folder and a rename."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}-")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
