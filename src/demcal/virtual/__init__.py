"""Virtual lab tests on the DEM engine: the cylinder-lifting angle-of-repose test and the
rotating drum (``run_drum``, :mod:`demcal.virtual.drum`).

``run_aor`` runs a batch of tests (one engine world each) and returns :class:`AoRResult`
objects with a typed :class:`Outcome`; ``fidelity_config`` and ``preset_parameters`` give the
quick, standard, large and paper configurations (``FIDELITY_REPLICATES``: their default seeds per
point) and the corn-stalk material.
"""

from demcal.virtual.aor import AoRResult, run_aor
from demcal.virtual.config import FIDELITY_REPLICATES, AoRTestConfig, fidelity_config
from demcal.virtual.drum import DrumResult, run_drum
from demcal.virtual.drum_settings import DrumSettings, drum_settings
from demcal.virtual.outcome import Outcome
from demcal.virtual.parameters import PARAMETERS, check_parameters, parse_assignments
from demcal.virtual.presets import PRESETS, preset_parameters

__all__ = [
    "FIDELITY_REPLICATES",
    "PARAMETERS",
    "PRESETS",
    "AoRResult",
    "AoRTestConfig",
    "DrumResult",
    "DrumSettings",
    "Outcome",
    "check_parameters",
    "drum_settings",
    "fidelity_config",
    "parse_assignments",
    "preset_parameters",
    "run_aor",
    "run_drum",
]
