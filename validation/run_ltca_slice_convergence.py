"""Convergence of the helical 3D LTCA's static TE harmonics in its number of face-width strips.

The helical pair's static TE ripple is small (its overlap ratio is close to 2, so the contact lines'
length hardly changes over a mesh period), and at the validation speeds the dynamic TE is dominated by
the mesh orders that lie near the mesh mode (order 4 at 2000 rpm, order 7 at 1250 rpm on the seed's pair),
amplified several to 25 times. The ROM-vs-FE comparison therefore needs those orders of the static TE
converged to a few nanometres. The 3D LTCA (:class:`gearrom.fe.ltca_helical.HelicalLTCA3D`) samples the
contact lines on ``n_slices`` strips across the face width; a finite strip count adds ripple at the order
where strips pass (``n_slices / eps_beta``) and its neighbours. This study solves one mesh period (64
positions, 120 N m) with doubling strip counts, for the perfect pair and with the drawing micro-geometry,
and gives the mean and the amplitudes of mesh orders 1-10 for each.

``--patches`` studies the other discretization of the 3D LTCA instead: the grid of load patches on which
each gear's 3D FE compliance is computed (:func:`gearrom.fe.compliance3d.compute_compliance3d`, ``n_sigma``
along the profile x ``n_zeta`` over the face; bilinear between the patch centres), at a fixed strip count.

Usage: ``python validation/run_ltca_slice_convergence.py [--slices 24 48 96 192]`` or
``python validation/run_ltca_slice_convergence.py --patches 8x12 12x18 16x24 [--slices 48]``

Writes ``validation/ltca_slice_convergence_helical.json`` (``ltca_patch_convergence_helical.json``).
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import time
import warnings
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.fe.compliance3d import cached_compliance3d
from gearrom.fe.ltca_helical import Helical3DLTCA
from gearrom.fe.sweep import build_ltca, default_cache_dir, mesh_cycle

HERE = Path(__file__).resolve().parent
log = logging.getLogger("run_ltca_slice_convergence")
TORQUE = 120.0
CONFIGS = ("thesis-helical", "thesis-helical-drawing")


def _ltca(pair, n_slices: int, patches: tuple[int, int] | None):
    """The 3D LTCA of ``pair`` on ``n_slices`` strips, its compliances on the default patch grid or on
    ``patches`` = (n_sigma, n_zeta)."""
    if patches is None:
        return build_ltca(pair, n_slices=n_slices)
    comps = tuple(cached_compliance3d(pair, i, None, cache_dir=default_cache_dir(), n_sigma=patches[0],
                                      n_zeta=patches[1]) for i in range(2))
    return Helical3DLTCA(pair, comps, n_slices=n_slices)


def main(slices=(24, 48, 96, 192), n_positions: int = 64, patches=None) -> Path:
    """``patches``: a sequence of (n_sigma, n_zeta) grids, studied at ``slices[0]`` strips (the patch study)."""
    out = {"torque_Nm": TORQUE, "n_positions": n_positions, "orders": list(range(1, 11)), "cases": {}}
    cases = [(ns, None) for ns in slices] if patches is None else [(slices[0], p) for p in patches]
    for name in CONFIGS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")   # the seed pair's marginal tip-fillet interference
            pair = load_config(name).pair
        out["eps_beta"] = float(pair.eps_beta)
        for ns, grid in cases:
            t0 = time.perf_counter()
            res = mesh_cycle(_ltca(pair, ns, grid), [TORQUE], n_positions=n_positions)
            x = np.asarray(res.ste)[0]
            amp = np.abs(np.fft.rfft(x - x.mean()))[1:11] * 2 / x.size
            key = f"{name}/{ns}" + ("" if grid is None else f"/{grid[0]}x{grid[1]}")
            out["cases"][key] = {"config": name, "n_slices": ns, "mean_um": float(x.mean() * 1e6),
                                 "ptp_um": float(np.ptp(x) * 1e6), "order_amplitudes_nm": (amp * 1e9).round(3).tolist(),
                                 "wall_s": time.perf_counter() - t0}
            if grid is not None:
                out["cases"][key].update(n_sigma=grid[0], n_zeta=grid[1])
            log.info("%s: mean %.4f um, orders 1-10 %s nm", key, x.mean() * 1e6, np.round(amp * 1e9, 2).tolist())
    out["machine"] = {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()}
    path = HERE / ("ltca_slice_convergence_helical.json" if patches is None else "ltca_patch_convergence_helical.json")
    path.write_text(json.dumps(out, indent=2) + "\n")
    return path


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--slices", type=int, nargs="+", default=None,
                    help="strip counts (default 24 48 96 192; with --patches the one strip count, default 48)")
    ap.add_argument("--patches", nargs="+", default=None, help="compliance patch grids n_sigma x n_zeta, e.g. 8x12")
    a = ap.parse_args()
    grids = None
    if a.patches:
        try:
            grids = [tuple(int(v) for v in g.lower().split("x")) for g in a.patches]
        except ValueError:
            ap.error(f"--patches: grids are n_sigma x n_zeta such as 8x12, got {a.patches}")
        if any(len(g) != 2 or min(g) < 2 for g in grids):
            ap.error(f"--patches: grids are two counts >= 2 such as 8x12, got {a.patches}")
    main(tuple(a.slices or ([48] if grids else [24, 48, 96, 192])), patches=grids)
