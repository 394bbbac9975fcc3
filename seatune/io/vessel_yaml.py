"""Vessel YAML: hull source, drafts, loading condition, channels and priors, validated.

Coordinates in this file are in the *hull frame*: x forward from the hydro reference station
(midship for the parametric hull), y to port, z up from the baseline (keel). The body frame of the
physics (DESIGN §3) is the hull frame shifted down by the draft, so its origin is on the calm
waterline. All values SI: kg, m, rad; a key ending in `_deg` holds degrees.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Discriminator, Field, Tag, field_validator, model_validator

from seatune.errors import UserError
from seatune.io.yaml_config import NonNegativeFloat, PositiveFloat, read_yaml, validate
from seatune.io.yaml_config import Strict as _Strict

LOADING_PARAMETERS = (
    "mass", "xcg", "ycg", "zcg", "r44", "r55", "r66",
    "gmt_fs", "gml_fs", "beta33", "beta44", "beta55",
)


def check_loading_names(names, extra: tuple[str, ...] = (), what: str = "loading parameter"):
    """Pydantic validator body: every name is a loading parameter (or one of `extra`)."""
    for name in names:
        if name not in LOADING_PARAMETERS and name not in extra:
            raise ValueError(f"unknown {what} '{name}' (one of {', '.join(LOADING_PARAMETERS)})")
    return names


class ParametricHullSpec(_Strict):
    length: PositiveFloat
    beam: PositiveFloat
    depth: PositiveFloat
    bilge_radius: PositiveFloat = 2.0
    midbody: Annotated[float, Field(ge=0, lt=1)] = 0.35
    bow_fineness: PositiveFloat = 1.8
    stern_fineness: PositiveFloat = 2.6
    stern_halfbreadth: Annotated[float, Field(ge=0, le=1)] = 0.0
    stations: Annotated[int, Field(ge=8)] = 56
    girth_panels: Annotated[int, Field(ge=6)] = 22

    def hull(self):
        """The geometry as `seatune.physics.hull.ParametricHull`."""
        from seatune.physics.hull import ParametricHull

        return ParametricHull(self.length, self.beam, self.depth, self.bilge_radius, self.midbody,
                              self.bow_fineness, self.stern_fineness, self.stern_halfbreadth)


class MeshHullSpec(_Strict):
    file: str
    draft: PositiveFloat  # the draft at which the mesh file was drawn (keel at z = -draft)


class WamitRunSpec(_Strict):
    prefix: str  # path without extension: PREFIX.1, PREFIX.3, PREFIX.hst (+ PREFIX.frc)
    draft: PositiveFloat
    mass: PositiveFloat | None = None  # kg the run's .hst was computed with, when PREFIX.frc does not give it


class WamitHullSpec(_Strict):
    prefix: str | None = None  # one run: path without extension (PREFIX.1, .3, .hst, optional .frc)
    draft: PositiveFloat | None = None
    runs: list[WamitRunSpec] | None = None  # or one WAMIT run per draft: a multi-draft database
    length_scale: PositiveFloat = 1.0  # WAMIT ULEN

    @model_validator(mode="after")
    def _one_form(self):
        if self.runs is None and (self.prefix is None or self.draft is None):
            raise ValueError("give `prefix` and `draft` (one run) or `runs` (one run per draft)")
        if self.runs is not None and (self.prefix is not None or self.draft is not None):
            raise ValueError("`prefix` and `draft` go with one run; with `runs` each run gives its own")
        if self.runs is not None and not self.runs:
            raise ValueError("`runs` is empty")
        return self

    def all_runs(self) -> list[WamitRunSpec]:
        return self.runs if self.runs is not None else [WamitRunSpec(prefix=self.prefix, draft=self.draft)]


class CapytaineHullSpec(_Strict):
    file: str | None = None  # netCDF written by Capytaine (one draft) or by `seatune vessel build` (several)
    draft: PositiveFloat | None = None  # needed for a single-draft Capytaine file without `draught`
    files: list[str] | str | None = None  # one Capytaine file per draft (a list, or a glob), drafts from `draught`

    @model_validator(mode="after")
    def _one_form(self):
        if (self.file is None) == (self.files is None):
            raise ValueError("give either `file` (one dataset) or `files` (one dataset per draft)")
        if self.files is not None and self.draft is not None:
            raise ValueError("`draft` goes with `file`; with `files` each dataset's `draught` gives its draft")
        return self


class HullSpec(_Strict):
    parametric: ParametricHullSpec | None = None
    mesh: MeshHullSpec | None = None
    wamit: WamitHullSpec | None = None
    capytaine: CapytaineHullSpec | None = None

    @model_validator(mode="after")
    def _one_source(self):
        given = [k for k in ("parametric", "mesh", "wamit", "capytaine") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one hull source (parametric, mesh, wamit, capytaine), "
                             f"got {given or 'none'}")
        return self

    @property
    def kind(self) -> str:
        return next(k for k in ("parametric", "mesh", "wamit", "capytaine") if getattr(self, k) is not None)


class BemSpec(_Strict):
    omega_min: PositiveFloat = 0.2
    omega_max: PositiveFloat = 2.0
    n_omega: Annotated[int, Field(ge=2)] = 60
    n_wave_directions: Annotated[int, Field(ge=4)] = 24
    lid: bool = True  # irregular-frequency removal


class LoadingSpec(_Strict):
    mass: PositiveFloat | None = None  # kg
    displacement: PositiveFloat | None = None  # displaced volume [m^3]; alternative to mass
    xcg: float = 0.0
    ycg: float = 0.0
    zcg: float  # above baseline [m]
    r44: PositiveFloat
    r55: PositiveFloat
    r66: PositiveFloat
    gmt_fs: NonNegativeFloat = 0.0
    gml_fs: NonNegativeFloat = 0.0
    beta33: NonNegativeFloat = 0.0
    beta44: NonNegativeFloat = 0.0
    beta55: NonNegativeFloat = 0.0

    @model_validator(mode="after")
    def _mass_or_displacement(self):
        if (self.mass is None) == (self.displacement is None):
            raise ValueError("give exactly one of mass [kg] or displacement [m^3]")
        return self


ChannelKind = Literal["angle", "rate", "displacement", "velocity", "acceleration", "specific_force"]


class ChannelSpec(_Strict):
    name: str
    kind: ChannelKind
    axis: Literal["x", "y", "z"]
    point: tuple[float, float, float] | None = None  # hull frame; required for point channels
    units: str | None = None
    sensor: str | None = None  # e.g. "imu", "heave_A": groups channels of one instrument

    @model_validator(mode="after")
    def _point_needed(self):
        if self.kind in ("displacement", "velocity", "acceleration", "specific_force") and self.point is None:
            raise ValueError(f"channel kind '{self.kind}' needs a point [x, y, z]")
        expected = {"angle": "rad", "rate": "rad/s", "displacement": "m", "velocity": "m/s",
                    "acceleration": "m/s^2", "specific_force": "m/s^2"}[self.kind]
        if self.units is not None and self.units != expected:
            raise ValueError(f"units of a {self.kind} channel are {expected}, got {self.units!r}")
        return self


class EulerRotation(_Strict):
    """ZYX (yaw, then pitch, then roll) angles in degrees, the attitude convention of DESIGN §3."""

    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float = 0.0


class SensorSpec(_Strict):
    """How an instrument is mounted; its lever arm is the `point` of its channels."""

    # sensor axes → body axes (v_body = R v_sensor): a quaternion [x, y, z, w] or {roll_deg, pitch_deg, yaw_deg}
    rotation: Annotated[Annotated[tuple[float, float, float, float], Tag("quaternion")]
                        | Annotated[EulerRotation, Tag("euler")],
                        Discriminator(lambda v: "euler" if isinstance(v, dict | EulerRotation) else "quaternion")
                        ] | None = None

    @field_validator("rotation")
    @classmethod
    def _unit_quaternion(cls, v):
        if isinstance(v, tuple) and abs(math.sqrt(sum(c * c for c in v)) - 1.0) > 1e-6:
            raise ValueError(f"a rotation quaternion [x, y, z, w] must have unit norm, got {list(v)}")
        return v

    def mounting(self):
        """The rotation sensor → body as a scipy Rotation (None when not given)."""
        from scipy.spatial.transform import Rotation

        if self.rotation is None:
            return None
        if isinstance(self.rotation, tuple):
            return Rotation.from_quat(self.rotation)
        r = self.rotation
        return Rotation.from_euler("ZYX", [r.yaw_deg, r.pitch_deg, r.roll_deg], degrees=True)


class PriorSpec(_Strict):
    mean: float | None = None  # default: the loading value
    std: PositiveFloat
    bounds: tuple[float, float] | None = None

    @field_validator("bounds")
    @classmethod
    def _ordered(cls, v):
        if v is not None and not v[0] < v[1]:
            raise ValueError("bounds must be [low, high] with low < high")
        return v


class VesselSpec(_Strict):
    name: str
    description: str = ""
    hull: HullSpec
    hydro_database: str | None = None  # netCDF built by `seatune vessel build`; relative to this file
    drafts: list[PositiveFloat] | None = None  # BEM drafts for parametric / mesh hulls
    water_depth: PositiveFloat | Literal["infinite"] = "infinite"
    rho: PositiveFloat = 1025.0
    g: PositiveFloat = 9.81
    bem: BemSpec = BemSpec()
    loading: LoadingSpec
    channels: list[ChannelSpec] = []
    sensors: dict[str, SensorSpec] = {}  # per sensor tag of the channels: its mounting rotation
    priors: dict[str, PriorSpec] = {}
    # physical effects added by `seatune diagnose` ({kind: <effect>, <parameters>}); tuning and prediction solve
    # the vessel with the model-side ones (moonpool, anti_roll_tank, imu_lever_arm, imu_misalignment)
    effects: list[dict] = []

    @field_validator("drafts")
    @classmethod
    def _increasing(cls, v):
        if v is not None and any(b <= a for a, b in zip(v, v[1:], strict=False)):
            raise ValueError("drafts must be strictly increasing")
        return v

    @field_validator("priors")
    @classmethod
    def _known_parameters(cls, v):
        return check_loading_names(v, extra=("displacement",), what="tunable parameter")

    @property
    def depth_m(self) -> float:
        return math.inf if self.water_depth == "infinite" else float(self.water_depth)


def parse_vessel(data: dict, source: str) -> VesselSpec:
    spec = validate(VesselSpec, data, source)
    _check_consistency(spec, source)
    return spec


def _check_consistency(spec: VesselSpec, source: str) -> None:
    """Cross-key rules, each reported at the key that breaks it."""
    names = [c.name for c in spec.channels]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise UserError(source, f"channels.{i}.name", f"duplicate channel name {name!r}")
    tags = sorted({c.sensor for c in spec.channels if c.sensor})
    for name in spec.sensors:
        if name not in tags:
            raise UserError(source, f"sensors.{name}", f"no channel has sensor: {name} (sensor tags: "
                                                       f"{', '.join(tags) or 'none'})")
    if spec.hull.kind in ("parametric", "mesh") and not spec.drafts:
        raise UserError(source, "drafts", "a parametric or mesh hull needs drafts: [..] for the BEM")
    if spec.hull.kind == "parametric" and spec.drafts and max(spec.drafts) >= spec.hull.parametric.depth:
        raise UserError(source, "drafts", f"every draft must be below the hull depth {spec.hull.parametric.depth:g} m")
    single_draft = (spec.hull.kind == "wamit" and len(spec.hull.wamit.all_runs()) == 1) or (
        spec.drafts is not None and len(spec.drafts) == 1)
    for name in ("mass", "displacement"):
        if name in spec.priors and single_draft:
            raise UserError(source, f"priors.{name}", "cannot be tuned with a single draft: give >= 2 drafts")
    from seatune.diagnosis.effects import check_entry

    for i, entry in enumerate(spec.effects):
        problem = check_entry(entry)
        if problem:
            raise UserError(source, f"effects.{i}", problem)
    for name, prior in spec.priors.items():
        if prior.bounds is not None and prior.mean is not None and not prior.bounds[0] <= prior.mean <= prior.bounds[1]:
            raise UserError(source, f"priors.{name}.mean", f"{prior.mean:g} is outside bounds {list(prior.bounds)}")


def load_vessel(path: str | Path) -> tuple[VesselSpec, Path]:
    """Read and validate a vessel YAML; returns the spec and the folder relative paths start from."""
    path = Path(path)
    spec = parse_vessel(read_yaml(path), str(path))
    base = path.parent
    for place, rel in _referenced_files(spec):
        if rel is not None and not (base / rel).exists():
            raise UserError(str(path), place, f"file not found: {base / rel}")
    return spec, base


def _referenced_files(spec: VesselSpec):
    h = spec.hull
    if h.mesh is not None:
        yield "hull.mesh.file", h.mesh.file
    if h.capytaine is not None:
        yield "hull.capytaine.file", h.capytaine.file
    if h.wamit is not None:
        for i, run in enumerate(h.wamit.all_runs()):
            place = "hull.wamit.prefix" if h.wamit.runs is None else f"hull.wamit.runs.{i}.prefix"
            for ext in (".1", ".3", ".hst"):
                yield place, run.prefix + ext
