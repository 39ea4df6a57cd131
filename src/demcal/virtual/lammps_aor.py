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

The paper fidelity's ``factory`` fill is written as LAMMPS' own insertion
(:mod:`demcal.virtual.lammps_factory`): an empty box, one molecule template per size class,
``fix deposit`` generating the clumps as demcal's factory does, then the same phases; one seed
then gives the two engines different fills.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from demcal.virtual.config import AoRTestConfig
from demcal.virtual.factory import draw_scales, make_template, pack_cylinder
from demcal.virtual.lammps_clumps import (
    Box,
    ClumpSet,
    LammpsClumps,
    settle_block,
    step_and_laws,
    write_clumps,
)
from demcal.virtual.lammps_factory import (
    TEMPLATE_ID,
    Factory,
    generation_lines,
    template_line,
    write_factory,
)
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
        The test: its ``packing`` fill is written as placed clumps, its ``factory`` fill as
        LAMMPS' insertion (:mod:`demcal.virtual.lammps_factory`).
    seed : int
        The run's seed (sizes, positions, orientations: as demcal's engine draws them).
    folder : path
        Where to write ``aor.data``, ``bodies.txt`` (packing) or the clump templates
        (factory), and ``in.aor``.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    template = make_template(config.particle)
    rho = params["particle.density"]
    half, zlo, zhi = _box(config)
    box = Box((-half, -half, zlo), (half, half, zhi))
    if config.fill.method == "factory":
        factory = write_factory(template, config, rho, seed, folder)
        written = factory.clumps
    else:
        factory = None
        rng = np.random.default_rng(int(seed))
        scales_all = draw_scales(int(config.fill.count), config.particle, rng)
        idx, pos, quat = pack_cylinder(template, scales_all, config, rng)
        # a tall loose packing (the standard fidelity's 1200 stalks at a solid fraction of
        # 0.18 stand ~0.5 m high in the 56 mm tube) must lie inside the box LAMMPS reads
        top = float(pos[:, 2].max()) + template.bounding_radius * float(scales_all.max())
        if top + 0.05 > zhi:
            box = Box(box.lo, (half, half, top + 0.1))
        written = write_clumps(ClumpSet(template, scales_all[idx], pos, quat, rho), box,
                               folder / DATA, folder / BODIES, title="demcal AoR test")
    dt, laws = step_and_laws(params, written, dt_fraction=config.dt_fraction,
                             rolling=config.rolling_model != "none")
    fill = _FillLines.factory(factory, config, dt, box) if factory is not None \
        else _FillLines.packing()
    (folder / INPUT).write_text(_script(config, dt, laws, written, fill))
    return LammpsCase(folder, written.n_clumps, written.n_spheres, float(dt), int(seed),
                      dict(params))


#: atom_style sphere has no molecule IDs: a per-atom property holds each sphere's clump
_MOLECULE_IDS = "fix pmol all property/atom mol ghost yes\n"


@dataclass(frozen=True)
class _FillLines:
    """The lines of the script that differ between the two fills."""

    atoms: str  #: the box and the spheres there at the start
    rigid: str  #: the rigid-body fix ``rig``
    generation: str  #: what runs before the fill settles (nothing for the packing)
    settle_from: str  #: when the fill starts to settle, s (a LAMMPS value)

    @classmethod
    def packing(cls) -> _FillLines:
        return cls(atoms=f"{_MOLECULE_IDS}read_data {DATA} fix pmol NULL Molecules\n",
                   rigid=f"fix rig all rigid/small molecule infile {BODIES}\n", generation="",
                   settle_from="0.0")

    @classmethod
    def factory(cls, factory: Factory, config: AoRTestConfig, dt: float, box: Box) -> _FillLines:
        lo, hi = box.lo, box.hi
        return cls(
            atoms=(f"region box block {_fmt(lo[0])} {_fmt(hi[0])} {_fmt(lo[1])} "
                   f"{_fmt(hi[1])} {_fmt(lo[2])} {_fmt(hi[2])} units box\n"
                   "create_box 1 box\n" + _MOLECULE_IDS + template_line(factory)),
            rigid=f"fix rig all rigid/small molecule mol {TEMPLATE_ID}\n",
            generation=generation_lines(factory, config, dt, config.phases.check_steps(dt),
                                        "rig"),
            settle_from="$(time)")


def _box(config: AoRTestConfig) -> tuple[float, float, float]:
    g = config.geometry
    half = 0.5 * g.plate_size + 0.02
    z_top = g.cylinder_height + (config.phases.lift_height or g.cylinder_height) + 0.1
    return half, -0.05, z_top


def _script(config: AoRTestConfig, dt: float, laws: Mapping[str, ContactLaw],
            clumps: LammpsClumps, fill: _FillLines) -> str:
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
    clumps : LammpsClumps
        The clumps (the largest one's reach sets the ghost cutoff, half the smallest sphere
        radius the neighbour skin).
    fill : _FillLines
        The fill's own lines.
    """
    reach, r_min = clumps.reach, clumps.r_min
    settle = settle_block(config.phases.settle_rms_speed, config.phases.settle_max_speed)
    pp, pw = model_string(laws["pp"]), model_string(laws["pw"])
    g, ph, p = config.geometry, config.phases, config.particle
    n_check = ph.check_steps(dt)
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
{fill.atoms}neighbor {_fmt(skin)} bin
neigh_modify delay 0 every 1 check yes exclude molecule/intra all
pair_style granular
pair_coeff * * {pp}
timestep {_fmt(dt)}
fix grav all gravity 9.81 vector 0 0 -1
{fill.rigid}fix plate all wall/gran granular {pw} zplane 0.0 NULL
variable dz equal 0.0
region tube cylinder z 0 0 {_fmt(r_in)} 0 {_fmt(g.cylinder_height)} side in move NULL NULL v_dz \
open 1 open 2 units box
fix tube all wall/gran/region granular {pw} region tube

{fill.generation}{settle}variable cleared equal "{lift_done}"
thermo_style custom step time atoms v_rms v_vmax v_top v_dz
thermo {n_check}
thermo_modify lost ignore norm no

print "DEMCAL start 0 {n_check}"
variable tp equal {fill.settle_from}
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
