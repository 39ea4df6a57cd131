"""``demcal simulate aor``: the JSON contract, the pile picture, and refusals before any run."""

import json

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
    assert png.read_bytes()[:4] == b"\x89PNG"
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
