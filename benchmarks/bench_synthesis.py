"""Time-series synthesis: the block/FFT evaluation against the direct cos-sum, and a 24 h trial.

Reference: Σ_n Re{H_n a_n e^{−i(ω_n t + φ_n)}} sample by sample (A2 eq. 17) for the 18 motion signals
(ξ, ξ̇, ξ̈) of a stationary 10-minute record with the sample scenario's 4,800 components. The 24 h run
(all sensor groups, 10 Hz) is timed in a fresh process so its peak memory (max RSS) is its own.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

_FULL_RUN = """
import json, resource, time, yaml
from seatune.simulate.scenario_yaml import ScenarioSpec, load_scenario
from seatune.simulate.scenario import simulate
from seatune.pipeline.vessel import open_vessel
spec, vessel = load_scenario('{scenario}')
data = spec.model_dump()
data['segments'] = [dict(kind='drift', duration=86400.0, heading_deg=40.0, heading_rate_deg_per_h=2.0,
                         speed=0.1, course_deg=90.0)]
data['sea_states'] = [dict(s, hour=float(4 * i)) for i, s in enumerate(data['sea_states'])]
data['sensors']['heave'] = dict(snr=100)
spec = ScenarioSpec.model_validate(data)
model = open_vessel(vessel)
t = time.perf_counter()
trial = simulate(spec, model)
print(json.dumps(dict(seconds=time.perf_counter() - t, samples=len(trial.time), channels=len(trial.channels),
                      streams=len(trial.streams),
                      max_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)))
"""


def run() -> dict:
    from seatune.physics.response import motion_raos_at
    from seatune.physics.synthesis import BlockPlan, amplitudes, direct_sum, draw_components, synthesize
    from seatune.pipeline.vessel import open_vessel
    from seatune.simulate.scenario import component_densities, sea_state_partitions
    from seatune.simulate.scenario_yaml import load_scenario

    scenario = ROOT / "configs/scenarios/sample_trial.yaml"
    spec, vessel = load_scenario(scenario)
    model = open_vessel(vessel)
    rng = np.random.default_rng(1)
    comps = draw_components(rng, 0.2, 2.0, spec.synthesis.components_per_direction)
    amp = amplitudes(comps, component_densities(comps, sea_state_partitions(spec))[0])
    transfer = motion_raos_at(model.db, model.base_loading, comps.omega)
    dt, n, heading = 0.1, 6000, 37.0
    plan = BlockPlan.covering(n, 8192)
    b = plan.centres.size
    start = time.perf_counter()
    fast = synthesize(dt, n, comps, plan, np.tile(amp, (b, 1)), transfer, np.full(b, heading), np.zeros((b, 2)),
                      np.zeros((b, 2)), orders=(0, 1, 2))
    seatune_s = time.perf_counter() - start

    from seatune.physics.interp import blend

    beta = np.mod(np.radians(heading - comps.dir_from_deg - 180.0), 2 * np.pi)
    d = 2 * np.pi / transfer.shape[1]
    i0 = np.floor(beta / d).astype(int) % transfer.shape[1]
    rows = np.arange(comps.omega.size)
    h = blend(transfer[rows, i0], transfer[rows, (i0 + 1) % transfer.shape[1]], ((beta - i0 * d) / d)[:, None])
    h_all = np.concatenate([h * ((-1j * comps.omega) ** q)[:, None] for q in (0, 1, 2)], axis=1)
    start = time.perf_counter()
    ref = direct_sum(np.arange(n) * dt, comps, amp, h_all)
    reference_s = time.perf_counter() - start
    rel = np.abs(fast - ref).max(axis=0) / np.abs(ref).max(axis=0)

    full = subprocess.run([sys.executable, "-c", _FULL_RUN.format(scenario=scenario)], capture_output=True,
                          text=True, check=True, cwd=ROOT)
    full = json.loads(full.stdout.strip().splitlines()[-1])
    return {
        "name": "synthesis_10min_4800_components_18_signals",
        "reference_s": round(reference_s, 3),
        "seatune_s": round(seatune_s, 4),
        "ratio": round(reference_s / seatune_s, 1),
        "max_rel_diff": float(rel.max()),
        "full_24h_10hz_s": round(full["seconds"], 1),
        "full_24h_channels": full["channels"],
        "full_24h_streams": full["streams"],
        "full_24h_max_rss_mb": round(full["max_rss_mb"]),
        "reference": "direct cos-sum over components per sample (A2 eq. 17)",
    }
