"""Executors: run virtual tests locally (in process, or a spawn process pool) or on Dask.

- :class:`~demcal.execute.tasks.RunTask` / :func:`~demcal.execute.tasks.run_chunk`: the unit
  of work (picklable) and how any worker runs it;
- :func:`~demcal.execute.local.run_local`: this process or a process pool
  (``NUMBA_NUM_THREADS=1`` per worker);
- :func:`~demcal.execute.dask_exec.run_dask`: a Dask cluster (``distributed.Client``);
- :mod:`demcal.execute.analytic`: the analytic stand-in virtual test (a test double).
- :mod:`demcal.execute.template_engine`: a run of an external DEM code through an input
  template (:mod:`~demcal.execute.engine_spec`: the study's ``[engine]`` table;
  :mod:`~demcal.execute.template_fill`: placeholders; :mod:`~demcal.execute.engine_results`:
  result readers).
"""

from demcal.execute.local import default_workers, run_local
from demcal.execute.tasks import RunTask, TestDef, run_chunk

__all__ = ["RunTask", "TestDef", "default_workers", "run_chunk", "run_local"]
