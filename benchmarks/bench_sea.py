"""The sea estimate of one 40-min window of the sample vessel (pipeline.sea.estimate_window, issue 16: < 1 s).

Data: the default sea channels of the sample's IMU (roll, pitch, yaw rate, three specific forces) synthesised from
the model's RAOs on the database's directions in a two-partition sea plus a swell the
"hindcast" prior lacks (random phases, 10 Hz). Reference: the same fit with scipy's 2-point Jacobian (a whole
residual evaluation per column) and the model cross-spectra summed direction by direction in a Python loop (what
Φ = Σ_D H Hᴴ S ΔD reads as), instead of the batched Jacobian and one batched product.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.timing import best_of

ROOT = Path(__file__).resolve().parents[1]
IMU = ["roll", "pitch", "roll_rate", "pitch_rate", "yaw_rate", "imu_fx", "imu_fy", "imu_fz"]


def _loop_cross_spectra(g, wave):
    out = np.zeros(g.shape[:1] + g.shape[2:])
    for d in range(wave.shape[1]):
        out += g[:, d] * wave[:, d, None]
    return out * 2 * np.pi / wave.shape[1]


def _scipy_jacobian(self, x, priors, lower, upper):
    from scipy.optimize._numdiff import approx_derivative

    return approx_derivative(self.residuals, x, method="2-point", bounds=(lower, upper), args=(priors,))


def _window(model, heading, channels, seed=3):
    from seatune.identification.sea_estimation import partition_spectrum
    from seatune.pipeline.sea import raos_at

    rng = np.random.default_rng(seed)
    omega = np.linspace(0.25, 2.0, 700)
    x_true = np.array([[np.log(1.5), np.log(7.5), 200.0, np.log(28.0), np.log(3.3)],
                       [np.log(1.2), np.log(11.5), 280.0, np.log(12.0), np.log(4.0)],
                       [np.log(0.8), np.log(16.0), 20.0, np.log(10.0), np.log(3.0)]])
    # the components on the database's own directions, where the RAOs are exact (the sea split onto that grid)
    dirs = np.sort(np.mod(heading - np.degrees(model.db.wave_direction) - 180.0, 360.0))
    s = partition_spectrum(omega, dirs, x_true)
    h = raos_at(model, model.base_loading, channels, omega, dirs, heading)[0]
    amp = np.sqrt(2 * s * (omega[1] - omega[0]) * 2 * np.pi / dirs.size)  # (nω, nD)
    phase = rng.uniform(0, 2 * np.pi, amp.shape)
    t = np.arange(0, 2400, 0.1)
    c = (h * (amp * np.exp(1j * phase))[:, :, None]).sum(axis=1)  # (nω, nch)
    x = np.real(c.T @ np.exp(-1j * omega[:, None] * t[None, :]))
    return x, x_true


def run() -> dict:
    import seatune.identification.sea_estimation as se
    from seatune.identification.sea_estimation import PartitionPrior
    from seatune.io.run_yaml import SeaSettings
    from seatune.pipeline.sea import design_loadings, estimate_window, sea_channels
    from seatune.pipeline.vessel import open_vessel
    from seatune.tuning.interface import Parameter

    model = open_vessel(ROOT / "configs/vessels/sample_osv.yaml")
    heading = 30.0
    channels = sea_channels(model, IMU)
    x, x_true = _window(model, heading, channels)
    params = [Parameter(n, p.mean, p.std, *p.bounds) for n, p in model.spec.priors.items()
              if n in ("gmt_fs", "r44", "beta44")]
    design = design_loadings(model, params)
    priors = [PartitionPrior(1.3, 7.9, 210.0), PartitionPrior(1.05, 11.0, 275.0)]  # the swell at 16 s is absent
    settings = SeaSettings()

    def fit():
        return estimate_window(model, design, channels, x, 10.0, priors, settings, heading, 128.0)

    t_seatune, est = best_of(fit, 3)
    fast, fast_jacobian = se.model_cross_spectra, se._Problem.jacobian
    se.model_cross_spectra, se._Problem.jacobian = _loop_cross_spectra, _scipy_jacobian
    try:
        t_ref, ref = best_of(fit, 1)
    finally:
        se.model_cross_spectra, se._Problem.jacobian = fast, fast_jacobian
    found = [(round(p.value["hs"], 2), round(p.value["tp"], 1), round(p.value["dir_from_deg"])) for p in est.partitions]
    return {"name": "sea", "window_s": 2400, "channels": channels,
            "reference": "scipy 2-point Jacobian and a Σ_D loop for Φ(ω) in the same fit",
            "reference_s": t_ref, "seatune_s": t_seatune, "ratio": t_ref / t_seatune,
            "max_rel_diff_hs": float(max(abs(a.value["hs"] / b.value["hs"] - 1)
                                         for a, b in zip(est.partitions, ref.partitions, strict=False))),
            "estimated_partitions": found, "true_partitions": [(1.5, 7.5, 200), (1.2, 11.5, 280), (0.8, 16.0, 20)]}
