"""The marker of a test that runs CalculiX."""

import shutil

import pytest

_without_ccx = pytest.mark.skipif(shutil.which("ccx") is None,
                                  reason="ccx (CalculiX) is not installed: apt-get install calculix-ccx")


def needs_ccx(test):
    """A test that runs CalculiX: marked ``ccx`` (``make check`` runs it, ``make test`` not), skipped without ccx."""
    return pytest.mark.ccx(_without_ccx(test))
