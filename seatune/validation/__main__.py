"""`python -m seatune.validation --bank trial_bank --out validation` (`make validate`): seatune on every trial of the
blind bank (`seatune batch` on Dask), each run scored against its truth.yaml, the clean trials also tuned once more
with their true sea given (validation/true_sea.py) → bank_summary.parquet (one row per trial),
bank_metrics.parquet (the figures beside the issues' targets), confusion.parquet and index.html.

Missed targets are reported, not failed on: exit 0 when every trial could be scored, 2 with one line on bad input.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from seatune.errors import UserError

ARTEFACTS = ("tuning_history", "validation", "natural_frequencies", "diagnosis", "sea_states",
             "sea_states_diagnosed", "natural_frequencies_diagnosed")


def read_bank(bank: Path) -> list[tuple[str, Path]]:
    """(trial name, trial folder) of every run in BANK/manifest.yaml."""
    manifest = bank / "manifest.yaml"
    if not manifest.is_file():
        raise UserError(str(manifest), None, "no trial bank here: make one with `make trial-bank`")
    try:
        runs = yaml.safe_load(manifest.read_text())["runs"]
        return [(r["name"], (bank / r["path"]).parent) for r in runs]
    except (yaml.YAMLError, KeyError, TypeError) as err:
        raise UserError(str(manifest), "runs", f"not a bank manifest ({err})") from None


def read_truth(folder: Path) -> dict:
    path = folder / "truth.yaml"
    try:
        truth = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as err:
        raise UserError(str(path), None, f"cannot be read ({err})") from None
    for key in ("trial", "loading", "natural_frequencies", "effects", "vessel"):
        if not isinstance(truth, dict) or key not in truth:
            raise UserError(str(path), key, "missing")
    return truth


def run_dir(folder: Path) -> Path:
    spec = yaml.safe_load((folder / "run.yaml").read_text())
    return folder / spec.get("run_dir", "run")


def modes_by_dof(vessel, loading) -> dict[str, float]:
    """{heave, roll, pitch: coupled ω_n} of one loading condition."""
    from seatune.physics.modes import coupled_modes

    return dict(zip(("heave", "roll", "pitch"), coupled_modes(vessel.db, loading).omega[0].tolist(), strict=True))


def model_modes_at_truth(truth: dict, folder: Path, cache: dict) -> dict[str, float]:
    """The vessel model's coupled ω_n at the true loading (what the model would say with the loading known)."""
    from seatune.physics.loading import PARAMETERS
    from seatune.pipeline.vessel import open_vessel

    path = (folder / truth["vessel"]).resolve()
    if path not in cache:
        cache[path] = open_vessel(path)
    vessel = cache[path]
    return modes_by_dof(vessel, vessel.loading(**{p: truth["loading"][p] for p in PARAMETERS if p in truth["loading"]}))


def tuned_model_modes(rd: Path) -> dict[str, float] | None:
    """The coupled ω_n of the run's tuned_vessel.yaml (the model tune hands on), or None without one or when it
    cannot be opened (written before its hull files were named absolutely: tune the run again)."""
    from seatune.pipeline.vessel import open_vessel

    if not (rd / "tuned_vessel.yaml").is_file():
        return None
    try:
        vessel = open_vessel(rd / "tuned_vessel.yaml")
    except UserError:
        return None
    return modes_by_dof(vessel, vessel.base_loading)


def _reference(folder: Path):
    from seatune.validation.true_sea import true_sea_posterior

    return true_sea_posterior(folder, read_truth(folder))


def sea_read(rd: Path) -> dict[str, tuple[float, float]]:
    """{parameter: (value, std)} the run's sea fit read (`sea.read_loading`; {} without one)."""
    from seatune.io.parquet import table_metadata

    path = rd / "sea_states.parquet"
    return {k: (float(v[0]), float(v[1])) for k, v in table_metadata(path).get("read", {}).items()} \
        if path.is_file() else {}


def true_sea_references(bank: Path, workers: int) -> dict[Path, dict]:
    """{trial folder: posterior with the true sea given} of the clean trials that ran (processes, `workers`)."""
    from concurrent.futures import ProcessPoolExecutor

    folders = [f for _, f in read_bank(bank) if read_truth(f).get("category") == "clean"
               and (run_dir(f) / "tuning_history.parquet").is_file()]
    with ProcessPoolExecutor(max(workers, 1)) as pool:
        return dict(zip(folders, pool.map(_reference, folders), strict=True))


def score_bank(bank: Path, references: dict[Path, dict] | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(bank summary, per window × true partition sea scores)."""
    from seatune.validation.score import score_trial, sea_rows

    rows, sea, cache = [], [], {}
    for _, folder in read_bank(bank):
        truth = read_truth(folder)
        rd = run_dir(folder)
        arts = {a: pd.read_parquet(rd / f"{a}.parquet") if (rd / f"{a}.parquet").is_file() else None
                for a in ARTEFACTS}
        missing = [a for a in ("tuning_history", "natural_frequencies", "diagnosis") if arts[a] is None]
        if arts["natural_frequencies_diagnosed"] is not None:  # the ω_n seatune delivers, as the sea below
            arts["natural_frequencies_stage"] = arts["natural_frequencies"]
            arts["natural_frequencies"] = arts["natural_frequencies_diagnosed"]
        status, message = ("ok", "") if not missing else ("failed", f"no {', '.join(missing)} in {rd}")
        rows.append(score_trial(truth, arts, model_modes_at_truth(truth, folder, cache), status, message,
                                tuned_model_modes(rd), (references or {}).get(folder), sea_read(rd)))
        windows = pd.read_parquet(rd / "windows.parquet") if (rd / "windows.parquet").is_file() else None
        # the sea seatune delivers: refitted through the named vessel effects when diagnose named one
        final = arts["sea_states_diagnosed"] if arts["sea_states_diagnosed"] is not None else arts["sea_states"]
        for estimate, table in (("final", final), ("sea stage", arts["sea_states"])):
            sea += [{**r, "estimate": estimate} for r in sea_rows(truth, table, windows)]
    return pd.DataFrame(rows), pd.DataFrame(sea)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m seatune.validation", description=__doc__.splitlines()[0])
    ap.add_argument("--bank", default="trial_bank", type=Path)
    ap.add_argument("--out", default="validation", type=Path)
    ap.add_argument("--workers", default=2, type=int)
    ap.add_argument("--scheduler", default=None, help="tcp://HOST:PORT of a running Dask scheduler")
    ap.add_argument("--no-run", action="store_true", help="score the runs already in the bank")
    ap.add_argument("--no-reference", action="store_true",
                    help="skip the clean trials' second tune with the true sea given (the estimated sea's cost)")
    args = ap.parse_args(argv)
    try:
        from seatune.io.parquet import write_table
        from seatune.validation.page import write_page
        from seatune.validation.score import bank_metrics, confusion, sea_metrics, summary_units

        read_bank(args.bank)
        if not args.no_run:  # the same code path as a fleet batch: `seatune batch` on Dask
            cmd = [sys.executable, "-m", "seatune", "batch", str(args.bank / "manifest.yaml"),
                   "--workers", str(args.workers), "--out", str(args.out / "fleet"), "--until", "diagnose"]
            if args.scheduler:
                cmd += ["--scheduler", args.scheduler]
            done = subprocess.run(cmd)
            if done.returncode == 2:
                return 2
        references = true_sea_references(args.bank, args.workers) if not args.no_reference else None
        summary, sea = score_bank(args.bank, references)
        metrics = pd.concat([bank_metrics(summary), *(sea_metrics(sea[sea["estimate"] == e], e)
                                                      for e in ("final", "sea stage") if len(sea))],
                            ignore_index=True)
        conf = confusion(summary)
        args.out.mkdir(parents=True, exist_ok=True)
        write_table(summary, args.out / "bank_summary.parquet", summary_units(summary.columns))
        write_table(metrics, args.out / "bank_metrics.parquet",
                    {"metric": "", "group": "", "value": "per row; see metric", "n": "",
                     "target": "per row; see metric", "passed": ""})
        if not sea.empty:
            write_table(sea, args.out / "sea_scores.parquet",
                        {c: ("m" if c in ("truth_hs", "false_hs") else "s" if c == "truth_tp" else
                             "deg" if c.endswith("deg") else "") for c in sea.columns})
        c = conf.reset_index()
        write_table(c, args.out / "confusion.parquet", {k: "" for k in c.columns})
        page = write_page(args.out / "index.html", summary, metrics, conf)
    except UserError as err:
        print(f"seatune: error: {err}", file=sys.stderr)
        return 2
    ok = summary["status"] == "ok"
    print(f"validate: {int(ok.sum())} of {len(summary)} trials scored → {page}")
    expected = metrics[metrics["metric"] == "parameter_within_tolerance_clean_expected"].set_index("group")["value"]
    for r in metrics[metrics["target"].notna()].itertuples():
        mark = "–" if r.passed is None or (isinstance(r.passed, float) and np.isnan(r.passed)) else (
            "pass" if r.passed else "MISS")
        reach = (f"; a calibrated posterior's {expected[r.group]:.3f}"
                 if r.metric == "parameter_within_tolerance_clean" and r.group in expected else "")
        print(f"  {r.metric:<30} {r.group:<34} {r.value:8.3f} (n={r.n}, target {r.target:g}{reach}) {mark}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
