"""The one interface both tuning backends (DBI, UKF) implement.

A backend holds a belief over the loading parameters φ. Each sea state brings one `Observation` (the
measured statistics of one window) and one `SeaState` (the acquired sea-state parameters θ with their
uncertainty, as a Gaussian and as discrete hypotheses). The backend asks a `ForwardModel` for predicted
statistics and updates its belief. Pure computation: no I/O here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np


@dataclass(frozen=True)
class Parameter:
    """One tuned loading parameter with its Gaussian prior and hard bounds (same units as the vessel YAML)."""

    name: str
    prior_mean: float
    prior_std: float
    lower: float
    upper: float

    def __post_init__(self):
        if not self.prior_std > 0:
            raise ValueError(f"parameter '{self.name}': prior std must be > 0")
        if not self.lower < self.prior_mean < self.upper:
            raise ValueError(f"parameter '{self.name}': prior mean {self.prior_mean} outside bounds "
                             f"[{self.lower}, {self.upper}]")


@dataclass(frozen=True)
class SeaState:
    """Acquired sea-state information θ' for one window.

    names: e.g. ("hs", "tp", "beta_deg", "spreading_n"); beta_deg is the model wave direction β (DESIGN §3:
    travelling towards, counter-clockwise from body +x, 180 = head seas) in degrees; the forward model wraps it.
    mean, cov: Gaussian θ' ~ N(mean, cov) (UKF weather update, A6 eq. 1).
    points, weights: discrete hypotheses θ_s with their PMF (DBI, A5 eq. 3.7); weights sum to 1.
    """

    names: tuple[str, ...]
    mean: np.ndarray
    cov: np.ndarray
    points: np.ndarray
    weights: np.ndarray

    @classmethod
    def certain(cls, names: Sequence[str], values: Sequence[float]) -> SeaState:
        v = np.asarray(values, dtype=float)
        return cls(tuple(names), v, np.zeros((v.size, v.size)), v[None, :], np.ones(1))


@dataclass(frozen=True)
class Observation:
    """Measured statistics of one window: z[j] for measurement names[j] ("channel:sigma", "channel:tz").

    variance: sampling variance of each z[j] for this record length (from the Welch degrees of freedom);
    used by the calibrated Gaussian likelihood (DBI) and as a floor for R (UKF).
    common_scale_variance: relative variance of a factor common to every σ̂ of the window — one sea realisation
    drives all channels, so their sampling errors are largely one factor (the realised Hs), not independent.
    variance_is_total: the variance is the whole error of z (e.g. a measured natural frequency against the model's
    own modes): the backends add no model error or R fraction, screen nothing out and use a Gaussian likelihood.
    """

    window_id: str
    names: tuple[str, ...]
    z: np.ndarray
    variance: np.ndarray
    duration_s: float
    common_scale_variance: float = 0.0
    variance_is_total: bool = False

    @classmethod
    def of_one_sea(cls, window_id: str, names, z, variance, duration_s: float) -> Observation:
        """Statistics of channels driven by one sea realisation: the common factor's relative variance is taken
        as the median relative sampling variance of the σ̂ (0 without σ measurements)."""
        z, variance = np.asarray(z, dtype=float), np.asarray(variance, dtype=float)
        sig = np.array([n.endswith(":sigma") for n in names])
        common = float(np.median(variance[sig] / z[sig] ** 2)) if sig.any() else 0.0
        return cls(window_id, tuple(names), z, variance, float(duration_s), common)


class ForwardModel(Protocol):
    """Predicted statistics of the measurement names, in the same order as Observation.names."""

    names: tuple[str, ...]
    parameter_names: tuple[str, ...]
    sea_state_names: tuple[str, ...]

    def predict(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """All combinations: phi (n, p), theta (h, q) -> (n, h, m)."""

    def predict_paired(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Row pairs: phi (n, p), theta (n, q) -> (n, m)."""


@dataclass
class Posterior:
    """Summary of a backend's belief after an update (one row of tuning_history per parameter)."""

    names: tuple[str, ...]
    mean: np.ndarray
    cov: np.ndarray
    quantiles: dict[float, np.ndarray]  # {0.05: (p,), 0.5: (p,), 0.95: (p,)}
    used: tuple[str, ...] = ()  # measurement names that entered this update (DBI screening)
    sea_state_mean: np.ndarray | None = None  # UKF: tuned θ; DBI: posterior mean over hypotheses
    sea_state_cov: np.ndarray | None = None
    marginals: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)  # DBI: name -> (grid, pmf)

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(np.diag(self.cov))


class Backend(Protocol):
    """A tuning backend. Constructed from the parameters and its own settings; updated once per sea state."""

    name: str
    parameters: tuple[Parameter, ...]

    def update(self, model: ForwardModel, observation: Observation, sea_state: SeaState) -> Posterior:
        """Assimilate one window; returns the posterior after it."""

    def posterior(self) -> Posterior:
        """Current belief (the prior before any update)."""
