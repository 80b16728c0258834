"""Quasi-static explicit FE solves of the seed's spur pair at a few input angles (dynamic relaxation).

Usage: ``python validation/run_explicit_static.py J [J ...] [--torque T]`` solves at the input angles
``theta_0 + J * P / 128`` where ``theta_0`` is the first sample of the 60 rpm run's steady window
(validation/spur_60rpm.*) and ``P`` the mesh period: ``J`` = 0..127 are the 60 rpm run's own samples
(same teeth), ``J + 128 m`` the same mesh phase ``m`` tooth pairs later. Results are merged into
validation/spur_static_points.json (keyed by J; another torque than the runs' 120 N m goes to
spur_static_points_<T>Nm.json: two torques separate the loaded kinematic TE from the compliance;
``--integration full`` appends ``_full``: fully integrated Q4, no hourglass modes).
Same mesh (0.15/1.5 mm Q4), penalty contact, hourglass control and clearance as the dynamic runs; see
:mod:`gearrom.validation.explicit_static`. About 40-70 s per angle on one core.
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
from gearrom.validation.report import load_fe_record

HERE = Path(__file__).resolve().parent
OUT = HERE / "spur_static_points.json"
SAMPLES_PER_PERIOD = 128

log = logging.getLogger("run_explicit_static")


def slow_run_origin(pair) -> tuple[float, float]:
    """(theta_0 [rad], sample step [rad]) of the 60 rpm run's steady window."""
    fe = load_fe_record(HERE, 60.0)
    th = fe.theta_in[fe.t >= float(fe.meta["t_steady_from_s"])]
    step = 2 * math.pi / pair.z[0] / SAMPLES_PER_PERIOD
    if abs(float(np.median(np.diff(th))) - step) > 1e-6 * step:
        raise SystemExit("the 60 rpm run is not sampled at 128 points per mesh period")
    return float(th[0]), step


def output_path(torque: float, integration: str = "reduced") -> Path:
    """The JSON file of the static points at ``torque`` [N m] with the ``integration`` elements."""
    stem = OUT.stem if abs(torque - 120.0) < 1e-9 else f"{OUT.stem}_{torque:g}Nm"
    return HERE / (stem + ("" if integration == "reduced" else f"_{integration}") + ".json")


def main(samples: list[int], torque: float = 120.0, outline: float = 0.15e-3, body: float = 1.5e-3,
         integration: str = "reduced") -> Path:
    out = output_path(torque, integration)
    pair = load_config("thesis-spur").pair
    theta0, step = slow_run_origin(pair)
    meshes = [gear_quad_mesh(pair, i, outline, body) for i in (0, 1)]
    data = json.loads(out.read_text()) if out.is_file() else {"points": {}}
    for j in samples:
        p = static_te(pair, meshes, theta0 + j * step, torque=torque, integration=integration)
        data["points"][str(j)] = dict(p.to_dict(), sample=j, load_average=os.getloadavg())
        data.update(config="thesis-spur", torque_out_Nm=torque, integration=integration, outline_size_mm=outline * 1e3, body_size_mm=body * 1e3,
                    theta0_rad=theta0, sample_step_rad=step, machine={"cpu_count": os.cpu_count(),
                                                                      "platform": platform.platform()},
                    definition="static TE of the explicit FE model (dynamic relaxation, "
                               "gearrom.validation.explicit_static) at theta0 + sample * sample_step; "
                               "theta0 = first sample of the 60 rpm run's steady window; FE TE convention")
        data["points"] = dict(sorted(data["points"].items(), key=lambda kv: int(kv[0])))
        out.write_text(json.dumps(data, indent=2, default=float) + "\n")
        log.info("sample %d written to %s", j, out)
    return out


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("samples", type=int, nargs="+", help="sample offsets J (128 per mesh period) from theta_0")
    ap.add_argument("--torque", type=float, default=120.0, help="output torque, N m")
    ap.add_argument("--integration", choices=("reduced", "full"), default="reduced",
                    help="element integration ('full': spur_static_points*_full.json)")
    a = ap.parse_args()
    main(a.samples, a.torque, integration=a.integration)
