"""End to end: `demcal calibrate` on the analytic stand-in study, then its report, checked
section by section and figure by figure (a renamed key becomes a render note: none allowed).

The analytic study runs in seconds (examples/analytic); its store is a real writer's store.
"""

from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
import tomllib
from html import escape
from pathlib import Path

import pytest
from htmltables import read_tables, section
from typer.testing import CliRunner

import demcal.virtual
from demcal.cli import app
from demcal.report import build_report
from demcal.store import RunStore
from demcal.virtual.material_card import read_material_card

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "analytic" / "study.toml"

SECTIONS = ("stages", "material", "measurement", "rangefind", "screening", "steepest", "rsm",
            "optimize", "verification", "excluded")
FIGURES = ("rangefind", "pareto", "screening_residuals", "screening_boxcox",
           "screening_perturbation", "screening_contours", "steepest", "rsm_residuals",
           "rsm_boxcox", "rsm_perturbation", "surface_x3_x4", "surface_x3_x8", "surface_x4_x8",
           "predicted_actual", "verification")
TABLES = ("stages", "material_card", "parameters", "lab_measurements", "target",
          "screening_design", "screening_anova", "screening_checks", "steepest", "rsm_design",
          "rsm_anova", "rsm_fit", "rsm_checks", "rsm_coefficients", "candidates",
          "verification_summary", "verification", "excluded_runs")
NOTES = ("could not be drawn", "could not be shown", "diagnostics not computed",
         "image not found", "material card not built")


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory) -> dict:
    """The analytic study calibrated by the CLI (which builds the report)."""
    root = tmp_path_factory.mktemp("analytic")
    study = root / "study.toml"
    shutil.copy(EXAMPLE, study)
    res = CliRunner().invoke(app, ["calibrate", str(study), "--workers", "1"])
    assert res.exit_code == 0, res.output
    assert "material card:" in res.output and "material.toml" in res.output
    html_path = root / "report" / "report.html"
    return {"root": root, "html_path": html_path, "html": html_path.read_text("utf-8"),
            "json": json.loads((root / "report" / "report.json").read_text("utf-8"))}


def test_every_section_table_and_figure_is_there_without_a_note(calibrated):
    html, doc = calibrated["html"], calibrated["json"]
    assert doc["problems"] == []
    assert all(s["status"] == "done" for s in doc["stages"].values())
    for note in NOTES:
        assert note not in html, note
    for sid in SECTIONS:
        assert f'<section id="{sid}">' in html, sid
    tables = read_tables(html)
    for key in TABLES:
        assert f"t-{key}" in tables and tables[f"t-{key}"]["rows"], key
        assert "(no rows)" not in str(tables[f"t-{key}"]["rows"]), key
    assert sorted(doc["figures"]) == sorted(f"figures/{k}.png" for k in FIGURES)
    out = calibrated["html_path"].parent
    imgs = re.findall(r'<img alt="[^"]*" src="data:image/png;base64,([^"]+)"', html)
    assert len(imgs) == len(FIGURES)
    for key in FIGURES:  # each figure file is the PNG embedded in the page
        png = (out / "figures" / f"{key}.png").read_bytes()
        assert png[:4] == b"\x89PNG" and len(png) > 5000, key
        assert base64.b64encode(png).decode() in imgs, key


def test_the_page_is_self_contained_and_fits_a_phone_and_print(calibrated):
    html = calibrated["html"]
    assert "<script" not in html.lower() and not re.search(r"(src|href)=\"(?!data:)", html)
    assert 'name="viewport" content="width=device-width' in html
    assert "@media (max-width: 640px)" in html
    css_print = html[html.index("@media print"):]
    assert "break-inside: avoid" in css_print and "figure" in css_print


def test_the_raw_measurement_dump_is_gone(calibrated):
    html = calibrated["html"]
    meas = section(html, "measurement")
    assert "derived." not in html and "raw." not in meas
    rows = read_tables(html)["t-parameters"]["rows"]
    assert len(rows) == len(demcal.virtual.PARAMETERS)
    by_symbol = {r[1]: r for r in rows}
    assert by_symbol["x3"][2] == "0.2-1" and by_symbol["x3"][5] == "calibrated"
    assert "searched 0-0.025" in by_symbol["x8"][2]  # the range finding's cut
    lab = read_tables(html)["t-lab_measurements"]["rows"]
    assert lab == [["angle of repose (target)", "deg", "40", "1", "5", "", ""]]


def ver_summary_confirmed(calibrated) -> bool:
    v = calibrated["json"]["summaries"]["verification"]
    return v["confirm_pi_low_deg"] <= v["aor_mean_deg"] <= v["confirm_pi_high_deg"]


def test_material_card_round_trips_the_verified_parameters(calibrated):
    out = calibrated["html_path"].parent
    ver = calibrated["json"]["summaries"]["verification"]["params"]
    for name in ("material.toml", "material.json"):
        card = read_material_card(out / name)
        assert list(card.parameters) == list(ver)
        assert all(card.parameters[k].hex() == float(v).hex() for k, v in ver.items())
        assert set(card.calibrated) == {"pp.static_friction", "pp.rolling_friction",
                                        "pp.surface_energy"}
        assert card.test.kind == "analytic" and card.rolling_model == "A"
    text = (out / "material.toml").read_text()
    card_ver = tomllib.loads(text)["verification"]
    assert card_ver["consistent"] is True
    assert card_ver["confirmed"] == ver_summary_confirmed(calibrated)  # Design-Expert's check
    assert card_ver["confirm_pi_low_deg"] < card_ver["predicted_aor_deg"]
    line = calibrated["json"]["material"]["verification"]["line"]
    assert line.startswith("verified AoR") and "(n = 3)" in line and "vs measured 40.00" in line
    assert "response surface's prediction" in line
    mat = section(calibrated["html"], "material")
    assert escape(line) in mat
    assert "JKR" in mat and "rolling friction model A" in mat
    assert "stalk of 7 spheres, 10 x 4 mm" in mat and "0.2 of the Rayleigh step" in mat
    assert read_material_card(out / "material.toml").shape.n_spheres == 7


def test_simulate_material_reruns_the_verification_parameters(calibrated, monkeypatch):
    seen: dict = {}

    def fake_run_aor(params_list, *, config, seeds, **kw):
        seen["params"] = params_list[0]
        raise SystemExit(0)  # the inputs are what is checked; no engine run here

    monkeypatch.setattr(demcal.virtual, "run_aor", fake_run_aor)
    card = calibrated["html_path"].parent / "material.toml"
    res = CliRunner().invoke(app, ["simulate", "aor", "--material", str(card)])
    assert res.exit_code == 0, res.output
    ver = calibrated["json"]["summaries"]["verification"]["params"]
    assert {k: v.hex() for k, v in seen["params"].items()} == \
        {k: float(v).hex() for k, v in ver.items()}


def test_diagnostics_agree_with_the_verdict(calibrated):
    diag = calibrated["json"]["diagnostics"]
    for stage in ("screening", "rsm"):
        d = diag[stage]
        assert d["adequate"] is not any(c["ok"] is False and c["binding"]
                                        for c in d["checks"])
        assert len(d["studentized"]) == len(d["predicted"]) == len(d["cooks"])
        assert d["boxcox"]["recommended"] == "none"
    rsm = section(calibrated["html"], "rsm")
    assert "Diagnostics verdict:</b> adequate" in rsm
    assert "the target 40.00° contour" in rsm  # drawn where the surface reaches it


def test_a_low_predicted_r2_is_not_called_adequate(calibrated, tmp_path):
    root = tmp_path / "study"
    shutil.copytree(calibrated["root"], root, ignore=shutil.ignore_patterns("report"))
    with RunStore(root / "demcal.sqlite") as store:
        rec = store.stage("rsm")
        summary = dict(rec.summary)
        summary["fit"] = {**summary["fit"], "pred_r2": 0.06}
        summary["adequacy"] = {**summary.get("adequacy", {}), "pred_r2": 0.06}
        summary["adequate"] = True
        store.set_stage("rsm", "done", summary, inputs_hash=rec.inputs_hash)
    path = build_report(root)
    doc = json.loads((path.parent / "report.json").read_text())
    assert doc["diagnostics"]["rsm"]["adequate"] is False
    rsm = section(path.read_text("utf-8"), "rsm")
    assert "Diagnostics verdict:</b> not adequate" in rsm and "predicted R²" in rsm
    assert "the diagnostics verdict is the one to trust" in rsm


def test_report_command_writes_the_material_card(calibrated, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["report", str(calibrated["root"]), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert f"material card: {out / 'material.toml'}" in res.output.replace("\n", "")
    assert (out / "material.toml").read_text() == \
        (calibrated["html_path"].parent / "material.toml").read_text()


@pytest.mark.slow
def test_report_renders_in_headless_chromium(calibrated, tmp_path):
    """The page renders (phone width too), the screenshot is not blank, and it prints to
    PDF."""
    exe = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                if shutil.which(n)), None)
    if exe is None:
        pytest.skip("no Chromium (Debian package chromium) on this machine")
    np = pytest.importorskip("numpy")
    from matplotlib.image import imread

    for width in (1200, 390):
        shot = tmp_path / f"shot_{width}.png"
        subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu",
                        f"--window-size={width},2400", f"--screenshot={shot}",
                        calibrated["html_path"].as_uri()], check=True, timeout=120,
                       capture_output=True)
        img = imread(shot)
        assert img.shape[1] == width
        assert float(np.std(img[..., :3])) > 0.05, "blank screenshot"
    pdf = tmp_path / "report.pdf"
    subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu",
                    "--no-pdf-header-footer", f"--print-to-pdf={pdf}",
                    calibrated["html_path"].as_uri()], check=True, timeout=120,
                   capture_output=True)
    data = pdf.read_bytes()
    assert data[:4] == b"%PDF" and len(re.findall(rb"/Type\s*/Page[^s]", data)) > 5


def test_calibrate_without_the_report_still_writes_the_material_card(calibrated, tmp_path):
    root = tmp_path / "study"
    shutil.copytree(calibrated["root"], root, ignore=shutil.ignore_patterns("report"))
    res = CliRunner().invoke(app, ["calibrate", str(root / "study.toml"), "--no-report"])
    assert res.exit_code == 0, res.output  # nothing reruns: every run is stored
    assert (root / "report" / "material.toml").read_text() == \
        (calibrated["html_path"].parent / "material.toml").read_text()
    assert not (root / "report" / "report.html").exists()
