"""The public API of demcal.report: listed names exist, docstring examples run."""

from __future__ import annotations

import doctest
import importlib

import pytest

from demcal import report
from demcal.report.tables import format_cell, term_label


def test_public_api_is_listed():
    for name in report.__all__:
        assert hasattr(report, name), name


@pytest.mark.parametrize("module", ["demcal.report.figures"])
def test_docstring_examples(module):
    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted > 0 and result.failed == 0


def test_cell_formats():
    assert format_cell(0.00001, "p") == "<0.0001"
    assert format_cell(0.04321, "p") == "0.0432"
    assert format_cell(160.9234, "SS") == "160.92"
    assert format_cell(float("nan")) == "" and format_cell(None) == ""
    assert format_cell(12) == "12" and format_cell(True) == "yes"
    assert term_label("a.b*c^2", {"a.b": "x3", "c": "x4"}) == "x3·x4²"
    assert term_label("intercept", {}) == "Intercept"
