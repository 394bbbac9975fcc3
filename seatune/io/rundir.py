"""Run-directory bookkeeping: an artefact is fresh when its recorded fingerprint (hash of the stage's
input files and settings) matches; a stage whose artefacts are fresh is skipped (DESIGN §1)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pyarrow.parquet as pq


def file_digest(path: Path) -> str:
    h = hashlib.sha256()
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    for f in files:
        with open(f, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    return h.hexdigest()


def fingerprint(inputs: list[Path], settings: dict) -> str:
    h = hashlib.sha256(json.dumps(settings, sort_keys=True, default=str).encode())
    for p in inputs:
        h.update(str(p.name).encode())
        h.update(file_digest(p).encode())
    return h.hexdigest()[:20]


def recorded_fingerprint(artefact: Path) -> str | None:
    if not artefact.exists():
        return None
    try:
        meta = pq.ParquetFile(artefact).metadata.metadata or {}  # file key-value: set by table_writer too
        return json.loads(meta.get(b"seatune", b"{}")).get("fingerprint")
    except (OSError, ValueError):
        return None  # unreadable: treat as stale


def is_fresh(artefacts: list[Path], fp: str) -> bool:
    return all(recorded_fingerprint(a) == fp for a in artefacts)
