"""Everything the report is built from, already read from the run directory (no I/O past this point)."""

from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd


@dataclass
class ReportInputs:
    """The run's artefacts as tables, plus the few facts about the run that are not in them.

    track: motions.parquet thinned to ~1 Hz: time, record, lat, lon [deg], sog [m/s], heading_deg.
    tuned_raos: the tuned model's effective RAO on the aggregate rows of raos.parquet (scope, window_id, channel,
    omega, model_tuned), or None when it could not be computed (`tuned_note` says why).
    Optional artefacts (tuning, validation, diagnosis) are None when absent.
    """

    run_name: str
    run_file: str
    vessel_name: str
    vessel_file: str
    logs: list[str]
    hindcast: str
    settings: dict  # the run YAML as validated (RunSpec.model_dump())
    version: str
    fingerprint: str
    samples: int
    time_span: tuple[pd.Timestamp, pd.Timestamp]
    ingest_meta: dict  # motions.parquet metadata: counts, warnings, truncated_logs
    motion_units: dict[str, str]
    track: pd.DataFrame
    waves: pd.DataFrame
    windows: pd.DataFrame
    window_stats: pd.DataFrame
    raos: pd.DataFrame
    natural_frequencies: pd.DataFrame
    # natural_frequencies_diagnosed.parquet: identify's ω_n in the sea diagnose refitted through its named effects
    natural_frequencies_diagnosed: pd.DataFrame | None = None
    history: pd.DataFrame | None = None
    validation: pd.DataFrame | None = None
    tuned_raos: pd.DataFrame | None = None
    tuned_note: str = ""
    tuned_omega_n: dict[str, float] | None = None  # the tuned model's coupled ω_n by DOF [rad/s]
    mode_shapes: dict[str, str] = field(default_factory=dict)  # DOF → the model's mode shape, in words
    prediction: pd.DataFrame | None = None  # prediction.parquet (seatune predict)
    prediction_units: dict[str, str] = field(default_factory=dict)
    diagnosis: pd.DataFrame | None = None
    diagnosis_units: dict[str, str] = field(default_factory=dict)
    diagnosis_residuals: pd.DataFrame | None = None  # diagnosis_residuals.parquet
    sea_states: pd.DataFrame | None = None  # sea_states.parquet (the sea estimated from the motions)
    # per window Hs of sea_states.parquet (hs) and of sea_states_diagnosed.parquet (hs_refit), when diagnose refitted
    sea_refit_hs: pd.DataFrame | None = None
    # loading parameters the sea fit read (sea.read_loading): name → (value, std, vessel-YAML prior mean, prior std)
    sea_read: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    artefacts: list[tuple[str, int, str]] = field(default_factory=list)  # (file, bytes, fingerprint)
    # measured Welch spectrum of each DOF's main channel per window and the model's (prior, tuned) [unit²·s/rad]
    spectra: pd.DataFrame | None = None
    not_run: dict[str, str] = field(default_factory=dict)  # stages that could not run this time: why
    rejections: list[tuple[str, int]] = field(default_factory=list)  # (reason kind, candidates), most first

    def channel_unit(self, channel: str) -> str:
        return self.motion_units.get(channel, "")
