"""Every public function of gearrom.signal documents every parameter (numpydoc), as python-control checks."""
from __future__ import annotations

import inspect

import pytest

import gearrom.signal as S


@pytest.mark.parametrize("name", S.__all__)
def test_public_api_documented(name):
    obj = getattr(S, name)
    doc = inspect.getdoc(obj) or ""
    assert doc.strip(), f"{name} has no docstring"
    if inspect.isfunction(obj):
        missing = [p for p in inspect.signature(obj).parameters if p not in doc]
        assert not missing, f"{name}: undocumented parameter(s) {missing}"
