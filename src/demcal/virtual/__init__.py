"""Virtual lab tests on the DEM engine (the cylinder-lifting angle-of-repose test)."""
