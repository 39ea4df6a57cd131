"""demcal.dem: the DEM engine (multi-sphere clumps, Hertz-Mindlin + JKR, rolling friction)."""

from demcal.dem._jit_cache import purge_stale_kernels

purge_stale_kernels()
