"""VTK output (parsed back and compared array by array) and snapshot/restart (bitwise)."""

from __future__ import annotations

import base64
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from demcal.dem import output
from demcal.dem.kernels import ACTIVE
from demcal.dem.materials import Interaction, Material, MaterialTable
from demcal.dem.shapes import sphere_template, stalk_template
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World
from demcal.dem.walls import PlaneWall, TubeWall
from demcal.errors import InputError

PARTICLE = Material("p", density=500.0, shear_modulus=2.0e6, poisson=0.3)
STEEL = Material("wall", density=7865.0, shear_modulus=7.9e10, poisson=0.3)
TYPES = {"Float64": "<f8", "Float32": "<f4", "Int32": "<i4", "Int64": "<i8", "UInt8": "<u1"}


def _world(seed: int, gamma: float = 0.05, n_stalks: int = 14, n_spheres: int = 6) -> World:
    rng = np.random.default_rng(seed)
    mats = MaterialTable([PARTICLE, STEEL], {
        ("p", "p"): Interaction(0.3, 0.5, 0.1, gamma),
        ("p", "wall"): Interaction(0.45, 0.55, 0.15, 0.0)})
    # a stack of horizontal stalks (random yaw, 0.2 mm apart) with spheres on top, in a tube
    # on a plate, thrown down so that contacts form at once
    scales = rng.uniform(0.8, 1.0, n_stalks)
    pos = np.column_stack([rng.uniform(-4e-3, 4e-3, n_stalks), rng.uniform(-4e-3, 4e-3, n_stalks),
                           2.2e-3 + 4.2e-3 * np.arange(n_stalks)])
    yaw = rng.uniform(0.0, 2.0 * np.pi, n_stalks)
    quat = np.column_stack([np.cos(yaw / 2), np.zeros(n_stalks), np.zeros(n_stalks),
                            np.sin(yaw / 2)])
    pos_s = np.column_stack([rng.uniform(-8e-3, 8e-3, n_spheres),
                             rng.uniform(-8e-3, 8e-3, n_spheres),
                             pos[-1, 2] + 4e-3 + 3.2e-3 * np.arange(n_spheres)])
    groups = [
        ClumpGroup(stalk_template(resolution=24), "p", n_stalks, scales=scales, positions=pos,
                   orientations=quat, velocities=np.tile([0.0, 0.0, -0.3], (n_stalks, 1))
                   + rng.normal(0.0, 0.05, (n_stalks, 3)),
                   angular_velocities=rng.normal(0.0, 20.0, (n_stalks, 3))),
        ClumpGroup(sphere_template(1.5e-3), "p", n_spheres, positions=pos_s,
                   velocities=rng.normal(0.0, 0.2, (n_spheres, 3))),
    ]
    walls = [
        PlaneWall(origin=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]),
                  half_size=(0.03, 0.025), name="plate"),
        TubeWall(base=np.zeros(3), axis=np.array([0.0, 0.0, 1.0]), inner_radius=0.011,
                 thickness=0.002, length=0.05, velocity=np.array([0.0, 0.0, 0.05]),
                 name="cylinder"),
        PlaneWall(origin=np.array([0.0, 0.0, -0.01]), normal=np.array([0.1, 0.0, 1.0]),
                  name="infinite"),
    ]
    return World(mats, groups, walls, domain_lo=(-0.05, -0.05, -0.02),
                 domain_hi=(0.05, 0.05, 0.12))


def _sim(rolling: str = "A", **kw) -> Simulation:
    return Simulation([_world(1), _world(2, gamma=0.0)], backend="cpu",
                      rolling_friction=rolling, **kw)


@pytest.fixture(scope="module")
def running() -> Simulation:
    sim = _sim()
    sim.advance(300)
    sim.remove_clumps(1, [3])   # a removed clump is not written
    return sim


# ------------------------------------------------------------------------------ VTK parsing
def _decode(da: ET.Element) -> np.ndarray:
    dtype = np.dtype(TYPES[da.get("type")])
    ncomp = int(da.get("NumberOfComponents", "1"))
    text = (da.text or "").strip()
    if da.get("format") == "binary":
        blob = base64.b64decode(text, validate=True)
        nbytes = int(np.frombuffer(blob[:8], dtype="<u8")[0])
        raw = blob[8:]
        assert len(raw) == nbytes
        arr = np.frombuffer(raw, dtype=dtype)
    else:
        assert da.get("format") == "ascii"
        arr = np.array(text.split(), dtype=float).astype(dtype)
    return arr.reshape(-1, ncomp) if ncomp > 1 else arr


def _parse(path) -> dict[str, np.ndarray]:
    root = ET.parse(path).getroot()
    assert root.get("type") == "PolyData" and root.get("header_type") == "UInt64"
    piece = root.find("PolyData/Piece")
    out = {"n_points": int(piece.get("NumberOfPoints")),
           "n_verts": int(piece.get("NumberOfVerts")),
           "n_polys": int(piece.get("NumberOfPolys"))}
    for section in ("PointData", "CellData", "Points", "Verts", "Polys"):
        node = piece.find(section)
        if node is None:
            continue
        for da in node.findall("DataArray"):
            out[f"{section}/{da.get('Name')}"] = _decode(da)
    return out


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
def test_vtk_spheres_round_trip(running, tmp_path, encoding):
    sim = running
    for world in (0, 1):
        files = output.write_vtk(sim, world, tmp_path / f"w{world}", encoding=encoding)
        assert [f.name for f in files] == [f"w{world}.vtp", f"w{world}_walls.vtp"]
        got = _parse(files[0])
        a = sim.arrays
        lo, hi = sim.sphere_range[world]
        clump = a["s_clump"][lo:hi]
        sel = a["c_state"][clump] == ACTIVE
        n = int(sel.sum())
        assert n == len(sim.spheres(world)[1]) and got["n_points"] == n == got["n_verts"]
        if world == 1:
            assert n == hi - lo - 7    # the removed stalk (7 spheres) is left out
        np.testing.assert_array_equal(got["Points/Points"], a["s_pos"][lo:hi][sel])
        np.testing.assert_array_equal(got["PointData/radius"], a["s_radius"][lo:hi][sel])
        cw = clump[sel]
        np.testing.assert_array_equal(got["PointData/clump_id"], cw - sim.clump_range[world, 0])
        np.testing.assert_array_equal(got["PointData/world_id"], np.full(n, world))
        # sphere velocity = v + omega x r, computed here independently, one sphere at a time
        vel = np.array([a["c_vel"][c] + np.cross(a["c_omega"][c], p - a["c_pos"][c])
                        for c, p in zip(cw, a["s_pos"][lo:hi][sel], strict=True)])
        np.testing.assert_allclose(got["PointData/velocity"], vel, rtol=0, atol=1e-15)
        assert np.abs(a["c_omega"][cw]).max() > 0     # the rotation term is exercised
        np.testing.assert_array_equal(got["Verts/connectivity"], np.arange(n))
        np.testing.assert_array_equal(got["Verts/offsets"], np.arange(1, n + 1))


def test_vtk_walls_are_meshes_at_their_current_position(running, tmp_path):
    sim = running
    files = output.write_vtk(sim, 0, tmp_path / "walls_check.vtp")
    got = _parse(files[1])
    pts = got["Points/Points"]
    conn = got["Polys/connectivity"].reshape(-1, 4)
    np.testing.assert_array_equal(got["Polys/offsets"], 4 * np.arange(1, len(conn) + 1))
    ids = got["CellData/wall_id"]
    seg = output.TUBE_SEGMENTS
    assert np.array_equal(np.bincount(ids), [1, 4 * seg, 1])
    # plate: the 0.06 x 0.05 m rectangle at z = 0
    plate = pts[conn[ids == 0][0]]
    np.testing.assert_allclose(plate[:, 2], 0.0, atol=1e-15)
    np.testing.assert_allclose(np.ptp(plate[:, :2], axis=0), [0.06, 0.05], rtol=1e-12)
    # tube: moved up by v t; every vertex at r_in or r_out, z in {z0, z0 + length}
    z0 = 0.05 * float(sim.time[0])
    assert z0 > 0
    tube = pts[np.unique(conn[ids == 1])]
    r = np.hypot(tube[:, 0], tube[:, 1])
    assert np.all(np.isclose(r, 0.011) | np.isclose(r, 0.013))
    assert np.all(np.isclose(tube[:, 2], z0) | np.isclose(tube[:, 2], z0 + 0.05))
    assert len(tube) == 4 * seg
    # quads of the inner surface: 2 vertices at the bottom, 2 at the top, all at r_in
    inner = pts[conn[ids == 1][:seg]]
    np.testing.assert_allclose(np.hypot(inner[..., 0], inner[..., 1]), 0.011, rtol=1e-12)
    # the infinite plane is clipped to the domain (largest extent 0.14 m) and lies in it
    inf_quad = pts[conn[ids == 2][0]]
    n = np.array([0.1, 0.0, 1.0]) / np.hypot(0.1, 1.0)
    np.testing.assert_allclose((inf_quad - [0, 0, -0.01]) @ n, 0.0, atol=1e-15)
    assert np.linalg.norm(inf_quad[0] - inf_quad[2]) == pytest.approx(0.14 * 2 * 2**0.5)


def test_vtk_series_writes_a_pvd_collection(running, tmp_path):
    sim = running
    series = output.VtkSeries(tmp_path / "out", "bed")
    series.add(sim, 0)
    series.add(sim, 0, time=0.5, label="later")
    pvd = series.close()
    root = ET.parse(pvd).getroot()
    assert root.get("type") == "Collection"
    rows = [(float(d.get("timestep")), int(d.get("part")), d.get("file"))
            for d in root.iter("DataSet")]
    t = float(sim.time[0])
    assert rows == [(t, 0, "bed_0000.vtp"), (t, 1, "bed_0000_walls.vtp"),
                    (0.5, 0, "bed_0001_later.vtp"), (0.5, 1, "bed_0001_later_walls.vtp")]
    for _, _, f in rows:
        assert _parse(pvd.parent / f)["n_points"] >= 0


def test_vtk_bad_input(running, tmp_path):
    with pytest.raises(InputError, match="encoding"):
        output.write_vtk(running, 0, tmp_path / "x", encoding="hdf5")
    with pytest.raises(InputError, match="world"):
        output.write_vtk(running, 2, tmp_path / "x")
    with pytest.raises(InputError, match="does not exist"):
        output.write_vtk(running, 0, tmp_path / "missing" / "x.vtp")
    with pytest.raises(InputError, match="series name"):
        output.VtkSeries(tmp_path, "a/b")


# ------------------------------------------------------------------------------ snapshots
@pytest.mark.parametrize("rolling", ["A", "C"])
def test_snapshot_continuation_is_bitwise_identical(tmp_path, rolling):
    ref = _sim(rolling)
    ref.advance(400)
    ref.set_world_enabled(1, False)     # a paused world stays paused after the restart
    path = output.save_snapshot(ref, tmp_path / "snap")
    assert path.name == "snap.npz"
    ref.advance(700)                    # crosses neighbour rebuilds and a chunk boundary
    assert ref.n_rebuilds > 2
    ref.set_world_enabled(1, True)
    ref.advance(200)

    new = output.load_snapshot(path)
    assert new is not ref and new.rolling_model == ref.rolling_model
    assert not new.is_enabled(1)
    new.advance(700)
    new.set_world_enabled(1, True)
    new.advance(200)
    assert set(new.arrays) == set(ref.arrays)
    for name, arr in ref.arrays.items():
        np.testing.assert_array_equal(new.arrays[name], arr, err_msg=name, strict=True)
    assert new.parity == ref.parity
    # the run really moved: clumps fell, the tube rose, contacts carry history
    assert np.all(ref.time > 0.0) and ref.wall_origin(0, 1)[2] > 0
    assert np.abs(ref.arrays["nb_hist_a"]).max() + np.abs(ref.arrays["nb_hist_b"]).max() > 0
    if rolling == "C":
        assert np.abs(ref.arrays["nb_rhist_a"]).max() + np.abs(ref.arrays["nb_rhist_b"]).max() > 0


def test_a_snapshot_without_wall_candidates_restarts_with_a_neighbour_build(tmp_path):
    """Snapshots written before the wall candidates existed lack ``s_wall_near`` and
    ``wall_ref``: the restart rebuilds them (one extra neighbour build), same trajectory."""
    ref = _sim("C")
    ref.advance(300)
    state = ref.state_dict()
    ref.advance(500)
    for name in ("s_wall_near", "wall_ref"):
        del state[name]
    new = _sim("C")
    new.load_state(state)
    new.advance(500)
    for name in ("c_pos", "c_quat", "c_angmom", "s_wall_force", "w_hist", "wall_origin"):
        np.testing.assert_array_equal(new.arrays[name], ref.arrays[name], err_msg=name)
    assert np.abs(ref.arrays["s_wall_force"]).max() > 0  # wall contacts were in play


def test_snapshot_restores_into_an_existing_simulation(tmp_path):
    ref = _sim()
    ref.advance(150)
    path = output.save_snapshot(ref, tmp_path / "s.npz")
    ref.advance(300)
    other = _sim()
    assert output.load_snapshot(path, other) is other
    other.advance(300)
    for name in ("c_pos", "c_quat", "c_angmom", "wall_origin", "world_time"):
        np.testing.assert_array_equal(other.arrays[name], ref.arrays[name], err_msg=name)
    wrong = _sim("C")
    with pytest.raises(InputError, match="rolling_friction"):
        output.load_snapshot(path, wrong)


def test_snapshot_bad_files(tmp_path):
    sim = _sim()
    with pytest.raises(InputError, match="does not exist"):
        output.load_snapshot(tmp_path / "nothing.npz")
    with pytest.raises(InputError, match="does not exist"):
        output.save_snapshot(sim, tmp_path / "no" / "dir" / "s.npz")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip file")
    with pytest.raises(InputError, match="not a demcal snapshot"):
        output.load_snapshot(junk)
    plain = tmp_path / "plain.npz"
    np.savez(plain, x=np.arange(3))
    with pytest.raises(InputError, match="not a demcal snapshot"):
        output.load_snapshot(plain)
    # a future format version is refused by name
    path = output.save_snapshot(sim, tmp_path / "v.npz")
    with np.load(path) as npz:
        data = {k: npz[k] for k in npz.files}
    meta = json.loads(data["meta"].tobytes())
    meta["version"] = output.SNAPSHOT_VERSION + 1
    data["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    np.savez_compressed(tmp_path / "v2.npz", **data)
    with pytest.raises(InputError, match="format version"):
        output.load_snapshot(tmp_path / "v2.npz")
    # a snapshot of another system does not fit
    small = Simulation([_world(1, n_stalks=5)], backend="cpu")
    with pytest.raises(InputError, match="does not fit"):
        output.load_snapshot(path, small)
