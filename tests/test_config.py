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
    with pytest.raises(ConfigError, match=r"input_gear.face_width_mm = -18 mm is out of range: it must be in \(0, "):
        load_config(write(tmp_path, SPUR.replace("face_width_mm = 18.0\nbore_diameter_mm = 35.3", "face_width_mm = -18.0\nbore_diameter_mm = 35.3")))
    with pytest.raises(ConfigError, match=r"operating.torque_out_Nm = 0 N m is out of range: it must be > 0 N m"):
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


@pytest.mark.parametrize("line, shown", [
    ("pair = 1.5", "[pair] must be a table, got 1.5"),
    ("material = 5", "[material] must be a table, got 5"),
    ("operating = 2", "[operating] must be a table, got 2"),
    ("rig = 3", "[rig] must be a table, got 3"),
    ("rom = [1, 2]", "[rom] must be a table, got [1, 2]"),
    ("fe = 3", "[fe] must be a table, got 3"),
    ('sweep = "fast"', "[sweep] must be a table, got 'fast'"),
    ("signal = 1", "[signal] must be a table, got 1"),
    ("calibrate = true", "[calibrate] must be a table, got True"),
    ('input_gear = "big"', "[input_gear] must be a table, got 'big'"),
])
def test_section_written_as_plain_value_names_file_and_section(tmp_path, line, shown):
    p = write(tmp_path, f'extends = "thesis-spur"\n{line}\n')
    with pytest.raises(ConfigError) as info:
        load_config(p)
    assert str(info.value) == f"{p}: {shown}"


@pytest.mark.parametrize("sub", ["tool", "microgeometry", "material"])
def test_gear_subsection_written_as_plain_value(tmp_path, sub):
    p = write(tmp_path, f'extends = "thesis-spur"\n[output_gear]\n{sub} = 4\n')
    with pytest.raises(ConfigError, match=rf"c.toml: \[output_gear.{sub}\] must be a table, got 4"):
        load_config(p)


@pytest.mark.parametrize("teeth", ["1", "3", "4", "1001", "100000", "32.5", "-32"])
def test_absurd_tooth_counts_rejected_at_load_with_range(tmp_path, teeth):
    p = write(tmp_path, SPUR.replace("teeth = 41", f"teeth = {teeth}"))
    with pytest.raises(ConfigError, match=r"c.toml: output_gear.teeth") as info:
        load_config(p, check=False)
    msg = str(info.value)
    assert "must be an integer" in msg or ("[5, 1000]" in msg and "teeth" in msg.split("(")[-1])


def test_values_reported_in_the_unit_of_the_key(tmp_path):
    p = write(tmp_path, SPUR + "[material]\nyoungs_modulus_GPa = -210\n")
    with pytest.raises(ConfigError, match=r"material.youngs_modulus_GPa = -210 GPa is out of range") as info:
        load_config(p)
    assert "e+11" not in str(info.value) and "210000000000" not in str(info.value)
    p = write(tmp_path, SPUR.replace("bore_diameter_mm = 34.25", "bore_diameter_mm = 34.25\n[output_gear.microgeometry]\n"
                                     "tip_relief_um = -8"))
    with pytest.raises(ConfigError, match=r"output_gear.microgeometry.tip_relief_um = -8 um is out of range"):
        load_config(p)


def test_dataclass_messages_use_the_key_unit():
    from gearrom.geometry.gear import Gear, Material

    with pytest.raises(ConfigError, match=r"input_gear.face_width_mm must be a positive finite number, got -18 mm"):
        Gear("input_gear", 20, face_width=-0.018, bore_diameter=0.01)
    with pytest.raises(ConfigError, match=r"material.youngs_modulus_GPa must be positive, got -210$"):
        Material(youngs_modulus=-210e9)


@pytest.mark.parametrize("text, pattern", [
    ('name = 5', r"name must be a string, got 5"),
    ('description = ["a"]', r"description must be a string"),
    ('[input_gear]\nhand = "up"', r"input_gear.hand must be one of 'right', 'left', 'spur', got 'up'"),
    ('[input_gear.microgeometry]\npitch_deviations_um = [1.0, nan]', r"pitch_deviations_um must be a list of finite"),
    ('[pair]\nnormal_pressure_angle_deg = 90', r"pair.normal_pressure_angle_deg = 90 deg is out of range: it must be in \(0, 45\) deg"),
])
def test_type_and_range_errors_name_the_key(tmp_path, text, pattern):
    with pytest.raises(ConfigError, match=pattern):
        load_config(write(tmp_path, f'extends = "thesis-spur"\n{text}\n'))


@pytest.mark.parametrize("name", ["", "   "])
def test_empty_config_name_is_an_error(name):
    with pytest.raises(ConfigError, match=r"config name is empty: give a bundled name \(.*thesis-spur"):
        load_config(name)


def test_non_utf8_file_is_a_config_error(tmp_path):
    p = tmp_path / "c.toml"
    p.write_bytes(b'name = "\xff\xfe"\n')
    with pytest.raises(ConfigError, match=r"c.toml: invalid TOML: not UTF-8 text"):
        load_config(p)


def test_unusable_path_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match=r"not a usable path"):
        load_config("x" * 300)
    p = tmp_path / "c.toml"
    p.write_text('extends = "' + "y" * 300 + '"\n')
    with pytest.raises(ConfigError, match=r"c.toml: extends = 'yyy.*not a usable path"):
        load_config(p)


def test_docs_list_every_range():
    """docs/config.md shows the range of every range-checked key as the loader checks it."""
    from pathlib import Path

    from gearrom import config as c

    doc = (Path(__file__).resolve().parents[1] / "docs" / "config.md").read_text()
    for key, limit in c.LIMITS.items():
        unit = c.unit_of(key)
        assert f"| `{key}` | {limit.describe()}{' ' + unit if unit else ''} |" in doc, key
