"""``gearrom geometry NAME_OR_PATH [--json]``: derived gear pair geometry (ISO 21771)."""
from __future__ import annotations

import argparse
import json
import math
import sys

from gearrom.config import load_config

NAME = "geometry"
HELP = "derived geometry of a gear pair (ISO 21771 / DIN 3960)"


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", metavar="NAME_OR_PATH", help="bundled config name or TOML path")
    parser.add_argument("--json", action="store_true", help="print a JSON object instead of a table")


def geometry_dict(pair) -> dict:
    """JSON-ready derived geometry of ``pair`` (lengths in mm, angles in degrees)."""
    mm = 1e3
    gears = []
    for i, g in enumerate(pair.gears):
        lead = pair.lead[i]
        gears.append({
            "name": g.name, "z": g.z, "x": g.x, "hand": g.hand,
            "d_mm": pair.d[i] * mm, "db_mm": pair.db[i] * mm, "da_mm": pair.da[i] * mm, "df_mm": pair.df[i] * mm,
            "dw_mm": pair.dw[i] * mm, "dFf_mm": pair.dff[i] * mm, "dNf_mm": pair.d_start_active[i] * mm,
            "lead_mm": None if lead is None else lead * mm,
            "s_mm": pair.s_t[i] * mm, "sn_mm": pair.s_n[i] * mm, "san_mm": pair.s_an[i] * mm,
            "span_teeth_k": pair.span_teeth(i), "base_tangent_length_mm": pair.base_tangent_length(i) * mm,
            "face_width_mm": g.face_width * mm, "bore_diameter_mm": g.bore_diameter * mm,
            "mass_kg": pair.blank_inertia(i)[0], "inertia_kg_m2": pair.blank_inertia(i)[1],
        })
    return {
        "mn_mm": pair.mn * mm, "mt_mm": pair.mt * mm, "alpha_n_deg": math.degrees(pair.alpha_n),
        "beta_deg": math.degrees(pair.beta), "ratio": pair.ratio,
        "center_distance_mm": pair.aw * mm, "reference_center_distance_mm": pair.a * mm, "y": pair.y,
        "alpha_t_deg": math.degrees(pair.alpha_t), "alpha_wt_deg": math.degrees(pair.alpha_wt),
        "beta_b_deg": math.degrees(pair.beta_b),
        "g_alpha_mm": pair.g_alpha * mm, "pt_mm": pair.p_t * mm, "pb_t_mm": pair.pb_t * mm, "pb_n_mm": pair.pb_n * mm,
        "eps_alpha": pair.eps_alpha, "eps_beta": pair.eps_beta, "eps_gamma": pair.eps_gamma,
        "gears": gears,
    }


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4f}" if v == 0 or 1e-2 <= abs(v) < 1e6 else f"{v:.4e}"
    return str(v)


def run(args: argparse.Namespace) -> int:
    cfg = load_config(args.config)
    out = geometry_dict(cfg.pair)
    out = {"config": cfg.name, **out, "warnings": list(cfg.warnings)}
    if args.json:
        sys.stdout.write(json.dumps(out, indent=2) + "\n")
        return 0
    lines = [f"gear pair '{cfg.name}': {cfg.description}", ""]
    for key, val in out.items():
        if key in ("gears", "config", "warnings"):
            continue
        lines.append(f"  {key:<28s} {_fmt(val)}")
    g1, g2 = out["gears"]
    lines += ["", f"  {'per gear':<28s} {g1['name']:>14s} {g2['name']:>14s}"]
    for key in g1:
        if key == "name":
            continue
        lines.append(f"  {key:<28s} {_fmt(g1[key]):>14s} {_fmt(g2[key]):>14s}")
    for w in cfg.warnings:
        lines.append(f"  warning: {w}")
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
