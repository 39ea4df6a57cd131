"""demcal.dem: the DEM engine (multi-sphere clumps, Hertz-Mindlin + JKR, rolling friction)."""
