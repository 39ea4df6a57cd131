"""Virtual lab tests on the DEM engine: the cylinder-lifting angle-of-repose test and the
rotating drum (``run_drum``, :mod:`demcal.virtual.drum`).

``run_aor`` runs a batch of tests (one engine world each) and returns :class:`AoRResult`
objects with a typed :class:`Outcome`; ``fidelity_config`` and ``preset_parameters`` give the
quick, standard, large and paper configurations (``FIDELITY_REPLICATES``: their default seeds per
point) and the corn-stalk material.
"""

# The public names, imported on first use (demcal._lazy): the study schema reads
# `demcal.virtual.config` and must not compile the engine (numba) to do so. The drum's settings
# are `demcal.virtual.drum_settings.drum_settings`: a name that is also a submodule's would read
# as the module once anything imports that submodule.
from demcal._lazy import exports

__getattr__, __dir__, __all__ = exports(__name__, {
    "AoRResult": "aor",
    "run_aor": "aor",
    "FIDELITY_REPLICATES": "config",
    "AoRTestConfig": "config",
    "fidelity_config": "config",
    "DrumResult": "drum",
    "run_drum": "drum",
    "DrumSettings": "drum_settings",
    "Outcome": "outcome",
    "PARAMETERS": "parameters",
    "check_parameters": "parameters",
    "parse_assignments": "parameters",
    "PRESETS": "presets",
    "preset_parameters": "presets",
})
