"""Diagnostic figures are drawn from real results (files written, artists present)."""

from __future__ import annotations

import numpy as np
import pytest
from aor_pile_photos import pile_photo
from aor_synth import sphere_cone

from demcal import measure
from demcal.errors import InputError


@pytest.fixture(scope="module")
def photo_result():
    img, _ = pile_photo(32.0, 41.0, rng=np.random.default_rng(1234), noise=0.04)
    return measure.photo_aor(img)


@pytest.fixture(scope="module")
def cone():
    return sphere_cone(38.0, base_radius=0.015, radius=0.001, rng=np.random.default_rng(1234))


def test_photo_figure_file_and_axes(photo_result, tmp_path):
    from matplotlib.figure import Figure

    out = tmp_path / "photo.png"
    measure.plot_photo_aor(photo_result, out)
    assert out.stat().st_size > 5000
    ax = Figure().add_subplot()
    measure.plot_photo_aor(photo_result, ax)
    labels = [line.get_label() for line in ax.get_lines()]
    assert any(lab.startswith("left: 32.") or lab.startswith("left: 31.") for lab in labels)
    assert "boundary" in labels and "base line" in labels
    # The solid left line runs along the fitted flank: its end points lie on the boundary.
    seg = photo_result.line_points("left")
    b = photo_result.boundary
    for row, col in seg:
        d = np.min(np.hypot(b[:, 0] - row, b[:, 1] - col))
        assert d < 2.0
    assert "32." in ax.get_title() or "36." in ax.get_title()


@pytest.mark.parametrize("method", ["silhouette", "profile"])
def test_pile_figure(cone, method, tmp_path):
    from matplotlib.figure import Figure

    func = measure.pile_aor_silhouette if method == "silhouette" else measure.pile_aor_profile
    res = func(*cone)
    out = tmp_path / f"{method}.png"
    measure.plot_pile_aor(res, out, *cone, view=2)
    assert out.stat().st_size > 3000
    ax = Figure().add_subplot()
    measure.plot_pile_aor(res, ax, *cone, view=5)
    labels = [line.get_label() for line in ax.get_lines() if ":" in line.get_label()]
    assert len(labels) == (2 if method == "silhouette" else 1)
    # Fitted lines in mm reach the plate near the cone's base radius.
    for line in ax.get_lines():
        if line.get_linestyle() == "--":
            x0 = line.get_xdata()[0]
            assert 13.0 < abs(x0) < 19.0
    with pytest.raises(InputError, match="view"):
        measure.plot_pile_aor(res, ax, *cone, view=99)


def test_bad_plot_target(photo_result):
    with pytest.raises(InputError, match="path_or_ax"):
        measure.plot_photo_aor(photo_result, 42)
