"""The cheap wall bound that skips far spheres never skips a sphere within reach.

Checked against the independent distance routines of the NumPy reference (tests/dem/naive.py)
on random points around a tilted finite plane and a tilted tube: whenever the bound says
"surely beyond", the true distance exceeds the reach; and it does prune most far points.
"""

import numpy as np
import pytest
from naive import plane_distance, tube_distance

from demcal.dem.walls import PlaneWall, TubeWall, surely_beyond


def _axis(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


@pytest.mark.parametrize("kind", ["plane", "tube"])
def test_bound_is_conservative_and_prunes(kind):
    rng = np.random.default_rng(7)
    origin = np.array([0.01, -0.02, 0.03])
    axis = _axis(rng)
    if kind == "plane":
        wall = PlaneWall(origin=origin, normal=axis, half_size=(0.02, 0.03))
    else:
        wall = TubeWall(base=origin, axis=axis, inner_radius=0.015, thickness=0.002,
                        length=0.05)
    wtype, o, geom = wall.packed()
    if kind == "plane":
        u, v = geom[3:6], geom[6:9]
        dist = lambda x: plane_distance(o, axis, u, v, 0.02, 0.03, x)[0]  # noqa: E731
    else:
        dist = lambda x: tube_distance(o, axis, 0.015, 0.017, 0.05, x)[0]  # noqa: E731
    skipped = far = 0
    for _ in range(4000):
        x = origin + rng.uniform(-0.06, 0.06, size=3)
        reach = rng.uniform(0.0005, 0.004)
        d = dist(x)
        beyond = surely_beyond(wtype, o[0], o[1], o[2], geom, x[0], x[1], x[2], reach)
        if beyond:
            assert d > reach, (x, reach, d)
            skipped += 1
        if d > reach + 0.005:
            far += 1
    assert skipped > 0.5 * far, (skipped, far)
