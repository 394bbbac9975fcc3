"""The vessel model every stage uses: validated spec + hydro database + channels + base loading."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from pathlib import Path

from seatune.errors import UserError
from seatune.io.vessel_yaml import LOADING_PARAMETERS, VesselSpec, load_vessel
from seatune.physics.channels import Channel
from seatune.physics.hydro import HydroDatabase, load_netcdf
from seatune.physics.loading import Loading


@dataclass(frozen=True)
class VesselModel:
    spec: VesselSpec
    source: Path
    db: HydroDatabase
    channels: list[Channel]

    @property
    def base_loading(self) -> Loading:
        return self.loading()

    def _replaced(self, overrides: dict) -> dict:
        """The YAML loading's values with `overrides` in place (mass and displacement replace each other)."""
        values = self.spec.loading.model_dump()
        for key, val in overrides.items():
            if key not in LOADING_PARAMETERS and key != "displacement":
                known = ", ".join((*LOADING_PARAMETERS, "displacement"))
                raise UserError(str(self.source), f"--set {key}", f"unknown loading parameter (one of {known})")
            if key in ("mass", "displacement"):
                values["mass"] = values["displacement"] = None
            values[key] = val
        return values

    def loading(self, **overrides) -> Loading:
        """The YAML loading condition with parameters replaced (scalars or arrays)."""
        values = self._replaced(overrides)
        try:
            loading = Loading.from_mapping(values, rho=self.db.rho)
        except ValueError as err:
            raise UserError(str(self.source), "loading", str(err)) from None
        self.check_in_database(loading)
        return loading

    def with_loading(self, **values) -> VesselModel:
        """The same vessel with values of its YAML loading replaced (the loading computer's `identify.known`):
        the condition every untuned parameter then keeps."""
        if not values:
            return self
        from seatune.io.vessel_yaml import LoadingSpec

        data = self._replaced({key: float(val) for key, val in values.items()})
        try:
            spec = self.spec.model_copy(update={"loading": LoadingSpec(**data)})
        except ValueError as err:
            raise UserError(str(self.source), "loading", str(err).splitlines()[-1]) from None
        out = replace(self, spec=spec)
        out.check_in_database(out.base_loading)
        return out

    def check_in_database(self, loading: Loading) -> None:
        try:
            self.db.draft_for_volume(loading.mass / self.db.rho)
        except ValueError as err:
            raise UserError(str(self.source), "loading.mass", str(err)) from None

    def channel(self, name: str) -> Channel:
        for ch in self.channels:
            if ch.name == name:
                return ch
        raise UserError(str(self.source), "channels", f"no channel named {name!r}")

    @property
    def length(self) -> float | None:
        return _attr_float(self.db, "length")

    @property
    def beam(self) -> float | None:
        return _attr_float(self.db, "beam")


def _attr_float(db: HydroDatabase, key: str) -> float | None:
    val = (db.attrs or {}).get(key)
    return None if val is None else float(val)


def database_path(spec: VesselSpec, base: Path) -> Path | None:
    return None if spec.hydro_database is None else base / spec.hydro_database


def load_database(spec: VesselSpec, base: Path, source: Path) -> HydroDatabase:
    h = spec.hull
    path = database_path(spec, base)
    if path is not None and path.exists():
        try:
            return load_netcdf(path)
        except (OSError, KeyError, ValueError) as err:
            raise UserError(str(path), None, f"not a seatune hydro database ({err})") from None
    if h.capytaine is not None:
        from seatune.io.capytaine_import import read_capytaine_dataset, read_capytaine_files

        if h.capytaine.files is not None:
            return read_capytaine_files(capytaine_files(h.capytaine.files, base))
        return read_capytaine_dataset(base / h.capytaine.file, draft=h.capytaine.draft)
    if h.wamit is not None:
        from seatune.io.capytaine_import import stack_drafts
        from seatune.io.wamit import read_wamit

        lo = spec.loading
        loading_mass = lo.mass if lo.mass is not None else spec.rho * lo.displacement
        runs = h.wamit.all_runs()
        for i, run in enumerate(runs if h.wamit.runs is not None else []):
            if run.mass is None and not (base / (run.prefix + ".frc")).exists():
                raise UserError(str(source), f"hull.wamit.runs.{i}.mass", f"needed: {run.prefix}.frc does not give "
                                "the mass the run's .hst restoring was computed with")
        dbs = [read_wamit(str(base / run.prefix), draft=run.draft, rho=spec.rho, g=spec.g,
                          length_scale=h.wamit.length_scale,
                          mass=run.mass if h.wamit.runs is not None else loading_mass,  # per run: its own mass
                          center_of_mass=(lo.xcg, lo.ycg, lo.zcg - run.draft), water_depth=spec.depth_m)
               for run in runs]
        if len(dbs) == 1:
            return dbs[0]
        return stack_drafts(dbs, [base / (run.prefix + ".hst") for run in runs], "hull.wamit.runs draft")
    where = f"hydro_database ({path})" if path is not None else "hydro_database"
    raise UserError(str(source), where, f"hydro database not built yet: run `seatune vessel build {source}`")


def capytaine_files(files: list[str] | str, base: Path) -> list[Path]:
    """`hull.capytaine.files`: a list of paths or one glob, relative to the vessel YAML."""
    import glob

    patterns = [files] if isinstance(files, str) else files
    out = []
    for pattern in patterns:
        found = sorted(glob.glob(str(base / pattern)))
        if not found:
            raise UserError(str(base / pattern), "hull.capytaine.files", "no such file")
        out += [Path(f) for f in found]
    return out


def with_mass_aliases(names) -> set:
    """`names`, holding both mass and displacement when either is among them (one quantity, two names)."""
    names = set(names)
    return names | {"mass", "displacement"} if names & {"mass", "displacement"} else names


def open_run_vessel(run, path: str | Path | None = None) -> VesselModel:
    """The run's vessel (or the vessel YAML at `path`, e.g. diagnose's augmented one) with the run YAML's
    `identify.known` loading values (mass, zcg, … from the loading computer) in its base condition for the
    parameters it does not tune: every stage then models them as known on board instead of at the vessel YAML's
    design values (a KG 0.5 m off the YAML's would otherwise be tuned into gmt_fs); a tuned parameter starts from
    its prior, as tune does."""
    tuned = with_mass_aliases(run.spec.tuning.parameters)
    known = {k: v for k, v in run.spec.identify.known.items() if k not in tuned}
    vessel = open_vessel(path or run.vessel_path)
    try:
        return vessel.with_loading(**known)
    except UserError as err:  # the run YAML's values are at fault, not the vessel's
        raise UserError(str(run.path), "identify.known", err.problem) from None


def open_vessel(path: str | Path) -> VesselModel:
    spec, base = load_vessel(path)
    db = load_database(spec, base, Path(path))
    channels = [Channel(c.name, c.kind, c.axis, c.point) for c in spec.channels]
    model = VesselModel(spec=spec, source=Path(path), db=db, channels=channels)
    mass_tuned = {"mass", "displacement"} & set(spec.priors)
    if mass_tuned and db.n_drafts == 1:
        raise UserError(str(path), f"priors.{sorted(mass_tuned)[0]}",
                        "cannot be tuned with a single-draft hydro database")
    model.check_in_database(model.base_loading)
    return model


def file_hash(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]

