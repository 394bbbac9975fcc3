"""Run YAML (`configs/runs/*.yaml`): where the logs, hindcast and vessel are, and every stage's settings.

Paths are relative to the run YAML. See README "Run YAML" for every key.
"""

from __future__ import annotations

import glob
from datetime import datetime
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import Discriminator, Field, Tag, field_validator, model_validator

from seatune.errors import UserError
from seatune.io.vessel_yaml import check_loading_names
from seatune.io.yaml_config import NonNegativeFloat, PositiveFloat, Strict, read_yaml, validate


class WindowSettings(Strict):
    max_sog: PositiveFloat = 0.5  # m/s
    sog_smoothing_s: PositiveFloat = 60.0
    max_heading_change_deg: PositiveFloat = 10.0
    min_duration_s: PositiveFloat = 1200.0  # Han: 20 min; de Jong: 17 min
    max_duration_s: PositiveFloat = 3600.0
    max_hs_change: NonNegativeFloat = 0.3  # fraction of the window's mean hindcast Hs
    stationarity_channel: str = "roll"
    sub_windows: int = 4
    stationarity_alpha: PositiveFloat = 1e-3


LogFormat = Literal["auto", "mcap", "ros1bag", "ros2bag", "csv", "parquet"]


class ColumnSpec(Strict):
    """A table-log column: its seatune name and its unit (converted to SI at ingest; no unit guessing)."""

    name: str | None = None  # None: keeps the log column's name
    unit: str | None = None

    @field_validator("unit")
    @classmethod
    def _known_unit(cls, v):
        from seatune.io.log_readers import COLUMN_UNITS

        if v is not None and v not in COLUMN_UNITS:
            raise ValueError(f"unknown unit {v!r} (one of {', '.join(COLUMN_UNITS)})")
        return v


# log column → seatune name, or {name, unit}; a string or a mapping decides the branch (one clear error)
Columns = dict[str, Annotated[Annotated[str, Tag("name")] | Annotated[ColumnSpec, Tag("spec")],
                              Discriminator(lambda v: "name" if isinstance(v, str) else "spec")]]


def column_options(*maps: Columns) -> tuple[dict[str, str], dict[str, str]]:
    """(log column → seatune name, log column → declared unit) of column maps, later maps winning."""
    names, units = {}, {}
    for m in maps:
        for column, spec in m.items():
            if isinstance(spec, str):
                names[column] = spec
            else:
                if spec.name is not None:
                    names[column] = spec.name
                if spec.unit is not None:
                    units[column] = spec.unit
    return names, units


class LogSpec(Strict):
    path: str  # file, directory (ROS2 bag) or glob
    format: LogFormat = "auto"
    kind: Literal["auto", "imu", "gnss", "heave", "motions"] = "auto"  # what a CSV / Parquet log carries
    time_column: str = "time"
    # log column → seatune name (e.g. {Lat: latitude}), or {name, unit} (e.g. {gyro_x: {name: roll_rate, unit: deg/s}})
    columns: Columns = {}


class TopicsSpec(Strict):
    """Topic names; `null` = auto-detect by message type."""

    imu: str | None = None
    gnss_fix: str | None = None
    gnss_vel: str | None = None
    odometry: str | None = None


class HindcastUncertainty(Strict):
    """1-σ errors of the hindcast at the vessel (Han A5 Table 4.1 defaults); used by identify and tune."""

    hs_rel_std: Annotated[float, Field(ge=0)] = 0.10  # relative std of Hs
    tp_std_s: Annotated[float, Field(ge=0)] = 0.5  # std of Tp [s]
    dir_std_deg: Annotated[float, Field(ge=0)] = 5.0  # std of the mean direction [deg]


class HindcastSource(Strict):
    path: str
    format: Literal["auto", "era5", "ww3", "wavespectra", "bulk_netcdf", "csv"] = "auto"
    uncertainty: HindcastUncertainty = HindcastUncertainty()


class PlausibilitySettings(Strict):
    """Ingest's plausibility gate (seatune.physics.plausibility): samples beyond these are masked and counted."""

    max_specific_force_g: PositiveFloat = 5.0  # per accelerometer axis
    max_angle_deg: Annotated[float, Field(gt=0, le=180)] = 90.0  # |roll|, |pitch|
    max_rate_rad_s: PositiveFloat = 5.0  # per gyro axis
    max_speed_m_s: PositiveFloat = 50.0  # GNSS / odometry velocity components
    max_stamp_offset_s: PositiveFloat = 3600.0  # header stamp vs receive time, beyond the topic's median offset


class IngestSettings(Strict):
    rate_hz: PositiveFloat = 10.0
    max_gap_s: PositiveFloat = 2.0  # longer gaps split the record instead of being interpolated
    frame: Literal["FLU", "NED", "auto"] = "FLU"  # REP-103 FLU/ENU, FRD/NED, or auto (NED if frame_id ends _ned)
    columns: Columns = {}  # like logs[].columns, for every CSV / Parquet log (a log's own entries win)
    plausibility: PlausibilitySettings = PlausibilitySettings()


class FilterSettings(Strict):
    theta_max: PositiveFloat = 0.05  # Han A3
    gamma_max: PositiveFloat = 0.9
    f_min_hz: PositiveFloat = 0.1
    f_max_hz: PositiveFloat = 0.9
    highpass_hz: PositiveFloat | None = None
    welch_segment_s: PositiveFloat = 256.0
    channels: list[str] | None = None  # default: every vessel channel present in the motion table


class SeaSettings(Strict):
    """The sea of each window estimated from the motions (wave-buoy analogy), the hindcast as its prior."""

    estimate: bool = True  # false: every stage takes the hindcast's sea as given
    channels: list[str] | None = None  # default: the vessel's angle and translational channels in the motions
    # wind sea and swells, counting a partition the search added and kept (a missing swell often comes second, after
    # a system the hindcast's shape lacked)
    max_partitions: Annotated[int, Field(ge=1, le=4)] = 4
    min_hs: PositiveFloat = 0.3  # an added partition (absent from the hindcast) must reach this Hs [m]
    omega_min: PositiveFloat = 0.25  # fitted band [rad/s]
    omega_max: PositiveFloat = 2.0
    iterations: Annotated[int, Field(ge=1, le=5)] = 1  # > 1: sea and vessel alternate (sea → tune → sea …)
    # rounds of the sea refitted through the r55 identify reads from the pitch mode, then identify again (0: off)
    mode_rounds: Annotated[int, Field(ge=0, le=5)] = 2
    roll_free: bool = True  # also fit each window's sea without the roll channels, for identify's roll ω_n
    # fit each window again with the hindcast's error the record's other windows found (partial pooling)
    pool_windows: bool = True
    # loading parameters read from the sea fit itself (its misfit profiled over the vessel prior) where they are
    # uncertain (a prior in the vessel YAML) and neither known nor tuned; [] turns the read off. On the blind bank
    # the LCG read put missing swells' Hs within 15 % in 100 % of windows (88 % without) (README "Offset")
    read_loading: list[str] = ["xcg"]
    segment_s: PositiveFloat = 128.0  # Welch segment of the cross-spectra (Δω 0.05 rad/s, twice the filter's ν)
    # prior widths of the hindcast's partitions, floors of hindcast.uncertainty (ERA5 vs buoys, Han A5 Table 4.1)
    hs_rel_std: PositiveFloat = 0.25
    tp_rel_std: PositiveFloat = 0.15
    dir_std_deg: PositiveFloat = 30.0

    @field_validator("read_loading")
    @classmethod
    def _read_loading(cls, v):
        return check_loading_names(v)


class IdentifySettings(Strict):
    band_fraction: Annotated[float, Field(gt=0, lt=1)] = 0.05  # energetic band: S_ζζ ≥ fraction·max (A7 §4.1)
    confidence: Annotated[float, Field(gt=0, lt=1)] = 0.95
    search_range: Annotated[float, Field(gt=0, lt=1)] = 0.3  # natural-frequency search: prior ω_n·(1 ± range)
    heading_sector_deg: Annotated[float, Field(gt=0, le=180)] = 30.0  # aggregation sectors of the wave direction β
    hs_bin_m: PositiveFloat = 1.0  # aggregation Hs bins
    low_frequency_share: Annotated[float, Field(gt=0, lt=1)] = 0.25  # missing-swell flag threshold
    debias_modes: bool = True  # scale each ω_n fit by the same fit's bias on the prior model's own spectrum
    mode_posterior: bool = True  # also each ω_n combined with the coupled modes over the loading prior
    mode_model_rel_std: Annotated[float, Field(ge=0)] = 0.01  # model-form error of a coupled ω_n (BEM A, C)
    known: dict[str, float] = {}  # loading values known on board (loading computer), used for derived parameters

    @field_validator("known")
    @classmethod
    def _known_parameters(cls, v):
        return check_loading_names(v)


class DbiSettings(Strict):
    database_points: Annotated[int, Field(ge=2)] = 7  # I_m per parameter (A2)
    # K_m per parameter; auto: min(40, ⌊pmf_budget^(1/M)⌋), so 5 parameters take 18⁵ cells, not 40⁵ (100 M)
    pmf_points: Annotated[int, Field(ge=3)] | Literal["auto"] = "auto"
    pmf_budget: Annotated[int, Field(ge=27)] = 2_000_000
    regrid: bool = True  # zoom each axis onto its posterior after an update (resolution where it lives)
    likelihood: Literal["gaussian", "idw"] = "gaussian"
    power: PositiveFloat = 0.4  # IDW power p (A2 eq. 10)
    screening_alpha: Annotated[float, Field(ge=0)] = 0.05  # α0 (A2 eq. 9)
    model_error: Annotated[float, Field(ge=0)] = 0.05  # relative model-error std added to the σ̂ sampling variance
    # database → PMF grid (of the predicted σ for the Gaussian likelihood): cubic follows σ's curvature in β44
    # (an A6 trial: β44 0.043 vs 0.063 linear, truth 0.040); idw always interpolates its weights linearly (A2)
    interpolation: Literal["linear", "cubic"] = "cubic"
    hypothesis_mixing: Literal["joint", "per_sensor"] = "joint"  # per_sensor = thesis eq. 3.7


class UkfSettings(Strict):
    alpha: PositiveFloat = 0.01  # A6 Table 5
    beta: float = 2.0
    kappa: float | None = None  # None: 3 − N
    r_fraction: Annotated[float, Field(ge=0)] = 0.02  # R = r_fraction · σ̂² (A6), floored by the sampling variance
    q_fraction: Annotated[float, Field(ge=0)] = 0.1  # Q std as a fraction of each prior std


class DampingGprSettings(Strict):
    """Sea-state-dependent β44 (A4): a GPR over (Hs·|sin β|, ω_p) gives each window's β44 prior."""

    enabled: bool = False
    # prior mean / σ_f: None takes the vessel's β44 prior (A4 eq. 23 uses 0.07 and 0.02)
    prior_mean: float | None = None
    sigma_f: PositiveFloat | None = None
    length_scales: tuple[PositiveFloat, PositiveFloat] = (0.7, 0.2)  # m, rad/s (A4 Table 5)


class HeadingRule(Strict):
    """Measurements used in windows whose mean wave direction β (DESIGN §3, folded to 0–180°: 180 = head seas,
    port and starboard alike) lies in `beta_deg` — A7 Case 4 (thesis Table 4.2) drops roll in head-to-bow-quartering
    seas and pitch from beam to following seas."""

    beta_deg: tuple[float, float]
    channels: list[str] | None = None  # None: tuning.channels
    statistics: list[Literal["sigma", "tz"]] | None = None  # None: tuning.statistics

    @field_validator("beta_deg")
    @classmethod
    def _range(cls, v):
        if not 0.0 <= v[0] < v[1] <= 180.0:
            raise ValueError("beta_deg must be [low, high] with 0 <= low < high <= 180 (folded wave direction)")
        return v


class TuningSettings(Strict):
    backend: Literal["dbi", "ukf"] = "dbi"
    parameters: list[str] = Field(default=["r44", "beta44"], min_length=1)  # priors from the vessel YAML
    channels: list[str] | None = None  # default: every filtered channel the vessel defines
    statistics: list[Literal["sigma", "tz"]] = ["sigma"]
    holdout_every: Annotated[int, Field(ge=0)] = 3  # every k-th accepted window is held out for validation (0: none)
    natural_frequencies: bool = True  # identify's ω_n (with their intervals) enter as one more observation
    dbi: DbiSettings = DbiSettings()
    ukf: UkfSettings = UkfSettings()
    damping_gpr: DampingGprSettings = DampingGprSettings()
    heading_rules: list[HeadingRule] = []  # first matching rule wins; no match: every configured measurement

    @field_validator("parameters")
    @classmethod
    def _known_parameters(cls, v):
        return check_loading_names(v)


class PredictSettings(Strict):
    """`seatune predict` (Han A5 RESP / RISK): the critical response, its limit and the exposure time."""

    channel: str  # vessel channel name (checked against the vessel when predicting)
    limit: PositiveFloat  # in the channel's units
    duration_s: PositiveFloat = 10800.0  # sea-state duration the maximum is taken over (3 h)
    # a step [deg] (headings 0, step, … < 360) or an explicit list of compass headings [deg]
    headings_deg: float | list[float] = 5.0
    position: tuple[float, float] | None = None  # [lat, lon] deg; default: the last logged position
    times: list[datetime] | None = None  # UTC (naive = UTC); default: every forecast time step
    uncertainty: HindcastUncertainty | None = None  # forecast errors; default: hindcast.uncertainty

    @field_validator("headings_deg")
    @classmethod
    def _headings(cls, v):
        if isinstance(v, list) and not (v and all(0.0 <= h < 360.0 for h in v)):
            raise ValueError("give a step in (0, 90] degrees or a non-empty list of headings in [0, 360)")
        if not isinstance(v, list) and not 0.0 < v <= 90.0:
            raise ValueError("a heading step must be in (0, 90] degrees")
        return v

    @field_validator("position")
    @classmethod
    def _position(cls, v):
        if v is not None and not (-90.0 <= v[0] <= 90.0 and -180.0 <= v[1] <= 360.0):
            raise ValueError("position must be [lat, lon] in degrees (lat in [-90, 90])")
        return v

    def heading_grid(self) -> list[float]:
        if isinstance(self.headings_deg, list):
            return sorted(set(float(h) for h in self.headings_deg))
        step = float(self.headings_deg)
        return [float(h) for h in step * np.arange(int(np.ceil(360.0 / step - 1e-9)))]


class DiagnoseCalibration(Strict):
    """The false-alarm test of a named effect: a parametric bootstrap under a sea that errs as estimates do and a
    vessel model with a smooth error (seatune/diagnosis/select.py NullSea, whose error defaults these are)."""

    # 0 (default): the fixed held-out-gain rule alone. 19 gives a 5 % test; not the default until its null holds the
    # misfit real trials show: on 8 blind-bank trials it dropped 1 of 5 false alarms and lost 1 of 2 hits, at 3–10×
    # the time
    replicates: Annotated[int, Field(ge=0)] = 0
    false_alarm: Annotated[float, Field(gt=0, lt=1)] = 0.05  # name an effect at p ≤ this
    hs_rel_std: NonNegativeFloat = 0.10  # the null sea's Hs error (relative)
    tp_rel_std: NonNegativeFloat = 0.04  # … Tp error (relative)
    dir_std_deg: NonNegativeFloat = 10.0  # … mean-direction error [deg]
    spread_deg: NonNegativeFloat = 10.0  # … extra directional spreading (half-normal scale) [deg]
    model_error: NonNegativeFloat = 0.15  # RMS of a smooth per-channel error of the vessel model's ln S
    model_error_scale: PositiveFloat = 0.1  # its correlation length in ω [rad/s]
    seed: int = 0

    @model_validator(mode="after")
    def _enough(self):
        if self.replicates and 1.0 / (self.replicates + 1) > self.false_alarm:
            raise ValueError(f"replicates must be at least {int(np.ceil(1.0 / self.false_alarm - 1))} for a "
                             f"false-alarm probability of {self.false_alarm:g} (the smallest p is 1/(replicates + 1))")
        return self


class DiagnoseSettings(Strict):
    """`seatune diagnose`: the candidate effects and the band analysed."""

    effects: list[str] | None = None  # default: the whole library (seatune/diagnosis/effects.py)
    channels: list[str] | None = None  # default: tuning.channels, else every filtered channel
    omega_min: PositiveFloat = 0.25  # rad/s; bins below (and above each channel's filter cutoff) are not analysed
    omega_max: PositiveFloat = 2.0  # rad/s
    relative_floor: Annotated[float, Field(gt=0, lt=1)] = 0.03  # bins below this × the channel's peak: noise
    moonpool_position: tuple[float, float] | None = None  # [x, y] m of a suspected moonpool, body frame; None: x fitted
    # vessel effects named in turn by greedy forward selection (name, add, refit, repeat; a sea-side correction
    # named first does not count); the second is tested again in the sea alternated with the first alone
    # (pipeline/diagnose.py retest_later_effect). 3 had raised the blind bank's clean-hull false alarms 6 → 10 of 24
    max_effects: Annotated[int, Field(ge=1, le=3)] = 2
    # rounds of alternation with the sea once a vessel effect is named (its parameters refitted in the sea refitted
    # through it); 0: the parameters of the selection, in the sea stage's sea
    alternation_rounds: Annotated[int, Field(ge=0, le=5)] = 2
    calibration: DiagnoseCalibration = DiagnoseCalibration()


class OutputSettings(Strict):
    """Extra artefacts for other tools."""

    # Hz: window_spectra_hz.parquet beside window_spectra.parquet (the stages read the rad/s one)
    spectrum_frequency: Literal["rad/s", "Hz"] = "rad/s"


class RunSpec(Strict):
    name: str
    run_dir: str
    vessel: str
    logs: list[LogSpec] = Field(min_length=1)
    topics: TopicsSpec = TopicsSpec()
    channels: dict[str, str] = {}  # motion-table column → vessel channel name, where they differ
    hindcast: HindcastSource
    ingest: IngestSettings = IngestSettings()
    windows: WindowSettings = WindowSettings()
    filter: FilterSettings = FilterSettings()
    sea: SeaSettings = SeaSettings()
    identify: IdentifySettings = IdentifySettings()
    tuning: TuningSettings = TuningSettings()
    predict: PredictSettings | None = None
    diagnose: DiagnoseSettings = DiagnoseSettings()
    output: OutputSettings = OutputSettings()


class Run:
    """A validated run YAML with its paths resolved."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.spec = validate(RunSpec, read_yaml(self.path), str(self.path))
        self.base = self.path.parent
        self.run_dir = (self.base / self.spec.run_dir).resolve()
        self.vessel_path = self.base / self.spec.vessel
        if not self.vessel_path.is_file():
            raise UserError(str(self.path), "vessel", f"vessel file not found: {self.vessel_path}")
        self.hindcast_path = self.base / self.spec.hindcast.path
        if not self.hindcast_path.exists():
            raise UserError(str(self.path), "hindcast.path", f"file not found: {self.hindcast_path}")
        self.logs: list[tuple[Path, LogSpec]] = []
        for i, log in enumerate(self.spec.logs):
            matches = sorted(glob.glob(str(self.base / log.path)))
            if not matches:
                raise UserError(str(self.path), f"logs.{i}.path", f"no file matches {self.base / log.path}")
            self.logs += [(Path(m), log) for m in matches]

    def artefact(self, name: str) -> Path:
        return self.run_dir / name
