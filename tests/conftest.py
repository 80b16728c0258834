"""Shared fixtures."""
from __future__ import annotations

import warnings

import pytest

from gearrom.config import load_config


@pytest.fixture(scope="session")
def spur():
    return load_config("thesis-spur")


@pytest.fixture(scope="session")
def helical():
    # the nominal drawing data is marginal (tip chamfer not modelled): it warns, see docs/config.md
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-helical")
