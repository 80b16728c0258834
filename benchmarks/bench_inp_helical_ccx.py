"""Benchmark: the CalculiX run of the 3D helical deck against the 3D LTCA (thesis-helical, 120 N m).

Cases (each: LTCA on the mesh, deck with the output rotation prescribed at the LTCA's STE, ccx,
the LTCA again at the torque ccx transmitted; gearrom.fe.export3d.calculix_crosscheck):

* the test's case: default Mesh3DSettings, 0.3 of the mesh period, face-to-face contact, 1e7 MPa/mm;
* the coarser level 1.25 (the coarsest the LTCA's flank load patches fit in) at 0.3 and 0.5 period;
* the penalty ten times stiffer (1e8 MPa/mm) at level 1.25: the share of the penalty's own compliance;
* node-to-surface contact at level 1.25 (CalculiX advises against it for quadratic elements);
* the LTCA with its half-space near field spread over 0.2 / 0.4 mm patches across the contact lines
  (instead of 0.03 mm) at the test's case: what a mesh that does not resolve the Hertz zone misses;
* with ``--refinement`` (~45 min more): level 1.25 with 0.72 mm layers at 0.9 period (pair 0 carries
  45 % of the load there), with the default and with a 0.3 mm flank on tooth 0 (the only flank
  sector_mesh refines). Measured by hand with the same calls: ratio 0.944 and 0.967.

Run: python benchmarks/bench_inp_helical_ccx.py [--refinement]   (needs ccx: apt-get install calculix-ccx)
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small dense contact problems: threads only stall

import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

from _common import peak_memory_MB, write_result  # noqa: E402

from gearrom.config import load_config  # noqa: E402
from gearrom.fe.export3d import calculix_crosscheck  # noqa: E402
from gearrom.fe.ltca_helical import Helical3DLTCA, build_helical3d  # noqa: E402
from gearrom.fe.mesh3d import Mesh3DSettings  # noqa: E402


def main() -> None:
    warnings.simplefilter("ignore")
    pair = load_config("thesis-helical").pair
    t0 = time.perf_counter()
    cases = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        runs = [("default_mesh", 1.0, 0.3, {}), ("level_1.25", 1.25, 0.3, {}), ("level_1.25_theta_0.5", 1.25, 0.5, {}),
                ("level_1.25_penalty_1e8", 1.25, 0.3, {"penalty_MPa_per_mm": 1e8}),
                ("level_1.25_node_to_surface", 1.25, 0.3, {"contact": "node"})]
        if "--refinement" in sys.argv[1:]:
            runs += [("level_1.25_layer_0.72_theta_0.9", Mesh3DSettings(0.9e-3, 1.6e-3, 6e-3, 0.72e-3), 0.9, {}),
                     ("level_1.25_layer_0.72_tooth0_flank_0.3_theta_0.9", Mesh3DSettings(0.3e-3, 1.6e-3, 6e-3, 0.72e-3),
                      0.9, {})]
        for name, f, frac, deck in runs:
            s = f if isinstance(f, Mesh3DSettings) else Mesh3DSettings().scaled(f)
            key = f if not isinstance(f, Mesh3DSettings) else name
            r = calculix_crosscheck(pair, tmp / name, s, theta_frac=frac, torque=120.0, cache_dir=tmp / f"cache{key}",
                                    **deck)
            r.update(mesh_factor=f if not isinstance(f, Mesh3DSettings) else None, **deck)
            cases[name] = r
            print(f"{name}: ccx {r['ste_ccx_um']:.4f} um at {r['torque_out_Nm']:.2f} N m, LTCA {r['ste_ltca_um']:.4f} um, "
                  f"ratio {r['ratio']:.4f}, {r['nodes']} nodes, ccx {r['ccx_s']:.0f} s", flush=True)
        base = cases["default_mesh"]
        ltca = build_helical3d(pair, Mesh3DSettings(), cache_dir=tmp / "cache1.0")
        theta = 0.3 * ltca.period
        near = {}
        for d_mu in (0.03e-3, 0.2e-3, 0.4e-3):
            lt = Helical3DLTCA(pair, ltca.c, n_slices=24, d_mu=d_mu, half_window=6 * d_mu)
            ste = lt.solve(theta, base["torque_out_Nm"]).ste * 1e6
            near[f"d_mu_{d_mu * 1e3:.2f}mm"] = {"ste_ltca_um": ste, "ccx_over_this": base["ste_ccx_um"] / ste}
    write_result("bench_inp_helical_ccx", {
        "cases": cases, "ltca_near_field_patch_width_at_default_mesh": near,
        "acceptance": "default mesh: |ste_ccx / ste_ltca - 1| <= 5 % (tests/fe/test_fe_export3d.py)",
        "total_s": time.perf_counter() - t0, "peak_memory_MB": peak_memory_MB(),
        "note": "2 cores shared with other jobs; ccx 2.20 (Debian calculix-ccx), spooles, OMP_NUM_THREADS=2"})


if __name__ == "__main__":
    main()
