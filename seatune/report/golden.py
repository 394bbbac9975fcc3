"""Golden regression: the key figures of a run (summary.parquet) against a committed JSON, each figure with
its stated tolerance. `make golden` regenerates tests/golden/sample_summary.json after a deliberate change:

    python -m seatune.report.golden runs/sample/summary.parquet tests/golden/sample_summary.json

Tolerances (first matching rule): counts and names exact; durations 0.1 %; natural frequencies (measured,
prior and tuned model) 1 %; derived displacement / r44 / GM 2 % (their std 10 %); posterior means within
0.05 prior std (15 % more added mass moves r44 by 0.1 prior std); posterior std 10 %;
held-out σ errors 0.02 absolute. The margins absorb BLAS / platform rounding, not a change of the model.
"""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

import pandas as pd

RULES: list[tuple[str, dict, str]] = [
    (r"run|vessel|backend", {"exact": True}, "names"),
    (r"samples|records|defects_repaired|truncated_logs|windows_\w+|train_windows|holdout_windows",
     {"exact": True}, "counts"),
    (r"hours_logged|accepted_minutes", {"rel": 1e-3}, "durations"),
    (r"omega_n_\w+", {"rel": 0.01}, "natural frequencies: 1 %"),
    (r"derived_\w+_std", {"rel": 0.10}, "std of a derived loading parameter"),
    (r"derived_\w+", {"rel": 0.02}, "loading parameter derived from a natural frequency"),
    (r"prior_(mean|std)_\w+", {"rel": 1e-9}, "the vessel YAML's priors"),
    (r"posterior_mean_(\w+)", {"prior_std_fraction": 0.05}, "posterior mean within 0.05 prior std"),
    (r"posterior_std_\w+", {"rel": 0.10}, "posterior std"),
    (r"holdout_sigma_error_\w+", {"abs": 0.02}, "mean |ln(predicted/measured)| on held-out windows"),
]
SKIP = ("seatune_version",)  # changes with every release, not with the physics


def _rule(name: str) -> tuple[dict, str] | None:
    for pattern, tol, why in RULES:
        if re.fullmatch(pattern, name):
            return tol, why
    return None


def _plain(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v.item() if hasattr(v, "item") else v


def make_golden(row: dict) -> dict:
    """The golden JSON of a summary row: {figure: {value, tolerance, why}} for every figure a rule covers."""
    figures = {}
    for name, value in row.items():
        rule = _rule(name)
        if name in SKIP or rule is None:
            continue
        tol, why = dict(rule[0]), rule[1]
        if "prior_std_fraction" in tol:  # posterior means: an absolute tolerance in the parameter's unit
            tol = {"abs": tol["prior_std_fraction"] * float(row[name.replace("posterior_mean_", "prior_std_")])}
        figures[name] = {"value": _plain(value), "tolerance": tol, "why": why}
    return {"about": "Key figures of the sample run (configs/runs/sample.yaml on sample_logs/) with their "
                     "tolerances; tests/test_report.py compares a fresh run against them. Regenerate with "
                     "`make golden` after a deliberate change, and say why in the commit.",
            "figures": figures}


def compare(row: dict, golden: dict) -> list[str]:
    """One line per figure outside its tolerance (empty when the run matches)."""
    out = []
    for name, spec in golden["figures"].items():
        if name not in row:
            out.append(f"{name}: missing from the summary")
            continue
        want, got, tol = spec["value"], _plain(row[name]), spec["tolerance"]
        if want is None or got is None:
            if (want is None) != (got is None):
                out.append(f"{name}: {got} (golden {want})")
            continue
        if tol.get("exact"):
            ok = got == want
        else:
            err = abs(float(got) - float(want))
            ok = err <= tol.get("abs", 0.0) + tol.get("rel", 0.0) * abs(float(want))
        if not ok:
            out.append(f"{name}: {got!r} (golden {want!r}, tolerance {tol})")
    return out


def read_summary(path: str | Path) -> dict:
    return pd.read_parquet(path).iloc[0].to_dict()


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: python -m seatune.report.golden SUMMARY.parquet GOLDEN.json", file=sys.stderr)
        return 2
    golden = make_golden(read_summary(argv[0]))
    Path(argv[1]).parent.mkdir(parents=True, exist_ok=True)
    lines = ",\n".join(f"    {json.dumps(k)}: {json.dumps(v, ensure_ascii=False)}"
                        for k, v in golden["figures"].items())
    text = f'{{\n  "about": {json.dumps(golden["about"], ensure_ascii=False)},\n  "figures": {{\n{lines}\n  }}\n}}\n'
    from seatune.atomic import atomic_path

    with atomic_path(argv[1]) as tmp:
        tmp.write_text(text)  # one line per figure: a regenerated file diffs figure by figure
    print(f"golden: {len(golden['figures'])} figures → {argv[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
