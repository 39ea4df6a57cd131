"""The target and the fixed parameters from photos and from a measurements file."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import matplotlib.image
import numpy as np

from demcal.calibrate import open_study
from demcal.store import RunStore

ROOT = Path(__file__).resolve().parents[2]


def _pile_photo(path: Path, angle_deg: float) -> None:
    """A dark symmetric pile (triangle) of known flank angle on a white background."""
    h, w, base_row, half = 300, 400, 250, 150
    rows, cols = np.mgrid[0:h, 0:w]
    height = (half - np.abs(cols - w / 2)) * math.tan(math.radians(angle_deg))
    img = np.where((rows < base_row) & (base_row - rows <= height), 0.1, 0.95)
    matplotlib.image.imsave(path, img, cmap="gray", vmin=0, vmax=1)


def test_target_from_photos(study_file):
    for i, a in enumerate((38.0, 42.0)):
        _pile_photo(study_file.parent / f"p{i}.png", a)
    text = study_file.read_text().replace("aor_deg = 40.0\nstd_deg = 1.0\nn = 5",
                                          'photos = ["p0.png", "p1.png"]')
    study_file.write_text(text)
    ctx = open_study(study_file)
    ctx.store.close()
    with RunStore(study_file.parent) as store:
        t = store.meta("target")
    assert t["source"] == "photos" and t["n"] == 2
    assert [round(p["mean_deg"]) for p in t["photos"]] == [38, 42]
    assert abs(t["aor_deg"] - 40.0) < 0.5 and abs(ctx.target - t["aor_deg"]) < 1e-12
    assert t["photos"][0]["file"].endswith("p0.png")
    for p in t["photos"]:
        assert Path(p["figure"]).stat().st_size > 1000  # the diagnostic figure


def test_corn_stalk_study_target_and_fixed_values(tmp_path):
    for f in ("study.toml", "measurements.toml"):
        shutil.copy(ROOT / "examples" / "corn_stalk" / f, tmp_path / f)
    ctx = open_study(tmp_path / "study.toml")
    ctx.store.close()
    assert round(ctx.target, 2) == 44.12  # mean of the paper's Table 2
    assert [f.symbol for f in ctx.factors] == [f"x{i}" for i in range(1, 9)]
    assert ctx.fixed["particle.density"] == pytest_approx(114.36)
    assert ctx.fixed["pp.surface_energy"] == 0.00025  # centre of the 0-0.0005 J/m^2 range
    assert ctx.study.test.kind == "aor" and ctx.study.test.fidelity == "quick"
    st = ctx.study.stages
    n_rf = st.rangefind.points * len(st.rangefind.factors)
    runs = n_rf + st.screening.runs + st.steepest.steps + 12 + st.rsm.center_points \
        + st.verification.n  # BBD of 3 factors: 12 edge runs
    assert runs == 38  # the lean count the README's main command relies on
    with RunStore(tmp_path) as store:
        assert store.meta("physical") is not None
        assert "particle.density" not in {f["name"] for f in store.meta("factors")}
        assert store.meta("fixed_params")["particle.density"] == ctx.fixed["particle.density"]


def pytest_approx(v: float):
    import pytest

    return pytest.approx(v, rel=1e-9)
