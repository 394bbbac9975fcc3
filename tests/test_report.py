"""`seatune report` on sample_logs/ through the CLI: the page is self-contained, its plots decode, it loads in
headless Chromium without console errors and is not blank; summary.parquet against the committed golden key
figures (tests/golden/sample_summary.json, `make golden`), which a deliberate physics change breaks."""

import base64
import html
import io
import json
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml

from seatune.io.motion_table import MotionTable
from seatune.io.parquet import table_metadata
from seatune.report.golden import compare, read_summary
from tests.conftest import ROOT, copy_of_sample
from tests.test_pipeline_sample import run_cli
from tests.test_tune_sample import sample_run

GOLDEN = ROOT / "tests" / "golden" / "sample_summary.json"
CHROMIUM = Path("/usr/bin/chromium")
SECTIONS = ("summary", "defects", "windows", "filter", "raos", "natural-frequencies", "tuning", "validation",
            "artefacts")


@pytest.fixture(scope="module")
def reported(tmp_path_factory, finished_sample):
    """`seatune report` on a copy of the finished sample run (conftest.py): the page made again, every stage before
    it up to date."""
    tmp = tmp_path_factory.mktemp("report")
    path = copy_of_sample(finished_sample, tmp)
    res = run_cli("report", path)
    assert res.returncode == 0, res.stderr
    return tmp / "run", path, res.stdout


def images(page: str) -> list[bytes]:
    return [base64.b64decode(b) for b in re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)]


def test_report_line_ends_with_the_page_path(reported):
    out, _, stdout = reported
    lines = stdout.strip().splitlines()
    assert [ln.split(":")[0] for ln in lines] == ["ingest", "windows", "filter", "sea", "identify", "tune", "diagnose",
                                                 "report"]
    assert lines[-1].endswith(str(out / "report.html"))
    assert (out / "report.html").is_file() and (out / "summary.parquet").is_file()
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary left behind


def test_page_is_self_contained_and_its_plots_decode(reported):
    from PIL import Image

    out, _, _ = reported
    page = (out / "report.html").read_text(encoding="utf-8")
    assert not re.search(r'(src|href)\s*=\s*["\']?\s*(https?:)?//', page, re.I)  # nothing fetched from outside
    assert "<script" not in page.lower() and "@import" not in page and "url(" not in page
    for anchor in SECTIONS:
        assert f'<section id="{anchor}">' in page, anchor
    # seatune run includes diagnose: its verdict, evidence table and residual map are on the page
    diag = page[page.index('<section id="diagnosis">'):]
    diag = diag[:diag.index("</section>")]
    assert "explains the misfit" in diag or "No known effect explains" in diag or "no effect named" in diag
    assert "Evidence per candidate effect" in diag and "Residual map" in diag
    pngs = images(page)
    assert len(pngs) == page.count("<img ") >= 8
    for data in pngs:
        im = Image.open(io.BytesIO(data))
        im.load()
        assert im.format == "PNG" and im.size[0] >= 400 and im.size[1] >= 200
        assert np.asarray(im.convert("L"), dtype=float).std() > 5  # something drawn
    # every ingest defect count is on the page (DESIGN §6: counted in the report)
    counts = table_metadata(out / "motions.parquet")["counts"]
    for key, n in counts.items():
        if key != "records":
            assert re.search(rf"<td>{key.replace('_', ' ')}</td><td class=\"num\">{n:,}</td>", page), key
    # every window and its reason for rejection
    windows = pd.read_parquet(out / "windows.parquet")
    for row in windows.itertuples():
        assert f"<td>W{row.window_id}</td>" in page and html.escape(row.reason) in page


def test_summary_row_and_units(reported):
    out, _, _ = reported
    summary = pd.read_parquet(out / "summary.parquet")
    assert len(summary) == 1
    row = summary.iloc[0]
    units = {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in pq.read_schema(out / "summary.parquet")}
    assert units["hours_logged"] == "h" and units["omega_n_roll"] == "rad/s" and units["derived_displacement"] == "t"
    assert units["posterior_mean_r44"] == "m" and units["posterior_std_r44"] == "m"
    windows = pd.read_parquet(out / "windows.parquet")
    assert row["windows_candidates"] == len(windows) and row["windows_accepted"] == windows["accepted"].sum()
    assert row["backend"] == "dbi" and row["run"] == "sample"
    hist = pd.read_parquet(out / "tuning_history.parquet")
    last = hist[hist["update"] == hist["update"].max()].set_index("parameter")
    assert row["posterior_mean_r44"] == pytest.approx(last.loc["r44", "mean"])
    meta = json.loads(pq.read_schema(out / "summary.parquet").metadata[b"seatune"])
    assert meta["fingerprint"] and "tuning_history.parquet" in meta["inputs"]


def test_tuned_model_path_reproduces_the_prior_model_of_identify(reported):
    """The report's RAO recomputation, fed the prior loading, gives identify's model_prior on every aggregate row."""
    from seatune.io.run_yaml import Run
    from seatune.pipeline.report import tuned_model_raos
    from seatune.pipeline.vessel import open_run_vessel

    out, path, _ = reported
    run = Run(path)
    vessel = open_run_vessel(run)
    raos = pd.read_parquet(out / "raos.parquet")
    motions = MotionTable(out / "motions.parquet")
    got = tuned_model_raos(run, vessel, vessel.base_loading, pd.read_parquet(out / "windows.parquet"), motions, raos)
    agg = raos[raos["scope"] == "aggregate"].merge(got, on=["window_id", "channel", "omega"], how="left")
    assert len(agg) and agg["model_tuned"].notna().all()
    np.testing.assert_allclose(agg["model_tuned"], agg["model_prior"], rtol=1e-9)


def test_up_to_date_report_is_skipped_and_diagnosis_joins_when_present(reported, tmp_path):
    from seatune.io.parquet import column_units, write_table
    from seatune.io.rundir import recorded_fingerprint

    out, path, _ = reported
    res = run_cli("report", path)
    assert res.returncode == 0 and res.stdout.strip().splitlines()[-1].startswith("report: up to date (skipped)")
    shutil.copytree(out, tmp_path / "run")  # a copy: the module's run keeps its own diagnosis
    data = yaml.safe_load(Path(path).read_text())
    data["run_dir"] = str(tmp_path / "run")
    copy = tmp_path / "run.yaml"
    copy.write_text(yaml.safe_dump(data))
    # the stage's own table with a named effect written in (under the stage's fingerprint, so diagnose stays up
    # to date and the report, its input changed, is made again)
    diag_path = tmp_path / "run" / "diagnosis.parquet"
    diag, fp = pd.read_parquet(diag_path), recorded_fingerprint(diag_path)
    units = column_units(diag_path)
    pick = diag.index[diag["effect"] == "imu_misalignment"][0]
    diag["selected"] = diag.index == pick
    diag.loc[pick, ["eligible", "gain_holdout"]] = [True, 12.5]
    write_table(diag, diag_path, units, {"fingerprint": fp})
    res = run_cli("report", copy)
    assert res.returncode == 0, res.stderr
    assert "diagnose: up to date" in res.stdout and "diagnosis included" in res.stdout.splitlines()[-1]
    page = (tmp_path / "run" / "report.html").read_text(encoding="utf-8")
    section = page[page.index('<section id="diagnosis">'):]
    section = section[:section.index("</section>")]
    assert "<b>imu_misalignment</b>" in section and "held-out gain 12.5 nats" in section

    # a table of another program (or an older seatune) under that fingerprint: one line naming it, exit 2, and the
    # report already written is kept
    before = (tmp_path / "run" / "report.html").read_bytes()
    write_table(pd.DataFrame({"effect": ["imu_misalignment"], "evidence": [12.5]}), diag_path,
                {"effect": "", "evidence": ""}, {"fingerprint": fp})
    res = run_cli("report", copy)
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert str(diag_path) in res.stderr and "no fitted, gain_train" in res.stderr
    assert (tmp_path / "run" / "report.html").read_bytes() == before


def test_prediction_joins_the_report_when_present(reported, tmp_path):
    out, path, _ = reported
    shutil.copytree(out, tmp_path / "run")
    data = yaml.safe_load(Path(path).read_text())
    data["run_dir"] = str(tmp_path / "run")
    copy = tmp_path / "run.yaml"
    copy.write_text(yaml.safe_dump(data))
    res = run_cli("predict", copy, "--forecast", data["hindcast"]["path"])
    assert res.returncode == 0, res.stderr
    res = run_cli("report", copy)
    assert res.returncode == 0, res.stderr
    page = (tmp_path / "run" / "report.html").read_text(encoding="utf-8")
    section = page[page.index('<section id="prediction">'):]
    section = section[:section.index("</section>")]
    assert "Advised heading" in section and "P (tuned)" in section and "P (prior)" in section
    assert len(images(section)) == 1


def test_report_stage_alone_on_an_empty_run_dir_is_a_user_error(tmp_path):
    from seatune.errors import UserError
    from seatune.io.run_yaml import Run
    from seatune.pipeline.report import report_stage
    from seatune.pipeline.vessel import open_run_vessel

    run = Run(sample_run(tmp_path))
    with pytest.raises(UserError, match="motions.parquet is missing"):
        report_stage(run, open_run_vessel(run))


def _chromium_page(html_path: Path, screenshot: Path):
    """Load the page in headless Chromium; (console errors, failed or outside requests, broken images)."""
    from playwright.sync_api import sync_playwright

    errors, outside = [], []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=[
            "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
            "--disable-component-update", "--disable-sync", "--no-first-run"])
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.on("console", lambda m: errors.append(f"{m.type}: {m.text}") if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(f"pageerror: {e}"))
            page.on("requestfailed", lambda r: errors.append(f"request failed: {r.url}"))
            page.on("request", lambda r: outside.append(r.url) if not r.url.startswith(("file:", "data:")) else None)
            page.goto(html_path.as_uri(), wait_until="load")
            broken = page.evaluate("Array.from(document.images).filter(i => !i.complete || i.naturalWidth === 0)"
                                   ".length")
            n_images = page.evaluate("document.images.length")
            page.screenshot(path=str(screenshot), full_page=True)
        finally:
            browser.close()
    return errors, outside, broken, n_images


def test_page_loads_in_headless_chromium(reported, tmp_path):
    from PIL import Image

    if not CHROMIUM.exists():
        msg = "chromium is not installed (apt-get install chromium; .ci/run does it)"
        pytest.fail(msg) if os.environ.get("CI") else pytest.skip(msg)
    out, _, _ = reported
    shot = tmp_path / "report.png"
    errors, outside, broken, n_images = _chromium_page(out / "report.html", shot)
    assert errors == [] and outside == []
    assert n_images >= 8 and broken == 0  # every plot rendered
    im = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert im.shape[0] > 3000 and im.shape[1] >= 1200  # the whole page, not an empty viewport
    assert im.std() > 20 and (im < 128).mean() > 0.01  # not blank: text and plots on a light page


def test_key_figures_match_the_golden_summary(reported):
    out, _, _ = reported
    golden = json.loads(GOLDEN.read_text())
    assert compare(read_summary(out / "summary.parquet"), golden) == []


def test_a_physics_change_breaks_the_golden_summary(reported, tmp_path):
    """Added mass 15 % higher in a copy of the hydro database: the natural frequencies and the tuned loading move
    outside their golden tolerances."""
    import xarray as xr

    ds = xr.load_dataset(ROOT / "configs" / "vessels" / "sample_osv_hydro.nc")
    for name in ("added_mass", "added_mass_inf"):
        ds[name] = ds[name] * 1.15
    ds.to_netcdf(tmp_path / "hydro.nc")
    vessel = yaml.safe_load((ROOT / "configs" / "vessels" / "sample_osv.yaml").read_text())
    vessel["hydro_database"] = "hydro.nc"
    (tmp_path / "vessel.yaml").write_text(yaml.safe_dump(vessel))
    _, path, _ = reported
    data = yaml.safe_load(Path(path).read_text())
    data["vessel"], data["run_dir"] = str(tmp_path / "vessel.yaml"), str(tmp_path / "run")
    # one cheap candidate: the figures compared are the stages' before diagnose (the wrong added mass would otherwise
    # send every vessel effect through the cross-validation and the sea's refit: 171 → 77 s side by side)
    data["diagnose"] = {**data.get("diagnose", {}), "effects": ["hs_bias"]}
    (tmp_path / "run.yaml").write_text(yaml.safe_dump(data))
    res = run_cli("report", tmp_path / "run.yaml")
    assert res.returncode == 0, res.stderr
    assert "ingest: up to date" not in res.stdout
    broken = compare(read_summary(tmp_path / "run" / "summary.parquet"), json.loads(GOLDEN.read_text()))
    names = {b.split(":")[0] for b in broken}
    assert {"omega_n_heave_prior", "omega_n_roll_prior", "omega_n_pitch_prior", "derived_displacement",
            "posterior_mean_r44"} <= names, broken


# --- issue 19: layout at 1280 px, response spectra, the evidence toggle, always a report, the warning card ---

LAYOUT_JS = """() => {
  const W = document.documentElement.clientWidth;
  const nav = document.querySelector('nav');
  const links = Array.from(nav.querySelectorAll('a')).map(a => {
    const r = a.getBoundingClientRect(); return [a.textContent, r.left, r.right, Math.round(r.top)]; });
  const tables = [];
  for (const t of document.querySelectorAll('table')) {
    if (t.closest('details:not([open])')) continue;  // behind a closed toggle: not on screen
    const box = t.parentElement, r = t.getBoundingClientRect();
    tables.push([t.caption ? t.caption.textContent.slice(0, 50) : t.rows[0].textContent.slice(0, 50),
                 box.scrollWidth, box.clientWidth, r.left, r.right]);
  }
  const diag = document.querySelector('#diagnosis');
  const toggles = diag ? Array.from(diag.querySelectorAll('details')).map(d => [d.open,
    Array.from(d.querySelectorAll('th')).map(th => th.firstChild.textContent)]) : [];
  const deciding = diag ? Array.from(diag.querySelector('table').querySelectorAll('thead th'))
    .map(th => th.firstChild.textContent) : [];
  return {width: W, page: document.documentElement.scrollWidth, nav: [nav.scrollWidth, nav.clientWidth],
          links, tables, toggles, deciding,
          spectra: Array.from(document.querySelectorAll('#spectra img')).map(i => [i.alt, i.naturalWidth])};
}"""


def _layout(html_path: Path) -> dict:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=["--headless", "--no-sandbox",
                                                                          "--disable-gpu", "--no-first-run"])
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.goto(html_path.as_uri(), wait_until="load")
            return page.evaluate(LAYOUT_JS)
        finally:
            browser.close()


def _need_chromium():
    if not CHROMIUM.exists():
        msg = "chromium is not installed (apt-get install chromium; .ci/run does it)"
        pytest.fail(msg) if os.environ.get("CI") else pytest.skip(msg)


def test_layout_at_1280px_nothing_cut_spectra_per_window_and_the_evidence_toggle(reported):
    """At a 1280 px viewport: no horizontal page scroll, the navigation wraps onto a second row with every link
    inside the viewport, no visible table wider than its box; one response-spectrum plot per accepted window;
    the diagnosis table shows the deciding columns, the rest behind a closed <details>."""
    _need_chromium()
    out, _, _ = reported
    got = _layout(out / "report.html")
    page = (out / "report.html").read_text(encoding="utf-8")
    assert got["width"] == 1280 and got["page"] <= 1280
    assert got["nav"][0] <= got["nav"][1]
    n_sections = page.count("<section id=")
    assert len(got["links"]) == n_sections >= 12
    assert all(0 <= left and right <= 1280 for _, left, right, _ in got["links"]), got["links"]
    assert len({top for *_, top in got["links"]}) >= 2  # wrapped, not cut
    assert len(got["tables"]) >= 10
    cut = [t for t in got["tables"] if t[1] > t[2] or t[4] > 1280]
    assert cut == []
    windows = pd.read_parquet(out / "windows.parquet")
    accepted = {f"response spectra W{w}" for w in windows.loc[windows["accepted"], "window_id"]}
    assert {alt for alt, _ in got["spectra"]} == accepted and len(got["spectra"]) == len(accepted) == 3
    assert all(width >= 800 for _, width in got["spectra"])
    assert got["deciding"] == ["step", "given", "effect", "decision", "held-out gain", "training gain", "BIC penalty",
                               "joint held-out gain", "parameters"]
    rest = [heads for is_open, heads in got["toggles"] if "gap_before_holdout" in heads]
    assert len(rest) == 1 and not [o for o, heads in got["toggles"] if heads == rest[0] and o]


def test_response_spectra_integrate_to_the_sigma_of_filter_and_tune(reported):
    """The plotted spectra against two independent computations: √∫S dω (trapezoid) of the measured Welch
    spectrum is the filter stage's σ of the filtered signal within 3 %, and of the model's spectrum with the prior
    and tuned loading the σ the tune stage's forward model predicted (validation.parquet) within 2 %."""
    from seatune.io.run_yaml import Run
    from seatune.pipeline.report import model_spectra, posterior_means
    from seatune.pipeline.vessel import open_run_vessel

    out, path, _ = reported
    run = Run(path)
    vessel = open_run_vessel(run)
    hist = pd.read_parquet(out / "tuning_history.parquet")
    loadings = {"prior": vessel.base_loading, "tuned": vessel.loading(**posterior_means(hist))}
    spectra = model_spectra(run, vessel, loadings, pd.read_parquet(out / "windows.parquet"),
                            MotionTable(out / "motions.parquet"), pd.read_parquet(out / "window_spectra.parquet"))
    stats = pd.read_parquet(out / "window_stats.parquet").set_index(["window_id", "channel"])
    val = pd.read_parquet(out / "validation.parquet")
    val = val.assign(key=val["window_id"].astype(str) + "/" + val["measurement"]).set_index("key")
    assert spectra["channel"].nunique() == 3 and spectra["window_id"].nunique() == 3
    for (wid, ch), part in spectra.groupby(["window_id", "channel"]):
        sigma = {c: np.sqrt(np.trapezoid(part[c].to_numpy(float), part["omega"].to_numpy(float)))
                 for c in ("measured", "prior", "tuned")}
        assert sigma["measured"] == pytest.approx(stats.loc[(wid, ch), "sigma"], rel=0.03), (wid, ch)
        v = val.loc[f"{wid}/{ch}:sigma"]
        assert sigma["prior"] == pytest.approx(v["predicted_prior"], rel=0.02), (wid, ch)
        assert sigma["tuned"] == pytest.approx(v["predicted_tuned"], rel=0.02), (wid, ch)


def test_partial_hindcast_stencil_count_is_on_the_page(reported):
    out, _, _ = reported
    waves = pd.read_parquet(out / "waves.parquet")
    if "sea_corners" not in waves:
        pytest.skip("the hindcast readers write no sea_corners column")
    page = (out / "report.html").read_text(encoding="utf-8")
    partial = int((waves["sea_corners"] < waves["stencil_corners"]).sum())
    expected = (f"{partial} of {len(waves)} track points used a partial hindcast stencil" if partial else
                f"All {len(waves)} track points had a full hindcast stencil")
    assert expected in page


def _copy_run(reported, tmp_path, **changes) -> Path:
    """The module's run directory copied (its ingest reused), the run YAML with `changes` merged per block."""
    out, path, _ = reported
    shutil.copytree(out, tmp_path / "run")
    data = yaml.safe_load(Path(path).read_text())
    data["run_dir"] = str(tmp_path / "run")
    for block, values in changes.items():
        data[block] = {**(data.get(block) or {}), **values}
    copy = tmp_path / "run.yaml"
    copy.write_text(yaml.safe_dump(data))
    return copy


def test_no_accepted_window_still_writes_the_report_with_the_reasons(reported, tmp_path):
    """windows.max_sog 0.01 m/s rejects every candidate of the sample as moving: `seatune run`
    exits 0 with one warning line, prints the histogram of reasons, writes report.html with the timeline and every
    reason, and shows nothing from the tuned run whose artefacts are still in the directory; `seatune tune`
    stops with one line naming the reasons."""
    from click.testing import CliRunner

    from seatune.cli import batch, stages  # noqa: F401  (registers the commands)
    from seatune.cli.main import cli

    copy = _copy_run(reported, tmp_path, windows={"max_sog": 0.01})
    res = CliRunner().invoke(cli, ["run", str(copy)])  # in process: exit code, stdout and stderr of the CLI
    assert res.exit_code == 0, res.output
    out = tmp_path / "run"
    windows = pd.read_parquet(out / "windows.parquet")
    n = len(windows)
    assert n >= 1 and not windows["accepted"].any()
    moving = int(windows["reason"].str.match(r"moving: speed over ground [\d.]+ m/s > 0.01 m/s$").sum())
    assert moving == n
    assert "ingest: up to date" in res.stdout
    hist = f"{moving} moving (speed over ground > 0.01 m/s)"
    assert f"windows: 0 of {n} candidates accepted, 0 min free floating; rejected: {hist}" in res.stdout
    for stage in ("filter", "sea", "identify", "tune", "diagnose"):
        assert f"{stage}: not run (no accepted window)" in res.stdout
    assert res.stdout.strip().splitlines()[-1] == f"report at {out / 'report.html'}"
    warning = [ln for ln in res.stderr.splitlines() if ln.startswith("seatune: warning:")]
    assert len(warning) == 1 and f"no accepted window: 0 of {n} candidates accepted: {hist}" in warning[0]
    page = (out / "report.html").read_text(encoding="utf-8")
    assert 'alt="timeline of windows"' in page and "No window accepted" in page
    for row in windows.itertuples():
        assert f"<td>W{row.window_id}</td>" in page and html.escape(row.reason) in page
    assert f"Rejected candidates by reason ({n} of {n})" in page
    kind = html.escape("moving (speed over ground > 0.01 m/s)")
    assert f'<td class="wide">{kind}</td><td class="num">{n}</td>' in page
    assert "response spectra W" not in page and "Not tuned this time: no accepted window" in page
    assert '<section id="diagnosis">' not in page and "Measured σ against the model" not in page
    summary = pd.read_parquet(out / "summary.parquet").iloc[0]
    assert summary["windows_accepted"] == 0 and summary["windows_candidates"] == n and summary["backend"] == ""
    res = CliRunner().invoke(cli, ["tune", str(copy)])
    assert res.exit_code == 2
    assert res.stderr.strip().splitlines() == [f"seatune: error: {copy}: windows: no accepted window to tune on: "
                                               f"0 of {n} candidates accepted: {hist}"]


def _held_out(validation: pd.DataFrame, column: str) -> float:
    held = validation[(validation["role"] == "holdout")]
    sig = held[held["measurement"].str.endswith(":sigma")]
    held = sig if len(sig) else held
    return float(np.mean(np.abs(np.log(held[column] / held["measured"]))))


def test_warning_card_only_when_tuning_worsens_the_held_out_error(reported):
    """Built by hand: the sample run's own validation.parquet with its prior and tuned predictions swapped (its
    tuning improves the held-out error, so the swapped table has a tuned model worse than the prior). The card
    appears with both errors for the swapped table and not for the real one, nor on the sample page."""
    from seatune.report.build import tuned_worse
    from seatune.report.summary import held_out_error

    out, _, _ = reported
    val = pd.read_parquet(out / "validation.parquet")
    prior, tuned = _held_out(val, "predicted_prior"), _held_out(val, "predicted_tuned")
    assert tuned < prior
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "Tuning made the held-out prediction worse" not in page
    swapped = val.rename(columns={"predicted_prior": "predicted_tuned", "predicted_tuned": "predicted_prior"})

    def row(v):
        p, t, n = held_out_error(v)
        return {"holdout_sigma_error_prior": p, "holdout_sigma_error_tuned": t, "holdout_windows": n}

    assert tuned_worse(row(val)) == ""
    text = tuned_worse(row(swapped))
    n_held = val.loc[val["role"] == "holdout", "window_id"].nunique()
    assert f"on the {n_held} held-out window(s)" in text
    assert f"all channels {100 * tuned:.1f} % (prior) → {100 * prior:.1f} % (tuned)" in text


@pytest.mark.slow
def test_warning_card_from_a_real_run_whose_tuning_misleads(reported, tmp_path):
    """A real tuning made to mislead: the sample tuned on the roll rate's zero-crossing period alone (a statistic
    that hardly constrains the loading, fitted to two windows' noise) predicts the held-out window's Tz worse than
    the prior (0.4 % → 1.1 % on this sample). The page carries the warning card with the errors of
    validation.parquet, at the top and in the Validation section."""
    from seatune.io.run_yaml import Run
    from seatune.pipeline.report import report_stage
    from seatune.pipeline.vessel import open_run_vessel

    copy = _copy_run(reported, tmp_path, tuning={"channels": ["roll_rate"], "statistics": ["tz"]})
    res = run_cli("tune", copy)
    assert res.returncode == 0, res.stderr
    assert "sea: up to date" in res.stdout and "identify: up to date" in res.stdout
    out = tmp_path / "run"
    for name in ("diagnosis.parquet", "diagnosis_residuals.parquet", "augmented_vessel.yaml"):
        (out / name).unlink(missing_ok=True)  # of the first tuning (augmented: if named)
    val = pd.read_parquet(out / "validation.parquet")
    prior, tuned = _held_out(val, "predicted_prior"), _held_out(val, "predicted_tuned")
    assert tuned > prior
    run = Run(copy)
    report_stage(run, open_run_vessel(run))
    page = (out / "report.html").read_text(encoding="utf-8")
    figures = f"all channels {100 * prior:.1f} % (prior) → {100 * tuned:.1f} % (tuned)"
    cards = re.findall(r'<div class="alert" role="alert"><div class="k">([^<]*)</div><div>([^<]*)</div>', page)
    assert len(cards) == 2 and all(k == "Tuning made the held-out prediction worse" and figures in html.unescape(t)
                                   for k, t in cards)
    validation = page[page.index('<section id="validation">'):]
    assert 'class="alert"' in validation[:validation.index("</section>")]


def test_a_step_withdrawn_after_the_sea_refit_is_said_so():
    """A candidate named at a greedy step, then withdrawn by diagnose's re-test in the sea refitted through the
    other named effects (diagnosis.parquet `withdrawn`): the evidence table says so, not "a stronger candidate"."""
    from types import SimpleNamespace

    from seatune.report.build import _decision

    row = dict(effect="anti_roll_tank", step=2, false_alarm_p=np.nan, cross_fold_gain=52.5, selected=False,
               eligible=True, gain_holdout=66.8, gain_train=85.7, bic_penalty=10.8, at_bound="", widened="")
    assert _decision(SimpleNamespace(**row, withdrawn=True)).startswith("named at step 2, then withdrawn")
    assert _decision(SimpleNamespace(**row, withdrawn=False)) == "eligible; a stronger candidate was named"


def test_a_candidate_named_in_its_own_sea_is_said_so():
    """A candidate that failed held out in the sea stage's sea but passed with the held-out sea refitted through it
    (diagnosis.parquet `own_sea_gain`): the evidence table gives that test, not the failed held-out gain; one that
    failed it too says so."""
    from types import SimpleNamespace

    from seatune.report.build import _decision

    row = dict(effect="imu_misalignment", step=1, false_alarm_p=np.nan, cross_fold_gain=np.nan, eligible=True,
               gain_holdout=-0.5, gain_train=864.8, bic_penalty=9.3, at_bound="", widened="", withdrawn=False)
    named = _decision(SimpleNamespace(**row, selected=True, own_sea_gain=83.7))
    assert named.startswith("named at step 1: held out in its own sea") and "83.7" in named
    failed = _decision(SimpleNamespace(**row | {"eligible": False}, selected=False, own_sea_gain=-5.4))
    assert failed.startswith("passed over: held-out gain ≤ 4 nats") and "its own sea" in failed and "-5.4" in failed


def test_a_candidate_tested_in_its_untouched_sea_is_said_so():
    """A lever arm named in a sea fitted from the channels it leaves untouched (diagnosis.parquet
    `untouched_sea_gain`): the evidence table gives that test; one that failed it, or passed it behind a stronger
    candidate, says which."""
    from types import SimpleNamespace

    from seatune.report.build import _decision

    row = dict(effect="imu_lever_arm", step=1, false_alarm_p=np.nan, cross_fold_gain=np.nan, eligible=False,
               gain_holdout=-35.1, gain_train=282.0, bic_penalty=9.5, at_bound="", widened="", withdrawn=False,
               own_sea_gain=np.nan)
    named = _decision(SimpleNamespace(**row, selected=True, untouched_sea_gain=28.7))
    assert named.startswith("named at step 1: held out in a sea fitted from the channels it leaves untouched")
    assert "28.7" in named
    failed = _decision(SimpleNamespace(**row, selected=False, untouched_sea_gain=-4.7))
    assert "its untouched" not in failed and "leaves untouched" in failed and "-4.7 nats ≤ 4" in failed
    behind = _decision(SimpleNamespace(**row, selected=False, untouched_sea_gain=5.7))
    assert "another vessel candidate fits that sea better" in behind
