"""Static consistency study: the explicit spur model's static TE against the LTCA at 16 angles and two torques.

Usage: ``python validation/run_static_gate.py [--points 16] [--torques 60 120] [--sag-um 1]`` (writes
validation/static_gate_spur.json, or static_gate_spur_sag<S>um.json with an outline refined to chords within
S um of the profile; points already in the file are kept, so an interrupted study resumes). About 20 s
per static solve on one idle core.

The explicit model is the reference runs' kind (fully integrated Q4, outline nodes on the profile,
penalty contact; sizes, sag, penalty and a tooth-periodic mesh by option), placed at the input angle ``j P / n`` from the FE start position and relaxed
under the output torque (:func:`gearrom.validation.explicit_static.static_te`). The LTCA side is the
quasi-static table at the same torque on the converged flank grid (:func:`gearrom.validation.pair_rom.reference_settings`), read at the table phase of the FE start plus the angle. The
limits and the verdict are :func:`gearrom.validation.static_gate.static_gate`'s.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import os
import platform
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.fe.explicit.gearmesh import gear_quad_mesh
from gearrom.validation.explicit_static import static_te
from gearrom.validation.pair_rom import fe_start_mesh_phase, mesh_excitation, reference_settings
from gearrom.validation.static_gate import static_gate

HERE = Path(__file__).resolve().parent
OUT = HERE / "static_gate_spur.json"
log = logging.getLogger("run_static_gate")


def main(n: int = 16, torques=(60.0, 120.0), outline: float = 0.15e-3, body: float = 1.5e-3,
         sag: float | None = None, penalty: float = 0.3, periodic: bool = False) -> Path:
    pair = load_config("thesis-spur").pair
    period = 2 * math.pi / pair.z[0]
    meshes = [gear_quad_mesh(pair, i, outline, body, sag=sag, periodic=periodic) for i in (0, 1)]
    out = OUT if sag is None else OUT.with_name(f"{OUT.stem}_sag{sag * 1e6:g}um.json")
    if penalty != 0.3:
        out = out.with_name(f"{out.stem}_penalty{penalty:g}.json")
    if body != 1.5e-3:
        out = out.with_name(f"{out.stem}_body{body * 1e3:g}mm.json")
    if periodic:
        out = out.with_name(f"{out.stem}_periodic.json")
    data = json.loads(out.read_text()) if out.is_file() else {}
    if data.get("n_points", n) != n:   # points are keyed by their index among n angles
        raise SystemExit(f"{out} holds points of {data['n_points']} angles per mesh period, not {n}: use "
                         f"--points {data['n_points']} or another file")
    pts = data.setdefault("points", {})
    data.update(config="thesis-spur", integration="full", outline_size_mm=outline * 1e3, body_size_mm=body * 1e3,
                outline_on_profile=True, outline_sag_um=None if sag is None else sag * 1e6, penalty_scale=penalty,
                periodic_mesh=periodic,
                n_points=n,
                definition="static TE (FE convention: zero at rigid first contact of the start position) at input "
                           "angle j * mesh_period / n_points from the FE start position")
    for t in torques:
        for j in range(n):
            key = f"{t:g}Nm/{j}"
            if key in pts:
                continue
            p = static_te(pair, meshes, j * period / n, torque=t, integration="full", penalty_scale=penalty)
            pts[key] = dict(p.to_dict(), load_average=os.getloadavg())
            out.write_text(json.dumps(data, indent=2, default=float) + "\n")
            log.info("%s: %.3f um", key, p.te * 1e6)
    phase0 = fe_start_mesh_phase(pair)
    th = np.arange(n) * period / n
    fe, lt = {}, {}
    for t in torques:
        fe[t] = np.array([pts[f"{t:g}Nm/{j}"]["te_um"] * 1e-6 for j in range(n)])
        ex, label = mesh_excitation(pair, t, "fe", settings=reference_settings(pair))
        lt[t] = np.asarray(ex.ste(np.mod(phase0 + th, period), t), float)
        data.setdefault("ltca_um", {})[f"{t:g}"] = (lt[t] * 1e6).tolist()
        data["ltca_table"] = label
    if len(torques) >= 2:   # the gate's tangent stiffness needs two torques
        data["gate"] = static_gate(fe, lt, pair.rb[1])
    else:
        data.pop("gate", None)
        log.info("mean static TE at %g N m: FE %.3f um, LTCA %.3f um (%+.2f %%); the gate needs two torques",
                 torques[0], fe[torques[0]].mean() * 1e6, lt[torques[0]].mean() * 1e6,
                 100 * (fe[torques[0]].mean() / lt[torques[0]].mean() - 1))
    data["machine"] = {"cpu_count": os.cpu_count(), "platform": platform.platform()}
    out.write_text(json.dumps(data, indent=2, default=float) + "\n")
    if "gate" in data:
        log.info("static gate: %s %s", "pass" if data["gate"]["passed"] else "FAIL", data["gate"]["misses"])
    return out


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=16)
    ap.add_argument("--torques", type=float, nargs="+", default=[60.0, 120.0])
    ap.add_argument("--sag-um", type=float, default=None, help="outline refined to chords within this of the profile")
    ap.add_argument("--penalty", type=float, default=0.3, help="contact penalty scale (ContactPair.penalty_scale)")
    ap.add_argument("--body-mm", type=float, default=1.5, help="body element size, mm (the references: 0.75)")
    ap.add_argument("--periodic", action="store_true", help="tooth-periodic mesh (the references' mesh)")
    a = ap.parse_args()
    main(a.points, tuple(a.torques), body=a.body_mm * 1e-3, sag=None if a.sag_um is None else a.sag_um * 1e-6,
         penalty=a.penalty, periodic=a.periodic)
