"""Sliding friction on a slowly tilted plane and type-A rolling friction on a plane."""

from __future__ import annotations

import math

import numpy as np
import pytest
from worlds import floor, table

from demcal.dem.materials import Interaction, Material
from demcal.dem.shapes import sphere_template, stalk_template
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World

G = 9.81


def test_clump_on_a_slowly_tilted_plane_slides_at_tan_alpha_equal_mu_s():
    """A 7-sphere stalk lying along the slope (so it cannot roll) on a plane whose tilt grows
    at 10 deg/s (the gravity vector turns; the plane stays put). Sliding starts when the
    stalk's speed along the slope passes 10 um/s; theory: tan(alpha) = mu_s."""
    mu_s = 0.5
    soft = Material("p", density=1000.0, shear_modulus=1.0e6, poisson=0.3)
    mats = table(Interaction(0.5, mu_s), Interaction(0.5, mu_s), particle=soft)
    stalk = stalk_template()
    r = float(stalk.radii[0])
    group = ClumpGroup(stalk, "p", 1, positions=np.array([[0.0, 0.0, 0.98 * r]]))

    def gravity(alpha_deg):
        a = math.radians(alpha_deg)
        return (G * math.sin(a), 0.0, -G * math.cos(a))

    alpha = 20.0
    world = World(mats, [group], walls=[floor()], gravity=gravity(alpha))
    sim = Simulation([world])
    dt = float(sim.dt[0])
    sim.run(0.05)  # settle
    x0 = float(sim.arrays["c_pos"][0, 0])
    rate = 10.0  # deg/s
    chunk = 20
    onset = None
    while alpha < 35.0:
        alpha += rate * chunk * dt
        sim.set_gravity(0, gravity(alpha))
        sim.advance(chunk)
        if sim.arrays["c_vel"][0, 0] > 1e-5:
            onset = alpha
            break
    expected = math.degrees(math.atan(mu_s))
    print(f"sliding onset at {onset:.3f} deg; atan(mu_s) = {expected:.3f} deg "
          f"(crept {1e6 * (sim.arrays['c_pos'][0, 0] - x0):.2f} um before)")
    assert onset is not None
    assert abs(onset - expected) < 1.0


def _sphere_on_floor(mu_r: float, mu_s: float = 0.5, model: str = "A"):
    mats = table(Interaction(0.5, mu_s), Interaction(0.5, mu_s, rolling_friction=mu_r))
    r = 2.0e-3
    group = ClumpGroup(sphere_template(r), "p", 1, positions=np.array([[0.0, 0.0, 0.999 * r]]))
    world = World(mats, [group], walls=[floor()], gravity=(0.0, 0.0, -G))
    sim = Simulation([world], rolling_friction=model)
    sim.run(0.02)  # settle on the floor
    return sim, r


@pytest.mark.parametrize("motion", ["spin", "roll"])
def test_spinning_sphere_decelerates_as_type_a_rolling_friction_implies(motion):
    """Type A: torque mu_r F_n R_arm against omega. Spinning about the vertical: the torque
    alone acts, d omega/dt = -mu_r m g R_arm / I. Rolling without slip: friction shares the
    load, dv/dt = -mu_r g / (1 + I/(m rho^2)) (rho = R_arm = contact lever). Once stopped,
    the body stays stopped (the limiter never reverses the rotation)."""
    mu_r = 0.1
    sim, r = _sphere_on_floor(mu_r)
    a = sim.arrays
    z = float(a["c_pos"][0, 2])
    rho = 0.5 * (r + z)  # contact point in the middle of the overlap
    mass = float(a["c_mass"][0])
    inertia = float(a["c_inertia"][0, 0])
    w0 = 50.0
    if motion == "spin":
        sim.place_clumps(0, [0], a["c_pos"][:1].copy(), angular_velocities=[[0.0, 0.0, w0]])
        expected = mu_r * mass * G * rho / inertia  # rad/s^2

        def read():
            return float(sim.arrays["c_omega"][0, 2])
    else:
        sim.place_clumps(0, [0], a["c_pos"][:1].copy(), velocities=[[w0 * rho, 0.0, 0.0]],
                         angular_velocities=[[0.0, w0, 0.0]])
        expected = mu_r * G / (1.0 + inertia / (mass * rho**2)) / rho  # as d omega/dt

        def read():
            return float(sim.arrays["c_omega"][0, 1])
    dt = float(sim.dt[0])
    t_stop = w0 / expected
    times, omegas = [], []
    for _ in range(int(1.5 * t_stop / (100 * dt))):
        sim.advance(100)
        times.append(float(sim.time[0]))
        omegas.append(read())
    times, omegas = np.array(times), np.array(omegas)
    moving = (omegas > 0.1 * w0) & (omegas < 0.9 * w0)
    slope = -np.polyfit(times[moving], omegas[moving], 1)[0]
    err = slope / expected - 1
    after = omegas[times > 1.1 * (times[0] + t_stop)]
    print(f"{motion}: deceleration {slope:.5g} vs {expected:.5g} rad/s^2 ({err:+.3%}); "
          f"after the stop |omega| <= {np.abs(after).max():.2g} rad/s")
    assert abs(err) < 0.03
    assert len(after) > 3
    print(f"{motion}: most negative omega {omegas.min():.3g} rad/s")
    if motion == "spin":  # the rolling torque alone: it stops the spin and never reverses it
        assert omegas.min() >= 0.0
    else:  # rolling: the tangential (Mindlin) spring recoils a little at the stop, then decays
        assert omegas.min() >= -1e-4 * w0
    assert np.abs(after).max() < 1e-6 * w0


def test_type_c_rolling_saturates_at_the_type_a_deceleration():
    """Type C (EPSD): once the rolling spring saturates at mu_r R* F_n (R* = R on a wall),
    a rolling sphere decelerates like type A with the arm R instead of R - delta/2."""
    mu_r = 0.1
    sim, r = _sphere_on_floor(mu_r, model="C")
    a = sim.arrays
    z = float(a["c_pos"][0, 2])
    rho = 0.5 * (r + z)
    mass = float(a["c_mass"][0])
    inertia = float(a["c_inertia"][0, 0])
    w0 = 50.0
    sim.place_clumps(0, [0], a["c_pos"][:1].copy(), velocities=[[w0 * rho, 0.0, 0.0]],
                     angular_velocities=[[0.0, w0, 0.0]])
    # torque mu_r r m g about the centre; friction at lever rho: d omega/dt = M rho / ...
    expected = mu_r * G * (r / rho) / (1.0 + inertia / (mass * rho**2)) / rho
    times, omegas = [], []
    for _ in range(25):
        sim.advance(100)
        times.append(float(sim.time[0]))
        omegas.append(float(sim.arrays["c_omega"][0, 1]))
    times, omegas = np.array(times), np.array(omegas)
    moving = (omegas > 0.1 * w0) & (omegas < 0.9 * w0)
    slope = -np.polyfit(times[moving], omegas[moving], 1)[0]
    err = slope / expected - 1
    print(f"type C: deceleration {slope:.5g} vs {expected:.5g} rad/s^2 ({err:+.3%})")
    assert abs(err) < 0.03
