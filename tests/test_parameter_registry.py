"""One parameter registry (issue 37): every parameter the engine knows stands once, with its
unit and label, and both the virtual test and the bench measurements read that entry."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from demcal import parameters as registry
from demcal.errors import InputError
from demcal.physical import PARAMETERS as PHYSICAL
from demcal.virtual import PARAMETERS as VIRTUAL
from demcal.virtual.presets import PRESETS

SRC = Path(__file__).resolve().parents[1] / "src" / "demcal"
#: a parameter name as the engine's code spells it: who.what
_NAME = re.compile(r"""["'](?:particle|wall|pp|pw)\.([a-z_]+)["']""")


def _engine_names() -> set[str]:
    """Every parameter name the engine's modules (demcal's own and LAMMPS') spell out."""
    names = set()
    for path in (SRC / "virtual").glob("*.py"):
        if path.name == "parameters.py":
            continue
        for m in _NAME.finditer(path.read_text()):
            names.add(m.group(0)[1:-1])
    return names


def test_every_engine_parameter_has_exactly_one_entry_with_unit_and_label() -> None:
    names = _engine_names() | {n for preset in PRESETS.values() for n in preset}
    assert names == set(registry.PARAMETERS)
    for name in names:
        spec = registry.PARAMETERS[name]
        assert spec.name == name and spec.label and spec.description
        assert spec.unit_text and spec.display_unit
        assert spec.low < spec.high
    rows = [p.table_row for p in registry.PARAMETERS.values()]
    assert sorted(rows) == list(range(1, len(rows) + 1))


def test_the_virtual_test_and_the_bench_read_the_same_entries() -> None:
    assert set(VIRTUAL) == set(PHYSICAL) == set(registry.PARAMETERS)
    for name, spec in registry.PARAMETERS.items():
        assert VIRTUAL[name] is spec and PHYSICAL[name] is spec
    # the bench's tables keep the paper's Table 1 order; the engine its own
    assert list(PHYSICAL)[:3] == ["particle.poisson", "particle.shear_modulus",
                                  "particle.density"]
    assert list(VIRTUAL)[:3] == ["particle.poisson", "particle.density",
                                 "particle.shear_modulus"]


def test_no_other_module_describes_a_parameter() -> None:
    """Only the registry builds parameter entries: a second table of units or bounds would
    drift from it."""
    for path in SRC.rglob("*.py"):
        if path == SRC / "parameters.py":
            continue
        text = path.read_text()
        assert not re.search(r"\bParameter(Spec|Info)?\(\s*\"", text), path


def test_the_bounds_read_the_same_on_both_sides() -> None:
    spec = registry.PARAMETERS["particle.poisson"]
    assert spec.bounds_text() == "[0, 0.5)" and not spec.contains(0.5)
    assert spec.clip_bounds() == (0.0, 0.499)
    with pytest.raises(InputError, match=r"particle.poisson must be in \[0, 0.5\); got 0.5"):
        spec.check(0.5)
    density = registry.PARAMETERS["particle.density"]
    assert density.unit_text == "kg/m^3" and density.clip_bounds()[0] > 0.0
    friction = registry.PARAMETERS["pp.static_friction"]
    assert friction.unit == "" and friction.unit_text == "-" and friction.display_unit == "-"
    modulus = registry.PARAMETERS["particle.shear_modulus"]
    assert (modulus.display_unit, modulus.display_scale) == ("MPa", 1e-6)
    assert modulus.label == "Shear modulus of the particle"
