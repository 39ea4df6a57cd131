"""The examples in demcal.measure's docstrings run and give what they say."""

from __future__ import annotations

import doctest

import pytest

from demcal.measure import photo, pile


@pytest.mark.parametrize("module", [photo, pile], ids=lambda m: m.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
