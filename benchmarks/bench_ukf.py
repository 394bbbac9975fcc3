"""One UKF update (A6 eqs. 1–11): seatune's `UKF.update` against filterpy's `UnscentedKalmanFilter`.

Problem: A6's base-case state (Table 5), N = 5: β44 and XCG plus Hs, Tp, β_W of the acquired sea state
(σ 10 % Hs, 0.5 s, 5°, Table 2), 9 heave statistics (displacement, velocity, acceleration at A6 Table 3's
points A, B, C), R = 2 % σ̂², Q of Table 5, α = 0.01, β = 2, κ = −2. The forward is a cheap analytic
stand-in for the RAO database: three damped one-DOF RAOs (heave, roll with damping β44, pitch) under a
Pierson–Moskowitz spectrum (A6 eq. 12) on 80 frequencies, heave at a point = η3 + y η4 − (x − XCG) η5.

Reference: filterpy (2.0) driven as A6 needs it (its own `predict` would redraw the sigma points from
P + Q): x, P ← weather update; `compute_process_sigmas` with identity fx (sigma points from P^w); P ← P + Q;
`update(z, R)`. It calls the measurement function once per sigma point (11 calls); seatune calls
`predict_paired` once for all 11. ``bounded=False`` so both filter the same state. Each timing is the
best of several runs in this process; agreement of the updated state and covariance is asserted.
"""

from __future__ import annotations

import numpy as np

from benchmarks.timing import best_of

G = 9.81
OMEGA = np.linspace(0.15, 2.1, 80)
D_OMEGA = OMEGA[1] - OMEGA[0]
POINTS = ((60.0, 0.0), (60.0, 13.0), (0.0, 10.0))  # A6 Table 3 (x, y) of A, B, C [m], origin at the stern
Q_STD = {"beta44": 0.005, "xcg": 0.1**0.5, "hs": 0.05, "tp": 0.1, "beta_deg": 0.5}  # A6 Table 5


class HeaveModel:
    parameter_names = ("beta44", "xcg")
    sea_state_names = ("hs", "tp", "beta_deg")
    names = tuple(f"heave_{kind}_{p}:sigma" for kind in ("disp", "vel", "acc") for p in "ABC")

    def predict_paired(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        b44, xcg = (c[:, None] for c in np.atleast_2d(phi).T)
        hs, tp, beta = (c[:, None] for c in np.atleast_2d(theta).T)
        w, wp = OMEGA, 2 * np.pi / tp
        s = 5 / 16 * hs**2 * wp**4 * w**-5 * np.exp(-1.25 * (w / wp) ** -4)  # A6 eq. 12
        b, slope = np.radians(beta), w**2 / G
        h3 = 1 / (1 - (w / 0.8) ** 2 + 0.4j * w / 0.8)
        h4 = np.sin(b) * slope / (1 - (w / 0.55) ** 2 + 2j * b44 * w / 0.55)
        h5 = 0.8 * np.cos(b) * slope / (1 - (w / 0.9) ** 2 + 0.6j * w / 0.9)
        h = np.stack([h3 + y * h4 - (x - xcg) * h5 for x, y in POINTS], axis=1)  # (n, 3, nw)
        m = np.abs(h) ** 2 * s[:, None, :] * D_OMEGA
        return np.sqrt(np.concatenate([m.sum(-1), (m * w**2).sum(-1), (m * w**4).sum(-1)], axis=1))

    def predict(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        phi, theta = np.atleast_2d(phi), np.atleast_2d(theta)
        n, h = phi.shape[0], theta.shape[0]
        return self.predict_paired(np.repeat(phi, h, 0), np.tile(theta, (n, 1))).reshape(n, h, -1)


def run() -> dict:
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    from seatune.tuning.interface import Observation, Parameter, SeaState
    from seatune.tuning.ukf import UKF

    model = HeaveModel()
    params = [Parameter("beta44", 0.07, 0.035, 0.0, 0.3), Parameter("xcg", 59.4, 4.0, 50.0, 70.0)]  # A6 Table 5
    truth_phi, truth_theta = np.array([0.04, 61.4]), np.array([2.5, 13.4, 317.4])  # A6 φ*, Table 8 k = 9
    acquired, sd = np.array([3.0, 14.1, 314.7]), np.array([0.25, 0.5, 5.0])
    z = model.predict_paired(truth_phi[None], truth_theta[None])[0]
    obs = Observation("bench", model.names, z, np.zeros(z.size), 1800.0)
    sea = SeaState(model.sea_state_names, acquired, np.diag(sd**2), acquired[None], np.ones(1))
    R = np.diag(0.02 * z**2)
    Q = np.diag([Q_STD[n] for n in model.parameter_names + model.sea_state_names]) ** 2
    x_w = np.r_[[p.prior_mean for p in params], acquired]
    P_w = np.diag(np.r_[[p.prior_std for p in params], sd] ** 2)

    fresh = [UKF(params, process_noise=Q_STD, bounded=False, use_sampling_variance=False) for _ in range(201)]

    def seatune_update() -> UKF:
        ukf = fresh.pop()  # a filter at its prior: only the update is timed
        ukf.update(model, obs, sea)
        return ukf

    fp = UnscentedKalmanFilter(5, 9, 1.0, hx=lambda x: model.predict_paired(x[:2], x[2:])[0],
                               fx=lambda x, dt: x, points=MerweScaledSigmaPoints(5, 0.01, 2.0, -2.0))

    def filterpy_update() -> np.ndarray:
        fp.x, fp.P = x_w.copy(), P_w.copy()  # A6 eq. 1
        fp.compute_process_sigmas(1.0)  # sigma points from P^w (A6 eqs. 2–5), identity fx
        fp.P = fp.P + Q  # A6 eq. 6b, sigma points kept
        fp.update(z, R=R)  # A6 eq. 11
        return np.c_[fp.x, fp.P]

    seatune_update()  # warm-up
    filterpy_update()
    seatune_s, ukf = best_of(seatune_update, 200)
    reference_s, ref = best_of(filterpy_update, 200)
    ours = np.c_[ukf.x_, ukf.P_]
    diff = np.abs(ours - ref)
    rel = float((diff / np.maximum(np.abs(ref), 1e-300)).max())
    assert rel < 1e-8, f"UKF update disagrees with filterpy: max relative difference {rel:.2e}"
    return {
        "name": "ukf_update",
        "reference_s": round(reference_s, 6),
        "seatune_s": round(seatune_s, 6),
        "ratio": round(reference_s / seatune_s, 2),
        "max_abs_diff": float(diff.max()),
        "max_rel_diff": rel,
        "state_dim": 5,
        "measurements": 9,
        "forward_calls": {"seatune": 1, "reference": 11},
        "reference": "filterpy UnscentedKalmanFilter: compute_process_sigmas (identity fx), P += Q, update(z, R)",
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run()))
