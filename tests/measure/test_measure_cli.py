"""``demcal measure`` on photo files: table, outputs, exit code 2 on bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from aor_pile_photos import pile_photo
from typer.testing import CliRunner

from demcal.cli import app


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    from skimage import io, util

    d = tmp_path_factory.mktemp("cli_photos")
    paths = []
    for i, (left, right) in enumerate([(40.0, 44.0), (46.0, 42.0)]):
        img, _ = pile_photo(left, right, rng=np.random.default_rng(i), noise=0.04)
        p = d / f"repeat_{i + 1}.png"
        io.imsave(p, util.img_as_ubyte(img), check_contrast=False)
        paths.append(p)
    return paths


def test_measure_prints_table_and_writes_outputs(photos, tmp_path):
    csv, js, plots = tmp_path / "aor.csv", tmp_path / "aor.json", tmp_path / "figs"
    res = CliRunner().invoke(app, ["measure", *map(str, photos), "--fit-window", "0.25", "0.75",
                                   "--csv", str(csv), "--json", str(js),
                                   "--plot-dir", str(plots)])
    assert res.exit_code == 0, res.output
    assert "repeat_1.png" in res.output and "standard deviation" in res.output
    assert "42.0" in res.output or "41.9" in res.output or "42.1" in res.output
    data = json.loads(js.read_text())
    assert data["n"] == 2 and abs(data["mean_deg"] - 43.0) < 0.5
    assert data["photos"][0]["fit_window"] == [0.25, 0.75]
    assert csv.read_text().splitlines()[-1].startswith("std,")
    assert sorted(p.name for p in plots.iterdir()) == ["repeat_1_aor.png", "repeat_2_aor.png"]


def test_measure_single_plot_and_options(photos, tmp_path):
    fig = tmp_path / "one.png"
    res = CliRunner().invoke(app, ["measure", str(photos[0]), "--plot", str(fig),
                                   "--threshold", "adaptive", "--fit", "ransac",
                                   "--roi", "20", "260", "5", "415", "--base-row", "208"])
    assert res.exit_code == 0, res.output
    assert fig.stat().st_size > 5000


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--threshold", "bright"], "--threshold"),
        (["--fit-window", "0.5", "1.5"], "fit_window"),
        (["--fit", "huber"], "fit must be one of"),
        (["--pixel-aspect", "-1"], "pixel_aspect"),
        (["--roi", "0", "10", "0", "10000"], "roi"),
    ],
)
def test_bad_options_exit_2(photos, extra, message):
    res = CliRunner().invoke(app, ["measure", str(photos[0]), *extra])
    assert res.exit_code == 2
    assert message in res.output
    assert "Traceback" not in res.output


def test_bad_photos_exit_2(photos, tmp_path):
    text = tmp_path / "notes.jpg"
    text.write_text("not an image")
    for args, message in (([str(text)], "not a readable image"),
                          ([str(tmp_path / "missing.png")], "no such file"),
                          ([*map(str, photos), "--plot", str(tmp_path / "x.png")], "--plot")):
        res = CliRunner().invoke(app, ["measure", *args])
        assert res.exit_code == 2, res.output
        assert message in res.output
