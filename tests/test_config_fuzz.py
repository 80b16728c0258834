"""Property-based test of the config loader through the command line.

Every key documented in docs/config.md (the tables are parsed, so a newly documented key is fuzzed
without touching this file) and every documented section gets values of the wrong type, sign,
unit and shape. ``gearrom geometry FILE`` must then exit 0 (the value happens to be valid) or 2
with one error line on stderr that names the key, and never show a traceback.
"""
from __future__ import annotations

import contextlib
import datetime
import io
import json
import math
import re
import tempfile
import warnings
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gearrom import config as cfgmod
from gearrom.cli import main

DOC = Path(__file__).resolve().parents[1] / "docs" / "config.md"
GEARS = ("input_gear", "output_gear")


def documented_keys() -> list[tuple[str, str]]:
    """``(dotted key, type)`` of every row of the key tables in docs/config.md."""
    rows = re.findall(r"^\|\s*`([A-Za-z0-9_.]+)`\s*\|\s*(\w+)\s*\|", DOC.read_text(), flags=re.M)
    return [(key, typ) for key, typ in rows if typ in ("str", "int", "float", "bool", "list")]


def documented_sections() -> list[str]:
    """Section names written as ``[name]`` in docs/config.md (top-level ones only)."""
    names = set(re.findall(r"`\[([A-Za-z_]+)\]`", DOC.read_text()))
    return sorted(names)


KEYS = documented_keys()
SECTIONS = documented_sections()


def test_docs_tables_are_found():
    keys = dict(KEYS)
    assert len(KEYS) >= 30
    assert {"extends", "pair.normal_module_mm", "input_gear.teeth", "operating.rpm_in"} <= set(keys)
    assert {"pair", "material", "input_gear", "output_gear", "operating", "rig", "rom", "sweep"} <= set(SECTIONS)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return '"' + "".join(f"\\u{ord(c):04x}" if ord(c) < 0x20 or ord(c) == 0x7F or c in '"\\' else c
                             for c in v) + '"'
    if isinstance(v, (datetime.date, datetime.datetime)):
        return v.isoformat()
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def dumps(data: dict[str, Any], prefix: str = "") -> str:
    """Minimal TOML writer: scalars and inline values first, then sub-tables as ``[a.b]`` headers."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    out = "\n".join(lines) + "\n"
    for k, v in data.items():
        if isinstance(v, dict):
            name = f"{prefix}{k}"
            out += f"\n[{name}]\n" + dumps(v, name + ".")
    return out


BASE, _ = cfgmod.resolve("thesis-helical")

scalars = st.one_of(
    st.text(max_size=12),
    st.sampled_from(["x" * 300, "a/" * 200, ".", "..", "~", "thesis-spur", "analytical", "thesis-spur.toml",
                    "18 mm", "1.5mm", "210 GPa", "0x10", "1_000"]),
    st.booleans(),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1, 0.0, -0.0, 1e-300, 1e300, -1e300, 2**62]),
    st.dates(),
)
bad_values = st.one_of(
    scalars,
    st.lists(scalars, max_size=4),
    st.lists(st.lists(st.integers(-5, 5), max_size=2), max_size=2),
    st.dictionaries(st.sampled_from(["a", "value", "mm"]), scalars, max_size=2),
)
unit_factors = st.sampled_from([1e3, 1e-3, 1e6, 1e-6, 1e9, 1e-9, -1.0, 0.0, 25.4, 1 / 25.4, 180 / math.pi])


def _get(data: dict, path: list[str]) -> Any:
    for p in path:
        if not isinstance(data, dict) or p not in data:
            return None
        data = data[p]
    return data


def _set(data: dict, path: list[str], value: Any) -> None:
    for p in path[:-1]:
        data = data.setdefault(p, {})
    data[path[-1]] = value


@st.composite
def mutation(draw):
    """``(path, value, kind)``: a documented key (or section) and a value that is probably wrong."""
    if draw(st.integers(0, 9)) == 0:
        section = draw(st.sampled_from(SECTIONS))
        return [section], draw(scalars | st.lists(scalars, max_size=3)), "section"
    key, typ = draw(st.sampled_from(KEYS))
    path = key.split(".")
    if path[0] in GEARS:
        path[0] = draw(st.sampled_from(GEARS))
    current = _get(BASE, path)
    how = draw(st.sampled_from(["bad", "unit", "list"]))
    if how == "unit" and isinstance(current, (int, float)) and not isinstance(current, bool):
        value = current * draw(unit_factors)
        if typ == "int":
            value = int(value) if draw(st.booleans()) and math.isfinite(value) and abs(value) < 2**62 else value
    elif how == "list" and isinstance(current, list) and current:
        value = [x * draw(unit_factors) for x in current] + draw(st.lists(bad_values, max_size=2))
    else:
        value = draw(bad_values)
    return path, value, "key"


def _run(text: str) -> tuple[int, str]:
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "fuzz.toml"
        p.write_text(text)
        err, out = io.StringIO(), io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rc = main(["geometry", str(p)])
    return rc, err.getvalue()


@settings(max_examples=90, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutation())
def test_wrong_values_give_one_line_error_naming_the_key(mut):
    path, value, kind = mut
    data = json.loads(json.dumps(BASE, default=str))  # deep copy of plain TOML data
    if kind == "section":
        data[path[0]] = value
    else:
        _set(data, path, value)
    rc, err = _run(dumps(data))
    assert "Traceback" not in err
    assert rc in (0, 2), err
    if rc == 0:
        return
    lines = [ln for ln in err.splitlines() if ln.startswith("gearrom geometry: error:")]
    assert len(lines) == 1, err
    assert len(err.strip().splitlines()) == 1, err
    line = lines[0]
    name = path[-1]
    if kind == "section":
        assert f"[{name}]" in line, line
        return
    # A value of the right type inside the documented range may still make the pair infeasible;
    # the feasibility checks then name the geometric quantity at fault, not necessarily this key.
    if _plausible(name, value):
        return
    assert name in line, line


def _plausible(key: str, value: Any) -> bool:
    """True when ``value`` has the key's type and lies in its allowed range (or has no range)."""
    spec = {}
    for table in (cfgmod.TOP_KEYS, cfgmod.PAIR_KEYS, cfgmod.MATERIAL_KEYS, cfgmod.GEAR_KEYS, cfgmod.TOOL_KEYS,
                  cfgmod.MICRO_KEYS, cfgmod.OPERATING_KEYS):
        spec.update(table)
    typ = spec[key][0]
    limit = cfgmod.LIMITS.get(key)
    if typ is str:
        return isinstance(value, str) and value in cfgmod.CHOICES.get(key, (value,))
    if typ is bool:
        return isinstance(value, bool)
    nums = value if typ is list else [value]
    if typ is list and not isinstance(value, list):
        return False
    for v in nums:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return False
        if typ is int and not isinstance(v, int):
            return False
        if limit is not None and not limit.contains(v):
            return False
    return True


@pytest.mark.parametrize("key", [k for k, _ in KEYS])
def test_every_documented_key_is_known_to_the_loader(key):
    path = key.split(".")
    spec = {(): cfgmod.TOP_KEYS, ("pair",): cfgmod.PAIR_KEYS, ("material",): cfgmod.MATERIAL_KEYS,
            ("input_gear",): cfgmod.GEAR_KEYS, ("input_gear", "tool"): cfgmod.TOOL_KEYS,
            ("input_gear", "microgeometry"): cfgmod.MICRO_KEYS, ("operating",): cfgmod.OPERATING_KEYS}
    assert path[-1] in spec[tuple(path[:-1])]
