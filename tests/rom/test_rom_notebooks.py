"""The ROM notebooks run top to bottom (code cells executed in order, as a kernel would)."""
import json
from pathlib import Path

import matplotlib
import pytest

NB = Path(__file__).resolve().parents[2] / "notebooks"


def _execute(name):
    matplotlib.use("Agg")
    nb = json.loads((NB / name).read_text())
    ns = {}
    for cell in nb["cells"]:
        if cell["cell_type"] == "code":
            exec(compile("".join(cell["source"]), f"{name}", "exec"), ns)  # noqa: S102 - our own notebook
    return ns


def test_campbell_notebook_runs():
    ns = _execute("campbell.ipynb")
    assert ns["c"].freqs.shape[0] == 25


@pytest.mark.slow
def test_speed_sweep_notebook_runs():
    ns = _execute("speed_sweep.ipynb")
    assert len(ns["res"].summary) == 10
