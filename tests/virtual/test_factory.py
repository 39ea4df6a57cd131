"""Particle placement (packing fill and dynamic factory): exact and overlap-free."""

from __future__ import annotations

import numpy as np

from demcal.dem.shapes import stalk_template
from demcal.dem.state import random_quaternions, rotate
from demcal.virtual.config import fidelity_config
from demcal.virtual.factory import SphereGrid, _clump_in_tube, pack_cylinder, place_in_cylinder


def test_the_placement_rotation_is_bitwise_the_vectorised_rotate():
    """The placement's one-quaternion rotation must equal ``rotate`` to the last bit, or
    every pile of every seed would change."""
    rng = np.random.default_rng(4)
    offs = stalk_template().offsets * rng.uniform(0.5, 2.0)
    pos = rng.normal(0.0, 0.01, 3)
    out = np.empty_like(offs)
    for q in random_quaternions(500, rng):
        assert _clump_in_tube(q, (offs, np.zeros(len(offs))), pos, np.inf, out)
        expected = pos + rotate(np.repeat(q[None], len(offs), 0), offs)
        assert np.array_equal(out, expected)


def test_a_packing_fill_has_no_overlap_and_stays_in_the_tube():
    cfg = fidelity_config("quick")
    tpl = stalk_template()
    scales = np.random.default_rng(1).uniform(0.75, 1.05, cfg.fill.count)
    idx, pos, quat = pack_cylinder(tpl, scales, cfg, np.random.default_rng(2))
    assert sorted(idx.tolist()) == list(range(cfg.fill.count))
    centres = np.concatenate([p + rotate(np.repeat(q[None], len(tpl.offsets), 0),
                                         tpl.offsets * scales[i])
                              for i, p, q in zip(idx, pos, quat, strict=True)])
    radii = np.concatenate([tpl.radii * scales[i] for i in idx])
    owner = np.repeat(np.arange(len(idx)), len(tpl.radii))
    d = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    touching = d < radii[:, None] + radii[None]
    assert not np.any(touching & (owner[:, None] != owner[None]))
    r_in = 0.5 * cfg.geometry.cylinder_inner_diameter
    assert np.all(np.hypot(centres[:, 0], centres[:, 1]) + radii <= r_in)


def test_the_factory_leaves_a_clump_that_does_not_fit():
    """A full region places nothing, and the random stream moves on by the attempts made."""
    tpl = stalk_template()
    grid = SphereGrid(0.006)
    xy = np.linspace(-0.02, 0.02, 15)
    full = np.array([(x, y, z) for x in xy for y in xy for z in np.linspace(0.14, 0.15, 4)])
    grid.add(full, np.full(len(full), 0.002))
    idx, pos, quat = place_in_cylinder(tpl, np.ones(10), radius=0.025, z_low=0.14,
                                       z_high=0.15, rng=np.random.default_rng(0), grid=grid,
                                       attempts=5)
    assert len(idx) == 0 and pos.shape == (0, 3) and quat.shape == (0, 4)
