"""``gearrom geometry`` in-process: table, JSON keys, one-line errors."""
from __future__ import annotations

import json

import pytest

from gearrom.cli import main
from gearrom.config import bundled_names


def test_json_has_required_keys(capsys):
    assert main(["geometry", "thesis-helical", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("center_distance_mm", "alpha_t_deg", "alpha_wt_deg", "g_alpha_mm", "pb_t_mm", "eps_alpha", "eps_beta", "eps_gamma"):
        assert key in out
    assert len(out["gears"]) == 2
    g1 = out["gears"][0]
    for key in ("z", "d_mm", "db_mm", "da_mm", "df_mm", "lead_mm", "s_mm"):
        assert key in g1
    assert g1["lead_mm"] == pytest.approx(284.5649, abs=5e-5)  # annex 11.1
    assert out["center_distance_mm"] == pytest.approx(64.50)


def test_spur_lead_is_null(capsys):
    assert main(["geometry", "thesis-spur", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["gears"][0]["lead_mm"] is None
    assert out["eps_alpha"] == pytest.approx(1.852, abs=5e-4)  # seed Table 2


def test_table_output(capsys):
    assert main(["geometry", "thesis-spur"]) == 0
    assert "eps_alpha" in capsys.readouterr().out


def test_bad_input_one_line_error(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[pair]\nnormal_module_mm = 1.5\n")
    assert main(["geometry", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "missing section [input_gear]" in err and "Traceback" not in err


@pytest.mark.parametrize("name", bundled_names())
def test_every_bundled_config_passes_the_geometry_checks(name, capsys):
    """A new user's first command works on every bundled config (feasible geometry, no undercut)."""
    assert main(["geometry", name, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["config"] == name
