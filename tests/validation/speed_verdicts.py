"""Shared pieces of the ROM-vs-FE verdict tests: one parameter per speed, a strict xfail where the
committed reference misses a tolerance (the reason states the measured miss), and the check itself."""
from __future__ import annotations

import pytest


def speed_params(rpms, misses: dict[int, str]) -> list:
    """``pytest.param`` per speed; a strict xfail with the measured miss where ``misses`` names one."""
    return [pytest.param(r, marks=[pytest.mark.xfail(strict=True, reason=misses[r])] if r in misses else [])
            for r in rpms]


def assert_speed_passes(report, rpm: int, what: str = "reference") -> None:
    """The report's comparison at ``rpm`` is within the validation tolerances (skip: no committed ``what`` there)."""
    speeds = {int(s.rpm_in): s for s in report.speeds}
    if rpm not in speeds:
        pytest.skip(f"no committed {what} at {rpm} rpm")
    assert speeds[rpm].passed, "; ".join(speeds[rpm].misses)
