"""TOML configuration: gear pair, operating point, and the sections of later stages.

A config is a TOML file whose keys carry their unit (``normal_module_mm``, ``torque_out_Nm``).
Values are converted to SI here and nowhere else. ``extends = "thesis-helical"`` (a bundled
name or a path relative to the file) merges another config underneath. Unknown keys, wrong
types and non-positive sizes raise :class:`gearrom.errors.ConfigError` naming the file and key.

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
from gearrom.geometry.gear import Gear, MicroGeometry, Material, RackTool
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
        The merged TOML content (after ``extends``), units as written.
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


def resolve(name_or_path: str | Path, _seen: tuple[Path, ...] = ()) -> tuple[dict[str, Any], Path]:
    """Read a config file (or bundled name) and apply ``extends`` recursively."""
    path = Path(name_or_path)
    if not path.exists():
        if str(name_or_path) in bundled_names():
            path = _bundled_path(str(name_or_path))
        else:
            raise ConfigError(
                f"config {str(name_or_path)!r} is neither a file nor a bundled example "
                f"(bundled: {', '.join(bundled_names())})"
            )
    path = path.resolve()
    if path in _seen:
        raise ConfigError(f"{path}: 'extends' forms a cycle ({' -> '.join(map(str, _seen))})")
    data = _read_toml(path)
    base_ref = data.pop("extends", None)
    if base_ref is not None:
        if not isinstance(base_ref, str):
            raise ConfigError(f"{path}: key 'extends' must be a string, got {base_ref!r}")
        candidate = path.parent / base_ref
        base, _ = resolve(candidate if candidate.exists() else base_ref, _seen + (path,))
        base.pop("name", None)
        base.pop("description", None)
        data = _merge(base, data)
    return data, path


def _convert(table: Mapping[str, Any], spec: Mapping[str, tuple], where: str, src: Path | None) -> dict[str, Any]:
    """Check keys and types of ``table`` against ``spec`` and return SI values."""
    loc = f"{src}: " if src else ""
    out: dict[str, Any] = {}
    for key, value in table.items():
        if key not in spec:
            hint = difflib.get_close_matches(key, list(spec), n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else f" (known: {', '.join(spec)})"
            raise ConfigError(f"{loc}unknown key '{where}.{key}'{extra}")
        typ, factor, _ = spec[key]
        name = f"{where}.{key}"
        if typ is bool:
            if not isinstance(value, bool):
                raise ConfigError(f"{loc}{name} must be true or false, got {value!r}")
        elif typ is int:
            if not isinstance(value, int) or isinstance(value, bool):
                raise ConfigError(f"{loc}{name} must be an integer, got {value!r}")
        elif typ is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"{loc}{name} must be a finite number, got {value!r}")
            value = float(value) * factor
        elif typ is list:
            if not isinstance(value, list) or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                raise ConfigError(f"{loc}{name} must be a list of numbers, got {value!r}")
            value = tuple(float(v) * factor for v in value)
        elif typ is str and not isinstance(value, str):
            raise ConfigError(f"{loc}{name} must be a string, got {value!r}")
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
    table = dict(table)
    sub = {k: table.pop(k, {}) for k in ("tool", "microgeometry", "material")}
    for k, v in sub.items():
        if not isinstance(v, Mapping):
            raise ConfigError(f"{src}: {name}.{k} must be a table, got {v!r}")
    v = _convert(table, GEAR_KEYS, name, src)
    for req in ("teeth", "face_width_mm", "bore_diameter_mm"):
        if req not in v:
            raise ConfigError(f"{src}: missing key '{name}.{req}' ({GEAR_KEYS[req][2]})")
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

    known = set(TOP_KEYS) | {"pair", "material", "operating"} | set(GEAR_SECTIONS) | set(STAGE_SECTIONS)
    for key in data:
        if key not in known:
            hint = difflib.get_close_matches(key, sorted(known), n=1)
            raise ConfigError(f"{source}: unknown key or section '{key}'" + (f" (did you mean {hint[0]!r}?)" if hint else ""))
    for sec in ("pair", *GEAR_SECTIONS):
        if sec not in data:
            raise ConfigError(f"{source}: missing section [{sec}]")
    try:
        p = _convert(data["pair"], PAIR_KEYS, "pair", source)
        for req in ("normal_module_mm", "normal_pressure_angle_deg"):
            if req not in p:
                raise ConfigError(f"{source}: missing key 'pair.{req}' ({PAIR_KEYS[req][2]})")
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
    for key in ("torque_out_Nm", "rpm_in"):
        if key in op and not op[key] > 0:
            raise ConfigError(f"{source}: operating.{key} must be positive, got {op[key]!r}")
    caught: list[str] = []
    if check:
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            try:
                check_pair(pair)
            except GearromError as exc:
                raise type(exc)(f"{source}: {exc}" if source is not None else str(exc)) from None
        for w in rec:
            caught.append(str(w.message))
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return GearConfig(
        name=str(data.get("name", source.stem if source else "config")), pair=pair,
        operating=Operating(torque_out=op.get("torque_out_Nm", 120.0), rpm_in=op.get("rpm_in", 1250.0)),
        raw=copy.deepcopy(dict(data)), description=str(data.get("description", "")), source=source,
        warnings=tuple(caught),
    )


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
