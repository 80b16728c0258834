"""TOML configuration: gear pair, operating point, and the sections of later stages.

A config is a TOML file whose keys carry their unit (``normal_module_mm``, ``torque_out_Nm``).
Values are converted to SI here and nowhere else. ``extends = "thesis-helical"`` (a bundled
name or a path relative to the file that holds it) merges another config underneath. Unknown
keys, sections that are not tables, wrong types and values out of range raise
:class:`gearrom.errors.ConfigError` naming the file and the key, with the value in the key's
own unit.

Relative paths never depend on the current directory: ``extends`` and path-valued keys
(:data:`PATH_KEYS`) resolve against the directory of the file that contains them. A bare name
without path separator and ``.toml`` suffix means the bundled config of that name unless a
file (not a directory) of that name exists.

The sections ``rig``, ``rom``, ``fe``, ``sweep``, ``signal`` and ``calibrate`` are kept as
plain dictionaries for the stage that owns them to validate (``GearConfig.section``).
"""
from __future__ import annotations

import copy
import difflib
import hashlib
import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from gearrom.errors import ConfigError
from gearrom.geometry.gear import MAX_TEETH, MIN_TEETH, Gear, MicroGeometry, Material, RackTool
from gearrom.geometry.pair import GearPair

MM, UM, DEG = 1e-3, 1e-6, math.pi / 180.0

# key -> (python type, factor to SI, description with unit). ``None`` factor: not a number.
PAIR_KEYS: dict[str, tuple[type, float | None, str]] = {
    "normal_module_mm": (float, MM, "normal module m_n [mm]"),
    "normal_pressure_angle_deg": (float, DEG, "normal pressure angle alpha_n [deg]"),
    "helix_angle_deg": (float, DEG, "helix angle beta [deg], 0 for spur (default 0)"),
    "center_distance_mm": (float, MM, "working centre distance a_w [mm] (optional; checked against x1 + x2)"),
    "center_distance_tolerance_um": (float, UM, "allowed a_w mismatch [um] (default 10)"),
    "min_tip_thickness_factor": (float, 1.0, "minimum normal tip thickness / m_n [-] (default 0.2)"),
}
MATERIAL_KEYS = {
    "youngs_modulus_GPa": (float, 1e9, "Young's modulus [GPa] (default 210)"),
    "poisson_ratio": (float, 1.0, "Poisson's ratio [-] (default 0.3)"),
    "density_kg_per_m3": (float, 1.0, "density [kg/m^3] (default 7850)"),
}
GEAR_KEYS = {
    "teeth": (int, None, "number of teeth z [-]"),
    "profile_shift": (float, 1.0, "profile shift coefficient x [-] (default 0)"),
    "hand": (str, None, "'right', 'left' or 'spur' (default 'spur')"),
    "face_width_mm": (float, MM, "face width b [mm]"),
    "bore_diameter_mm": (float, MM, "bore diameter [mm]"),
    "addendum_coefficient": (float, 1.0, "h_a* [-] (default 1.0)"),
    "dedendum_coefficient": (float, 1.0, "h_f* [-] (default 1.25)"),
    "tip_diameter_mm": (float, MM, "explicit tip diameter d_a [mm] (drawing; overrides h_a*)"),
    "root_diameter_mm": (float, MM, "explicit root diameter d_f [mm] (drawing; overrides h_f*)"),
    "root_form_diameter_mm": (float, MM, "root form diameter d_Ff [mm] (drawing; else from the tool)"),
    "tip_edge_radius_mm": (float, MM, "tip edge rounding radius [mm] (default 0: sharp)"),
}
TOOL_KEYS = {
    "addendum_mm": (float, MM, "tool addendum h_aP0 [mm] (else from d_f or h_f*)"),
    "tip_radius_mm": (float, MM, "tool tip radius rho_aP0 [mm] (default 0.38 m_n)"),
    "protuberance_mm": (float, MM, "protuberance pr_P0 [mm] (default 0)"),
    "protuberance_angle_deg": (float, DEG, "protuberance flank angle [deg] (default 10)"),
}
MICRO_KEYS = {
    "enabled": (bool, None, "apply the micro-geometry (default false)"),
    "tip_relief_um": (float, UM, "tip relief C_a [um]"),
    "tip_relief_start_diameter_mm": (float, MM, "tip relief start diameter d_Ca [mm]"),
    "profile_crowning_um": (float, UM, "profile crowning C_H [um]"),
    "lead_crowning_um": (float, UM, "lead crowning C_b [um]"),
    "helix_slope_um": (float, UM, "helix slope deviation f_Hbeta over the face width [um]"),
    "profile_slope_um": (float, UM, "profile slope deviation f_Halpha [um]"),
    "pitch_deviations_um": (list, UM, "single pitch deviation of each tooth [um] (list of z values)"),
    "runout_um": (float, UM, "radial runout F_r [um] (= 2 x eccentricity)"),
    "runout_phase_deg": (float, DEG, "angle of the largest radius from tooth 0 [deg]"),
    "tip_form_diameter_mm": (float, MM, "tip form diameter d_Na where a tip chamfer starts [mm]"),
}
OPERATING_KEYS = {
    "torque_out_Nm": (float, 1.0, "load torque on the output shaft [N m]"),
    "rpm_in": (float, 1.0, "input speed [rpm]"),
}
TOP_KEYS = {"name": (str, None, "config name"), "description": (str, None, "free text"),
            "extends": (str, None, "bundled name or relative path of a base config")}
STAGE_SECTIONS = ("rig", "rom", "fe", "sweep", "signal", "calibrate", "validation")
GEAR_SECTIONS = ("input_gear", "output_gear")
GEAR_SUBSECTIONS = ("tool", "microgeometry", "material")

#: (section, key) -> values that are keywords, not paths. Any other string value of such a key is
#: a path; a relative one is made absolute against the directory of the file that holds it.
PATH_KEYS: dict[tuple[str, str], tuple[str, ...]] = {("rom", "excitation"): ("analytical", "fe")}

#: Unit shown in messages, from the key's suffix (values are reported as written in the file).
UNIT_SUFFIXES = (("_kg_per_m3", "kg/m^3"), ("_mm", "mm"), ("_um", "um"), ("_deg", "deg"), ("_GPa", "GPa"),
                 ("_Nm", "N m"))


@dataclass(frozen=True)
class Limit:
    """Allowed range of a numeric key, in the key's own unit (as written in the file).

    Parameters
    ----------
    lo, hi : float or None
        Bounds; ``None`` means unbounded on that side.
    lo_closed, hi_closed : bool
        Whether the bound itself is allowed.
    why : str
        Reason for the range, appended to the error message.
    """

    lo: float | None = None
    hi: float | None = None
    lo_closed: bool = False
    hi_closed: bool = True
    why: str = ""

    def contains(self, value: float) -> bool:
        """True when ``value`` lies in the range."""
        if self.lo is not None and not (value >= self.lo if self.lo_closed else value > self.lo):
            return False
        return self.hi is None or (value <= self.hi if self.hi_closed else value < self.hi)

    def describe(self) -> str:
        """The range as text, e.g. ``"in (0, 45)"`` or ``"> 0"``."""
        lo, hi = _num_text(self.lo), _num_text(self.hi)
        if self.hi is None:
            return f"{'>=' if self.lo_closed else '>'} {lo}"
        if self.lo is None:
            return f"{'<=' if self.hi_closed else '<'} {hi}"
        return f"in {'[' if self.lo_closed else '('}{lo}, {hi}{']' if self.hi_closed else ')'}"


_SIZE = Limit(0.0, 1e4, why="a size; more than 10 m is a unit mistake")
_MODIFICATION = Limit(0.0, 1e4, lo_closed=True, why="a flank modification or error; more than 10 mm is a unit mistake")
_DEVIATION = Limit(-1e4, 1e4, lo_closed=True, why="more than 10 mm is a unit mistake")
#: key -> allowed range, in the key's unit. Keys of the same name share the range in every section.
LIMITS: dict[str, Limit] = {
    "normal_module_mm": Limit(0.0, 100.0, why="a module above 100 mm is a unit mistake (ISO 54 ends at 50 mm)"),
    "normal_pressure_angle_deg": Limit(0.0, 45.0, hi_closed=False, why="involute basic rack"),
    "helix_angle_deg": Limit(0.0, 60.0, lo_closed=True, hi_closed=False,
                             why="its direction is given by 'hand'"),
    "center_distance_mm": _SIZE,
    "center_distance_tolerance_um": _MODIFICATION,
    "min_tip_thickness_factor": Limit(0.0, 1.0, lo_closed=True, why="a fraction of the module"),
    "youngs_modulus_GPa": Limit(0.0, 2000.0, why="stiffer than any engineering material above 2000 GPa"),
    "poisson_ratio": Limit(-1.0, 0.5, hi_closed=False, why="stable isotropic elastic material"),
    "density_kg_per_m3": Limit(0.0, 1e5, why="denser than any material above 1e5 kg/m^3"),
    "teeth": Limit(MIN_TEETH, MAX_TEETH, lo_closed=True,
                   why=f"fewer than {MIN_TEETH} teeth are outside involute gear practice; more than "
                       f"{MAX_TEETH} is beyond any cylindrical gear, and the models sample every mesh period, "
                       "so their cost grows with the tooth count"),
    "profile_shift": Limit(-1.5, 2.0, hi_closed=False, why="beyond it the tooth is undercut away or pointed"),
    "face_width_mm": _SIZE, "bore_diameter_mm": _SIZE, "tip_diameter_mm": _SIZE, "root_diameter_mm": _SIZE,
    "root_form_diameter_mm": _SIZE,
    "addendum_coefficient": Limit(0.0, 5.0, why="a multiple of the module"),
    "dedendum_coefficient": Limit(0.0, 5.0, why="a multiple of the module"),
    "tip_edge_radius_mm": Limit(0.0, 1e4, lo_closed=True, why="a size; more than 10 m is a unit mistake"),
    "addendum_mm": _SIZE,
    "tip_radius_mm": Limit(0.0, 1e4, lo_closed=True, why="a size; more than 10 m is a unit mistake"),
    "protuberance_mm": Limit(0.0, 1e4, lo_closed=True, why="a size; more than 10 m is a unit mistake"),
    "protuberance_angle_deg": Limit(0.0, 90.0, lo_closed=True, hi_closed=False, why="an angle to the tool flank"),
    "tip_relief_um": _MODIFICATION, "profile_crowning_um": _MODIFICATION, "lead_crowning_um": _MODIFICATION,
    "runout_um": _MODIFICATION,
    "helix_slope_um": _DEVIATION, "profile_slope_um": _DEVIATION, "pitch_deviations_um": _DEVIATION,
    "tip_relief_start_diameter_mm": _SIZE, "tip_form_diameter_mm": _SIZE,
    "torque_out_Nm": Limit(0.0, None, why="load torque on the output shaft"),
    "rpm_in": Limit(0.0, None, why="input speed"),
}
#: key -> allowed string values.
CHOICES: dict[str, tuple[str, ...]] = {"hand": ("right", "left", "spur")}


def _num_text(value: float | None) -> str:
    """``value`` as written by a person: ``-18`` rather than ``-18.0``, full precision otherwise."""
    if value is None:
        return ""
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(value)


def unit_of(key: str) -> str:
    """Unit of a config key from its suffix (``"mm"`` for ``face_width_mm``), ``""`` when dimensionless."""
    if key.startswith("rpm"):
        return "rpm"
    for suffix, unit in UNIT_SUFFIXES:
        if key.endswith(suffix):
            return unit
    return ""


@dataclass(frozen=True)
class Operating:
    """Operating point: output load torque [N m] and input speed [rpm]."""

    torque_out: float = 120.0
    rpm_in: float = 1250.0


@dataclass(frozen=True)
class GearConfig:
    """A loaded, validated configuration.

    Attributes
    ----------
    name : str
        Config name.
    pair : GearPair
        The gear pair (SI).
    operating : Operating
        Nominal operating point.
    raw : dict
        The merged TOML content (after ``extends``), units as written; relative path-valued keys
        (:data:`PATH_KEYS`) made absolute against the file that holds them.
    source : Path or None
        File the config came from.
    """

    name: str
    pair: GearPair
    operating: Operating
    raw: Mapping[str, Any]
    description: str = ""
    source: Path | None = None
    warnings: tuple[str, ...] = field(default=())

    @property
    def reference(self) -> str:
        """How a config file refers to this one (``extends``): the bundled name, else the resolved file path
        (the name when it was built from a dict without a file)."""
        if self.source is None:
            return self.name
        src = Path(self.source).resolve()
        if src == _bundled_path(src.stem).resolve():
            return src.stem
        return str(src)

    def section(self, name: str) -> dict[str, Any]:
        """A copy of the stage section ``name`` (empty dict when absent)."""
        return copy.deepcopy(dict(self.raw.get(name, {})))

    def digest(self) -> str:
        """SHA-256 of the canonical merged content: a cache key for everything derived from it."""
        return hashlib.sha256(json.dumps(self.raw, sort_keys=True, default=str).encode()).hexdigest()


def bundled_names() -> list[str]:
    """Names of the configs shipped with gearrom."""
    root = resources.files("gearrom") / "data" / "configs"
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml"))


def _bundled_path(name: str) -> Path:
    return Path(str(resources.files("gearrom") / "data" / "configs" / f"{name}.toml"))


def _read_toml(path: Path) -> dict[str, Any]:
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: not UTF-8 text (byte {exc.start})") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read config: {exc.strerror}") from None


def _merge(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def _not_found(ref: str, tried: str, referrer: Path | None) -> ConfigError:
    where = f"{referrer}: extends = {ref!r}: " if referrer is not None else f"config {ref!r}: "
    return ConfigError(f"{where}{tried} (bundled: {', '.join(bundled_names())})")


def _unknown(ref: str) -> ConfigError:
    return ConfigError(f"config {ref!r} is neither a file nor a bundled example (bundled: {', '.join(bundled_names())})")


def _is_bare_name(ref: str) -> bool:
    """A name without path separator and without ``.toml`` suffix (a bundled config name candidate)."""
    return not any(sep in ref for sep in ("/", "\\")) and not ref.lower().endswith(".toml") and ref not in (".", "..")


def _locate(ref: str | Path, referrer: Path | None = None) -> Path:
    """The file meant by ``ref``: a command-line argument (``referrer`` None) or an ``extends`` value.

    A relative ``extends`` is taken relative to the directory of ``referrer``, never the current
    directory. A bare name means the file of that name when one exists (a directory never matches),
    else the bundled config of that name.
    """
    text = str(ref)
    if not text.strip():
        where = f"{referrer}: extends" if referrer is not None else "config name"
        raise ConfigError(f"{where} is empty: give a bundled name ({', '.join(bundled_names())}) or a TOML file path")
    path = Path(text).expanduser()
    if referrer is not None and not path.is_absolute():
        path = referrer.parent / path
    try:
        is_file, is_dir = path.is_file(), path.is_dir()
    except (OSError, ValueError) as exc:  # name too long, embedded NUL...
        reason = getattr(exc, "strerror", None) or str(exc)
        raise _not_found(text, f"not a usable path ({reason})", referrer) from None
    if is_file:
        return path
    bare = _is_bare_name(text)
    if bare and text in bundled_names():
        return _bundled_path(text)
    if is_dir:
        why = f"{path} is a directory, not a config file"
        raise _not_found(text, why + (f", and {text!r} is no bundled config" if bare else ""), referrer)
    if referrer is not None:
        why = f"base config {path} does not exist"
        raise _not_found(text, why + (" and is no bundled config" if bare else ""), referrer)
    raise _unknown(text)


def _anchor_paths(data: dict[str, Any], path: Path) -> None:
    """Make the relative path-valued keys (:data:`PATH_KEYS`) of ``data`` absolute against ``path``'s directory."""
    for (section, key), keywords in PATH_KEYS.items():
        table = data.get(section)
        if not isinstance(table, dict):
            continue
        value = table.get(key)
        if isinstance(value, str) and value.strip() and value not in keywords:
            target = Path(value).expanduser()
            table[key] = str(target if target.is_absolute() else path.parent / target)


def resolve(name_or_path: str | Path, _seen: tuple[Path, ...] = (), _referrer: Path | None = None
            ) -> tuple[dict[str, Any], Path]:
    """Read a config file (or bundled name) and apply ``extends`` recursively.

    Parameters
    ----------
    name_or_path : str or Path
        Bundled name or file path (relative to the current directory).

    Returns
    -------
    data : dict
        The merged content; relative path-valued keys (:data:`PATH_KEYS`) are made absolute
        against the directory of the file that holds them.
    path : Path
        The absolute path of the file read.
    """
    path = _locate(name_or_path, _referrer).resolve()
    if path in _seen:
        raise ConfigError(f"{path}: 'extends' forms a cycle ({' -> '.join(map(str, (*_seen, path)))})")
    data = _read_toml(path)
    _anchor_paths(data, path)
    base_ref = data.pop("extends", None)
    if base_ref is not None:
        if not isinstance(base_ref, str):
            raise ConfigError(f"{path}: key 'extends' must be a string, got {base_ref!r}")
        base, _ = resolve(base_ref, _seen + (path,), _referrer=path)
        base.pop("name", None)
        base.pop("description", None)
        data = _merge(base, data)
    return data, path


def _check_number(value: Any, key: str, name: str, loc: str) -> None:
    """Range check of one number as written in the file (message in the key's unit)."""
    limit = LIMITS.get(key)
    if limit is None or limit.contains(value):
        return
    unit = unit_of(key)
    suffix = f" {unit}" if unit else ""
    why = f" ({limit.why})" if limit.why else ""
    raise ConfigError(f"{loc}{name} = {_num_text(value)}{suffix} is out of range: it must be "
                      f"{limit.describe()}{suffix}{why}")


def _convert(table: Mapping[str, Any], spec: Mapping[str, tuple], where: str, src: Path | None) -> dict[str, Any]:
    """Check keys, types and ranges of ``table`` against ``spec`` and return SI values."""
    loc = f"{src}: " if src else ""
    if not isinstance(table, Mapping):
        raise ConfigError(f"{loc}[{where}] must be a table, got {table!r}")
    out: dict[str, Any] = {}
    for key, value in table.items():
        if key not in spec:
            hint = difflib.get_close_matches(key, list(spec), n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else f" (known: {', '.join(spec)})"
            raise ConfigError(f"{loc}unknown key '{where + '.' if where else ''}{key}'{extra}")
        typ, factor, _ = spec[key]
        name = f"{where}.{key}" if where else key
        unit = unit_of(key)
        in_unit = f" of {unit}" if unit else ""
        if typ is bool:
            if not isinstance(value, bool):
                raise ConfigError(f"{loc}{name} must be true or false, got {value!r}")
        elif typ is int:
            if not isinstance(value, int) or isinstance(value, bool):
                raise ConfigError(f"{loc}{name} must be an integer, got {value!r}")
            _check_number(value, key, name, loc)
        elif typ is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"{loc}{name} must be a finite number{in_unit}, got {value!r}")
            _check_number(value, key, name, loc)
            value = float(value) * factor
        elif typ is list:
            if not isinstance(value, list) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value
            ):
                raise ConfigError(f"{loc}{name} must be a list of finite numbers{in_unit}, got {value!r}")
            for i, v in enumerate(value):
                _check_number(v, key, f"{name}[{i}]", loc)
            value = tuple(float(v) * factor for v in value)
        elif typ is str:
            if not isinstance(value, str):
                raise ConfigError(f"{loc}{name} must be a string, got {value!r}")
            if key in CHOICES and value not in CHOICES[key]:
                raise ConfigError(f"{loc}{name} must be one of {', '.join(map(repr, CHOICES[key]))}, got {value!r}")
        out[key] = value
    return out


def _material(table: Mapping[str, Any], where: str, src: Path | None, base: Material | None = None) -> Material:
    v = _convert(table, MATERIAL_KEYS, where, src)
    base = base or Material()
    return Material(
        youngs_modulus=v.get("youngs_modulus_GPa", base.youngs_modulus),
        poisson_ratio=v.get("poisson_ratio", base.poisson_ratio),
        density=v.get("density_kg_per_m3", base.density),
    )


def _gear(name: str, table: Mapping[str, Any], default_mat: Material, src: Path | None) -> Gear:
    loc = f"{src}: " if src is not None else ""
    if not isinstance(table, Mapping):
        raise ConfigError(f"{loc}[{name}] must be a table, got {table!r}")
    table = dict(table)
    sub = {k: table.pop(k, {}) for k in GEAR_SUBSECTIONS}
    for k, v in sub.items():
        if not isinstance(v, Mapping):
            raise ConfigError(f"{loc}[{name}.{k}] must be a table, got {v!r}")
    v = _convert(table, GEAR_KEYS, name, src)
    for req in ("teeth", "face_width_mm", "bore_diameter_mm"):
        if req not in v:
            raise ConfigError(f"{loc}missing key '{name}.{req}' ({GEAR_KEYS[req][2]})")
    t = _convert(sub["tool"], TOOL_KEYS, f"{name}.tool", src)
    m = _convert(sub["microgeometry"], MICRO_KEYS, f"{name}.microgeometry", src)
    tool = RackTool(
        addendum=t.get("addendum_mm"), tip_radius=t.get("tip_radius_mm"),
        protuberance=t.get("protuberance_mm", 0.0), protuberance_angle=t.get("protuberance_angle_deg", 10 * DEG),
    )
    micro = MicroGeometry(
        enabled=m.get("enabled", False), tip_relief=m.get("tip_relief_um", 0.0),
        tip_relief_start_diameter=m.get("tip_relief_start_diameter_mm"),
        profile_crowning=m.get("profile_crowning_um", 0.0), lead_crowning=m.get("lead_crowning_um", 0.0),
        helix_slope=m.get("helix_slope_um", 0.0), profile_slope=m.get("profile_slope_um", 0.0),
        pitch_deviations=m.get("pitch_deviations_um", ()), runout=m.get("runout_um", 0.0),
        runout_phase=m.get("runout_phase_deg", 0.0), tip_form_diameter=m.get("tip_form_diameter_mm"),
    )
    return Gear(
        name=name, z=v["teeth"], face_width=v["face_width_mm"], bore_diameter=v["bore_diameter_mm"],
        x=v.get("profile_shift", 0.0), hand=v.get("hand", "spur"),
        addendum_coefficient=v.get("addendum_coefficient", 1.0), dedendum_coefficient=v.get("dedendum_coefficient", 1.25),
        tip_diameter=v.get("tip_diameter_mm"), root_diameter=v.get("root_diameter_mm"),
        root_form_diameter=v.get("root_form_diameter_mm"), tip_edge_radius=v.get("tip_edge_radius_mm", 0.0),
        material=_material(sub["material"], f"{name}.material", src, default_mat) if sub["material"] else default_mat,
        tool=tool, micro=micro,
    )


def from_dict(data: Mapping[str, Any], source: Path | None = None, check: bool = True) -> GearConfig:
    """Build a :class:`GearConfig` from an already merged TOML dictionary."""
    import warnings

    from gearrom.errors import GearromError
    from gearrom.geometry.checks import check_pair

    loc = f"{source}: " if source is not None else ""
    known = set(TOP_KEYS) | {"pair", "material", "operating"} | set(GEAR_SECTIONS) | set(STAGE_SECTIONS)
    for key in data:
        if key not in known:
            hint = difflib.get_close_matches(key, sorted(known), n=1)
            raise ConfigError(f"{loc}unknown key or section '{key}'" + (f" (did you mean {hint[0]!r}?)" if hint else ""))
    for sec in ("pair", *GEAR_SECTIONS):
        if sec not in data:
            raise ConfigError(f"{loc}missing section [{sec}]")
    for sec in ("pair", "material", "operating", *GEAR_SECTIONS, *STAGE_SECTIONS):
        # Stage sections are validated by their stage, but only a table can be handed to it.
        if sec in data and not isinstance(data[sec], Mapping):
            raise ConfigError(f"{loc}[{sec}] must be a table, got {data[sec]!r}")
    _convert({k: v for k, v in data.items() if k in TOP_KEYS}, TOP_KEYS, "", source)
    try:
        p = _convert(data["pair"], PAIR_KEYS, "pair", source)
        for req in ("normal_module_mm", "normal_pressure_angle_deg"):
            if req not in p:
                raise ConfigError(f"{loc}missing key 'pair.{req}' ({PAIR_KEYS[req][2]})")
        mat = _material(data.get("material", {}), "material", source)
        gears = tuple(_gear(name, data[name], mat, source) for name in GEAR_SECTIONS)
        pair = GearPair(
            normal_module=p["normal_module_mm"], normal_pressure_angle=p["normal_pressure_angle_deg"],
            helix_angle=p.get("helix_angle_deg", 0.0), gears=gears, center_distance=p.get("center_distance_mm"),
            center_distance_tolerance=p.get("center_distance_tolerance_um", 10 * UM),
            min_tip_thickness_factor=p.get("min_tip_thickness_factor", 0.2),
        )
        op = _convert(data.get("operating", {}), OPERATING_KEYS, "operating", source)
    except GearromError as exc:
        msg = str(exc)
        if source is not None and not msg.startswith(str(source)):
            msg = f"{source}: {msg}"
        raise type(exc)(msg) from None
    caught: list[str] = []
    if check:
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            try:
                check_pair(pair)
            except GearromError as exc:
                raise type(exc)(f"{loc}{exc}") from None
        for w in rec:
            caught.append(str(w.message))
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return GearConfig(
        name=str(data.get("name", source.stem if source else "config")), pair=pair,
        operating=Operating(torque_out=op.get("torque_out_Nm", 120.0), rpm_in=op.get("rpm_in", 1250.0)),
        raw=copy.deepcopy(dict(data)), description=str(data.get("description", "")), source=source,
        warnings=tuple(caught),
    )


def as_config(config: GearConfig | str | Path, *, check: bool = False, quiet: bool = True) -> GearConfig:
    """``config`` itself when it is a loaded :class:`GearConfig`, else :func:`load_config` of the name or path.

    Library functions take either and resolve a name once through this function; ``quiet`` silences the
    warnings of the load (the command line reports them where it resolves the name).
    """
    if isinstance(config, GearConfig):
        return config
    if not quiet:
        return load_config(config, check=check)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config(config, check=check)


def load_config(name_or_path: str | Path, check: bool = True) -> GearConfig:
    """Load a bundled config by name (``thesis-spur``, ``thesis-helical``, ``thesis-rig``) or a TOML path.

    Parameters
    ----------
    name_or_path : str or Path
        Bundled name or file path.
    check : bool
        Run the feasibility checks (:func:`gearrom.geometry.checks.check_pair`).

    Raises
    ------
    ConfigError
        Unreadable file, invalid TOML, unknown key, wrong type or value.
    GeometryError
        An infeasible gear pair (undercut, pointed tip, interference, contact ratio < 1...).
    """
    data, path = resolve(name_or_path)
    return from_dict(data, source=path, check=check)
