"""Every study file the examples ship loads as written (a renamed or removed option breaks
here, not in a user's first run), and the two-fidelity LAMMPS study reads as its header says."""

from __future__ import annotations

from pathlib import Path

import pytest

from demcal.calibrate.study import load_study

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
STUDIES = sorted(EXAMPLES.glob("*/study*.toml"))


def test_the_examples_have_studies():
    assert len(STUDIES) >= 10


@pytest.mark.parametrize("path", STUDIES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_an_example_study_loads(path):
    study = load_study(path)
    assert study.factors, "a study calibrates at least one factor"


def test_the_lammps_standard_study_fits_its_surface_on_the_small_test():
    study = load_study(EXAMPLES / "corn_stalk" / "study_lammps_low_cohesion_standard.toml")
    small = load_study(EXAMPLES / "corn_stalk" / "study_lammps_low_cohesion.toml")
    assert study.test.fidelity == "standard"
    assert study.stage_fidelities() == {"rangefind": "small", "rsm": "small"}
    assert study.executor.engine == "lammps"
    # the small study's runs are reused: same seed, factors and replicates
    assert (study.seed, study.replicates) == (small.seed, small.replicates)
    assert [f.model_dump() for f in study.factors] == [f.model_dump() for f in small.factors]
