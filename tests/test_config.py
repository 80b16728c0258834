"""TOML configs: bundled examples, extends, unit conversion, and errors that name file and key."""
from __future__ import annotations

import math
import warnings

import pytest

from gearrom.config import bundled_names, load_config
from gearrom.errors import ConfigError, GeometryError

SPUR = """
name = "t"
[pair]
normal_module_mm = 1.5
normal_pressure_angle_deg = 17.0
[input_gear]
teeth = 32
face_width_mm = 18.0
bore_diameter_mm = 35.3
[output_gear]
teeth = 41
face_width_mm = 18.0
bore_diameter_mm = 34.25
"""


def write(tmp_path, text, name="c.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_bundled_examples_exist_and_load():
    names = bundled_names()
    for n in ("thesis-spur", "thesis-helical", "thesis-rig"):
        assert n in names
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cfg = load_config(n)
        assert cfg.name == n
        assert cfg.operating.torque_out == pytest.approx(120.0)


def test_units_converted_to_si(tmp_path):
    cfg = load_config(write(tmp_path, SPUR))
    p = cfg.pair
    assert p.mn == pytest.approx(1.5e-3)
    assert p.alpha_n == pytest.approx(math.radians(17))
    assert p.gears[0].bore_diameter == pytest.approx(35.3e-3)
    assert p.gears[0].material.youngs_modulus == pytest.approx(210e9)


def test_extends_merges_and_overrides(tmp_path):
    write(tmp_path, SPUR, "base.toml")
    child = write(tmp_path, 'extends = "base.toml"\nname = "child"\n[input_gear]\nprofile_shift = 0.1\n'
                  '[output_gear]\nprofile_shift = -0.1\n[operating]\ntorque_out_Nm = 60\n', "child.toml")
    cfg = load_config(child)
    assert cfg.name == "child"
    assert cfg.pair.gears[0].x == pytest.approx(0.1) and cfg.pair.gears[0].z == 32
    assert cfg.operating.torque_out == pytest.approx(60.0)


def test_unknown_key_names_file_and_key(tmp_path):
    p = write(tmp_path, SPUR.replace("normal_module_mm", "normal_modul_mm"))
    with pytest.raises(ConfigError, match=r"c.toml: unknown key 'pair.normal_modul_mm' \(did you mean 'normal_module_mm'\?\)"):
        load_config(p)


def test_unknown_section(tmp_path):
    with pytest.raises(ConfigError, match=r"unknown key or section 'gearz'"):
        load_config(write(tmp_path, SPUR + "[gearz]\na = 1\n"))


def test_wrong_type_and_sign(tmp_path):
    with pytest.raises(ConfigError, match=r"input_gear.teeth must be an integer, got '32'"):
        load_config(write(tmp_path, SPUR.replace("teeth = 32", 'teeth = "32"')))
    with pytest.raises(ConfigError, match=r"input_gear.face_width_mm must be a positive"):
        load_config(write(tmp_path, SPUR.replace("face_width_mm = 18.0\nbore_diameter_mm = 35.3", "face_width_mm = -18.0\nbore_diameter_mm = 35.3")))
    with pytest.raises(ConfigError, match=r"operating.torque_out_Nm must be positive"):
        load_config(write(tmp_path, SPUR + "[operating]\ntorque_out_Nm = 0\n"))


def test_missing_key_and_bad_toml(tmp_path):
    with pytest.raises(ConfigError, match=r"missing key 'input_gear.face_width_mm'"):
        load_config(write(tmp_path, SPUR.replace("face_width_mm = 18.0\nbore_diameter_mm = 35.3\n", "bore_diameter_mm = 35.3\n")))
    with pytest.raises(ConfigError, match=r"c.toml: invalid TOML: .*line"):
        load_config(write(tmp_path, SPUR + "[pair\n"))


def test_unknown_name_lists_bundled():
    with pytest.raises(ConfigError, match=r"'no-such' is neither a file nor a bundled example \(bundled: .*thesis-spur"):
        load_config("no-such")


def test_geometry_errors_name_the_file(tmp_path):
    p = write(tmp_path, SPUR.replace("teeth = 32", "teeth = 32\nprofile_shift = -0.5"))
    with pytest.raises(GeometryError, match=r"c.toml: input_gear: undercut"):
        load_config(p)


def test_digest_changes_with_content(tmp_path):
    a = load_config(write(tmp_path, SPUR, "a.toml"))
    b = load_config(write(tmp_path, SPUR.replace("18.0", "18.5", 1), "b.toml"))
    assert a.digest() != b.digest()
    assert a.digest() == load_config(tmp_path / "a.toml").digest()


def test_helical_micro_geometry_recorded_but_off(helical):
    g1, g2 = helical.pair.gears
    assert not g1.micro.enabled and not g2.micro.enabled
    assert g1.micro.tip_relief == pytest.approx(8e-6)
    assert g2.micro.tip_relief == pytest.approx(15e-6)
    assert g2.micro.tip_relief_start_diameter == pytest.approx(74.29e-3)


def test_docs_list_every_key():
    """docs/config.md documents every config key with its unit (the spec tables are the source)."""
    from pathlib import Path

    from gearrom import config as c

    doc = (Path(__file__).resolve().parents[1] / "docs" / "config.md").read_text()
    for spec in (c.TOP_KEYS, c.PAIR_KEYS, c.MATERIAL_KEYS, c.GEAR_KEYS, c.TOOL_KEYS, c.MICRO_KEYS, c.OPERATING_KEYS):
        for key in spec:
            assert f"{key}`" in doc, key
