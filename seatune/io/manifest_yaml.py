"""Batch manifest YAML (`seatune batch MANIFEST.yaml`): which runs make up a fleet batch and where it goes.

Two ways to list runs (both may be used in one manifest): `runs`, run YAML files (a path or glob, or
`{path, name}`), and `template` + `overrides`, one run per override made from a template run YAML.
Paths are relative to the manifest (template values: relative to the template). See README "seatune batch".
"""

from __future__ import annotations

import glob
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import Field, field_validator

from seatune.errors import UserError
from seatune.io.yaml_config import Strict, read_yaml, validate

NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")  # a run's name is a file name in the fleet folder


def _check_name(v: str | None) -> str | None:
    if v is not None and not NAME_PATTERN.match(v):
        raise ValueError(f"run name {v!r} must be letters, digits, '.', '_' or '-' (it names files)")
    return v


class RunEntry(Strict):
    path: str  # run YAML, or a glob of run YAMLs
    name: str | None = None  # default: the run YAML's file name without .yaml

    _name = field_validator("name")(classmethod(lambda cls, v: _check_name(v)))


class Override(Strict):
    """One run made from the template: its name and what differs from the template."""

    name: str
    run_dir: str | None = None  # default: OUT/NAME
    vessel: str | None = None
    logs: list[dict[str, Any]] | None = Field(default=None, min_length=1)
    hindcast: dict[str, Any] | None = None
    topics: dict[str, Any] | None = None
    channels: dict[str, str] | None = None
    # settings sections: merged key by key into the template's
    ingest: dict[str, Any] | None = None
    windows: dict[str, Any] | None = None
    filter: dict[str, Any] | None = None
    identify: dict[str, Any] | None = None
    tuning: dict[str, Any] | None = None

    _name = field_validator("name")(classmethod(lambda cls, v: _check_name(v)))


class ManifestSpec(Strict):
    out: str | None = None  # fleet folder (relative to the manifest); --out overrides
    runs: list[RunEntry] = []  # a plain string is {path: STRING}
    template: str | None = None
    overrides: list[Override] = []

    @field_validator("runs", mode="before")
    @classmethod
    def _plain_paths(cls, v):
        return [{"path": e} if isinstance(e, str) else e for e in v] if isinstance(v, list) else v


@dataclass(frozen=True)
class BatchRun:
    """One run of a batch: its fleet name and its run YAML; `data` set = a template run still to be written."""

    name: str
    run_yaml: Path
    place: str  # where in the manifest it comes from (for error lines)
    data: dict | None = None


@dataclass(frozen=True)
class Manifest:
    path: Path
    out: Path
    runs: tuple[BatchRun, ...]


def _abs(base: Path, value: str) -> str:
    return value if Path(value).is_absolute() else str((base / value).resolve())


def _template_run(template: dict, tbase: Path, o: Override, mbase: Path, out: Path) -> dict:
    """The template with one override applied; every path made absolute (the result is written elsewhere)."""
    data = {k: v for k, v in template.items()}
    for key in ("vessel", "run_dir"):
        if isinstance(data.get(key), str):
            data[key] = _abs(tbase, data[key])
    data["logs"] = [{**log, "path": _abs(tbase, log["path"])} if isinstance(log, dict) and "path" in log else log
                    for log in data.get("logs") or []]
    if isinstance(data.get("hindcast"), dict) and isinstance(data["hindcast"].get("path"), str):
        data["hindcast"] = {**data["hindcast"], "path": _abs(tbase, data["hindcast"]["path"])}
    given = o.model_dump(exclude_none=True)
    data["name"] = o.name
    data["run_dir"] = _abs(mbase, given.pop("run_dir")) if "run_dir" in given else str(out / o.name)
    if "vessel" in given:
        data["vessel"] = _abs(mbase, given.pop("vessel"))
    if "logs" in given:
        data["logs"] = [{**log, "path": _abs(mbase, log["path"])} if "path" in log else log
                        for log in given.pop("logs")]
    if "hindcast" in given:
        h = given.pop("hindcast")
        data["hindcast"] = {**h, "path": _abs(mbase, h["path"])} if "path" in h else {**data["hindcast"], **h}
    for key, value in given.items():  # name (done), topics, channels, settings sections
        if key != "name":
            base = data.get(key)
            data[key] = {**base, **value} if isinstance(base, dict) else value
    return data


def read_manifest(path: str | Path, out: str | Path | None = None) -> Manifest:
    """Validate a manifest; expand globs; check that names are unique. Run YAMLs themselves are not read here
    (a bad run fails on its own in the batch, the others go on)."""
    path = Path(path)
    src = str(path)
    spec = validate(ManifestSpec, read_yaml(path), src)
    base = path.parent
    if out is not None:
        out_dir = Path(out).resolve()
    elif spec.out is not None:
        out_dir = (base / spec.out).resolve()
    else:
        raise UserError(src, "out", "required key is missing (or give --out DIR)")
    runs: list[BatchRun] = []
    for i, entry in enumerate(spec.runs):
        pattern = base / entry.path
        matches = sorted(glob.glob(str(pattern))) if glob.has_magic(entry.path) else [str(pattern)]
        if not matches:
            raise UserError(src, f"runs.{i}", f"no run YAML matches {pattern}")
        if entry.name and len(matches) > 1:
            raise UserError(src, f"runs.{i}.name", f"a name needs a single run YAML, {entry.path} matches "
                                                   f"{len(matches)}")
        for m in matches:
            m = Path(m)
            name = entry.name or m.stem
            if not entry.name and not NAME_PATTERN.match(name):
                raise UserError(src, f"runs.{i}", f"run YAML {m.name}: give it a `name:` made of letters, digits, "
                                                  f"'.', '_' or '-' (it names files)")
            runs.append(BatchRun(name, m.resolve(), f"runs.{i}"))
    if spec.overrides and spec.template is None:
        raise UserError(src, "template", "overrides need a template run YAML")
    if spec.template is not None:
        if not spec.overrides:
            raise UserError(src, "overrides", "a template needs at least one override (one per run)")
        tpath = base / spec.template
        template = read_yaml(tpath)  # unreadable template: a manifest error (every run would fail alike)
        for j, o in enumerate(spec.overrides):
            data = _template_run(template, tpath.parent, o, base, out_dir)
            runs.append(BatchRun(o.name, out_dir / "runs" / f"{o.name}.yaml", f"overrides.{j}", data))
    if not runs:
        raise UserError(src, "runs", "no run listed (give `runs` or `template` + `overrides`)")
    seen: dict[str, str] = {}
    for r in runs:
        if r.name in seen:
            raise UserError(src, r.place, f"run name {r.name!r} is used twice (also {seen[r.name]}); "
                                          f"give the runs different names")
        seen[r.name] = r.place
    return Manifest(path.resolve(), out_dir, tuple(runs))
