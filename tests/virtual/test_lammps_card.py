"""``demcal card lammps``: a material card as the LAMMPS lines of its contact laws."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from demcal.cli import app
from demcal.dem.contact import rayleigh_time_step
from demcal.virtual import fidelity_config, preset_parameters
from demcal.virtual import lammps_run as lr
from demcal.virtual.card_blocks import CardEngine, CardTest
from demcal.virtual.factory import make_template
from demcal.virtual.lammps_card import lammps_lines
from demcal.virtual.lammps_laws import contact_laws, model_string
from demcal.virtual.material_card import MaterialCard, read_material_card

#: the LAMMPS cards committed in examples/corn_stalk, each with its .in beside it
COMMITTED_CARDS = ["material_lammps_small", "material_lammps_low_cohesion",
                   "material_lammps_low_cohesion_standard"]


def _card(engine: str = "lammps", rolling: str = "C", **params: float) -> MaterialCard:
    return MaterialCard(parameters={**preset_parameters("corn_stalk"), **params}, study="t",
                        engine=CardEngine(name=engine, rolling_model=rolling),
                        test=CardTest(kind="aor", fidelity="quick", overrides={}))


def test_the_lines_are_the_lammps_engine_s_own_mapping() -> None:
    """Independent of the module: the same laws from the quick test's template."""
    card = _card(**{"pp.surface_energy": 0.0})
    lines = lammps_lines(card)
    config = fidelity_config("quick", rolling_model="C")
    template = make_template(config.particle)
    p = card.parameters
    laws = contact_laws(p, sphere_radius=float(np.mean(template.radii)),
                        clump_mass=p["particle.density"] * template.volume)
    assert lines.pair_coeff == model_string(laws["pp"])
    assert lines.wall_model == model_string(laws["pw"])
    assert f"pair_coeff * * {lines.pair_coeff}\n" in lines.text
    assert f"wall/gran granular {lines.wall_model} zplane" in lines.text
    dt = config.dt_fraction * rayleigh_time_step(
        float(template.radii.min()) * config.particle.size_min, p["particle.density"],
        p["particle.shear_modulus"], p["particle.poisson"])
    assert lines.timestep_s == pytest.approx(dt, rel=1e-12)
    assert lines.warning is None and "hertz/material" in lines.pair_coeff
    assert "rolling sds" in lines.pair_coeff  # the calibrated rolling friction
    assert repr(p["pp.rolling_friction"]) in lines.pair_coeff


def test_cohesion_gives_jkr() -> None:
    lines = lammps_lines(_card(**{"pp.surface_energy": 2e-4}))
    assert lines.pair_coeff.startswith("jkr ") and "2e-04" not in lines.pair_coeff
    assert repr(2e-4) in lines.pair_coeff


def test_a_model_a_card_is_written_with_a_warning(tmp_path) -> None:
    path, _ = _card(engine="demcal", rolling="A").write(tmp_path)
    out = CliRunner().invoke(app, ["card", "lammps", str(path)])
    assert out.exit_code == 0, out.output
    assert "# WARNING: this card was calibrated in demcal's engine with rolling model A" in \
        out.output
    assert "warning:" in out.output  # and said beside the lines


@pytest.mark.parametrize(("card", "message"), [
    (MaterialCard(parameters=preset_parameters("corn_stalk"),
                  engine=CardEngine(name="template", command="lmp -in in.x")), "external engine"),
    (MaterialCard(parameters=preset_parameters("corn_stalk"), test=CardTest(kind="analytic")),
     "analytic stand-in"),
])
def test_cards_that_are_not_lammps_parameters_are_refused(tmp_path, card, message) -> None:
    path, _ = card.write(tmp_path)
    out = CliRunner().invoke(app, ["card", "lammps", str(path)])
    assert out.exit_code == 2 and message in out.output, out.output


def test_the_lines_go_to_a_file(tmp_path) -> None:
    path, _ = _card().write(tmp_path)
    out = CliRunner().invoke(app, ["card", "lammps", str(path), "--out",
                                   str(tmp_path / "in.material")])
    assert out.exit_code == 0, out.output
    assert (tmp_path / "in.material").read_text() == lammps_lines(_card()).text
    refused = CliRunner().invoke(app, ["card", "lammps", str(path), "--out", str(path)])
    assert refused.exit_code == 2  # never onto the card itself


def _settled_height(lines_text: str, folder: Path, r: float = 0.002) -> float:
    """Highest sphere top (m) after two spheres of radius ``r`` fell under the lines' laws."""
    script = "\n".join([
        "units si", "atom_style sphere", "boundary f f f",
        "region box block -0.02 0.02 -0.02 0.02 -0.001 0.04", "create_box 1 box",
        f"create_atoms 1 single 0 0 {3 * r}", f"create_atoms 1 single 0.001 0 {6 * r}",
        f"set type 1 diameter {2 * r}", "set type 1 density 114.36",
        "comm_modify vel yes", "neighbor 0.001 bin",
        lines_text, "fix grav all gravity 9.81 vector 0 0 -1", "fix nve all nve/sphere",
        "run 20000", "variable zmax equal bound(all,zmax)", 'print "ZMAX ${zmax}"'])
    (folder / "in.bed").write_text(script)
    run = subprocess.run([lr._find("lmp"), "-in", "in.bed"], cwd=folder, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    return float(run.stdout.split("ZMAX ")[-1].split()[0])


@pytest.mark.skipif(lr._find("lmp") is None, reason="LAMMPS not installed (demcal[lammps])")
def test_the_lines_run_in_lammps_on_a_small_bed(tmp_path) -> None:
    """Pasted into a script: two spheres dropped on the floor settle on it."""
    r = 0.002
    zmax = _settled_height(lammps_lines(_card(**{"pp.surface_energy": 2e-4})).text, tmp_path, r)
    assert zmax < 5 * r and math.isfinite(zmax)  # fell and rests on the floor or the other


@pytest.mark.skipif(lr._find("lmp") is None, reason="LAMMPS not installed (demcal[lammps])")
@pytest.mark.parametrize("name", COMMITTED_CARDS)
def test_a_committed_lammps_input_runs_as_printed(name: str, tmp_path) -> None:
    # the committed file itself, not lines built again: what a LAMMPS user pastes must run
    r = 0.002
    text = (Path(__file__).parents[2] / "examples" / "corn_stalk" / f"{name}.in").read_text()
    zmax = _settled_height(text, tmp_path, r)
    assert zmax < 5 * r and math.isfinite(zmax)


@pytest.mark.parametrize("name", COMMITTED_CARDS)
def test_a_committed_lammps_input_is_its_card_s_lines(name: str) -> None:
    # the .in files beside the LAMMPS cards are what a LAMMPS user pastes: they must be the
    # card's own numbers as this release maps them, not a copy left behind by a re-run
    folder = Path(__file__).parents[2] / "examples" / "corn_stalk"
    card = read_material_card(folder / f"{name}.toml")
    assert lammps_lines(card).text == (folder / f"{name}.in").read_text(encoding="utf-8")
