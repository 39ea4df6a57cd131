"""``demcal simulate aor``: the JSON contract, the pile picture, and refusals before any run."""

import json
import re

import pytest
from typer.testing import CliRunner

from demcal.cli import app

TINY = ["--test", "fill.count=80", "--test", "phases.pile_settle_max_time=1.0",
        "--set", "pp.surface_energy=0", "--set", "pp.static_friction=0.2",
        "--set", "pp.rolling_friction=0.02", "--backend", "cpu"]


def test_simulate_aor_json_and_plot(tmp_path):
    out, png = tmp_path / "r.json", tmp_path / "pile.png"
    res = CliRunner().invoke(app, ["simulate", "aor", *TINY, "--seed", "3", "--json", str(out),
                                   "--plot", str(png)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    for key in ("aor_deg", "aor_left_deg", "aor_right_deg", "aor_std_deg", "n_particles",
                "particles_lost", "settled", "time_step_s", "wall_time_s", "params", "outcome"):
        assert key in data, key
    assert data["outcome"] == "pile" and 10.0 < data["aor_deg"] < 60.0
    assert data["n_particles"] == 80 and data["settled"] is True
    assert data["params"]["pp.static_friction"] == 0.2
    assert data["params"]["particle.density"] == 114.36       # the preset's fixed values
    # the pile's side view with the fitted flanks, where asked (issue 4's --plot): also
    # run_aor's check of plot_paths, which ran this same pile a second time on its own
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000
    assert data["runs"][0]["artefacts"]["pile_png"] == str(png)
    assert "angle of repose" in res.output


@pytest.mark.parametrize(("args", "field"), [
    (["--set", "pp.static_friction=-0.1"], "pp.static_friction"),
    (["--set", "pp.restitution=1.5"], "pp.restitution"),
    (["--set", "pp.restitution=0"], "pp.restitution"),
    (["--test", "geometry.cylinder_inner_diameter=0.01"], "cylinder_inner_diameter"),
    (["--test", "dt_fraction=1.5"], "dt_fraction"),
    (["--set", "no.such=1"], "no.such"),
    (["--seeds", "0"], "--seeds"),
    (["--plot", "/no/such/folder/pile.png"], "--plot"),
])
def test_simulate_aor_refuses_bad_input(args, field):
    res = CliRunner().invoke(app, ["simulate", "aor", "--backend", "cpu", *args])
    assert res.exit_code == 2, res.output
    assert field in res.output and "Traceback" not in res.output


def test_summary_spread_leaves_out_rejected_flanks():
    """The printed spread is over the flanks that count (a rejected 95 deg 'flank' of a stalk
    standing at the edge must not widen it)."""
    from types import SimpleNamespace

    from demcal.cli.simulate_cmd import summarize_runs

    views = [{"left_deg": 40.0, "right_deg": 42.0, "left_rejected": None,
              "right_rejected": None},
             {"left_deg": 41.0, "right_deg": 94.7, "left_rejected": None,
              "right_rejected": "94.7 deg is steeper than the limit (80 deg) (an overhang)"}]
    run = SimpleNamespace(outcome="pile", aor_deg=41.0, aor_left_deg=40.5, aor_right_deg=42.0,
                          aor_profile_deg=None, views_deg=views, n_particles=150,
                          particles_lost=0, settled=True, time_step_s=1e-6, sim_time_s=1.0,
                          wall_time_s=1.0, params={})
    out = summarize_runs([run])
    assert out["aor_std_deg"] == pytest.approx(1.0)


def test_summary_outcome_of_a_tie_is_the_first_runs_in_every_process():
    """Two replicates, two outcomes: the summary names the first run's, whatever the order in
    which this process hashes strings (it once took a set's order: 'column' in one process,
    'unsettled' in the next, for the same runs)."""
    from types import SimpleNamespace

    from demcal.cli.simulate_cmd import summarize_runs

    common = {"aor_deg": None, "n_particles": 150, "particles_lost": 0, "settled": False,
              "time_step_s": 1e-6, "sim_time_s": 1.0, "wall_time_s": 1.0, "params": {}}
    column = SimpleNamespace(outcome="column", **common)
    unsettled = SimpleNamespace(outcome="unsettled", **common)
    assert summarize_runs([column, unsettled])["outcome"] == "column"
    assert summarize_runs([unsettled, column])["outcome"] == "unsettled"
    assert summarize_runs([unsettled, column, column])["outcome"] == "column"


def test_summary_line_gives_the_standard_error_and_the_seed_scatter():
    from demcal.cli.simulate_cmd import summary_line

    one = {"aor_deg": 41.0, "aor_std_deg": 1.0, "time_step_s": 7e-6, "aor_sem_deg": None,
           "n_piles": 1}
    assert summary_line(one) == "AoR = 41.00 deg (flank views' spread 1.00), time step 7e-06 s"
    three = {"aor_deg": 44.63, "aor_std_deg": 4.42, "time_step_s": 7e-6, "n_piles": 3,
             "aor_seed_std_deg": 2.02, "aor_sem_deg": 2.02 / 3 ** 0.5,
             "aor_seed_std_ci95_deg": [1.05, 12.7]}
    line = summary_line(three)
    assert line.startswith("AoR = 44.63 +/- 1.17 deg (mean of 3 piles")
    assert "seed-to-seed std 2.02 (95 % interval 1.05-12.70)" in line
    assert "flank views' spread 4.42" in line


def test_summary_of_several_piles_gives_the_seed_scatter_with_its_interval():
    """Three piles: the seed-to-seed std of their angles, its standard error of the mean and
    the 95 % interval of the std (chi-square, 2 degrees of freedom: s x 0.5207 to
    s x 6.2847)."""
    from types import SimpleNamespace

    from demcal.cli.simulate_cmd import summarize_runs

    def run(angle):
        return SimpleNamespace(outcome="pile", aor_deg=angle, aor_left_deg=angle,
                               aor_right_deg=angle, aor_profile_deg=None, views_deg=[],
                               n_particles=1200, particles_lost=0, settled=True,
                               time_step_s=1e-6, sim_time_s=1.0, wall_time_s=1.0, params={})

    out = summarize_runs([run(42.0), run(44.0), run(46.0)])
    assert out["aor_seed_std_deg"] == pytest.approx(2.0)
    assert out["aor_sem_deg"] == pytest.approx(2.0 / 3 ** 0.5)
    lo, hi = out["aor_seed_std_ci95_deg"]
    assert lo == pytest.approx(2.0 * 0.5207, abs=2e-3)
    assert hi == pytest.approx(2.0 * 6.2847, abs=5e-3)


#: the cheapest drum through the command line: few frames, a short steady-state window
DRUM_SHORT = ["--preset", "corn_stalk_dry", "--backend", "cpu", "--test", "drum.frames=4",
              "--test", "drum.steady_window=2"]


def test_simulate_drum_json(tmp_path):
    out = tmp_path / "drum.json"
    res = CliRunner().invoke(app, ["simulate", "drum", *DRUM_SHORT, "--test", "drum.rpm=0",
                                   "--seeds", "2", "--seed", "5", "--set",
                                   "pp.static_friction=0.4", "--json", str(out),
                                   "--vtk", str(tmp_path / "vtk"),
                                   "--test", "drum.wall_static_friction=0.8"])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    # a ParaView series per run: settled, spun up, steady, then every averaged frame
    for seed in (5, 6):
        pvd = (tmp_path / "vtk" / f"drum_seed{seed}.pvd").read_text()
        labels = re.findall(r'file="drum_seed\d+_\d{4}_([a-z_]+?)(_walls)?\.vtp"', pvd)
        beds = [name for name, walls in labels if not walls]
        assert beds == ["settled", "spun_up", "steady"] + ["frame"] * 4, labels
        assert len(labels) == 2 * len(beds)  # each with the drum's walls
    for key in ("outcome", "dynamic_aor_deg", "dynamic_aor_seed_std_deg", "com_angle_deg",
                "surface_fluctuation_deg", "froude", "n_particles", "wall_time_s", "runs"):
        assert key in data, key
    assert data["outcome"] == "slumping" and data["froude"] == 0.0  # at rest nothing flows
    assert [r["seed"] for r in data["runs"]] == [5, 6]
    assert data["dynamic_aor_seed_std_deg"] >= 0.0 and abs(data["dynamic_aor_deg"]) < 15.0
    assert data["params"]["pp.static_friction"] == 0.4
    # the drum's own lining is what its walls ran with
    assert data["params"]["pw.static_friction"] == 0.8
    assert "rotating drum" in res.output and "dynamic angle" in res.output


@pytest.mark.parametrize(("args", "words"), [
    (["--test", "drum.fill_fraction=1.2"], "drum.fill_fraction must be in (0, 1)"),
    (["--test", "drum.rpm=400"], "the material centrifuges; the critical speed"),
    (["--test", "drum.width=0.01"], "must be at least 2 particle sizes"),
    (["--test", "drum.speed=3"], "drum.speed is not a drum setting"),
    (["--fidelity", "paper"], "fidelity must be one of quick, standard"),
    (["--seeds", "0"], "--seeds must be in 1..256"),
    (["--set", "pp.static_friction=-1"], "pp.static_friction"),
    (["--json", "/no/such/folder/d.json"], "--json"),
])
def test_simulate_drum_refuses_bad_settings_in_one_line_before_a_run(args, words):
    res = CliRunner().invoke(app, ["simulate", "drum", "--backend", "cpu", *args])
    assert res.exit_code == 2, res.output
    assert words in res.output and "Traceback" not in res.output
    assert len(res.output.strip().splitlines()) == 1, res.output


def test_drum_summary_averages_only_when_every_run_measured():
    from types import SimpleNamespace

    from demcal.cli.simulate_drum_cmd import summarize_drum_runs

    def run(outcome, angle, seed):
        return SimpleNamespace(outcome=outcome, dynamic_aor_deg=angle, com_angle_deg=angle,
                               surface_fluctuation_deg=2.0, froude=0.03, rpm=30.0,
                               n_particles=90, time_step_s=1e-5, sim_time_s=1.0,
                               wall_time_s=10.0, params={}, seed=seed)

    both = summarize_drum_runs([run("rolling", 40.0, 0), run("slumping", 44.0, 1)])
    assert both["outcome"] == "rolling" and both["dynamic_aor_deg"] == 42.0
    assert both["dynamic_aor_seed_std_deg"] == pytest.approx(2.0 * 2**0.5)
    assert both["wall_time_s"] == 20.0
    mixed = summarize_drum_runs([run("slipping", None, 0), run("rolling", 40.0, 1),
                                 run("slipping", None, 2)])
    assert mixed["outcome"] == "slipping" and mixed["dynamic_aor_deg"] is None
    assert mixed["n_measured"] == 1


def test_simulate_drum_runs_a_material_card_exactly(tmp_path):
    """A calibrated card in the drum: its parameters bit for bit, its rolling model."""
    from demcal.virtual.card_blocks import CardEngine, CardTest
    from demcal.virtual.material_card import MaterialCard
    from demcal.virtual.presets import preset_parameters

    params = {**preset_parameters("corn_stalk_dry"), "pp.static_friction": 0.1 + 0.2,
              "pp.rolling_friction": 1.0 / 3.0}
    card = MaterialCard(parameters=params, calibrated=("pp.static_friction",), study="t",
                        engine=CardEngine(version="0.1.0", backend="cpu", rolling_model="C"),
                        test=CardTest(kind="aor", fidelity="quick",
                                      overrides={"fill": {"count": 80}}))
    toml_path, _ = card.write(tmp_path)
    out = tmp_path / "drum.json"
    short = [a for a in DRUM_SHORT if a not in ("--preset", "corn_stalk_dry")]
    res = CliRunner().invoke(app, ["simulate", "drum", *short, "--test", "drum.rpm=0",
                                   "--material", str(toml_path), "--json", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert data["rolling_model"] == "C" and data["material"] == str(toml_path)
    run_params = data["runs"][0]["params"]
    assert all(run_params[k].hex() == v.hex() for k, v in params.items())
    both = CliRunner().invoke(app, ["simulate", "drum", "--material", str(toml_path),
                                    "--preset", "corn_stalk"])
    assert both.exit_code == 2 and "exclude each other" in both.output
