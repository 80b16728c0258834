"""Static TE of the explicit FE model with one-point (hourglass-controlled) and fully integrated Q4,
against the ROM's quasi-static TE (LTCA table + facet kinematic TE) at the same input angles.

Usage: ``python validation/run_static_integration.py`` (after
``python validation/run_explicit_static.py J ... [--integration full]`` for both integrations):
writes validation/static_integration_spur.json. The reference is the LTCA of the quasi-static FE
(P2 triangles, analytic Hertz near field, :mod:`gearrom.fe.ltca`), an independent discretisation;
the explicit model's two element formulations share mesh, penalty contact and clearance.
"""
from __future__ import annotations

import json
import logging
import sys
import os
import platform
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.validation.pair_rom import mesh_excitation

sys.path.insert(0, str(Path(__file__).resolve().parent / "studies"))
import same_discretization as sd  # noqa: E402  (validation/studies: a study, not a library module)

HERE = Path(__file__).resolve().parent
OUT = HERE / "static_integration_spur.json"


def main() -> Path:
    pair = load_config("thesis-spur").pair
    th_r, te_r, meta_r = sd.load_static_points(HERE / "spur_static_points.json")
    th_f, te_f, meta_f = sd.load_static_points(HERE / "spur_static_points_full.json")
    common = np.array([t for t in th_f if np.min(np.abs(th_r - t)) < 1e-9])
    ir = np.array([int(np.argmin(np.abs(th_r - t))) for t in common])
    jf = np.array([int(np.argmin(np.abs(th_f - t))) for t in common])
    table, source = mesh_excitation(pair, 120.0)
    rom = sd.rom_static_te(pair, table, common, meta_f["outline_size_mm"] * 1e-3, meta_f["body_size_mm"] * 1e-3, 120.0)
    red, full = te_r[ir], te_f[jf]
    out = {
        "config": "thesis-spur", "torque_out_Nm": 120.0, "reference": f"ROM quasi-static TE: {source} + facet kinematic TE",
        "theta_in_rad": common.tolist(),
        "te_um": {"reduced": (red * 1e6).tolist(), "full": (full * 1e6).tolist(), "rom": (rom * 1e6).tolist()},
        "mean_um": {"reduced": float(red.mean() * 1e6), "full": float(full.mean() * 1e6), "rom": float(rom.mean() * 1e6)},
        "mean_rel_error_vs_rom": {"reduced": float(red.mean() / rom.mean() - 1), "full": float(full.mean() / rom.mean() - 1)},
        "rms_rel_error_vs_rom": {k: float(np.sqrt(np.mean((v - rom) ** 2)) / abs(rom.mean()))
                                 for k, v in (("reduced", red), ("full", full))},
        "ptp_um": {"reduced": float(np.ptp(red) * 1e6), "full": float(np.ptp(full) * 1e6), "rom": float(np.ptp(rom) * 1e6)},
        "full_minus_reduced_um": float((full - red).mean() * 1e6),
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()},
    }
    OUT.write_text(json.dumps(out, indent=2) + "\n")
    logging.getLogger(__name__).info("static TE mean: reduced %.3f, full %.3f, ROM %.3f um", *out["mean_um"].values())
    return OUT


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    main()
