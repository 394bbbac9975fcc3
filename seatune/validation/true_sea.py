"""The reference tune of the bank: a trial tuned once more with its true directional sea (truth.yaml's partitions,
in the independent generator's own spectra and spreading) given to the tuner, everything else as the run had it.
What the estimated sea costs the loading is then the difference of the two posteriors (issue 16: inside 1σ).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from seatune.identification.sea_estimation import DIRS_FROM
from seatune.validation.score import match_windows

GIVEN_SEA_STD = (0.03, 0.2, 3.0)  # Hs relative, Tp [s], direction [deg]: the floors of an estimated sea
_FIELDS = ("kind", "hs", "tp", "dir_from_deg", "gamma", "spreading", "spread_deg", "shape")


def true_sea(truth: dict, windows: pd.DataFrame):
    """given_sea(row, omega) → (S(ω, D), D, WindowSea) of the truth window each accepted window overlaps most."""
    from seatune.pipeline.sea import WindowSea
    from seatune.simulate.independent.seas import Partition, directional_spectrum

    matched = match_windows(truth.get("windows") or [], windows)

    def given(row, omega):
        w = matched.get(str(row.window_id))
        if w is None:
            raise ValueError(f"window {row.window_id} overlaps no truth window")
        parts = [Partition(**{k: p[k] for k in _FIELDS}) for p in w["partitions"]]
        top = max(w["partitions"], key=lambda p: p["hs"])
        sea = WindowSea(float(w["hs"]), float(top["tp"]), *GIVEN_SEA_STD, estimated=True)
        return directional_spectrum(omega, DIRS_FROM, parts), DIRS_FROM.copy(), sea

    return given


def true_sea_posterior(folder: Path, truth: dict) -> dict[str, tuple[float, float]]:
    """{parameter: (mean, std)} of the trial's run tuned with its true sea (nothing is written), on the vessel the
    run's tune had: with the loading the sea fit read (`sea.read_loading`), so that the two posteriors differ by the
    sea alone."""
    from seatune.io.run_yaml import Run
    from seatune.pipeline.sea import with_sea_read
    from seatune.pipeline.tune import fit_loading
    from seatune.pipeline.vessel import open_run_vessel

    run = Run(str(Path(folder) / "run.yaml"))
    windows = pd.read_parquet(run.artefact("windows.parquet"))
    vessel = with_sea_read(run, open_run_vessel(run))
    fit = fit_loading(run, vessel, echo=lambda *a, **k: None, given_sea=true_sea(truth, windows))
    return {name: (float(m), float(s)) for name, m, s in zip(fit.post.names, fit.post.mean, fit.post.std,
                                                              strict=True)}
