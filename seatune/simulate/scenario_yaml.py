"""Scenario YAML for `seatune simulate`: vessel and hidden truth, voyage, sea states, sensors, defects.

Times are seconds from `start_time`; directions are compass degrees, `dir_from_deg` the nautical
coming-from direction as hindcasts give it.
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path
from typing import Annotated, Literal

from pydantic import ConfigDict, Field

from seatune.errors import UserError
from seatune.io.vessel_yaml import LOADING_PARAMETERS
from seatune.io.yaml_config import NonNegativeFloat as NonNegative
from seatune.io.yaml_config import PositiveFloat as Positive
from seatune.io.yaml_config import Strict as _Strict
from seatune.io.yaml_config import read_yaml, validate


class PartitionSpec(_Strict):
    hs: NonNegative
    tp: Positive
    dir_from_deg: float
    gamma: Annotated[float, Field(ge=1)] = 3.3
    spreading: Literal["cos2s", "cosn", "long_crested"] = "cos2s"
    spreading_param: Positive | None = None


class SeaStateSpec(_Strict):
    hour: Annotated[float, Field(ge=0)]  # hours from the start; the state holds at that instant
    wind_sea: PartitionSpec | None = None
    swell: PartitionSpec | None = None


class SegmentSpec(_Strict):
    kind: Literal["transit", "drift", "station_keeping"]
    duration: Positive  # s
    start: NonNegative | None = None  # s from the trial start; default: when the previous one ends
    heading_deg: float | None = None  # transit: = course
    heading_rate_deg_per_h: float = 0.0
    speed: NonNegative = 0.0  # transit speed, or drift speed over ground
    course_deg: float | None = None  # transit course, or drift direction (going to)


class HindcastErrorSpec(_Strict):
    """Han paper A5 Table 4.1: σ_Hs = 10 %, σ_Tp = 0.5 s, σ_β = 5°."""

    hs_rel_std: NonNegative = 0.10
    tp_std: NonNegative = 0.5
    dir_std_deg: NonNegative = 5.0
    hs_rel_bias: float = 0.0
    tp_bias: float = 0.0
    dir_bias_deg: float = 0.0
    drop_swell: bool = False  # the hindcast misses the swell (de Jong's failure case)


class HindcastSpec(_Strict):
    error: HindcastErrorSpec = HindcastErrorSpec()
    resolution_deg: Positive = 0.5
    spectra_2d: bool = True


class ImuSpec(_Strict):
    point: tuple[float, float, float]  # hull frame
    angle_noise_std: NonNegative = 1.0e-4  # rad, white noise on the reported attitude
    gyro_noise_density: NonNegative = 2.0e-4  # rad/s/√Hz → per-sample σ = density·√fs
    gyro_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)  # rad/s
    accel_noise_density: NonNegative = 1.0e-3  # m/s²/√Hz
    accel_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m/s²
    frame_id: str = "imu_link"


class GnssSpec(_Strict):
    rate_hz: Positive = 1.0
    position_std: NonNegative = 1.5  # m
    velocity_std: NonNegative = 0.05  # m/s


class HeaveSpec(_Strict):
    snr: Positive = 100.0  # Han A2 eq. 18: σ_N² = σ_X² / SNR
    sensors: list[str] | None = None  # vessel channel `sensor` tags; default every point heave channel


class SensorsSpec(_Strict):
    sample_rate_hz: Annotated[float, Field(ge=1, le=100)] = 10.0
    quantize: bool = True  # sensor output resolution (IMU fixed-point LSBs, GNSS and heave decimals)
    imu: ImuSpec
    gnss: GnssSpec = GnssSpec()
    heave: HeaveSpec | None = HeaveSpec()


class GapSpec(_Strict):
    at: NonNegative  # s
    duration: Positive  # s


class DefectsSpec(_Strict):
    duplicate_stamps: Annotated[int, Field(ge=0)] = 0
    out_of_order: Annotated[int, Field(ge=0)] = 0
    gaps: list[GapSpec] = []
    truncate_mcap: Annotated[float, Field(gt=0, le=1)] | None = None  # keep this fraction of the file


StreamGroup = Literal["imu", "gnss", "heave"]
ALL_GROUPS: list = ["imu", "gnss", "heave"]


class OutputsSpec(_Strict):
    """Which sensor groups each log format carries ([] = not written)."""

    mcap: list[StreamGroup] = ALL_GROUPS
    ros1_bag: list[StreamGroup] = []
    ros2_bag: list[StreamGroup] = []
    csv: list[StreamGroup] = ALL_GROUPS
    mcap_zstd_level: Annotated[int, Field(ge=1, le=22)] = 3
    mcap_message_index: bool = True
    hindcast_netcdf: bool = True
    hindcast_csv: bool = True


class SynthesisSpec(_Strict):
    components_per_direction: Annotated[int, Field(ge=10)] = 200
    block_seconds: Positive = 819.2
    omega_min: Positive = 0.2
    omega_max: Positive = 2.0


class EffectSpec(_Strict):
    model_config = ConfigDict(extra="allow", frozen=True)
    kind: str


class ScenarioSpec(_Strict):
    name: str
    vessel: str  # vessel YAML, relative to the scenario file
    seed: int
    start_time: datetime
    start_position: tuple[float, float]  # lat, lon [deg]
    truth_loading: dict[str, float] = {}
    transition_s: NonNegative = 120.0
    segments: Annotated[list[SegmentSpec], Field(min_length=1)]
    sea_states: Annotated[list[SeaStateSpec], Field(min_length=1)]
    hindcast: HindcastSpec = HindcastSpec()
    sensors: SensorsSpec
    defects: DefectsSpec = DefectsSpec()
    outputs: OutputsSpec = OutputsSpec()
    synthesis: SynthesisSpec = SynthesisSpec()
    effects: list[EffectSpec] = []


def load_scenario(path: str | Path) -> tuple[ScenarioSpec, Path]:
    path = Path(path)
    spec = validate(ScenarioSpec, read_yaml(path), str(path))
    _check(spec, str(path))
    vessel = path.parent / spec.vessel
    if not vessel.is_file():
        raise UserError(str(path), "vessel", f"vessel file not found: {vessel}")
    return spec, vessel


def _check(spec: ScenarioSpec, source: str) -> None:
    for name in spec.truth_loading:
        if name not in LOADING_PARAMETERS:
            known = ", ".join(LOADING_PARAMETERS)
            raise UserError(source, f"truth_loading.{name}", f"unknown loading parameter (one of {known})")
    if spec.start_time.tzinfo is None:
        raise UserError(source, "start_time", "give a UTC time with its zone, e.g. 2026-03-14T06:00:00Z")
    end = 0.0
    for i, seg in enumerate(spec.segments):
        if seg.start is not None and seg.start < end - 1e-9:
            raise UserError(source, f"segments.{i}.start",
                            f"segment starts at {seg.start:g} s, before the previous one ends ({end:g} s)")
        end = (seg.start if seg.start is not None else end) + seg.duration
        if seg.kind == "transit" and seg.course_deg is None and seg.heading_deg is None:
            raise UserError(source, f"segments.{i}", "a transit needs course_deg")
        if seg.kind != "transit" and seg.heading_deg is None:
            raise UserError(source, f"segments.{i}.heading_deg", f"a {seg.kind} segment needs heading_deg")
    from seatune.simulate.effects import EFFECTS

    for i, eff in enumerate(spec.effects):
        if eff.kind not in EFFECTS:
            raise UserError(source, f"effects.{i}.kind", f"unknown effect {eff.kind!r} (one of {', '.join(EFFECTS)})")
    hours = [s.hour for s in spec.sea_states]
    if any(b <= a for a, b in zip(hours, hours[1:], strict=False)):
        raise UserError(source, "sea_states", "hours must be strictly increasing")
    for i, s in enumerate(spec.sea_states):
        if s.wind_sea is None and s.swell is None:
            raise UserError(source, f"sea_states.{i}", "give wind_sea and/or swell")
    if spec.synthesis.omega_max <= spec.synthesis.omega_min:
        raise UserError(source, "synthesis.omega_max", "must exceed omega_min")
