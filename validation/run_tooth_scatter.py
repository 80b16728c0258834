"""Tooth-to-tooth scatter of the spur reference mesh: static TE at one mesh phase on successive tooth pairs.

Usage: ``python validation/run_tooth_scatter.py [--teeth 8] [--phases 0 0.5] [--periodic yes|no]`` (writes
validation/tooth_scatter_spur[_periodic].json; points already in the file are kept, so an interrupted study
resumes). About a minute per static solve on one idle core.

The explicit reference model (the mesh of ``validation/ringdown_spur.json``: fully integrated Q4,
outline on the profile and refined to its sag, its penalty) is relaxed under 120 N m at input angles
``(phase + k) P`` from the FE start position, k = 0 .. teeth - 1, P the mesh period: the same point of
the mesh cycle on ``teeth`` different tooth pairs. Identical teeth would give one static TE per phase;
gmsh meshes each tooth of the whole gear differently, and the spread of these values is the per-tooth
content that the dynamic references carry between their mesh orders. The file gives, per phase, the
values, their standard deviation and range, and the standard deviation relative to the GMF1 amplitude
of the LTCA's static TE at that torque.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import os
import platform
import sys
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.validation.explicit_static import static_te
from gearrom.validation.pair_rom import mesh_excitation

HERE = Path(__file__).resolve().parent
OUT = HERE / "tooth_scatter_spur.json"
TORQUE = 120.0
log = logging.getLogger("run_tooth_scatter")


def main(teeth: int = 8, phases=(0.0, 0.5), periodic: bool | None = None) -> Path:
    sys.path.insert(0, str(HERE))
    from run_ringdown import reference_meshes

    pair = load_config("thesis-spur").pair
    period = 2 * math.pi / pair.z[0]
    cal = json.loads((HERE / "ringdown_spur.json").read_text())["mesh"]
    if periodic is not None:
        cal = {**cal, "periodic": periodic}
    meshes = reference_meshes(pair, cal)
    out = OUT.with_name(f"{OUT.stem}_periodic.json") if cal.get("periodic") else OUT
    data = json.loads(out.read_text()) if out.is_file() else {}
    pts = data.setdefault("points", {})
    data.update(config="thesis-spur", torque_out_Nm=TORQUE, integration="full", mesh=cal,
                definition="static TE (FE convention) at input angle (phase + k) * mesh_period from the FE start "
                           "position, k = tooth pair offset")
    for ph in phases:
        for k in range(teeth):
            key = f"{ph:g}/{k}"
            if key in pts:
                continue
            p = static_te(pair, meshes, (ph + k) * period, torque=TORQUE, integration="full",
                          penalty_scale=cal["penalty_scale"])
            pts[key] = dict(p.to_dict(), load_average=os.getloadavg())
            out.write_text(json.dumps(data, indent=2, default=float) + "\n")
            log.info("phase %g, tooth pair +%d: %.4f um", ph, k, p.te * 1e6)
    ex, label = mesh_excitation(pair, TORQUE, "fe")
    th = np.linspace(0.0, period, 256, endpoint=False)
    ste = np.asarray(ex.ste(th, TORQUE), float)
    gmf1 = 2 * abs(np.fft.rfft(ste)[1]) / th.size
    summary = {}
    for ph in phases:
        te = np.array([pts[f"{ph:g}/{k}"]["te_um"] for k in range(teeth) if f"{ph:g}/{k}" in pts])
        summary[f"{ph:g}"] = {"te_um": te.tolist(), "std_um": float(te.std(ddof=1)), "range_um": float(np.ptp(te)),
                              "std_over_static_gmf1": float(te.std(ddof=1) / (gmf1 * 1e6))}
    data.update(summary=summary, ltca_static_gmf1_um=gmf1 * 1e6, ltca_table=label,
                machine={"cpu_count": os.cpu_count(), "platform": platform.platform()})
    out.write_text(json.dumps(data, indent=2, default=float) + "\n")
    for ph, s in summary.items():
        log.info("phase %s: std %.4f um (%.1f %% of the static GMF1 %.3f um), range %.4f um", ph, s["std_um"],
                 100 * s["std_over_static_gmf1"], gmf1 * 1e6, s["range_um"])
    return out


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--teeth", type=int, default=8)
    ap.add_argument("--phases", type=float, nargs="+", default=[0.0, 0.5])
    ap.add_argument("--periodic", choices=("yes", "no"), default=None,
                    help="tooth-periodic mesh or not (default: as validation/ringdown_spur.json); 'yes' writes "
                         "tooth_scatter_spur_periodic.json")
    a = ap.parse_args()
    main(a.teeth, tuple(a.phases), None if a.periodic is None else a.periodic == "yes")
