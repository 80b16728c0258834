"""Relative paths in configs: ``extends`` and path-valued keys resolve against the file that holds
them, never against the current directory; bundled names are not shadowed by directories."""
from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from gearrom.config import _bundled_path, load_config, resolve
from gearrom.errors import ConfigError

SPUR = """
name = "base"
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


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def test_extends_does_not_fall_back_to_the_cwd(tmp_path, monkeypatch):
    (tmp_path / "cwd").mkdir()
    (tmp_path / "cfg").mkdir()
    (tmp_path / "cwd" / "base.toml").write_text(SPUR)
    child = tmp_path / "cfg" / "child.toml"
    child.write_text('extends = "base.toml"\n')
    monkeypatch.chdir(tmp_path / "cwd")
    with pytest.raises(ConfigError) as info:
        load_config(child)
    msg = str(info.value)
    assert msg.startswith(f"{child}: extends = 'base.toml': base config {tmp_path / 'cfg' / 'base.toml'} does not exist")


def test_extends_resolves_against_the_referring_file_from_any_cwd(tmp_path, monkeypatch):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "b" / "base.toml").write_text(SPUR)
    (tmp_path / "b" / "mid.toml").write_text('extends = "base.toml"\n[input_gear]\nprofile_shift = 0.1\n'
                                             '[output_gear]\nprofile_shift = -0.1\n')
    child = tmp_path / "a" / "child.toml"
    child.write_text('extends = "../b/mid.toml"\nname = "child"\n')
    # a decoy next to the cwd must not be picked up
    (tmp_path / "elsewhere" / "base.toml").write_text(SPUR.replace("teeth = 32", "teeth = 30"))
    monkeypatch.chdir(tmp_path / "elsewhere")
    cfg = load_config(child)
    assert cfg.pair.gears[0].z == 32 and cfg.pair.gears[0].x == pytest.approx(0.1)


def test_bare_extends_name_prefers_a_file_next_to_the_config_then_bundled(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "thesis-spur").mkdir()  # a directory never matches
    child = tmp_path / "child.toml"
    child.write_text('extends = "thesis-spur"\nname = "c"\n')
    assert load_config(child).pair.gears[0].z == 32
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "mybase").write_text(SPUR.replace("teeth = 32", "teeth = 30"))
    (tmp_path / "sub" / "child.toml").write_text('extends = "mybase"\n')
    assert load_config(tmp_path / "sub" / "child.toml").pair.gears[0].z == 30


def test_directory_in_cwd_does_not_shadow_a_bundled_config(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "thesis-rig").mkdir()
    cfg = load_config("thesis-rig")
    assert cfg.source == _bundled_path("thesis-rig").resolve()
    assert cfg.name == "thesis-rig"


def test_existing_file_with_a_bare_name_is_used(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "thesis-spur").write_text(SPUR.replace("teeth = 32", "teeth = 30"))
    assert load_config("thesis-spur").pair.gears[0].z == 30


def test_directory_given_as_path_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mydir").mkdir()
    with pytest.raises(ConfigError, match=r"mydir is a directory, not a config file"):
        load_config("mydir")
    with pytest.raises(ConfigError, match=r"is a directory, not a config file"):
        load_config("./mydir")


def test_missing_bundled_style_base_names_the_referring_file(tmp_path):
    child = tmp_path / "child.toml"
    child.write_text('extends = "thesis-nope"\n')
    with pytest.raises(ConfigError) as info:
        load_config(child)
    msg = str(info.value)
    assert msg.startswith(f"{child}: extends = 'thesis-nope': ")
    assert "no bundled config" in msg and "thesis-spur" in msg


def test_empty_extends_is_an_error(tmp_path):
    child = tmp_path / "child.toml"
    child.write_text('extends = ""\n')
    with pytest.raises(ConfigError, match=rf"{child.name}: extends is empty"):
        load_config(child)


def test_extends_cycle(tmp_path):
    (tmp_path / "a.toml").write_text('extends = "b.toml"\n')
    (tmp_path / "b.toml").write_text('extends = "a.toml"\n')
    with pytest.raises(ConfigError, match=r"'extends' forms a cycle"):
        load_config(tmp_path / "a.toml")


def test_path_valued_key_resolves_against_the_file_that_holds_it(tmp_path, monkeypatch):
    (tmp_path / "base").mkdir()
    (tmp_path / "proj").mkdir()
    (tmp_path / "base" / "base.toml").write_text(SPUR + '[rom]\nexcitation = "tables/k.nc"\n')
    child = tmp_path / "proj" / "child.toml"
    child.write_text('extends = "../base/base.toml"\n')
    monkeypatch.chdir(tmp_path / "proj")
    cfg = load_config(child)
    assert Path(cfg.section("rom")["excitation"]) == tmp_path / "base" / "tables" / "k.nc"
    # the child's own value is anchored to the child
    child.write_text('extends = "../base/base.toml"\n[rom]\nexcitation = "mine.nc"\n')
    assert Path(load_config(child).section("rom")["excitation"]) == tmp_path / "proj" / "mine.nc"


def test_path_valued_key_keywords_and_absolute_paths_are_kept(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text(SPUR + '[rom]\nexcitation = "analytical"\n')
    assert load_config(p).section("rom")["excitation"] == "analytical"
    p.write_text(SPUR + f'[rom]\nexcitation = "{tmp_path / "abs.nc"}"\n')
    assert load_config(p).section("rom")["excitation"] == str(tmp_path / "abs.nc")


def test_resolve_returns_absolute_source(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("c.toml").write_text(SPUR)
    _, path = resolve("c.toml")
    assert path == tmp_path / "c.toml" and path.is_absolute()


def test_cli_empty_name_exits_2_with_one_line(capsys):
    from gearrom.cli import main

    assert main(["geometry", ""]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("gearrom geometry: error: config name is empty")


def test_path_valued_key_with_home_is_expanded(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    p = tmp_path / "c.toml"
    p.write_text(SPUR + '[rom]\nexcitation = "~/tables/k.nc"\n')
    assert Path(load_config(p).section("rom")["excitation"]) == tmp_path / "home" / "tables" / "k.nc"
