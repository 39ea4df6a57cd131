"""The report of the paper's study: renders offline, and every number matches the store."""

from __future__ import annotations

import csv
import math
import re

import numpy as np
import pandas as pd
import pytest
from htmltables import read_tables, section
from matplotlib.figure import Figure
from paper_store import DATA, NAME, rsm_fit
from scipy import stats

from demcal import report
from demcal.store import RunStore
from demcal.summaries import RangeFind, Screening, Steepest, Surface, Target, Verification


def _number(cell: str) -> float | None:
    return None if cell == "" else float(cell.lstrip("<"))


def assert_cell(cell: str, value, where: str) -> None:
    """A table cell shows ``value``: same text, or the same number to the 5 digits shown."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        assert cell == "", f"{where}: expected an empty cell, got {cell!r}"
    elif isinstance(value, bool):
        assert cell == ("yes" if value else "no"), where
    elif isinstance(value, int | float):
        if cell.startswith("<"):
            assert value < float(cell[1:]), f"{where}: {value} shown as {cell}"
        elif where.endswith(".p"):  # p-values: 4 decimals, as Design-Expert prints them
            assert float(cell) == pytest.approx(value, abs=5.001e-5), f"{where}: {value}"
        else:
            assert float(cell) == pytest.approx(value, rel=6e-5, abs=1e-12), \
                f"{where}: {value} shown as {cell}"
    else:
        assert cell == str(value), f"{where}: {value!r} shown as {cell!r}"


# --------------------------------------------------------------------------------- renders
def test_report_renders_offline_with_every_file(paper_report):
    html, doc, out = paper_report["html"], paper_report["json"], paper_report["html_path"].parent
    assert doc["problems"] == []
    assert all(s["status"] == "done" for s in doc["stages"].values())
    # self-contained: no scripts, no external URLs, every image a data URI
    assert "<script" not in html.lower()
    assert not re.search(r"(src|href)=\"(?!data:)", html)
    assert "http://" not in html and "https://" not in html
    imgs = re.findall(r'<img [^>]*src="data:image/png;base64,', html)
    assert len(imgs) == len(doc["figures"]) >= 12
    for rel in doc["figures"]:
        assert (out / rel).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for key in ("screening_design", "screening_anova", "steepest", "rsm_design", "rsm_anova",
                "rsm_fit", "candidates", "verification", "excluded_runs", "measurements"):
        assert (out / "tables" / f"{key}.csv").is_file(), key
    for fig in ("pareto", "steepest", "surface_x3_x4", "predicted_actual", "rangefind",
                "verification", "comparison", "photo_1"):
        assert f"figures/{fig}.png" in doc["figures"], fig


def test_every_html_table_equals_report_json_and_csv(paper_report):
    html_tables = read_tables(paper_report["html"])
    json_tables = paper_report["json"]["tables"]
    assert set(html_tables) == {f"t-{k}" for k in json_tables}
    out = paper_report["html_path"].parent / "tables"
    for key, jt in json_tables.items():
        ht = html_tables[f"t-{key}"]
        assert ht["columns"] == jt["columns"], key
        rows = ht["rows"] if jt["rows"] else []
        assert len(rows) == len(jt["rows"]), key
        for i, (hrow, jrow) in enumerate(zip(rows, jt["rows"], strict=True)):
            for col, cell, value in zip(jt["columns"], hrow, jrow, strict=True):
                assert_cell(cell, value, f"{key}[{i}].{col}")
        with open(out / f"{key}.csv", newline="", encoding="utf-8") as fh:
            crow = list(csv.reader(fh))
        assert crow[0] == jt["columns"]
        for crow_i, jrow in zip(crow[1:], jt["rows"], strict=True):
            for c, v in zip(crow_i, jrow, strict=True):
                if isinstance(v, float):
                    assert float(c) == v  # CSV keeps full precision
                elif v is None:
                    assert c == ""


# ------------------------------------------------------------------- tables against the store
def test_table4_design_and_responses_match_the_store_runs(paper_report):
    t = read_tables(paper_report["html"])["t-screening_design"]
    with RunStore(paper_report["study"]) as store:
        runs = {r.point: r for r in store.runs(stage="screening")}
    t4 = pd.read_csv(DATA / "table4_pb.csv").set_index("run")
    cols = t["columns"]
    assert cols[1:9] == [f"x{i}" for i in range(1, 9)]
    assert len(t["rows"]) == 12
    for row in t["rows"]:
        run = int(row[0])
        assert float(row[cols.index("AoR (deg)")]) == runs[run].aor_deg == t4.loc[run, "aor_deg"]
        for j in range(1, 9):
            assert int(row[j]) == t4.loc[run, f"x{j}"]


def test_table5_anova_and_effects_match_the_stored_fit(paper_report):
    summary = paper_report["json"]["summaries"]["screening"]
    t = read_tables(paper_report["html"])["t-screening_anova"]
    cols = t["columns"]
    rows = {r[0]: r for r in t["rows"]}
    anova = {rec["term"]: rec for rec in summary["anova"]}
    assert rows["Model"][cols.index("SS")] == "124.81"
    assert rows["Model"][cols.index("p")] == "0.0226"
    for name, sym in [(NAME[f"x{i}"], f"x{i}") for i in range(1, 9)]:
        for col, key in (("SS", "ss"), ("F", "f"), ("p", "p"), ("MS", "ms")):
            assert_cell(rows[sym][cols.index(col)], anova[name][key], f"{sym}.{col}")
    eff = {e["term"]: e for e in summary["effects"]}
    for name, sym in [(NAME[f"x{i}"], f"x{i}") for i in range(1, 9)]:
        assert_cell(rows[sym][cols.index("effect")], eff[name]["effect"], sym)
        assert_cell(rows[sym][cols.index("contribution %")], eff[name]["contribution_percent"],
                    sym)
        assert int(rows[sym][cols.index("rank")]) == eff[name]["rank"]
    # the paper's ranking and markers (Table 5)
    ranks = {s: int(rows[s][cols.index("rank")]) for s in (f"x{i}" for i in range(1, 9))}
    assert ranks == {"x1": 4, "x2": 6, "x3": 3, "x4": 2, "x5": 5, "x6": 8, "x7": 7, "x8": 1}
    assert [rows[f"x{i}"][cols.index("significance")] for i in (3, 4, 8)] == ["*", "**", "**"]


def test_table6_path_matches_the_paper(paper_report):
    t = read_tables(paper_report["html"])["t-steepest"]
    t6 = pd.read_csv(DATA / "table6_steepest.csv")
    cols = t["columns"]
    got = np.array([[float(r[cols.index(c)]) for c in ("x3", "x4", "x8", "AoR (deg)",
                                                       "relative error %")] for r in t["rows"]])
    np.testing.assert_array_equal(got, t6[["x3", "x4", "x8", "aor_deg",
                                           "relative_error_percent"]].to_numpy())
    assert [r[cols.index("best")] for r in t["rows"]] == ["", "", "", "best", ""]


def test_table7_and_table8_match_the_store_and_the_paper(paper_report):
    tables = read_tables(paper_report["html"])
    t7 = pd.read_csv(DATA / "table7_bbd.csv").set_index("run")
    d = tables["t-rsm_design"]
    cols = d["columns"]
    with RunStore(paper_report["study"]) as store:
        runs = {r.point: r for r in store.runs(stage="rsm")}
    for row in d["rows"]:
        run = int(row[0])
        assert [int(row[cols.index(s)]) for s in ("x3", "x4", "x8")] == \
            list(t7.loc[run, ["x3", "x4", "x8"]])
        assert float(row[cols.index("AoR (deg)")]) == runs[run].aor_deg
        assert float(row[cols.index("x3 actual")]) == runs[run].params["pp.static_friction"]
    a = tables["t-rsm_anova"]
    rows = {r[0]: r for r in a["rows"]}
    ss = a["columns"].index("SS")
    # Table 8's printed sums of squares, to its 2 decimals
    paper = {"Model": 160.92, "x3": 47.19, "x4": 17.58, "x8": 80.71, "x3·x4": 1.93,
             "x3·x8": 0.65, "x4·x8": 0.14, "x3²": 5.75, "x4²": 0.51, "x8²": 5.51,
             "Residual": 1.33, "Lack of Fit": 1.19, "Pure Error": 0.14}
    for term, value in paper.items():
        assert round(float(rows[term][ss]), 2) == value, term
    p = a["columns"].index("p")
    assert rows["x3"][p] == "<0.0001" and rows["Lack of Fit"][p] == "0.1538"
    fit = {r[0]: r[1] for r in tables["t-rsm_fit"]["rows"]}
    assert round(float(fit["R²"]), 4) == 0.9918
    assert round(float(fit["Adjusted R²"]), 4) == 0.9770
    assert round(float(fit["C.V. %"]), 2) == 1.23
    assert fit["Adeq Precision"] == "26.586"
    assert "Predicted R²" in fit and "Lack of fit p" in fit
    stored = paper_report["json"]["summaries"]["rsm"]["fit"]
    assert_cell(fit["Predicted R²"], stored["pred_r2"], "pred R2")


def test_optimum_and_verification_tables(paper_report):
    tables = read_tables(paper_report["html"])
    summ = paper_report["json"]["summaries"]
    c = tables["t-candidates"]
    cols = c["columns"]
    assert len(c["rows"]) == len(summ["optimize"]["candidates"]) >= 2
    for row, cand in zip(c["rows"], summ["optimize"]["candidates"], strict=True):
        assert_cell(row[cols.index("predicted AoR (deg)")], cand["predicted_aor_deg"], "pred")
        assert_cell(row[cols.index("x4")], cand["params"]["pp.rolling_friction"], "x4")
    v = tables["t-verification_summary"]["rows"][0]
    reps = [43.1, 44.5, 43.9, 44.2, 43.4]
    sd = np.std(reps, ddof=1)
    half = stats.t.ppf(0.975, 4) * sd / np.sqrt(5)
    p = 2 * stats.t.sf(abs(43.82 - 44.12) / (sd / np.sqrt(5)), 4)  # one-sample, target 44.12
    assert v == ["5", "43.82", format(sd, ".5g"), f"{43.82 - half:.2f}-{43.82 + half:.2f}",
                 "44.116", "0.67996", f"{p:.4f}", "consistent",  # p: 4 decimals
                 "", ""]  # a store written before the confirmation: its columns stay empty
    ex = tables["t-excluded_runs"]["rows"]
    assert ex == [["rangefind", "30", "0", "done", "column",
                   "no pile: the material stayed a column"]]


def test_equations_and_coefficients_from_the_store(paper_report):
    html = section(paper_report["html"], "rsm")
    assert "AoR (°) = +41.77 +2.429·x3 +1.482·x4 +3.176·x8 -0.695·x3·x4" in html
    rows = {r[0]: r for r in read_tables(paper_report["html"])["t-rsm_coefficients"]["rows"]}
    coefs = paper_report["json"]["summaries"]["rsm"]["coefficients_actual"]
    assert_cell(rows["x8²"][2], coefs["pp.surface_energy^2"], "actual x8^2")


# ------------------------------------------------------------------------ figures from Python
def test_stored_surface_reproduces_the_fit(paper_report):
    s = paper_report["json"]["summaries"]["rsm"]
    surf = report.StoredSurface.from_summary(s)
    rs = rsm_fit()
    pts = np.random.default_rng(1234).uniform(-1, 1, (20, 3))
    np.testing.assert_allclose(surf.predict_coded(pts), rs.predict(pts, units="coded"),
                               rtol=1e-12)
    # terms written with symbols instead of names evaluate the same
    sym = dict(s)
    sym["coefficients_coded"] = {k.replace("pp.static_friction", "x3")
                                 .replace("pp.rolling_friction", "x4")
                                 .replace("pp.surface_energy", "x8"): v
                                 for k, v in s["coefficients_coded"].items()}
    np.testing.assert_allclose(report.StoredSurface.from_summary(sym).predict_coded(pts),
                               surf.predict_coded(pts), rtol=1e-14)
    assert report.significant_pairs(Surface.from_summary(s)) == [
        ("pp.static_friction", "pp.rolling_friction")]


def test_figures_are_callable_from_python(paper_report):
    summ = paper_report["json"]["summaries"]
    target = Target.from_summary(paper_report["json"]["target"])
    assert len(target.photos) == 5 and target.photos[0].mean_deg is not None
    figs = [report.measurement_figure(target),
            report.rangefind_figure(RangeFind.from_summary(summ["rangefind"]), 44.12),
            report.pareto_figure(Screening.from_summary(summ["screening"]).effects or []),
            report.steepest_figure(Steepest.from_summary(summ["steepest"]), 44.12),
            report.surface_figure(Surface.from_summary(summ["rsm"]), ("x3", "x4")),
            report.predicted_actual_figure(Surface.from_summary(summ["rsm"])),
            report.verification_figure(Verification.from_summary(summ["verification"]), 44.12),
            report.comparison_figure(None, summ["verification"]["pile_png"])]
    assert all(isinstance(f, Figure) and f.axes for f in figs)
    contour = figs[4].axes[1]
    zmin, zmax = contour.collections[0].get_array().min(), contour.collections[0].get_array().max()
    assert 38 < zmin < zmax < 50
    assert len(figs[1].axes) == 8  # one small plot per factor
