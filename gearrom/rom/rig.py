"""Build the test-rig drivetrain (:class:`~gearrom.rom.model.Drivetrain`) from a config.

Layout per shaft (axial positions from the ``[rig.input_shaft]`` / ``[rig.output_shaft]`` tables)::

    sensor_end -- ball_bearing -- gear -- needle_bearing -- clutch_end ==clutch== motor | brake

Every station is 6-DOF (``ux, uy, uz, rx, ry, rz``); motor and brake rotors are 1-DOF (``rz``).
DOFs: 10 x 6 + 2 = 62. Defaults below are the ``thesis-rig`` assumptions (see that config). Stations
are named ``<shaft>.<station>`` (``in.gear``, ``out.clutch_end``...), ``motor`` and ``brake``; more
bearings, disks and couplings go on them through ``[[rig.components]]`` (:mod:`gearrom.rom.catalog`).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from gearrom.config import GearConfig, as_config
from gearrom.errors import ConfigError
from gearrom.excitation.sources import describe_excitation, load_excitation_source
from gearrom.excitation.table import MeshExcitation
from gearrom.rom.catalog import components_from_config
from gearrom.rom.components import (BallBearing, Clutch, Disk, Encoder, Load, Motor, NeedleBearing, ShaftSegment,
                                    Station)
from gearrom.rom.model import Drivetrain, MeshSpec

STATIONS = ("sensor_end", "ball_bearing", "gear", "needle_bearing", "clutch_end")
SHAFT_DEFAULTS = {
    "in": {"sensor_end_mm": 0.0, "ball_bearing_mm": 40.0, "gear_mm": 90.0, "needle_bearing_mm": 140.0,
           "clutch_end_mm": 200.0, "diameters_mm": [20.0, 35.3, 35.3, 30.0], "sensor_radius_mm": 10.0,
           "clutch_radius_mm": 15.0},
    "out": {"sensor_end_mm": 0.0, "ball_bearing_mm": 40.0, "gear_mm": 90.0, "needle_bearing_mm": 140.0,
            "clutch_end_mm": 200.0, "diameters_mm": [22.0, 34.25, 34.25, 40.0], "sensor_radius_mm": 11.0,
            "clutch_radius_mm": 20.0},
}
DEFAULTS: dict[str, dict[str, Any]] = {
    "bearings": {"ball_radial_N_per_um": 200.0, "ball_axial_N_per_um": 50.0, "needle_radial_N_per_um": 300.0,
                 "damping_beta_us": 5.0},
    "clutch": {"stiffness_Nm_per_rad": 200000.0, "damping_Nms_per_rad": 1.0, "hub_inertia_kg_m2": 5e-4},
    "motor": {"inertia_kg_m2": 0.02, "speed_gain_Nms_per_rad": 20.0, "integral_gain_Nm_per_rad": 0.0},
    "load": {"inertia_kg_m2": 0.05},
}
ROM_DEFAULTS = {"mesh_damping_ratio": 0.05, "shaft_damping_beta_us": 2.0, "backlash_um": 50.0,
                "cutoff_frequency_kHz": 12.0, "min_mesh_energy_share": 1e-6, "max_step_us": 10.0,
                "excitation": "fe", "mesh_law": "load-dependent",
                "excitation_torques_Nm": [], "n_theta": 256}


def _num(table: dict, key: str, where: str, src, positive: bool = True, allow_zero: bool = False) -> float:
    v = table[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ConfigError(f"{src}: {where}.{key} must be a finite number, got {v!r}")
    if positive and not (v > 0 or (allow_zero and v == 0)):
        raise ConfigError(f"{src}: {where}.{key} must be {'>= 0' if allow_zero else 'positive'}, got {v!r}")
    return float(v)


def _merged(raw: dict, defaults: dict, where: str, src) -> dict:
    if not isinstance(raw, dict):
        raise ConfigError(f"{src}: [{where}] must be a table, got {raw!r}")
    unknown = set(raw) - set(defaults)
    if unknown:
        raise ConfigError(f"{src}: unknown key '{where}.{sorted(unknown)[0]}' (known: {', '.join(defaults)})")
    out = dict(defaults)
    out.update(raw)
    return out


def rom_section(cfg: GearConfig) -> dict:
    """The validated ``[rom]`` section with defaults."""
    return _merged(cfg.section("rom"), ROM_DEFAULTS, "rom", cfg.source)


def load_excitation(cfg: GearConfig, rom: dict, torque: float, progress: bool = False) -> MeshExcitation:
    """The configured excitation: the source ``[rom] excitation`` names (see :mod:`gearrom.excitation.sources`:
    ``"fe"``, ``"analytical"``, a registered source, or a MeshExcitation NetCDF path relative to the config);
    ``progress``: a progress bar while an FE table is computed."""
    return load_excitation_source(cfg, rom, torque, progress=progress)


def excitation_info(cfg: GearConfig, torque: float, progress: bool = False) -> dict[str, Any]:
    """Which excitation a model of ``cfg`` at ``torque`` [N m] runs on (computing an FE table here if
    it is not cached): ``source`` (the source name or the table file), the table's ``torques_Nm`` and
    ``n_theta``, and what the source adds (the FE ``cache_key`` and ``n_positions``)."""
    rom = rom_section(cfg)
    return describe_excitation(rom["excitation"], load_excitation(cfg, rom, torque, progress=progress))


def model_revisions(cfg: GearConfig, torque: float) -> dict[str, Any]:
    """Revisions of the models whose results a ROM run of ``cfg`` at the output ``torque`` [N m] is built from.

    Parameters
    ----------
    cfg : GearConfig
        Loaded config.
    torque : float
        Output torque [N m].

    Returns
    -------
    dict
        JSON-serialisable: ``slices``, the thin-slice model's revision
        (:data:`gearrom.excitation.slices.MODEL_REVISION`: the ROM follows the pitch deviations with it,
        with the pair's flank modifications); with the ``"fe"`` excitation (``[rom] excitation``),
        ``nominal_table``, that table's cache key (:func:`gearrom.excitation.sources.fe_table_key`: its
        revision, pair and micro-geometry, torques, mesh, the revision of the FE compliances behind it
        and the gearrom version). A table file named by ``[rom] excitation`` is covered by the file hashes of
        :func:`gearrom.rom.sweep.reuse_key`; the analytical excitation and registered sources by the
        gearrom version.
    """
    from gearrom.excitation.slices import MODEL_REVISION

    out: dict[str, Any] = {"slices": MODEL_REVISION}
    rom = rom_section(cfg)
    if rom["excitation"] == "fe":
        from gearrom.excitation.sources import fe_table_key

        out.update(nominal_table=fe_table_key(cfg, rom, torque))
    return out


def rig_parameters(config: GearConfig | str | Path) -> dict[str, Any]:
    """Every ``[rig]`` / ``[rom]`` parameter with its effective value (config or default), dotted keys.

    The keys (e.g. ``"rig.clutch.stiffness_Nm_per_rad"``) are the ones :func:`build_rig` accepts in
    ``overrides``.
    """
    cfg = _load(config)
    out: dict[str, Any] = {}
    rig = cfg.section("rig")
    for shaft, table in (("in", "input_shaft"), ("out", "output_shaft")):
        for k, v in _merged(rig.get(table, {}), SHAFT_DEFAULTS[shaft], f"rig.{table}", cfg.source).items():
            out[f"rig.{table}.{k}"] = v
    for name, d in DEFAULTS.items():
        for k, v in _merged(rig.get(name, {}), d, f"rig.{name}", cfg.source).items():
            out[f"rig.{name}.{k}"] = v
    for k, v in rom_section(cfg).items():
        out[f"rom.{k}"] = v
    return out


def with_overrides(config: GearConfig | str | Path, overrides) -> GearConfig:
    """A copy of ``config`` with dotted-key values replaced (``{"rig.clutch.stiffness_Nm_per_rad": 3e5}``).

    Raises
    ------
    ConfigError
        A key that is not a ``rig.*`` / ``rom.*`` parameter (see :func:`rig_parameters`).
    """
    import copy

    from gearrom.config import from_dict

    cfg = _load(config)
    known = rig_parameters(cfg)
    raw = copy.deepcopy(dict(cfg.raw))
    for key, value in dict(overrides).items():
        if key not in known:
            raise ConfigError(f"override {key!r} is not a rig/rom parameter (known: {', '.join(sorted(known))})")
        parts = key.split(".")
        node = raw
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = value
    return from_dict(raw, source=cfg.source, check=False)


def _load(config) -> GearConfig:
    return as_config(config, check=True)


def build_rig(config: GearConfig | str | Path, torque_out: float | None = None,
              excitation: MeshExcitation | None = None, overrides=None) -> Drivetrain:
    """Build the rig drivetrain of a config (``[rig]``, ``[rom]`` sections; defaults = thesis-rig assumptions).

    Parameters
    ----------
    config : GearConfig or str or Path
        Loaded config, bundled name or path.
    torque_out : float, optional
        Load torque [N m] for the excitation table (default: the config's operating torque).
    excitation : MeshExcitation, optional
        Use this table instead of the configured one.
    overrides : mapping, optional
        Dotted-key parameter values replacing the config's (see :func:`rig_parameters`), e.g. for
        identification: ``{"rig.clutch.stiffness_Nm_per_rad": 3e5, "rom.mesh_damping_ratio": 0.08}``.

    Raises
    ------
    ConfigError
        Unknown keys, non-positive values, stations out of order (the message names file and key).
    """
    config = _load(config) if not overrides else with_overrides(config, overrides)
    cfg, src = config, config.source
    pair = cfg.pair
    rig = cfg.section("rig")
    rom = rom_section(cfg)
    allowed = {"input_shaft", "output_shaft", "components", *DEFAULTS}
    for key in rig:
        if key not in allowed:
            raise ConfigError(f"{src}: unknown key 'rig.{key}' (known: {', '.join(sorted(allowed))})")
    sec = {k: _merged(rig.get(k, {}), v, f"rig.{k}", src) for k, v in DEFAULTS.items()}
    mat = pair.gears[0].material
    spin = {"in": 1.0, "out": -pair.z[0] / pair.z[1]}
    stations, comps, encoders = [], [], []
    for shaft, table in (("in", "input_shaft"), ("out", "output_shaft")):
        s = _merged(rig.get(table, {}), SHAFT_DEFAULTS[shaft], f"rig.{table}", src)
        zs = [_num(s, f"{n}_mm", f"rig.{table}", src, positive=False) * 1e-3 for n in STATIONS]
        if any(b <= a for a, b in zip(zs, zs[1:])):
            raise ConfigError(f"{src}: rig.{table}: stations must increase strictly in the order "
                              f"{', '.join(n + '_mm' for n in STATIONS)}; got {[z * 1e3 for z in zs]}")
        diams = s["diameters_mm"]
        if not isinstance(diams, list) or len(diams) != 4 or not all(
                isinstance(d, (int, float)) and not isinstance(d, bool) and d > 0 for d in diams):
            raise ConfigError(f"{src}: rig.{table}.diameters_mm must list 4 positive diameters (one per segment), "
                              f"got {diams!r}")
        names = [f"{shaft}.{n}" for n in STATIONS]
        stations += [Station(nm, shaft, z, 6, spin[shaft]) for nm, z in zip(names, zs)]
        beta = _num(rom, "shaft_damping_beta_us", "rom", src, allow_zero=True) * 1e-6
        for a, b, d in zip(names, names[1:], diams):
            comps.append(ShaftSegment(a, b, d * 1e-3, mat.youngs_modulus, mat.poisson_ratio, mat.density, beta))
        i = 0 if shaft == "in" else 1
        g = pair.gears[i]
        m, ip = pair.blank_inertia(i)
        ri, ro = 0.5 * g.bore_diameter, 0.5 * pair.df[i]
        comps.append(Disk(f"{shaft}.gear", m, ip, m * (3 * (ri**2 + ro**2) + g.face_width**2) / 12))
        bb = sec["bearings"]
        bbeta = _num(bb, "damping_beta_us", "rig.bearings", src, allow_zero=True) * 1e-6
        comps.append(BallBearing(f"{shaft}.ball_bearing", _num(bb, "ball_radial_N_per_um", "rig.bearings", src) * 1e6,
                                 _num(bb, "ball_axial_N_per_um", "rig.bearings", src) * 1e6, bbeta))
        comps.append(NeedleBearing(f"{shaft}.needle_bearing",
                                   _num(bb, "needle_radial_N_per_um", "rig.bearings", src) * 1e6, bbeta))
        cl = sec["clutch"]
        hub = _num(cl, "hub_inertia_kg_m2", "rig.clutch", src)
        comps.append(Disk(f"{shaft}.clutch_end", 0.0, hub, hub / 2))
        rotor = "motor" if shaft == "in" else "brake"
        stations.append(Station(rotor, shaft, zs[-1], 1, spin[shaft]))
        comps.append(Clutch(f"{shaft}.clutch_end", rotor, _num(cl, "stiffness_Nm_per_rad", "rig.clutch", src),
                            _num(cl, "damping_Nms_per_rad", "rig.clutch", src, allow_zero=True)))
        encoders.append(Encoder(f"{shaft}.sensor", f"{shaft}.sensor_end",
                                _num(s, "sensor_radius_mm", f"rig.{table}", src) * 1e-3, "sensor", shaft))
        encoders.append(Encoder(f"{shaft}.clutch", f"{shaft}.clutch_end",
                                _num(s, "clutch_radius_mm", f"rig.{table}", src) * 1e-3, "clutch", shaft))
    mo, lo = sec["motor"], sec["load"]
    comps.append(Motor("motor", _num(mo, "inertia_kg_m2", "rig.motor", src),
                       _num(mo, "speed_gain_Nms_per_rad", "rig.motor", src, allow_zero=True),
                       _num(mo, "integral_gain_Nm_per_rad", "rig.motor", src, allow_zero=True)))
    comps.append(Load("brake", _num(lo, "inertia_kg_m2", "rig.load", src)))
    comps += components_from_config(rig.get("components", []), {s.name for s in stations}, src)
    torque = cfg.operating.torque_out if torque_out is None else float(torque_out)
    ex = excitation if excitation is not None else load_excitation(cfg, rom, torque)
    if rom["mesh_law"] not in ("load-dependent", "secant"):
        raise ConfigError(f"{src}: rom.mesh_law must be \"load-dependent\" or \"secant\", got {rom['mesh_law']!r}")
    mesh = MeshSpec(("in.gear", "out.gear"), _num(rom, "mesh_damping_ratio", "rom", src, allow_zero=True),
                    _num(rom, "backlash_um", "rom", src) * 1e-6, rom["mesh_law"] == "load-dependent")
    return Drivetrain(
        name=cfg.name, pair=pair, stations=tuple(stations), components=tuple(comps), mesh=mesh, excitation=ex,
        encoders=tuple(encoders), motor_station="motor", load_station="brake",
        cutoff_frequency=_num(rom, "cutoff_frequency_kHz", "rom", src) * 1e3,
        max_step=_num(rom, "max_step_us", "rom", src) * 1e-6,
        min_mesh_share=_num(rom, "min_mesh_energy_share", "rom", src, allow_zero=True),
        metadata={"config": cfg.name, "config_digest": cfg.digest(), "torque_out_Nm": torque},
    )
