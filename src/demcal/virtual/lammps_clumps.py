"""demcal's clumps as LAMMPS input: the data file, the rigid bodies and the settle rule.

Both LAMMPS tests (:mod:`demcal.virtual.lammps_aor`, :mod:`demcal.virtual.lammps_drum`)
write their particles the same way:

- a data file (``atom_style sphere``: diameter, density, position) with each sphere's clump
  as its molecule ID; each sphere's density is set so that its clump has demcal's mass
  (density x the union's volume);
- a ``fix rigid/small ... infile`` bodies file: every clump's mass, centre of mass and
  space-frame inertia tensor from demcal's union-of-spheres template (LAMMPS would otherwise
  sum the overlapping spheres' inertia);
- the settle criterion of :mod:`demcal.virtual.settle` as LAMMPS computes and variables.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from demcal.dem.contact import rayleigh_time_step
from demcal.dem.shapes import ClumpTemplate
from demcal.dem.state import rotate
from demcal.limits import check_time_step
from demcal.virtual.lammps_laws import ContactLaw, contact_laws

__all__ = ["Box", "ClumpSet", "DataSpheres", "LammpsClumps", "clump_mass_inertia",
           "rotation_matrices", "settle_block", "step_and_laws", "write_clumps", "write_data"]


@dataclass(frozen=True)
class ClumpSet:
    """Clumps placed in the test's frame (SI units)."""

    template: ClumpTemplate  #: the unscaled template
    scales: np.ndarray  #: (n,) size factor of each clump
    positions: np.ndarray  #: (n, 3) centres (the template's origin), m
    orientations: np.ndarray  #: (n, 4) unit quaternions (w, x, y, z)
    density: float  #: the particle's solid density, kg/m^3


class DataSpheres(NamedTuple):
    """The spheres of a data file, one row each (SI units)."""

    centres: np.ndarray  #: (n, 3) positions, m
    radii: np.ndarray  #: (n,) radii, m
    density: np.ndarray  #: (n,) densities that give each clump demcal's mass, kg/m^3
    clump: np.ndarray  #: (n,) the clump (molecule ID, from 1) a sphere belongs to


@dataclass(frozen=True)
class Box:
    """The simulation box of the data file, m."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


@dataclass(frozen=True)
class LammpsClumps:
    """What a test's script needs to know of the clumps it wrote."""

    n_clumps: int
    n_spheres: int
    r_min: float  #: smallest sphere radius, m (sets the time step and the neighbour skin)
    r_mean: float  #: mean sphere radius, m (the typical contact of the laws)
    mass_mean: float  #: mean clump mass, kg
    reach: float  #: the largest clump's bounding radius, m (sets the ghost cutoff)

    @classmethod
    def of_sizes(cls, template: ClumpTemplate, scales: np.ndarray, density: float,
                 n_clumps: int) -> LammpsClumps:
        """``n_clumps`` clumps of ``template`` whose sizes are those of ``scales`` (the placed
        clumps', or a factory's size classes) at solid ``density`` (kg/m^3)."""
        mass, _ = clump_mass_inertia(template, scales, density)
        radii = template.radii[None, :] * scales[:, None]
        return cls(n_clumps=n_clumps, n_spheres=n_clumps * len(template.radii),
                   r_min=float(radii.min()), r_mean=float(np.mean(radii)),
                   mass_mean=float(np.mean(mass)),
                   reach=float(template.bounding_radius * scales.max()))


def rotation_matrices(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of unit quaternions (w, x, y, z)."""
    cols = [rotate(q, np.tile(e, (len(q), 1))) for e in np.eye(3)]
    return np.stack(cols, axis=2)


def clump_mass_inertia(template: ClumpTemplate, scales: np.ndarray,
                       density: float) -> tuple[np.ndarray, np.ndarray]:
    """Each clump's mass (kg, ``(n,)``: density x the union's volume) and its principal
    moments of inertia in the template's body frame (kg m^2, ``(n, 3)``) at size factors
    ``scales`` and solid ``density`` (kg/m^3)."""
    mass = density * template.volume * scales**3
    inertia = density * template.inertia_per_density[None, :] * scales[:, None] ** 5
    return mass, inertia


def write_clumps(clumps: ClumpSet, box: Box, data_path: Path, bodies_path: Path, *,
                 title: str) -> LammpsClumps:
    """Write ``clumps`` as a LAMMPS data file and a ``rigid/small`` bodies file.

    Parameters
    ----------
    clumps : ClumpSet
        The placed clumps.
    box : Box
        The data file's box, m.
    data_path, bodies_path : Path
        Where to write the data file and the bodies file.
    title : str
        The data file's first line.
    """
    t, scales, quat = clumps.template, clumps.scales, clumps.orientations
    n, ns = len(scales), len(t.radii)
    mass, inertia = clump_mass_inertia(t, scales, clumps.density)
    centres = clumps.positions[:, None, :] + np.stack(
        [rotate(quat, t.offsets[k][None, :] * scales[:, None]) for k in range(ns)], 1)
    radii = t.radii[None, :] * scales[:, None]
    atom_density = mass / (4.0 / 3.0 * math.pi * np.sum(radii**3, axis=1))
    rmat = rotation_matrices(quat)
    tensor = np.einsum("nij,nj,nkj->nik", rmat, inertia, rmat)
    # LAMMPS checks the given centre of mass against its own (sphere-mass weighted)
    w = radii**3
    com = np.sum(centres * w[..., None], axis=1) / np.sum(w, axis=1)[:, None]
    write_data(data_path, box, title, DataSpheres(
        centres.reshape(-1, 3), radii.reshape(-1), np.repeat(atom_density, ns),
        np.repeat(np.arange(1, n + 1), ns)))
    _write_bodies(bodies_path, mass, com, tensor)
    return LammpsClumps.of_sizes(t, scales, clumps.density, n)


def write_data(path: Path, box: Box, title: str, spheres: DataSpheres) -> None:
    """The spheres as a LAMMPS data file (``atom_style sphere``, clumps as molecules), with
    ``title`` as its first line and ``box`` (m) as its bounds."""
    n = len(spheres.radii)
    ids = np.arange(1, n + 1)
    with path.open("w") as fh:
        fh.write(f"{title}\n\n{n} atoms\n1 atom types\n\n")
        for k, axis in enumerate("xyz"):
            fh.write(f"{float(box.lo[k])!r} {float(box.hi[k])!r} {axis}lo {axis}hi\n")
        fh.write("\nAtoms # sphere\n\n")
        np.savetxt(fh, np.column_stack([ids, np.ones(n), 2 * spheres.radii, spheres.density,
                                        spheres.centres]),
                   fmt=["%d", "%d", "%.17g", "%.17g", "%.17g", "%.17g", "%.17g"])
        fh.write("\nMolecules\n\n")
        np.savetxt(fh, np.column_stack([ids, spheres.clump]), fmt="%d")


def _write_bodies(path: Path, mass: np.ndarray, com: np.ndarray, tensor: np.ndarray) -> None:
    n = len(mass)
    rows = np.column_stack([
        np.arange(1, n + 1), mass, com,
        tensor[:, 0, 0], tensor[:, 1, 1], tensor[:, 2, 2],
        tensor[:, 0, 1], tensor[:, 0, 2], tensor[:, 1, 2],
        np.zeros((n, 9))])
    with path.open("w") as fh:
        fh.write("# demcal clumps: id mass xcm ycm zcm ixx iyy izz ixy ixz iyz v L image\n")
        fh.write(f"{n}\n")
        np.savetxt(fh, rows, fmt=["%d"] + ["%.17g"] * 10 + ["%d"] * 9)


def settle_block(rms_limit: float, max_limit: float) -> str:
    """LAMMPS lines that define ``v_rms``, ``v_vmax`` (m/s), ``v_top`` (the material's top,
    m) and ``v_still`` (1 when settled): the settle criterion of
    :func:`demcal.virtual.settle.settle_state` on the clumps' centre-of-mass speeds over the
    clumps that touch another clump when more than half do, else over all clumps."""
    head = ("# settle criterion (demcal.virtual.settle): clump centre-of-mass speeds over the "
            "clumps that\n# touch another clump when more than half do, else over all clumps\n")
    return head + f"""compute cnt all contact/atom
compute cmol all chunk/atom molecule
compute ctouch all reduce/chunk cmol max c_cnt
compute touch all chunk/spread/atom cmol c_ctouch
compute cvcm all vcm/chunk cmol
compute vsp all chunk/spread/atom cmol c_cvcm[*]
variable tch atom "c_touch > 0"
variable s2 atom "c_vsp[1]*c_vsp[1] + c_vsp[2]*c_vsp[2] + c_vsp[3]*c_vsp[3]"
variable s2t atom "v_tch*v_s2"
variable ztop atom "z + radius"
compute red all reduce sum v_tch v_s2t v_s2
compute mx all reduce max v_s2t v_s2 v_ztop
variable natoms equal count(all)
variable pile equal "c_red[1] > 0.5*v_natoms"
variable nt equal "c_red[1] + (c_red[1] < 1)"
variable rms equal "sqrt(v_pile*c_red[2]/v_nt + (1 - v_pile)*c_red[3]/v_natoms)"
variable vmax equal "sqrt(v_pile*c_mx[1] + (1 - v_pile)*c_mx[2])"
variable top equal "c_mx[3]"
variable still equal "v_rms < {float(rms_limit)!r} && v_vmax < {float(max_limit)!r}"
"""


def step_and_laws(params: Mapping[str, float], written: LammpsClumps, *, dt_fraction: float,
                  rolling: bool) -> tuple[float, dict[str, ContactLaw]]:
    """The time step (``dt_fraction`` of the smallest sphere's Rayleigh time step, s) and the
    contact laws at the written clumps' typical contact (:mod:`demcal.virtual.lammps_laws`),
    as demcal's engine takes them for the same test."""
    dt = check_time_step(dt_fraction * rayleigh_time_step(
        written.r_min, params["particle.density"], params["particle.shear_modulus"],
        params["particle.poisson"]))
    laws = contact_laws(params, sphere_radius=written.r_mean, clump_mass=written.mass_mean,
                        rolling=rolling)
    return float(dt), dict(laws)
