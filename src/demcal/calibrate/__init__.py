"""Calibration studies: the study file (TOML, pydantic), stages, and the runner."""
