"""The cylinder-lifting AoR test as a LAMMPS input: data file, rigid bodies and phase script.

:func:`write_case` writes, for one parameter set and seed, the same test that
:func:`demcal.virtual.run_aor` runs (same geometry, same packing fill: the same seed gives both
engines the same initial clumps; the same time step, lift speed, settle rules and limits):

- ``aor.data``: the spheres (``atom_style sphere``: diameter, density, position) with their
  clump as molecule ID; each sphere's density is set so that its clump has demcal's mass;
- ``bodies.txt``: ``fix rigid/small ... infile``: every clump's mass, centre of mass and
  space-frame inertia tensor from demcal's union-of-spheres template (LAMMPS would otherwise
  sum the overlapping spheres' inertia);
- ``in.aor``: ``pair_style granular`` (coefficients from :mod:`demcal.virtual.lammps_laws`),
  gravity, the plate as a ``wall/gran`` z-plane, the tube as a ``wall/gran/region`` open
  cylinder that moves up at the lift speed, and the phases as a loop of short runs: every
  ``check_interval`` the settle criterion of :mod:`demcal.virtual.settle` is evaluated from
  the clumps' centre-of-mass speeds (over the clumps that touch another clump when more than
  half do), the tube stops once it clears the material, and the script prints one
  ``DEMCAL <event> ...`` line per phase change and dumps the settled fill's, the lifted and
  the final spheres.

Only the ``packing`` fill is written (the quick, standard and large fidelities); the factory
fill of the paper fidelity is not (an :class:`~demcal.errors.InputError` says so).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from demcal.errors import InputError
from demcal.virtual.config import AoRTestConfig
from demcal.virtual.factory import draw_scales, make_template, pack_cylinder
from demcal.virtual.lammps_clumps import Box, ClumpSet, settle_block, step_and_laws, write_clumps
from demcal.virtual.lammps_laws import ContactLaw, model_string

__all__ = ["LammpsCase", "write_case"]

#: files of a case
DATA, BODIES, INPUT, LIFTED, FINAL = "aor.data", "bodies.txt", "in.aor", "lifted.dump", "final.dump"
#: the settled fill before the lift: its level and bulk density are read from it
FILLED = "filled.dump"


@dataclass(frozen=True)
class LammpsCase:
    """A written case: where, and what :mod:`demcal.virtual.lammps_run` needs to read it."""

    folder: Path
    n_clumps: int
    n_spheres: int
    time_step_s: float
    seed: int
    params: dict[str, float]


def _fmt(x: float) -> str:
    return repr(float(x))


def write_case(params: Mapping[str, float], config: AoRTestConfig, seed: int,
               folder: str | Path) -> LammpsCase:
    """Write the LAMMPS files of one run into ``folder`` (created).

    Parameters
    ----------
    params : mapping
        A complete demcal parameter set (SI units).
    config : AoRTestConfig
        The test; ``fill.method`` must be ``packing``.
    seed : int
        The run's seed (sizes, positions, orientations: as demcal's engine draws them).
    folder : path
        Where to write ``aor.data``, ``bodies.txt`` and ``in.aor``.
    """
    if config.fill.method != "packing":
        raise InputError("the LAMMPS engine runs the packing fill only (fidelities quick, "
                         "standard and large); fill.method = 'factory' is not written for "
                         "LAMMPS yet")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    template = make_template(config.particle)
    rng = np.random.default_rng(int(seed))
    scales_all = draw_scales(int(config.fill.count), config.particle, rng)
    idx, pos, quat = pack_cylinder(template, scales_all, config, rng)
    rho = params["particle.density"]
    half, zlo, zhi = _box(config)
    written = write_clumps(ClumpSet(template, scales_all[idx], pos, quat, rho),
                           Box((-half, -half, zlo), (half, half, zhi)), folder / DATA,
                           folder / BODIES, title="demcal AoR test")
    dt, laws = step_and_laws(params, written, dt_fraction=config.dt_fraction,
                             rolling=config.rolling_model != "none")
    (folder / INPUT).write_text(_script(config, dt, laws, written.reach, written.r_min))
    return LammpsCase(folder, written.n_clumps, written.n_spheres, float(dt), int(seed),
                      dict(params))


def _box(config: AoRTestConfig) -> tuple[float, float, float]:
    g = config.geometry
    half = 0.5 * g.plate_size + 0.02
    z_top = g.cylinder_height + (config.phases.lift_height or g.cylinder_height) + 0.1
    return half, -0.05, z_top


def _script(config: AoRTestConfig, dt: float, laws: Mapping[str, ContactLaw], reach: float,
            r_min: float) -> str:
    """The phase script ``in.aor``.

    Parameters
    ----------
    config : AoRTestConfig
        The test.
    dt : float
        Time step, s.
    laws : mapping
        The contact laws by kind, ``pp`` (particle-particle) and ``pw`` (particle-wall), as
        :func:`demcal.virtual.lammps_laws.contact_laws` gives them.
    reach : float
        The largest clump's bounding radius, m (sets the ghost cutoff).
    r_min : float
        The smallest sphere radius, m (the neighbour skin is half of it).
    """
    pp, pw = model_string(laws["pp"]), model_string(laws["pw"])
    g, ph, p = config.geometry, config.phases, config.particle
    n_check = max(1, round(ph.check_interval / dt))
    r_in = 0.5 * g.cylinder_inner_diameter
    skin = 0.5 * r_min
    limit = ph.lift_height if ph.lift_height is not None else g.cylinder_height
    clear = 0.5 * p.diameter
    # the tube stops when it clears the material (unless a lift height is set) or at its limit
    lift_done = f"v_dz >= {_fmt(limit)}"
    if ph.lift_height is None:
        lift_done = f"v_dz > v_top + {_fmt(clear)} || " + lift_done
    return f"""# demcal: the cylinder-lifting AoR test (written by demcal.virtual.lammps_aor)
units si
atom_style sphere
atom_modify map array
boundary f f f
comm_modify vel yes cutoff {_fmt(2.0 * reach + skin)}
fix pmol all property/atom mol ghost yes
read_data {DATA} fix pmol NULL Molecules
neighbor {_fmt(skin)} bin
neigh_modify delay 0 every 1 check yes exclude molecule/intra all
pair_style granular
pair_coeff * * {pp}
timestep {_fmt(dt)}
fix grav all gravity 9.81 vector 0 0 -1
fix rig all rigid/small molecule infile {BODIES}
fix plate all wall/gran granular {pw} zplane 0.0 NULL
variable dz equal 0.0
region tube cylinder z 0 0 {_fmt(r_in)} 0 {_fmt(g.cylinder_height)} side in move NULL NULL v_dz \
open 1 open 2 units box
fix tube all wall/gran/region granular {pw} region tube

{settle_block(ph.settle_rms_speed, ph.settle_max_speed)}variable cleared equal "{lift_done}"
thermo_style custom step time atoms v_rms v_vmax v_top v_dz
thermo {n_check}
thermo_modify lost ignore norm no

print "DEMCAL start 0 {n_check}"
variable tp equal 0.0
label fill_loop
run {n_check} post no
if "${{still}} && $(time - v_tp) >= {_fmt(ph.min_settle_time)}" then "jump SELF fill_done"
if "$(time - v_tp) > {_fmt(ph.fill_settle_max_time)}" then &
  "print 'DEMCAL unsettled_fill $(time) ${{rms}} ${{vmax}}'" "jump SELF finish"
jump SELF fill_loop
label fill_done
print "DEMCAL filled $(time) ${{top}}"
write_dump all custom {FILLED} id mol mass radius x y z modify sort id
variable tl equal $(time)
variable dz equal "{_fmt(ph.lift_speed)}*(time - v_tl)"
label lift_loop
run {n_check} post no
if "${{cleared}}" then "jump SELF lift_done"
jump SELF lift_loop
label lift_done
variable zb equal ${{dz}}
variable dz equal ${{zb}}
print "DEMCAL lifted $(time) ${{zb}}"
write_dump all custom {LIFTED} id mol mass radius x y z modify sort id
variable tp equal $(time)
label pile_loop
run {n_check} post no
if "${{still}} && $(time - v_tp) >= {_fmt(ph.min_settle_time)}" then "jump SELF pile_done"
if "$(time - v_tp) > {_fmt(ph.pile_settle_max_time)}" then &
  "print 'DEMCAL unsettled_pile $(time) ${{rms}} ${{vmax}}'" "jump SELF finish"
jump SELF pile_loop
label pile_done
print "DEMCAL settled $(time)"
label finish
write_dump all custom {FINAL} id mol mass radius x y z modify sort id
print "DEMCAL end $(time)"
"""
