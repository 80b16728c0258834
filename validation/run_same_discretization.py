"""Static vs dynamic parts of the pair ROM's miss against the explicit FE (same discretised gears).

Usage: ``python validation/run_same_discretization.py`` (about 5 minutes: ROM runs and rigid facet
geometry only, no explicit FE run) writes validation/rom_vs_fe_spur_same_discretization.json from
the stored records: the dynamic runs spur_1250rpm / spur_2000rpm, the slow run spur_60rpm and the
quasi-static explicit solves spur_static_points.json (120 N m; the sub-window needs J = 152, 160,
..., 528) and spur_static_points_60Nm.json (J = 152, 160, ..., 272), written by
validation/run_explicit_static.py. See validation/studies/same_discretization.py.
"""
from __future__ import annotations

import json
import logging
import sys
import math
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.validation.compare import steady_window
from gearrom.validation.explicit_table import (CUTOFF_ORDER, explicit_qs_excitation, explicit_scaled_excitation,
                                               slow_run_deflection)
from gearrom.validation.pair_rom import mesh_excitation
from gearrom.validation.report import load_fe_record, output_inertia

sys.path.insert(0, str(Path(__file__).resolve().parent / "studies"))
import same_discretization as sd  # noqa: E402  (validation/studies: a study, not a library module)

HERE = Path(__file__).resolve().parent
OUT = HERE / "rom_vs_fe_spur_same_discretization.json"
STATIC = HERE / "spur_static_points.json"
STATIC_LO = HERE / "spur_static_points_60Nm.json"
RPMS = (1250.0, 2000.0)
#: static sub-window: 3 mesh periods, 16 points each, from sample J = 152 of the 60 rpm run's grid
SUB_J0, SUB_PER_PERIOD, SUB_PERIODS = 152, 16, 3

log = logging.getLogger("run_same_discretization")


def _metric_rows(comparisons: dict) -> dict:
    return {name: {str(int(rpm)): {"metrics": s.metrics, "passed": s.passed, "misses": s.misses,
                                   "k_mean_N_per_um": s.rom_meta["k_mean_N_per_m"] * 1e-6,
                                   "mesh_mode_Hz": s.rom_meta["mesh_mode_Hz"]}
                   for rpm, s in per.items()} for name, per in comparisons.items()}


def _two_torque(pair, outline: float, body: float) -> dict:
    """Static solves at 60 and 120 N m on the same angles against the ROM's static model (LTCA + facets)."""
    from gearrom.fe.sweep import stiffness_sweep

    lo, hi = json.loads(STATIC_LO.read_text())["points"], json.loads(STATIC.read_text())["points"]
    keys = sorted((k for k in lo if k in hi), key=int)
    th = np.array([lo[k]["theta_in_rad"] for k in keys])
    t_lo, t_hi = (np.array([d[k]["te_um"] for k in keys]) * 1e-6 for d in (lo, hi))
    table = stiffness_sweep(pair, [60.0, 120.0], 64).to_excitation()
    e_lo, kin_lo = sd.static_parts(pair, table, th, outline, body, 60.0)
    e_hi, kin_hi = sd.static_parts(pair, table, th, outline, body, 120.0)
    out = sd.two_torque_split(t_hi, t_lo, e_hi + kin_hi, e_lo + kin_lo, e_hi, e_lo)
    return {"samples_J": [int(k) for k in keys], "theta_in_rad": th.tolist(), "torques_Nm": [60.0, 120.0], **out}


def _mode_bands(pair, records: dict, roms: dict) -> dict:
    """DTE RMS by mesh order on the 10-period windows, band +-30 % around the ROM's mesh mode order."""
    z1 = pair.z[0]
    out = {}
    for rpm, fe in records.items():
        s0 = roms["ltca"][rpm]
        order = s0.rom_meta["mesh_mode_Hz"] / s0.rom_meta["mesh_frequency_Hz"]
        band = (0.7 * order, 1.3 * order)
        w = steady_window(fe.theta_in, fe.t, float(fe.meta["t_steady_from_s"]), z1)
        row = {"rom_mesh_mode_order": order, "fe": sd.mode_band_rms(fe.theta_in[w], fe.te[w], z1, band)}
        for name, per in roms.items():
            s = per[rpm]
            row[name] = sd.mode_band_rms(s.rom_theta_in[s.rom_window], s.rom_te[s.rom_window], z1, band)
        out[str(int(rpm))] = row
    return out


def main() -> Path:
    pair = load_config("thesis-spur").pair
    records = {rpm: load_fe_record(HERE, rpm) for rpm in RPMS}
    fe0 = records[RPMS[0]]
    torque = float(fe0.meta["torque_out_Nm"])
    outline, body = fe0.meta["outline_size_mm"] * 1e-3, fe0.meta["body_size_mm"] * 1e-3
    ref, ref_label = mesh_excitation(pair, torque, "fe")
    slow = slow_run_deflection(pair, load_fe_record(HERE, 60.0), ref)
    tables = {"ltca": (ref, ref_label, {"table": "ltca", "source": ref_label}),
              "explicit_scaled": explicit_scaled_excitation(pair, ref, slow=slow),
              "explicit_qs": explicit_qs_excitation(pair, ref, slow=slow)}
    inertia = output_inertia(pair, outline, body)
    roms = sd.rom_runs(pair, tables, records, inertia)
    theta0 = json.loads(STATIC.read_text())["theta0_rad"]
    step128 = 2 * math.pi / pair.z[0] / 128
    window = sd.static_window_analysis(pair, STATIC, theta0 + SUB_J0 * step128, SUB_PER_PERIOD, SUB_PERIODS,
                                       records, roms, {n: t[0] for n, t in tables.items()}, outline, body)
    points = sd.static_point_check(pair, tables, STATIC, (float(slow.theta_in[0]), float(slow.theta_in[-1])),
                                   outline, body)
    cutoff = {}
    for order in (8, 24):
        runs = sd.rom_runs(pair, {"explicit_qs": explicit_qs_excitation(pair, ref, slow=slow, cutoff_order=order)},
                           records, inertia)
        cutoff[str(order)] = _metric_rows(runs)["explicit_qs"]
    out = {"config": "thesis-spur", "torque_out_Nm": torque,
           "tables": {n: t[2] for n, t in tables.items()},
           "rom_vs_fe": _metric_rows(roms),
           "decomposition": {name: {str(int(rpm)): sd.decomposition(roms["ltca"][rpm].metrics, roms[name][rpm].metrics)
                                    for rpm in RPMS} for name in ("explicit_scaled", "explicit_qs")},
           "static_vs_dynamic": sd.static_dynamic_summary(_metric_rows(roms), window),
           "static_window": window, "two_torque": _two_torque(pair, outline, body),
           "mode_bands": _mode_bands(pair, records, roms), "static_points": points,
           "explicit_qs_cutoff_sensitivity": {"default": CUTOFF_ORDER, **cutoff},
           "definitions": {
               "rel_error": "(rom - fe) / |fe| on the FE's steady window (10 mesh periods)",
               "static_table_rel": "(rom_ltca - rom_table) / |fe|: what the table change moves",
               "remaining_rel": "(rom_table - fe) / |fe|",
               "static_vs_dynamic": "default ROM (ltca): static = ROM static / explicit static - 1 and dynamic = "
                                    "ROM amplification / FE amplification - 1 on the static window; static_share "
                                    "= |ln(1+static)| / (|ln(1+static)| + |ln(1+dynamic)|)",
               "static_window": "3 mesh periods inside both dynamic windows; FE static = dynamic-relaxation "
                                "solves of the explicit model (16 per mesh period); amplification = dynamic / "
                                "static metric on that window",
               "two_torque": "offset = 2 TE(60 N m) - TE(120 N m) (loaded kinematic TE), increment = "
                             "TE(120) - TE(60) (compliance); model = LTCA (60/120 N m) + facets",
               "mode_bands": "DTE RMS [um] by mesh order: whole orders 1-3, whole orders > 3, bins between "
                             "whole orders (not mesh-periodic) inside / outside +-30 % of the ROM's mesh mode order"}}
    OUT.write_text(json.dumps(out, indent=2, default=float) + "\n")
    log.info("written %s", OUT)
    return OUT


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    main()
