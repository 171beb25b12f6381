"""The runnable examples in the lfd.dmp docstrings stay correct."""

import doctest

import pytest

import lfd.dmp
import lfd.dmp.functional
import lfd.dmp.layer


@pytest.mark.parametrize("module", [lfd.dmp, lfd.dmp.functional, lfd.dmp.layer], ids=lambda m: m.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module, raise_on_error=False, verbose=False)
    assert result.attempted > 0 and result.failed == 0
