"""The examples in the public docstrings run and print what they say."""
from __future__ import annotations

import doctest

import pytest

import impactgen.compare
import impactgen.engines
import impactgen.paper
import impactgen.results
import impactgen.scene
import impactgen.scene.loading
import impactgen.scene.model


@pytest.mark.parametrize("module", [impactgen.engines, impactgen.results, impactgen.scene,
                                    impactgen.scene.loading, impactgen.scene.model, impactgen.compare,
                                    impactgen.paper])
def test_docstring_examples(module):
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0
