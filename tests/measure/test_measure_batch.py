"""Repeated photos -> a table like the paper's Table 2, as CSV and JSON."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from aor_pile_photos import pile_photo

from demcal import measure
from demcal.errors import InputError

ANGLES = [(44.0, 45.2), (45.5, 46.7), (41.0, 42.8)]


@pytest.fixture(scope="module")
def photo_files(tmp_path_factory):
    from skimage import io, util

    d = tmp_path_factory.mktemp("photos")
    paths = []
    for i, (left, right) in enumerate(ANGLES):
        img, _ = pile_photo(left, right, rng=np.random.default_rng(i), noise=0.04)
        p = d / f"pile_{i + 1}.png"
        io.imsave(p, util.img_as_ubyte(img), check_contrast=False)
        paths.append(p)
    return paths


def test_table_each_mean_std(photo_files, tmp_path):
    table = measure.photos_aor(photo_files, threshold="otsu")
    truth = np.array([0.5 * (a + b) for a, b in ANGLES])
    assert np.allclose(table.angles_deg, truth, atol=0.5)
    assert table.mean_deg == pytest.approx(truth.mean(), abs=0.3)
    assert table.std_deg == pytest.approx(np.std(truth, ddof=1), abs=0.3)
    measure.save_table(table, csv=tmp_path / "t.csv", json=tmp_path / "t.json")
    frame = pd.read_csv(tmp_path / "t.csv")
    assert list(frame["photo"][-2:]) == ["mean", "std"]
    assert frame["mean_deg"].iloc[-2] == pytest.approx(table.mean_deg, abs=1e-4)
    assert frame["mean_deg"].iloc[-1] == pytest.approx(table.std_deg, abs=1e-4)
    assert frame["photo"].iloc[0] == str(photo_files[0])
    data = json.loads((tmp_path / "t.json").read_text())
    assert data["n"] == 3 and data["mean_deg"] == pytest.approx(table.mean_deg)
    assert [p["photo"] for p in data["photos"]] == [str(p) for p in photo_files]


def test_single_photo_std_is_none(photo_files, tmp_path):
    table = measure.photos_aor(photo_files[:1])
    assert np.isnan(table.std_deg)
    measure.save_table(table, json_path=tmp_path / "one.json")
    assert json.loads((tmp_path / "one.json").read_text())["std_deg"] is None


def test_batch_errors_name_the_photo(photo_files, tmp_path):
    bad = tmp_path / "blank.png"
    from skimage import io

    io.imsave(bad, np.full((50, 50), 255, np.uint8), check_contrast=False)
    with pytest.raises(InputError, match=r"blank\.png: the image is uniform"):
        measure.photos_aor([photo_files[0], bad])
    with pytest.raises(InputError, match="at least one photo"):
        measure.photos_aor([])
    table = measure.photos_aor(photo_files[:1])
    with pytest.raises(InputError, match="csv and/or json"):
        measure.save_table(table)
    with pytest.raises(InputError, match="cannot write"):
        measure.save_table(table, csv=tmp_path / "no" / "such" / "dir.csv")
