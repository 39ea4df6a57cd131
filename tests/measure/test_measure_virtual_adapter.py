"""The virtual test's adapter (demcal.virtual.pile) on synthetic piles."""

from __future__ import annotations

import json

import numpy as np
import pytest
from aor_synth import sphere_cone

from demcal.virtual.config import MeasurementOptions
from demcal.virtual.pile import measure_pile


@pytest.fixture(scope="module")
def cone():
    return sphere_cone(40.0, base_radius=0.02, radius=0.0007, rng=np.random.default_rng(1234))


@pytest.mark.parametrize("method", ["silhouette", "profile"])
def test_adapter_reports_both_methods_as_strict_json(cone, method):
    out = measure_pile(*cone, MeasurementOptions(method=method, n_views=4))
    json.dumps(out, allow_nan=False)
    assert "error" not in out and "measure_errors" not in out
    for key in ("aor_deg", "aor_silhouette_deg", "aor_profile_deg"):
        assert abs(out[key] - 40.0) < 1.0, key
    assert out["aor_deg"] == out[f"aor_{method}_deg"]
    assert out["aor_left_deg"] is not None and out["aor_std_deg"] >= 0
    assert len(out["views"]) == (4 if method == "silhouette" else 8)
    assert 0.01 < out["pile_height_m"] < 0.02 and 0.04 < out["base_diameter_m"] < 0.05


def test_adapter_passes_fit_window(cone):
    out = measure_pile(*cone, MeasurementOptions(fit_window=(0.3, 0.6)))
    assert abs(out["aor_deg"] - 40.0) < 1.5


def test_profile_failure_does_not_fail_silhouette(cone, monkeypatch):
    from demcal import measure
    from demcal.errors import InputError

    def fail(*args, **kwargs):
        raise InputError("no view of the pile could be measured (flat top)")

    monkeypatch.setattr(measure, "pile_aor_profile", fail)
    out = measure_pile(*cone, MeasurementOptions(method="silhouette", n_views=2))
    assert abs(out["aor_deg"] - 40.0) < 1.0
    assert out["aor_profile_deg"] is None
    assert "flat top" in out["measure_errors"]["profile"]
    json.dumps(out, allow_nan=False)
    # Asking for the failed method reports the error instead.
    bad = measure_pile(*cone, MeasurementOptions(method="profile"))
    assert bad == {"error": "no measurable pile: no view of the pile could be measured "
                            "(flat top)"}


def test_unmeasurable_pile_returns_error():
    c = np.array([[0.0, 0.0, 0.001]])
    out = measure_pile(c, np.array([0.001]), MeasurementOptions())
    assert out["error"].startswith("no measurable pile")


def test_adapter_saves_the_picture_or_says_why_not(cone, tmp_path):
    png = tmp_path / "pile.png"
    out = measure_pile(*cone, MeasurementOptions(n_views=2), figure=png)
    assert out["figure"] == str(png) and png.read_bytes()[:4] == b"\x89PNG"
    bad = measure_pile(*cone, MeasurementOptions(n_views=2), figure=tmp_path / "no" / "p.png")
    assert "figure" not in bad and "cannot write figure" in bad["figure_error"]
    assert bad["aor_deg"] == out["aor_deg"]  # the measurement does not depend on the picture
