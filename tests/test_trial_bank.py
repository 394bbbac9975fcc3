"""The trial bank (issue 15): the ci subset generates, its manifest is a seatune batch manifest and the contract
files are complete; regeneration is bit-identical (slow: ~1 min on 2 cores)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
import yaml

from seatune.simulate.independent.bank import build, definitions

CONTRACT_TRUTH = {"trial", "seed", "hull", "vessel", "category", "effects", "loading", "natural_frequencies",
                  "hindcast", "windows"}


def _hashes(root: Path) -> dict:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.slow
def test_ci_bank_contract_and_bit_identical_regeneration(tmp_path):
    from seatune.io.manifest_yaml import read_manifest

    build(tmp_path / "a", "ci", workers=2)
    build(tmp_path / "b", "ci", workers=2)
    assert _hashes(tmp_path / "a") == _hashes(tmp_path / "b")
    man = read_manifest(tmp_path / "a" / "manifest.yaml")
    assert [r.name for r in man.runs] == [d["trial"] for d in definitions("ci")]
    for d in definitions("ci"):
        tdir = tmp_path / "a" / d["trial"]
        truth = yaml.safe_load((tdir / "truth.yaml").read_text())
        assert CONTRACT_TRUTH <= set(truth) and truth["trial"] == d["trial"]
        assert len(truth["windows"]) == 3
        assert (tdir / truth["vessel"]).resolve().exists()
        run = yaml.safe_load((tdir / "run.yaml").read_text())
        assert run["run_dir"] == "run" and run["tuning"]["backend"] == "dbi"
        assert set(run["identify"]["known"]) == {"mass", "zcg"}
