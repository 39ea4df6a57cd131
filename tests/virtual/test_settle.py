"""The settle criterion on constructed states: lone clumps do not hold a phase back."""

import numpy as np
import pytest

from demcal.virtual.settle import settle_state, touching_clumps

R = 0.002


def _stalks(n_touching, lone_at=None):
    """n_touching two-sphere clumps (spheres R apart) in a row along x, each overlapping the
    next by 1 um, and optionally one lone clump at x = lone_at."""
    centres, clump = [], []
    for k in range(n_touching):
        x0 = k * (3 * R - 1e-6)
        centres += [[x0, 0.0, R], [x0 + R, 0.0, R]]
        clump += [k, k]
    if lone_at is not None:
        centres += [[lone_at, 0.0, R], [lone_at + R, 0.0, R]]
        clump += [n_touching, n_touching]
    return np.array(centres), np.full(len(centres), R), np.array(clump)


def _state(v, centres, radii, clump, **kw):
    limits = {"rms_limit": 0.005, "max_limit": 0.03, "tolerance": 1e-4} | kw
    return settle_state(v, lambda: (np.unique(clump), centres, radii, clump), **limits)


def test_touching_clumps_are_found_and_a_lone_one_is_not():
    c, r, ids = _stalks(4, lone_at=0.1)
    assert list(touching_clumps(c, r, ids, 1e-4)) == [0, 1, 2, 3]
    assert list(touching_clumps(c[:2], r[:2], ids[:2], 1e-4)) == []   # one clump alone


def test_lone_rolling_clump_does_not_hold_back():
    c, r, ids = _stalks(30, lone_at=0.5)
    v = np.zeros((31, 3))
    v[30] = [0.1, 0.0, 0.0]                # alone it would give rms 18 mm/s over all clumps
    st = _state(v, c, r, ids)
    assert st.settled and st.n_alone == 1 and st.max_speed == 0.0 and st.rms_speed == 0.0


def test_moving_pile_member_is_not_settled():
    c, r, ids = _stalks(30, lone_at=0.5)
    v = np.zeros((31, 3))
    v[7] = [0.0, 0.0, 0.05]
    st = _state(v, c, r, ids, rms_limit=0.01)
    assert not st.settled and st.max_speed == 0.05 and st.n_alone == 1


def test_slow_creep_of_the_whole_pile_is_not_settled():
    c, r, ids = _stalks(30)
    v = np.full((30, 3), 0.004)            # every clump under the max, rms 6.9 mm/s
    st = _state(v, c, r, ids)
    assert not st.settled and abs(st.rms_speed - 0.004 * 3**0.5) < 1e-12


def test_scattered_material_counts_every_clump():
    c, r, ids = _stalks(3, lone_at=0.5)
    c2, r2, ids2 = _stalks(1, lone_at=0.9)   # 3 touching + 3 lone clumps: half touch
    c = np.vstack([c, c2 + np.array([1.0, 0.0, 0.0])])
    r = np.concatenate([r, r2])
    ids = np.concatenate([ids, ids2 + 4])
    v = np.zeros((6, 3))
    v[3] = [0.05, 0.0, 0.0]
    st = _state(v, c, r, ids)
    assert list(touching_clumps(c, r, ids, 1e-4)) == [0, 1, 2]
    assert not st.settled and st.max_speed == 0.05   # 3 of 6 touch: not a pile, all count


def test_empty_world_is_settled():
    st = settle_state(np.zeros((0, 3)), lambda: pytest.fail("no sphere data needed"),
                      rms_limit=0.005, max_limit=0.03, tolerance=1e-4)
    assert st.settled


def test_settled_speeds_need_no_sphere_data():
    v = np.full((10, 3), 0.001)
    st = settle_state(v, lambda: pytest.fail("sphere data fetched"), rms_limit=0.005,
                      max_limit=0.03, tolerance=1e-4)
    assert st.settled
