"""Flank quality gates and the robust combination of flank angles (demcal.measure.quality)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from aor_synth import sphere_cone

from demcal import measure
from demcal.errors import InputError
from demcal.measure.linefit import Flank, fit_line
from demcal.measure.quality import FlankGates, combine_angles, flank_rejection, spread_deg


def _flank(angle_deg: float, *, n: int = 50, noise: float = 0.0, height: float = 10.0,
           side: str = "right") -> Flank:
    rng = np.random.default_rng(3)
    z = np.linspace(0.0, height, n)
    slope = 1.0 / math.tan(math.radians(angle_deg))
    x = (-slope if side == "right" else slope) * z + rng.normal(0.0, noise, n)
    return Flank(side, fit_line(z, x, "least_squares"), 0.0, height)


def test_a_clean_flank_passes():
    assert flank_rejection(_flank(40.0)) is None


@pytest.mark.parametrize(("flank", "reason"), [
    (_flank(85.0), "85.0 deg is steeper than the limit (80 deg)"),
    (_flank(94.7), "94.7 deg is steeper than the limit (80 deg) (an overhang)"),
    (_flank(3.0), "3.0 deg is flatter than the limit (5 deg)"),
    (_flank(40.0, n=6), "6 boundary points (need 8)"),
    (_flank(40.0, noise=4.0), "poor fit"),
])
def test_each_gate_names_its_reason(flank, reason):
    why = flank_rejection(flank)
    assert why is not None and reason in why
    assert flank_rejection(flank, None) is None  # no gates: everything counts


def test_gates_are_settable_and_validated():
    assert flank_rejection(_flank(85.0), FlankGates(max_angle_deg=88.0)) is None
    with pytest.raises(InputError, match="min_angle_deg < max_angle_deg"):
        FlankGates(min_angle_deg=50.0, max_angle_deg=40.0)
    with pytest.raises(InputError, match=r"gates\.min_points"):
        FlankGates(min_points=1)


def test_combine_median_and_trimmed_mean_resist_one_odd_flank():
    angles = [44.0, 45.0, 46.0, 44.5, 45.5, 95.0]
    assert combine_angles(angles, "median") == pytest.approx(45.25)
    assert combine_angles(angles, "trimmed_mean") == pytest.approx(45.25)
    assert combine_angles(angles, "mean") == pytest.approx(np.mean(angles))
    assert spread_deg([45.0]) == 0.0
    with pytest.raises(InputError, match="combine must be one of"):
        combine_angles(angles, "mode")


def test_a_stalk_standing_at_the_edge_is_rejected_not_averaged_in():
    """A 45-degree sphere cone with a vertical stack of spheres at its toe (a stalk standing
    at the edge): the views that see it on their outline fit a near-vertical flank."""
    centres, radii = sphere_cone(45.0, rng=np.random.default_rng(5))
    stack = np.column_stack([np.full(8, 0.0195), np.zeros(8), 0.001 + 0.002 * np.arange(8)])
    centres = np.vstack([centres, stack])
    radii = np.concatenate([radii, np.full(8, 0.001)])
    legacy = measure.pile_aor_silhouette(centres, radii, gates=None, combine="mean")
    gated = measure.pile_aor_silhouette(centres, radii)
    rejected = gated.rejections()
    assert rejected and all("steeper than the limit" in r["reason"] or "poor fit" in r["reason"]
                            for r in rejected)
    assert gated.n_flanks + gated.n_rejected == 16
    assert abs(gated.aor_deg - 45.0) < 1.0
    assert abs(legacy.mean_deg - 45.0) > abs(gated.aor_deg - 45.0) + 0.5
    d = gated.to_dict()
    assert d["n_rejected"] == len(d["rejected"]) and d["combine"] == "mean"
