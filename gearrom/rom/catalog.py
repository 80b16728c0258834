"""Component types a config can place on the rig's stations (``[[rig.components]]``), and their registry.

Each entry of the array of tables ``[[rig.components]]`` names a ``type``, the ``station`` it sits on
(``in.gear``, ``out.ball_bearing``, ``motor``, ...; see :mod:`gearrom.rom.rig`) and the type's keys, with
units in their names. The components are added to those of the rig's default layout, e.g. a second
bearing, a flywheel, or a coupling between two stations::

    [[rig.components]]
    type = "ball_bearing"
    station = "in.sensor_end"
    radial_N_per_um = 150.0
    axial_N_per_um = 40.0

A new type is one :class:`ComponentType` passed to :func:`register_component`: its keys with defaults
(``None`` = required) and a ``build(values, station)`` returning :class:`~gearrom.rom.components.Component`
objects in SI units.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from gearrom.errors import ConfigError
from gearrom.rom.components import BallBearing, Clutch, Component, Disk, NeedleBearing

__all__ = ["COMPONENT_TYPES", "ComponentType", "components_from_config", "register_component"]


@dataclass(frozen=True)
class ComponentType:
    """A component type of ``[[rig.components]]``.

    Attributes
    ----------
    name : str
        The ``type`` value.
    keys : dict
        Key -> default (``None``: required). Numeric keys must be finite and >= 0; strings name stations.
    build : callable
        ``build(values, station) -> list of Component`` with the checked values (config units) and the
        station name.
    doc : str
        One line for error messages and docs.
    """

    name: str
    keys: dict
    build: Callable[[dict, str], list[Component]]
    doc: str = ""


#: registered component types by name
COMPONENT_TYPES: dict[str, ComponentType] = {}


def register_component(ct: ComponentType) -> ComponentType:
    """Make ``ct.name`` a valid ``type`` of ``[[rig.components]]`` (replacing a type of that name)."""
    COMPONENT_TYPES[ct.name] = ct
    return ct


register_component(ComponentType(
    "ball_bearing", {"radial_N_per_um": None, "axial_N_per_um": None, "damping_beta_us": 0.0},
    lambda v, st: [BallBearing(st, v["radial_N_per_um"] * 1e6, v["axial_N_per_um"] * 1e6, v["damping_beta_us"] * 1e-6)],
    "radial and axial springs to ground"))
register_component(ComponentType(
    "needle_bearing", {"radial_N_per_um": None, "damping_beta_us": 0.0},
    lambda v, st: [NeedleBearing(st, v["radial_N_per_um"] * 1e6, v["damping_beta_us"] * 1e-6)],
    "radial springs to ground, axially free"))
register_component(ComponentType(
    "disk", {"mass_kg": 0.0, "polar_inertia_kg_m2": None, "diametral_inertia_kg_m2": None},
    lambda v, st: [Disk(st, v["mass_kg"], v["polar_inertia_kg_m2"], v["diametral_inertia_kg_m2"])],
    "rigid disk: mass, polar and diametral inertia"))
register_component(ComponentType(
    "coupling", {"to": None, "stiffness_Nm_per_rad": None, "damping_Nms_per_rad": 0.0},
    lambda v, st: [Clutch(st, v["to"], v["stiffness_Nm_per_rad"], v["damping_Nms_per_rad"])],
    "torsional spring-damper between the station and the station `to`"))


def components_from_config(entries, stations: set[str], src) -> list[Component]:
    """The components of ``[[rig.components]]`` (a list of tables), checked against the known ``stations``.

    Raises
    ------
    ConfigError
        Not a list of tables, an unknown type, station or key, a missing key, or a value that is not a
        finite number >= 0 (the message names the file, the entry and the key).
    """
    if not isinstance(entries, list):
        raise ConfigError(f"{src}: rig.components must be an array of tables ([[rig.components]]), got {entries!r}")
    out: list[Component] = []
    for i, e in enumerate(entries):
        where = f"rig.components[{i}]"
        if not isinstance(e, dict):
            raise ConfigError(f"{src}: {where} must be a table, got {e!r}")
        kind = e.get("type")
        if kind not in COMPONENT_TYPES:
            raise ConfigError(f"{src}: {where}.type {kind!r} is not a component type "
                              f"(known: {', '.join(sorted(COMPONENT_TYPES))})")
        ct = COMPONENT_TYPES[kind]
        unknown = set(e) - {"type", "station"} - set(ct.keys)
        if unknown:
            raise ConfigError(f"{src}: unknown key '{where}.{sorted(unknown)[0]}' for type {kind!r} "
                              f"(known: station, {', '.join(ct.keys)})")
        values = {}
        for key in ("station", *ct.keys):
            v = e.get(key, ct.keys.get(key))
            if v is None:
                raise ConfigError(f"{src}: {where}.{key} is required for type {kind!r}")
            if key in ("station", "to"):
                if v not in stations:
                    raise ConfigError(f"{src}: {where}.{key} {v!r} is not a station (known: {', '.join(sorted(stations))})")
            elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ConfigError(f"{src}: {where}.{key} must be a finite number >= 0, got {v!r}")
            values[key] = v if key in ("station", "to") else float(v)
        out.extend(ct.build(values, values.pop("station")))
    return out
