"""`seatune run` on a simulated 24 h, 10 Hz day (the issue's speed target: the whole run under 60 s on 2 cores),
with each stage's share, against the same run on one worker process per stage (SEATUNE_WORKERS=1, the reference:
the stages' tasks in a loop), and the SDOF resonance fit identify calls ~1000 times on it.

Day: `bench_simulate_day.day_scenario` (the sample vessel drifting 24 h at 0.1 m/s through the sample's sea
states), its own ERA5 file as the hindcast, the sample run's settings. The run is a fresh process. Ratio: the
SDOF fit with its analytic Jacobian against the same trust-region fit with scipy's finite-difference Jacobian
(the implementation before), on identical noisy resonance curves; their ω_n must agree.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from benchmarks.bench_simulate_day import day_run_yaml, day_scenario
from benchmarks.timing import best_of
from seatune.parallel import WORKERS_ENV
from seatune.parallel import workers as workers_available

ROOT = Path(__file__).resolve().parents[1]


def _curves(n: int = 200, seed: int = 3):
    from seatune.identification.natural_frequency import sdof_amplitude

    rng = np.random.default_rng(seed)
    omega = np.linspace(0.2, 1.2, 120)
    for _ in range(n):
        wn, zeta = rng.uniform(0.35, 0.95), rng.uniform(0.03, 0.25)
        amp = sdof_amplitude(omega, wn, zeta, 1.0) * np.exp(0.1 * rng.standard_normal(omega.size))
        yield omega, amp, amp * np.exp(-0.2), amp * np.exp(0.2), wn


def _finite_difference_fit(omega, amp, lo, hi, guess):
    from scipy import optimize, stats

    from seatune.identification.natural_frequency import _half_power_zeta, sdof_amplitude

    mask = (omega >= guess * 0.7) & (omega <= guess * 1.3)
    x, y = omega[mask], amp[mask]
    k = int(np.argmax(y))
    z0 = _half_power_zeta(x, y, k)
    p0 = np.array([guess, z0, y[k] * 2 * z0])
    sig = (np.log(hi[mask]) - np.log(lo[mask])) / (2 * stats.norm.ppf(0.975))
    lb, ub = np.array([x.min() * 0.5, 1e-6, 0.0]), np.array([x.max() * 2.0, 2.0, np.inf])
    p0 = np.clip(p0, lb * 1.0001 + 1e-12, np.where(np.isfinite(ub), ub * 0.9999, np.inf))
    sol = optimize.least_squares(lambda p: (np.log(sdof_amplitude(x, *p)) - np.log(y)) / sig, p0, bounds=(lb, ub),
                                 x_scale=p0.copy(), method="trf", xtol=1e-12, ftol=1e-12)
    return sol.x[0]


def _sdof_ratio() -> dict:
    from seatune.identification.natural_frequency import fit_sdof

    curves = list(_curves())
    ref_s, ref = best_of(lambda: [_finite_difference_fit(o, a, lo, hi, wn) for o, a, lo, hi, wn in curves], 2)
    our_s, ours = best_of(lambda: [fit_sdof(o, a, lo, hi, omega_guess=wn).omega_n for o, a, lo, hi, wn in curves], 3)
    return {"sdof_fits": len(curves), "sdof_reference_s": round(ref_s, 3), "sdof_seatune_s": round(our_s, 3),
            "sdof_ratio": round(ref_s / our_s, 1),
            "sdof_max_rel_diff_omega_n": float(np.max(np.abs(np.array(ours) / np.array(ref) - 1)))}


def run() -> dict:
    out = {"name": "day_run_24h"}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        scenario = day_scenario(tmp)
        subprocess.run([sys.executable, "-m", "seatune", "simulate", str(scenario), "--out", str(tmp / "day")],
                       capture_output=True, text=True, check=True, cwd=ROOT)
        day = tmp / "day"
        run_yaml = day_run_yaml(day, tmp / "run")
        (tmp / "run.yaml").write_text(yaml.safe_dump(run_yaml, sort_keys=False))
        for label, workers in (("serial", "1"), ("", "")):  # the reference first: one worker process per stage
            shutil.rmtree(tmp / "run", ignore_errors=True)
            env = {**os.environ, WORKERS_ENV: workers} if workers else {
                k: v for k, v in os.environ.items() if k != WORKERS_ENV}
            t = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "seatune", "run", str(tmp / "run.yaml")], capture_output=True,
                                  text=True, check=True, cwd=ROOT, env=env)
            key = f"run_{label}_s" if label else "run_s"
            out[key] = round(time.perf_counter() - t, 1)
            for stage, seconds in re.findall(r"^(\w+): .*\((\d+) s\)", done.stdout, flags=re.M):
                out[f"{stage}_{label}_s" if label else f"{stage}_s"] = int(seconds)
    out["workers"] = workers_available()
    out["ratio_serial_to_workers"] = round(out["run_serial_s"] / out["run_s"], 2)
    out["log_hours_per_run_minute"] = round(24.0 / (out["run_s"] / 60.0), 1)
    out.update(_sdof_ratio())
    return out
