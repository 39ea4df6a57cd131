"""The paper's dynamic factory as LAMMPS input: clumps as molecule templates, ``fix deposit``.

demcal's factory (``fill.method = "factory"``, :mod:`demcal.virtual.aor`) generates ``rate``
clumps a second, up to the fill's :func:`~demcal.virtual.factory.fill_capacity`, at random
positions and orientations in a thin disc at ``factory_height``, each without overlap, falling
at ``drop_speed``. LAMMPS does the same with ``fix deposit``, inserting one rigid clump every
``M`` time steps (``M`` the whole number nearest ``1 / (rate dt)``) from a set of molecule
templates, until every clump is in or ``filling_time`` is over:

- **sizes**: demcal draws a clump's size factor uniformly from ``[size_min, size_max]``;
  LAMMPS inserts from templates, so the interval is cut into :data:`SIZE_CLASSES` equal
  classes at their middle sizes (the mean size is kept; the sizes' spread is
  ``sqrt(1 - 1/K^2)`` of the uniform one's);
- **orientations**: ``fix deposit`` turns each molecule by a uniform angle about a random
  axis, which favours small turns (not a uniform rotation: a stalk's axis stays near the
  template's ``x``; the axis' components are 0.23 from uniform in the Kolmogorov-Smirnov
  distance, and the mean ``|x|`` of 53 inserted stalks' axes was 0.63 against 0.5 for
  uniform directions). Each size class is therefore written in :data:`ORIENTATIONS`
  templates, each turned by its own uniformly random rotation from the run's seed: a turn of
  a uniformly random orientation is uniformly random, and the 32 templates' mixture is
  0.013-0.032 from uniform (seeds 1, 2, 3, 7), under the sampling noise of a 1550-stalk
  fill (0.035 at 95 %);
- each template gives its clump's mass (density x the union's volume), centre of mass and
  inertia tensor (demcal's union of spheres: LAMMPS would sum the overlapping spheres'
  inertia), as the packing fill's bodies file does (:mod:`~demcal.virtual.lammps_clumps`);
- an insertion point is kept a clump's reach inside the tube (demcal checks each sphere
  against the wall, which lets a clump lying along it sit a little further out); ``near``
  refuses a point closer than two of the largest sphere radius to any sphere; an insertion
  that finds no free point in :data:`ATTEMPTS` tries is skipped (demcal tries again at its next
  generation event), and ``DEMCAL generated <time> <spheres>`` says how many went in.

The two factories draw other random numbers, so one seed gives each engine another fill: the
engines are compared over seeds (docs/lammps.md), not pile by pile.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from demcal.dem.shapes import ClumpTemplate
from demcal.dem.state import random_quaternions
from demcal.virtual.config import AoRTestConfig, ParticleShape
from demcal.virtual.factory import fill_capacity
from demcal.virtual.lammps_clumps import LammpsClumps, clump_mass_inertia, rotation_matrices

__all__ = ["ATTEMPTS", "ORIENTATIONS", "SIZE_CLASSES", "TEMPLATE_ID", "Factory",
           "generation_lines", "insertion_interval", "size_classes", "template_line",
           "write_factory"]

#: how many size classes stand for demcal's uniform size distribution
SIZE_CLASSES = 8
#: how many randomly turned templates each size class is written in
ORIENTATIONS = 4
#: tries per insertion before LAMMPS skips it (demcal: 5 now, then again at the next event)
ATTEMPTS = 10
#: the molecule template set's ID in the script
TEMPLATE_ID = "clumps"


@dataclass(frozen=True)
class Factory:
    """A written factory: its template files and what the script's lines need (SI units)."""

    files: tuple[str, ...]  #: the molecule template files (size classes x orientations)
    scales: np.ndarray  #: (k,) size factor of each size class
    #: the clumps to insert (``n_clumps``: demcal's
    #: :func:`~demcal.virtual.factory.fill_capacity`), sized over the classes (for the time
    #: step and the laws)
    clumps: LammpsClumps
    r_max: float  #: the largest sphere radius, m (sets ``near``)
    seed: int  #: ``fix deposit``'s seed (a positive integer)


def size_classes(shape: ParticleShape, k: int = SIZE_CLASSES) -> np.ndarray:
    """The middle size factors of ``k`` equal classes of ``[size_min, size_max]``, ``(k,)``
    (one class when the two are equal)."""
    if shape.size_max == shape.size_min:
        return np.array([float(shape.size_min)])
    edges = np.linspace(shape.size_min, shape.size_max, k + 1)
    return 0.5 * (edges[:-1] + edges[1:])


def _f(x: float) -> str:
    return repr(float(x))


def _section(name: str, rows: Iterable[str]) -> str:
    return f"\n{name}\n\n" + "\n".join(f"{i + 1} {row}" for i, row in enumerate(rows)) + "\n"


def _molecule_text(template: ClumpTemplate, scale: float, quat: np.ndarray,
                   density: float) -> str:
    """A LAMMPS molecule file of one clump at size factor ``scale``, turned by ``quat``."""
    mass, inertia = clump_mass_inertia(template, np.array([scale]), density)
    rmat = rotation_matrices(quat[None, :])[0]
    offsets = template.offsets * scale @ rmat.T
    tensor = rmat @ np.diag(inertia[0]) @ rmat.T
    radii = template.radii * scale
    w = radii**3  # sphere masses go as their volumes: LAMMPS' centre of mass is this one
    com = np.sum(offsets * w[:, None], axis=0) / np.sum(w)
    moments = (tensor[0, 0], tensor[1, 1], tensor[2, 2], tensor[0, 1], tensor[0, 2],
               tensor[1, 2])
    return (
        f"# demcal clump: size factor {scale!r} (demcal.virtual.lammps_factory)\n\n"
        f"{len(radii)} atoms\n{_f(mass[0])} mass\n{' '.join(map(_f, com))} com\n"
        f"{' '.join(map(_f, moments))} inertia\n"
        + _section("Coords", (" ".join(map(_f, x)) for x in offsets))
        + _section("Types", ("1" for _ in radii))
        + _section("Diameters", (_f(2 * r) for r in radii))
        + _section("Masses", (_f(mass[0] * wi / np.sum(w)) for wi in w)))


def write_factory(template: ClumpTemplate, config: AoRTestConfig, density: float, seed: int,
                  folder: Path) -> Factory:
    """Write the factory's molecule templates into ``folder`` and plan the insertion.

    Parameters
    ----------
    template : ClumpTemplate
        The unscaled clump.
    config : AoRTestConfig
        The test (``fill.method = "factory"``).
    density : float
        The particle's solid density, kg/m^3.
    seed : int
        The run's seed: it draws the templates' orientations, and ``fix deposit`` takes
        ``seed + 1`` (it needs a positive one).
    folder : Path
        Where to write ``clump<k>.mol``.
    """
    scales = size_classes(config.particle)
    turns = random_quaternions(len(scales) * ORIENTATIONS, np.random.default_rng(int(seed)))
    files = []
    for k, (s, q) in enumerate(zip(np.repeat(scales, ORIENTATIONS), turns, strict=True)):
        name = f"clump{k}.mol"
        (folder / name).write_text(_molecule_text(template, float(s), q, density))
        files.append(name)
    clumps = LammpsClumps.of_sizes(template, scales, density, fill_capacity(config, template))
    return Factory(tuple(files), scales, clumps, float((template.radii.max() * scales).max()),
                   int(seed) + 1)


def insertion_interval(rate: float, dt: float) -> int:
    """Time steps between two insertions: the whole number nearest ``1 / (rate dt)``, >= 1
    (``rate`` in 1/s, ``dt`` in s)."""
    return max(1, round(1.0 / (rate * dt)))


def template_line(factory: Factory) -> str:
    """The ``molecule`` command that reads the factory's templates."""
    return f"molecule {TEMPLATE_ID} {' '.join(factory.files)}\n"


def generation_lines(factory: Factory, config: AoRTestConfig, dt: float, n_check: int,
                     rigid_fix: str) -> str:
    """The LAMMPS lines of the generation phase at time step ``dt`` (s): the insertion disc,
    ``fix deposit`` (ID ``fac``; the rigid fix ``rigid_fix`` must take ``mol clumps``), a
    loop of ``n_check``-step runs until every clump is in or ``filling_time`` is over (as
    demcal's factory stops), and the ``DEMCAL generated <time> <spheres>`` line."""
    g, fill = config.geometry, config.fill
    every = insertion_interval(fill.rate, dt)
    reach = factory.clumps.reach
    z_f = fill.factory_height if fill.factory_height is not None else g.cylinder_height
    radius = 0.5 * g.cylinder_inner_diameter - reach
    frac = " ".join(_f(1.0 / len(factory.files)) for _ in factory.files)
    # the thermo line needs no atoms here: the settle variables divide by their count
    return (
        f"region fac cylinder z 0 0 {_f(radius)} {_f(z_f - reach)} {_f(z_f)} side in units box\n"
        f"fix fac all deposit {factory.clumps.n_clumps} 0 {every} {factory.seed} region fac "
        f"near {_f(2.0 * factory.r_max)} attempt {ATTEMPTS} vz {_f(-fill.drop_speed)} "
        f"{_f(-fill.drop_speed)} mol {TEMPLATE_ID} molfrac {frac} rigid {rigid_fix} units box\n"
        f"thermo_style custom step time atoms\nthermo {n_check}\n"
        "label generation_loop\n"
        f"run {n_check} post no\n"
        f'if "$(count(all)) >= {factory.clumps.n_spheres} || '
        f'$(time) >= {_f(fill.filling_time)}" then "jump SELF generation_done"\n'
        "jump SELF generation_loop\n"
        "label generation_done\n"
        "unfix fac\n"
        'print "DEMCAL generated $(time) $(count(all))"\n')
