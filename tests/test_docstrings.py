"""The examples in the public docstrings run and print what they say."""
from __future__ import annotations

import doctest

import pytest

import impactgen.compare
import impactgen.engines
import impactgen.results
import impactgen.scene


@pytest.mark.parametrize("module", [impactgen.engines, impactgen.results, impactgen.scene, impactgen.compare])
def test_docstring_examples(module):
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0
