"""The examples in the doe docstrings run and print what they say."""

from __future__ import annotations

import doctest
import importlib

import pytest


@pytest.mark.parametrize("module", ["demcal.doe.designs", "demcal.doe.model"])
def test_docstring_examples(module):
    result = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0
    assert result.failed == 0


def test_public_api_is_listed():
    from demcal import doe

    for name in doe.__all__:
        assert hasattr(doe, name), name
    assert {"fit", "box_behnken", "plackett_burman", "optimize_target", "ResponseSurface"} <= set(
        doe.__all__
    )
