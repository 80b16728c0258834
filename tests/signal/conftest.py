"""Fixtures of the signal tests (the synthetic runs with a known TE are built in signal_synth.py)."""
from __future__ import annotations

from pathlib import Path

import pytest

from signal_synth import write_run


@pytest.fixture(scope="session")
def base_run(tmp_path_factory) -> Path:
    """A clean 1250 rpm run, 4000 edges/rev, 42 input revolutions (CSV)."""
    return write_run(tmp_path_factory.mktemp("base") / "run.json", 1250.0, 4000)
