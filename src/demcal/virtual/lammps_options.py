"""How LAMMPS is started for the virtual test (a light module: a study file validates it)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from demcal.limits import MAX_REPLICATES

__all__ = ["LammpsOptions"]


class LammpsOptions(BaseModel):
    """How LAMMPS is started (none of these change a run's result)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    np: int = Field(1, ge=1, le=100_000, description="MPI ranks per run (mpirun -np)")
    launcher: str | None = Field(
        None, description="command prefix that starts the ranks, replacing 'mpirun -np N', "
        "e.g. 'mpirun -np 64 -f hosts' or 'srun -n 64'; the lmp command follows it")
    hostfile: str | None = Field(None, description="MPI hostfile (mpirun -f FILE): ranks on "
                                 "several machines; LAMMPS and the run folder must be there")
    lmp: str | None = Field(None, description="the LAMMPS executable (default: lmp next to "
                            "this Python, else on the PATH)")
    timeout_s: float = Field(7 * 86400.0, gt=0, description="wall-time limit of one run, s")
    work_dir: str | None = Field(None, description="keep each run's LAMMPS files in "
                                 "a new folder WORK_DIR/seed<k>-... (default: a temporary "
                                 "folder, removed)")
    jobs: int = Field(1, ge=1, le=MAX_REPLICATES, description="runs at once outside a "
                      "study (simulate aor --engine lammps --seeds N --jobs J), each on np "
                      "ranks; a study runs [executor] workers at once instead")
