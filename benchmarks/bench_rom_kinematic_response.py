"""Sensor TE response of the exudyn ROM to a unit kinematic error at the mesh, by rig support variant.

The diagnosis' pulse-train effects (a displaced tooth) excite the drivetrain across 20-500 Hz. A purely
torsional rig with a mesh much stiffer than the shafts passes a kinematic error to the encoders' TE
almost unchanged (|H| near 1). The ROM of thesis-rig also carries the gears' lateral and axial
motion on their bearings; the helical mesh force has an axial component that the ball bearings
alone hold (the needle bearings are axially free). This script measures ``|H|`` at
input orders 2-20, 1250 rpm, 120 N m, for the nominal rig, for 100x axial ball-bearing stiffness and
for 100x on all bearing stiffnesses, together with the first modes of each. It compares them with
the linearized modes that the independent simulator ``tests/datasim`` (purely torsional, same rig
numbers) reports, and with ``|H|`` of datasim's own lumped rig linearized at its mean mesh stiffness.

Usage::

    python benchmarks/bench_rom_kinematic_response.py
"""
from __future__ import annotations

import logging
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_result  # noqa: E402

RPM, TORQUE, ORDERS, AMP = 1250.0, 120.0, (2, 4, 6, 8, 11, 14, 20), 1e-6
VARIANTS = {
    "nominal": {},
    "ball_axial_x100": {"rig.bearings.ball_axial_N_per_um": 5000.0},
    "all_bearings_x100": {"rig.bearings.ball_axial_N_per_um": 5000.0, "rig.bearings.ball_radial_N_per_um": 20000.0,
                          "rig.bearings.needle_radial_N_per_um": 30000.0},
}


def response(model, order: int, base) -> complex:
    """Sensor-TE amplitude per unit kinematic error ``AMP sin(order theta_in)`` (complex; its phase is
    relative to the record's time origin, not to the probe, so only the magnitude is reported)."""
    import gearrom.rom as rom
    from gearrom.rom import Effects, ExtraTE

    eff = Effects(extra=(ExtraTE(lambda t1, t2: AMP * np.sin(order * t1), label="probe"),))
    run = rom.simulate_run(model, RPM, TORQUE, duration_s=0.2, effects=eff, sample_rate_hz=50e3, settle_s=0.05)
    th = 2 * np.pi * RPM / 60.0 * base.time
    d = run.dte["sensor"] - base.dte["sensor"]
    return complex(2 * np.mean(d * np.exp(-1j * order * th)) / AMP)


def _datasim_response(freqs_hz) -> list[complex]:
    """Sensor TE per unit kinematic error of datasim's own lumped rig, linearized at its mean mesh
    stiffness (its mass, stiffness and damping matrices, the motor's speed gain on node 0)."""
    from datasim.geometry import geometry_from_config
    from datasim.mesh import build_mesh, mean_stiffness
    from datasim.rig import lumped, mesh_damping, rig_from_config

    g = geometry_from_config("helical")
    p = rig_from_config(g)
    k = mean_stiffness(g, build_mesh(g), TORQUE / g.rb2)
    J, springs = lumped(p)
    K, C = np.zeros((8, 8)), np.zeros((8, 8))
    for a, b, kk, c in springs:
        for M, v in ((K, kk), (C, c)):
            M[[int(a), int(b)], [int(a), int(b)]] += v
            M[int(a), int(b)] -= v
            M[int(b), int(a)] -= v
    r = np.zeros(8)
    r[2], r[4] = g.rb1, -g.rb2
    cm = mesh_damping(p, g, k)
    K += k * np.outer(r, r)
    C += cm * np.outer(r, r)
    C[0, 0] += p.c_speed
    out = []
    for f in freqs_hz:
        s = 2j * np.pi * f
        x = np.linalg.solve(s * s * np.diag(J) + s * C + K, r * (k + s * cm))
        out.append(complex(g.rb1 * x[3] - g.rb2 * x[5]))  # node 3 / 5: the encoders
    return out


def main() -> int:
    import gearrom.rom as rom
    from gearrom.config import as_config

    logging.basicConfig(level=logging.WARNING)
    warnings.simplefilter("ignore")
    cfg = as_config("thesis-rig")
    out = {"rpm_in": RPM, "torque_out_Nm": TORQUE, "orders": list(ORDERS),
           "frequencies_Hz": [q * RPM / 60.0 for q in ORDERS], "variants": {}}
    for name, ov in VARIANTS.items():
        model = rom.build_rig(rom.with_overrides(cfg, ov) if ov else cfg, TORQUE)
        ma = rom.modal_analysis(model)
        base = rom.simulate_run(model, RPM, TORQUE, duration_s=0.2, sample_rate_hz=50e3, settle_s=0.05)
        H = [response(model, q, base) for q in ORDERS]
        out["variants"][name] = {"overrides": ov, "first_modes_Hz": [round(float(f), 1) for f in ma.freqs[:3]],
                                 "first_mode_damping": round(float(ma.damping[0]), 3),
                                 "H_abs": [round(abs(h), 3) for h in H]}
        logging.getLogger("bench").warning("%s: %s", name, out["variants"][name])
    try:
        from datasim import Case, simulate

        res = simulate(Case("clean", ()), rpm_in=RPM, torque_out_Nm=TORQUE, output_revs=1, pair="helical", seed=0)
        out["datasim_modes_Hz"] = [round(float(f), 1) for f, _ in res.truth["modes_hz"][:3]]
        out["datasim_first_mode_damping"] = round(float(res.truth["modes_hz"][0][1]), 3)
        out["datasim_H_abs_linear"] = [round(abs(h), 3) for h in _datasim_response([q * RPM / 60.0 for q in ORDERS])]
    except Exception as exc:  # noqa: BLE001  (datasim lives under tests/; informative only)
        out["datasim_modes_Hz"] = f"not available: {exc}"
    write_result("bench_rom_kinematic_response", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
