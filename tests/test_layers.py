"""The package layering of README § Layout: no module imports a package above its own (issue 18)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import seatune

ROOT = Path(seatune.__file__).parent
README = ROOT.parent / "README.md"


def _layers() -> list[list[str]]:
    """The layer order as README's Layout section states it: `layers: a · b, c · …` (bottom first)."""
    text = README.read_text(encoding="utf-8")
    m = re.search(r"^Layers, bottom first: (.+)$", text, flags=re.M)
    assert m, "README's Layout section lost its 'Layers, bottom first:' line"
    return [[p.strip(" `.") for p in layer.split(",")] for layer in m.group(1).split("<")]


def _module(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Every seatune module this file imports, at the top or inside functions."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("seatune"):
            out |= {f"{node.module}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("seatune")}
    return out


def _unit(module: str, units: list[str]) -> str | None:
    """The longest layer unit (`seatune.io`, `seatune.errors`, …) that `module` is in or under."""
    hits = [u for u in units if module == u or module.startswith(u + ".")]
    return max(hits, key=len) if hits else None


def test_no_module_imports_a_layer_above_its_own():
    layers = _layers()
    rank = {f"seatune.{u}": i for i, layer in enumerate(layers) for u in layer}
    units = list(rank)
    upward, unplaced = [], []
    for path in sorted(ROOT.rglob("*.py")):
        mod = _module(path)
        if mod == "seatune":
            continue
        own = _unit(mod, units)
        if own is None:
            unplaced.append(mod)
            continue
        for target in _imports(path):
            tgt = _unit(target, units) if target != "seatune" else None
            if tgt is not None and rank[tgt] > rank[own]:
                upward.append(f"{mod} → {target}")
    assert not unplaced, f"modules in no layer of README's Layout: {unplaced}"
    assert not upward, "upward imports:\n" + "\n".join(upward)


def test_the_independent_trial_path_shares_no_modelling_code():
    """seatune.simulate.independent makes the blind-validation trials: it may share the file writers, never the
    estimator's physics, identification, diagnosis, tuning or stages, nor seatune's own simulator."""
    allowed = ("seatune.simulate.independent", "seatune.simulate.log_writers", "seatune.atomic", "seatune.errors")
    bad = []
    for path in sorted((ROOT / "simulate" / "independent").rglob("*.py")):
        for target in _imports(path):
            if not target.startswith(allowed) and target != "seatune":
                bad.append(f"{_module(path)} → {target}")
    assert not bad, bad
