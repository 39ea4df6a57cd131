"""VTK snapshots of a virtual AoR run: one ParaView series per run, its path in the result."""

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from demcal.errors import InputError
from demcal.virtual import fidelity_config, preset_parameters, run_aor

TINY = {"fill": {"count": 20}, "phases": {"pile_settle_max_time": 0.3}}


def test_aor_run_writes_a_vtk_series(tmp_path):
    cfg = fidelity_config("quick", **TINY)
    p = preset_parameters("corn_stalk", {"pp.surface_energy": 0.0})
    results = run_aor([p, p], config=cfg, seeds=[3, 4], backend="cpu", vtk_dir=tmp_path / "vtk")
    for k, res in enumerate(results):
        pvd = Path(res.artefacts["vtk_series"])
        assert pvd == tmp_path / "vtk" / f"run{k:03d}.pvd"
        rows = [(float(d.get("timestep")), int(d.get("part")), d.get("file"))
                for d in ET.parse(pvd).getroot().iter("DataSet")]
        spheres = [r for r in rows if r[1] == 0]
        walls = [r for r in rows if r[1] == 1]
        assert len(spheres) == len(walls) >= 2          # filled, lifted (+ settled or end)
        assert spheres[0][2] == f"run{k:03d}_0000_filled.vtp"
        assert spheres[1][2] == f"run{k:03d}_0001_lifted.vtp"
        times = [t for t, _, _ in spheres]
        assert times == sorted(times) and times[-1] == pytest.approx(res.sim_time_s)
        for _, _, name in rows:
            assert (pvd.parent / name).is_file()
        # the last file holds the particles left on the plate (7 spheres per stalk)
        last = ET.parse(pvd.parent / spheres[-1][2]).getroot().find("PolyData/Piece")
        assert int(last.get("NumberOfPoints")) == 7 * (res.n_particles - res.particles_lost)


def test_aor_bad_vtk_dir(tmp_path):
    (tmp_path / "file").write_text("x")
    cfg = fidelity_config("quick", **TINY)
    p = preset_parameters("corn_stalk", {"pp.surface_energy": 0.0})
    with pytest.raises(InputError, match="vtk_dir"):
        run_aor([p], config=cfg, seeds=[1], backend="cpu", vtk_dir=tmp_path / "file" / "sub")



def test_aor_plot_paths_one_per_run():
    cfg = fidelity_config("quick", **TINY)
    p = preset_parameters("corn_stalk", {"pp.surface_energy": 0.0})
    with pytest.raises(InputError, match="plot_paths"):
        run_aor([p, p], config=cfg, seeds=[3, 4], backend="cpu", plot_paths=["a.png"])
