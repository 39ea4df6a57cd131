"""Output of a :class:`~demcal.dem.simulation.Simulation`: VTK files for ParaView and snapshots.

* :func:`write_vtk` writes one world as a ``.vtp`` PolyData file (one point per active sphere,
  with point data ``radius`` m, ``velocity`` m/s, ``clump_id``, ``world_id``) and its walls as
  meshes in ``<name>_walls.vtp`` (plane rectangles, tubes as quads: inner and outer surface and
  the two rims). The XML is written here with numpy (VTK's inline base64 binary or ASCII), so
  no VTK library is needed; ParaView reads the files (Point Gaussian shows the spheres by
  ``radius``).
* :class:`VtkSeries` writes a time series and its ``.pvd`` collection.
* :func:`save_snapshot` / :func:`load_snapshot` store the whole engine state in a compressed
  ``.npz`` (format :data:`SNAPSHOT_VERSION`) and restore it for a bitwise-identical
  continuation on the CPU backend (every array, the neighbour-list parity, the worlds'
  description, paused and failed worlds).
"""

from __future__ import annotations

import base64
import json
import math
import zipfile
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

from demcal.dem.kernels import ACTIVE
from demcal.dem.materials import Interaction, Material, MaterialTable
from demcal.dem.shapes import ClumpTemplate
from demcal.dem.simulation import ROLLING_MODELS, Simulation
from demcal.dem.state import ClumpGroup, World
from demcal.dem.walls import WALL_PLANE, WALL_TUBE, PlaneWall, TubeWall
from demcal.errors import InputError

__all__ = ["SNAPSHOT_VERSION", "VtkSeries", "load_snapshot", "save_snapshot", "sphere_data",
           "wall_mesh", "write_vtk"]

#: version of the snapshot format written by :func:`save_snapshot`
SNAPSHOT_VERSION = 1

#: segments around a tube in its mesh
TUBE_SEGMENTS = 48

_VTK_TYPES = {np.dtype("<f8"): "Float64", np.dtype("<f4"): "Float32",
              np.dtype("<i4"): "Int32", np.dtype("<i8"): "Int64", np.dtype("<u1"): "UInt8"}


# ---------------------------------------------------------------------------------- VTK
def sphere_data(sim: Simulation, world: int) -> dict[str, np.ndarray]:
    """Active spheres of a world: ``points`` (n, 3) m, ``radius`` (n,) m, ``velocity`` (n, 3)
    m/s (clump velocity + omega x lever arm), ``clump_id`` (n,) (index within the world) and
    ``world_id`` (n,)."""
    sim._check_world(world)
    sim.runner.pull("s_pos", "c_pos", "c_vel", "c_omega", "c_state")
    a = sim.arrays
    lo, hi = sim.sphere_range[world]
    clump = a["s_clump"][lo:hi]
    sel = a["c_state"][clump] == ACTIVE
    clump = clump[sel]
    pos = a["s_pos"][lo:hi][sel]
    vel = a["c_vel"][clump] + np.cross(a["c_omega"][clump], pos - a["c_pos"][clump])
    return {
        "points": pos.astype(np.float64),
        "radius": a["s_radius"][lo:hi][sel].astype(np.float64),
        "velocity": vel.astype(np.float64),
        "clump_id": (clump - sim.clump_range[world, 0]).astype(np.int32),
        "world_id": np.full(len(clump), world, dtype=np.int32),
    }


def _plane_mesh(origin: np.ndarray, geom: np.ndarray, clip: float):
    u, v = geom[3:6], geom[6:9]
    hu, hv = min(geom[9], clip), min(geom[10], clip)
    pts = np.array([origin - hu * u - hv * v, origin + hu * u - hv * v,
                    origin + hu * u + hv * v, origin - hu * u + hv * v])
    return pts, np.array([[0, 1, 2, 3]])


def _tube_mesh(origin: np.ndarray, geom: np.ndarray, n_seg: int):
    axis = geom[0:3]
    r_in, r_out, length = geom[3], geom[4], geom[5]
    trial = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = trial - np.dot(trial, axis) * axis
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = 2.0 * np.pi * np.arange(n_seg) / n_seg
    radial = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2
    # rings: inner bottom, inner top, outer bottom, outer top (n_seg points each)
    rings = [origin + r * radial + z * axis
             for r, z in ((r_in, 0.0), (r_in, length), (r_out, 0.0), (r_out, length))]
    pts = np.concatenate(rings)
    k = np.arange(n_seg)
    k1 = (k + 1) % n_seg
    ib, it, ob, ot = 0, n_seg, 2 * n_seg, 3 * n_seg
    quads = np.concatenate([
        np.stack([ib + k, ib + k1, it + k1, it + k], 1),   # inner surface
        np.stack([ob + k, ot + k, ot + k1, ob + k1], 1),   # outer surface
        np.stack([ib + k, ob + k, ob + k1, ib + k1], 1),   # bottom rim
        np.stack([it + k, it + k1, ot + k1, ot + k], 1),   # top rim
    ])
    return pts, quads


def wall_mesh(sim: Simulation, world: int,
              n_segments: int = TUBE_SEGMENTS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The walls of a world at their current position as quads: points (m, 3) m, quads
    (k, 4) point indices, wall index of each quad (k,). Infinite planes are clipped to the
    world's domain."""
    sim._check_world(world)
    sim.runner.pull("wall_origin")
    a = sim.arrays
    clip = float(np.max(a["world_hi"][world] - a["world_lo"][world]))
    pts_all, quads_all, ids = [], [], []
    n_pts = 0
    for k in range(len(sim.worlds[world].walls)):
        wtype = int(a["wall_type"][world, k])
        origin = a["wall_origin"][world, k]
        geom = a["wall_geom"][world, k]
        if wtype == WALL_PLANE:
            pts, quads = _plane_mesh(origin, geom, clip)
        elif wtype == WALL_TUBE:
            pts, quads = _tube_mesh(origin, geom, n_segments)
        else:
            continue
        pts_all.append(pts)
        quads_all.append(quads + n_pts)
        ids.append(np.full(len(quads), k, dtype=np.int32))
        n_pts += len(pts)
    if not pts_all:
        return np.zeros((0, 3)), np.zeros((0, 4), dtype=np.int64), np.zeros(0, dtype=np.int32)
    return np.concatenate(pts_all), np.concatenate(quads_all), np.concatenate(ids)


def _data_array(name: str, arr: np.ndarray, encoding: str, indent: str) -> str:
    arr = np.ascontiguousarray(arr)
    dt = arr.dtype.newbyteorder("<")
    arr = arr.astype(dt, copy=False)
    ncomp = 1 if arr.ndim == 1 else arr.shape[1]
    head = (f'{indent}<DataArray type="{_VTK_TYPES[dt]}" Name={quoteattr(name)} '
            f'NumberOfComponents="{ncomp}" format="{encoding}">')
    if encoding == "binary":
        raw = arr.tobytes()
        # uncompressed inline binary: one base64 stream of the UInt64 byte count + the data
        body = base64.b64encode(np.array([len(raw)], dtype="<u8").tobytes() + raw).decode("ascii")
    else:
        fmt = "%.17g" if arr.dtype.kind == "f" else "%d"
        body = " ".join(fmt % x for x in arr.reshape(-1))
    return f"{head}\n{indent}  {body}\n{indent}</DataArray>\n"


def _polydata_xml(points: np.ndarray, point_data: dict[str, np.ndarray],
                  verts: bool, polys: np.ndarray | None, cell_data: dict[str, np.ndarray],
                  encoding: str) -> str:
    n = len(points)
    n_verts = n if verts else 0
    n_polys = 0 if polys is None else len(polys)
    out = ['<?xml version="1.0"?>\n',
           '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" '
           'header_type="UInt64">\n', '  <PolyData>\n',
           f'    <Piece NumberOfPoints="{n}" NumberOfVerts="{n_verts}" NumberOfLines="0" '
           f'NumberOfStrips="0" NumberOfPolys="{n_polys}">\n']
    ind = "        "
    out.append("      <PointData>\n")
    out += [_data_array(k, v, encoding, ind) for k, v in point_data.items()]
    out.append("      </PointData>\n      <CellData>\n")
    out += [_data_array(k, v, encoding, ind) for k, v in cell_data.items()]
    out.append("      </CellData>\n      <Points>\n")
    out.append(_data_array("Points", np.asarray(points, dtype=np.float64).reshape(n, 3),
                           encoding, ind))
    out.append("      </Points>\n")
    if verts:
        out.append("      <Verts>\n")
        out.append(_data_array("connectivity", np.arange(n, dtype=np.int64), encoding, ind))
        out.append(_data_array("offsets", np.arange(1, n + 1, dtype=np.int64), encoding, ind))
        out.append("      </Verts>\n")
    if polys is not None:
        out.append("      <Polys>\n")
        out.append(_data_array("connectivity", polys.astype(np.int64).reshape(-1), encoding,
                               ind))
        out.append(_data_array("offsets", 4 * np.arange(1, n_polys + 1, dtype=np.int64),
                               encoding, ind))
        out.append("      </Polys>\n")
    out.append("    </Piece>\n  </PolyData>\n</VTKFile>\n")
    return "".join(out)


def _vtp_path(path: str | Path) -> Path:
    p = Path(path)
    if p.suffix != ".vtp":
        p = p.with_name(p.name + ".vtp")
    if not p.parent.is_dir():
        raise InputError(f"VTK path: folder {str(p.parent)!r} does not exist")
    return p


def write_vtk(sim: Simulation, world: int, path: str | Path, *, encoding: str = "binary",
              walls: bool = True) -> list[Path]:
    """Write the active spheres of one world (and its walls) as VTK PolyData.

    Parameters
    ----------
    sim : Simulation
        The engine.
    world : int
        World index.
    path : path
        Output file; ``.vtp`` is appended if missing. The walls go to ``<stem>_walls.vtp``.
    encoding : {"binary", "ascii"}
        VTK XML data format (inline base64 binary, or text).
    walls : bool
        Also write the walls (if the world has any).

    Returns
    -------
    list of Path
        The files written (spheres first).
    """
    if encoding not in ("binary", "ascii"):
        raise InputError(f"encoding must be 'binary' or 'ascii'; got {encoding!r}")
    if not isinstance(world, (int, np.integer)) or not (0 <= world < sim.n_worlds):
        raise InputError(f"world must be an integer in [0, {sim.n_worlds - 1}]; got {world!r}")
    p = _vtp_path(path)
    d = sphere_data(sim, int(world))
    point_data = {k: d[k] for k in ("radius", "velocity", "clump_id", "world_id")}
    p.write_text(_polydata_xml(d["points"], point_data, True, None, {}, encoding))
    written = [p]
    if walls and sim.worlds[world].walls:
        pts, quads, ids = wall_mesh(sim, int(world))
        wp = p.with_name(p.stem + "_walls.vtp")
        wp.write_text(_polydata_xml(pts, {}, False, quads, {"wall_id": ids}, encoding))
        written.append(wp)
    return written


class VtkSeries:
    """A time series of VTK files of one world with its ParaView ``.pvd`` collection.

    Files are ``<folder>/<name>_<k>.vtp`` (and ``_walls.vtp``); the collection
    ``<folder>/<name>.pvd`` is rewritten at every :meth:`add`, so it is valid at any time.

    Parameters
    ----------
    folder : path
        Output folder (created if missing).
    name : str
        Base name of the files (letters, digits, ``_-.``).
    encoding : {"binary", "ascii"}
        As for :func:`write_vtk`.
    """

    def __init__(self, folder: str | Path, name: str, *, encoding: str = "binary"):
        if not name or not all(c.isalnum() or c in "_-." for c in name):
            raise InputError(f"series name must be letters, digits, '_', '-' or '.'; "
                             f"got {name!r}")
        if encoding not in ("binary", "ascii"):
            raise InputError(f"encoding must be 'binary' or 'ascii'; got {encoding!r}")
        self.folder = Path(folder)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"VTK series folder {str(folder)!r}: {exc.strerror}") from None
        self.name = name
        self.encoding = encoding
        self.entries: list[tuple[float, int, str]] = []
        self.pvd_path = self.folder / f"{name}.pvd"
        self._count = 0

    def add(self, sim: Simulation, world: int, time: float | None = None,
            label: str | None = None) -> list[Path]:
        """Write the current state of ``world``; ``time`` in s (default: the world's time),
        ``label`` an optional suffix of the file name. Returns the files written."""
        t = float(sim.time[world]) if time is None else float(time)
        if not math.isfinite(t):
            raise InputError(f"time must be finite (s); got {time!r}")
        stem = f"{self.name}_{self._count:04d}" + (f"_{label}" if label else "")
        files = write_vtk(sim, world, self.folder / f"{stem}.vtp", encoding=self.encoding)
        self._count += 1
        for part, f in enumerate(files):
            self.entries.append((t, part, f.name))
        self._write_pvd()
        return files

    def _write_pvd(self) -> None:
        rows = "".join(f'    <DataSet timestep="{t!r}" group="" part="{part}" '
                       f"file={quoteattr(f)}/>\n" for t, part, f in self.entries)
        self.pvd_path.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" '
                                 'version="0.1" byte_order="LittleEndian">\n  <Collection>\n'
                                 f"{rows}  </Collection>\n</VTKFile>\n")

    def close(self) -> Path:
        """Write the collection (again) and return its path."""
        self._write_pvd()
        return self.pvd_path


# ---------------------------------------------------------------------------------- snapshots
def _wall_dict(wall: PlaneWall | TubeWall) -> dict[str, Any]:
    def vec(v):
        return None if v is None else [float(x) for x in np.asarray(v, dtype=float)]

    if isinstance(wall, PlaneWall):
        return {"type": "plane", "origin": vec(wall.origin), "normal": vec(wall.normal),
                "half_size": [float(h) for h in wall.half_size], "u_axis": vec(wall.u_axis),
                "material": wall.material, "velocity": vec(wall.velocity), "name": wall.name,
                "angular_velocity": vec(wall.angular_velocity)}
    return {"type": "tube", "base": vec(wall.base), "axis": vec(wall.axis),
            "inner_radius": float(wall.inner_radius), "thickness": float(wall.thickness),
            "length": float(wall.length), "material": wall.material,
            "velocity": vec(wall.velocity), "name": wall.name,
            "angular_velocity": vec(wall.angular_velocity)}


def _wall_from(d: dict[str, Any]) -> PlaneWall | TubeWall:
    d = dict(d)
    kind = d.pop("type")
    for key in ("origin", "normal", "u_axis", "velocity", "base", "axis", "angular_velocity"):
        if d.get(key) is not None:
            d[key] = np.array(d[key])
    if kind == "plane":
        d["half_size"] = tuple(d["half_size"])
        return PlaneWall(**d)
    return TubeWall(**d)


def _describe(sim: Simulation, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    worlds = []
    for w, world in enumerate(sim.worlds):
        groups = []
        for g, grp in enumerate(world.groups):
            t = grp.template
            arrays[f"tpl/{w}/{g}/offsets"] = np.asarray(t.offsets)
            arrays[f"tpl/{w}/{g}/radii"] = np.asarray(t.radii)
            arrays[f"tpl/{w}/{g}/inertia"] = np.asarray(t.inertia_per_density)
            arrays[f"tpl/{w}/{g}/scales"] = grp.scale_array()
            groups.append({"template_name": t.name, "volume": float(t.volume),
                           "material": grp.material, "count": int(grp.count)})
        mats = world.materials
        worlds.append({
            "materials": [[m.name, m.density, m.shear_modulus, m.poisson]
                          for m in mats.materials],
            "interactions": [[a, b, i.restitution, i.static_friction, i.rolling_friction,
                              i.surface_energy] for (a, b), i in mats.interactions.items()],
            "groups": groups,
            "walls": [_wall_dict(wall) for wall in world.walls],
            "domain_lo": [float(x) for x in world.domain_lo],
            "domain_hi": [float(x) for x in world.domain_hi],
            "gravity": [float(x) for x in world.gravity],
            "time_step": None if world.time_step is None else float(world.time_step),
        })
    rolling = {v: k for k, v in ROLLING_MODELS.items()}[sim.rolling_model]
    return {"format": "demcal-dem-snapshot", "version": SNAPSHOT_VERSION, "worlds": worlds,
            "dt_fraction": sim.dt_fraction, "rolling_friction": rolling, "skin": sim.skin,
            "raise_on_unstable": sim.raise_on_unstable, "parity": int(sim.parity),
            "world_errors": list(sim.world_errors),
            "enabled": [bool(e) for e in sim._enabled]}


def _worlds_from(meta: dict[str, Any], data) -> list[World]:
    worlds = []
    for w, wd in enumerate(meta["worlds"]):
        mats = MaterialTable([Material(*m) for m in wd["materials"]],
                             {(i[0], i[1]): Interaction(*i[2:]) for i in wd["interactions"]})
        groups = []
        for g, gd in enumerate(wd["groups"]):
            tpl = ClumpTemplate(gd["template_name"], data[f"tpl/{w}/{g}/offsets"],
                                data[f"tpl/{w}/{g}/radii"], gd["volume"],
                                data[f"tpl/{w}/{g}/inertia"])
            groups.append(ClumpGroup(tpl, gd["material"], gd["count"],
                                     scales=data[f"tpl/{w}/{g}/scales"]))
        worlds.append(World(mats, groups, [_wall_from(x) for x in wd["walls"]],
                            tuple(wd["domain_lo"]), tuple(wd["domain_hi"]),
                            tuple(wd["gravity"]), wd["time_step"]))
    return worlds


def save_snapshot(sim: Simulation, path: str | Path) -> Path:
    """Save the complete engine state as a compressed ``.npz`` (``.npz`` appended if missing).

    The file holds every engine array (clump poses, quaternions, velocities, angular momenta,
    neighbour lists with tangential and rolling-spring history, wall positions and velocities,
    world times and steps), the worlds' description (materials, templates, sizes, walls) and
    the run settings, so :func:`load_snapshot` continues the run bitwise identically.
    """
    p = Path(path)
    if p.suffix != ".npz":
        p = p.with_name(p.name + ".npz")
    if not p.parent.is_dir():
        raise InputError(f"snapshot path: folder {str(p.parent)!r} does not exist")
    state = sim.state_dict()
    arrays: dict[str, np.ndarray] = {f"a/{k}": v for k, v in state.items() if k != "parity"}
    meta = _describe(sim, arrays)
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode("utf-8"), dtype=np.uint8)
    with p.open("wb") as fh:
        np.savez_compressed(fh, **arrays)
    return p


def _read(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"snapshot file {str(p)!r} does not exist")
    try:
        with np.load(p, allow_pickle=False) as npz:
            data = {k: npz[k] for k in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise InputError(f"snapshot file {str(p)!r} is not a demcal snapshot ({exc})") from None
    try:
        meta = json.loads(data.pop("meta").tobytes().decode("utf-8"))
        if meta.get("format") != "demcal-dem-snapshot":
            raise ValueError("wrong format tag")
    except (KeyError, ValueError, AttributeError):
        raise InputError(f"snapshot file {str(p)!r} is not a demcal snapshot") from None
    if meta.get("version") != SNAPSHOT_VERSION:
        raise InputError(f"snapshot file {str(p)!r} has format version {meta.get('version')!r}; "
                         f"this demcal reads version {SNAPSHOT_VERSION}")
    return meta, data


def load_snapshot(path: str | Path, sim: Simulation | None = None, *,
                  backend: str = "cpu") -> Simulation:
    """Restore a snapshot written by :func:`save_snapshot`.

    Parameters
    ----------
    path : path
        The ``.npz`` file.
    sim : Simulation, optional
        Restore into this simulation (it must hold the same worlds and sizes); by default a
        new one is built from the snapshot's description.
    backend : {"cpu", "cuda", "auto"}
        Backend of the new simulation (ignored when ``sim`` is given).

    Returns
    -------
    Simulation
        Ready to continue (``sim`` itself when given).
    """
    meta, data = _read(path)
    if sim is None:
        sim = Simulation(_worlds_from(meta, data), backend=backend,
                         dt_fraction=meta["dt_fraction"],
                         rolling_friction=meta["rolling_friction"], skin=meta["skin"],
                         raise_on_unstable=meta["raise_on_unstable"])
    saved = {k[2:]: v for k, v in data.items() if k.startswith("a/")}
    if set(saved) != set(sim.arrays):
        raise InputError("snapshot does not match this simulation (different engine arrays: "
                         f"{sorted(set(saved) ^ set(sim.arrays))})")
    if meta["rolling_friction"] != {v: k for k, v in ROLLING_MODELS.items()}[sim.rolling_model]:
        raise InputError(f"snapshot uses rolling_friction={meta['rolling_friction']!r}; this "
                         "simulation uses another model")
    for name, arr in saved.items():
        mine = sim.arrays[name]
        growable = name.startswith(("nb_", "bucket_members"))
        if arr.dtype != mine.dtype or (arr.shape != mine.shape and not growable):
            raise InputError(f"snapshot array {name!r} ({arr.dtype}, {arr.shape}) does not "
                             f"fit this simulation ({mine.dtype}, {mine.shape})")
    for name, arr in saved.items():
        sim.arrays[name] = np.array(arr, copy=True)
    sim.world_errors = list(meta["world_errors"])
    sim._enabled = np.asarray(meta["enabled"], dtype=bool)
    sim.runner.push_all(parity=int(meta["parity"]))
    return sim

