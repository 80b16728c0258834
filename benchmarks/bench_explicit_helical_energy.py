"""Energy balance of the explicit helical pair at speed from its loaded static state: where it jumps.

Usage: ``python benchmarks/bench_explicit_helical_energy.py [--outline-mm 0.5] [--layers 8] [--rpm 2000]
[--duration-ms 0.3]``

A coarse tooth-periodic model of the seed's helical pair (``--sag-um``: its outline refined where it curves,
the tip-edge roundings) (whole bodies, penalty scale 3, the reference's
relative damping 1.468e5 1/s) starts from its direct static solve at 120 N m with the rigid-body speeds and
runs ``--duration-ms``. Variants on the same model and start: ``base`` (the references' contact),
``nosag`` (the facets' sag not restored), ``cand64`` (64 candidate facets per slave instead of 32),
``noends`` (no slave nodes on the two end faces), ``undamped``. Figures per variant: the final balance error
and its four largest steps between samples with their times, next to the peak internal energy; the period
at which the contact line passes a layer plane, ``(mesh period) eps_beta / n_layers``, for comparison with
the steps' spacing. The references' gate allows 1 % of the peak internal energy over the whole run.
Writes ``benchmarks/results/bench_explicit_helical_energy_<outline>mm_<layers>layers.json``.
"""
from __future__ import annotations

import argparse
import dataclasses
import logging
import time
import warnings

import numpy as np

from _common import write_result
from gearrom.config import load_config
from gearrom.fe.explicit.driver import prepare, solve
from gearrom.fe.explicit.gearpair import GearPairSetup, loaded_model
from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model
from gearrom.fe.explicit.result import ENERGY_NAMES
from gearrom.fe.explicit.static3d import StaticPair3D

ALPHA = 1.468e5   # validation/ringdown_helical.json
VARIANTS = ("base", "nosag", "cand64", "noends", "undamped")


def _without_end_slaves(model):
    z = model.nodes[:, 2]
    zmax = np.abs(z).max()
    sets = dict(model.node_sets)
    for k in ("flank_1", "flank_2"):
        ids = np.asarray(sets[k])
        sets[k] = ids[np.abs(z[ids]) < zmax - 1e-9]
    return dataclasses.replace(model, node_sets=sets)


def run_variant(pair, meshes, layers: int, rpm: float, duration: float, name: str, states: dict) -> dict:
    setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, start="loaded", integration="full", mass_scaling_dt=6e-8,
                          penalty_scale=3.0, hourglass_stiffness=0.1,
                          relative_damping=0.0 if name == "undamped" else ALPHA)
    model, info = helical_pair_model(pair, meshes, setup, layers)
    if name == "noends":
        model = _without_end_slaves(model)
    key = "noends" if name == "noends" else "model"
    if key not in states:
        states[key] = StaticPair3D(model, info, pair).loaded_state(120.0)
    u, theta, _ = states[key]
    run = loaded_model(model, info, setup, (u, theta, 0.0))
    d = prepare(run, 0.9, 64 if name == "cand64" else 32)
    if name == "nosag":
        d["seg_sag"][:] = 0.0
    t0 = time.perf_counter()
    res = solve(run, duration, duration / 120, prepared=d, chunks=6, parallel=True)
    e = {k: res.energies[:, j] for j, k in enumerate(ENERGY_NAMES)}
    be = e["balance_error"]
    steps = np.diff(be)
    big = np.argsort(np.abs(steps))[-4:][::-1]
    peak = float(np.max(e["internal"] + e["contact"] + e["hourglass"]))
    out = {"final_balance_error_J": float(be[-1]), "max_abs_balance_error_J": float(np.abs(be).max()),
           "peak_internal_J": peak, "max_error_rel_peak_internal": float(np.abs(be).max() / peak),
           "largest_steps": [{"t_ms": float(res.t[i] * 1e3), "step_J": float(steps[i])} for i in big],
           "wall_s": time.perf_counter() - t0}
    logging.info("%s: balance error %.3g J (%.2f %% of peak internal), largest steps %s", name, be[-1],
                 100 * out["max_error_rel_peak_internal"], [(round(s["t_ms"], 4), s["step_J"]) for s in out["largest_steps"]])
    return out


def main(outline: float, layers: int, rpm: float, duration: float, variants=VARIANTS, sag: float | None = None) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # the seed pair's marginal tip-fillet interference
        pair = load_config("thesis-helical").pair
    meshes = helical_meshes(pair, outline, 3e-3, 1e-3, periodic=True, sag=sag)
    mesh_period = 60.0 / (rpm * pair.z[0])
    figs = {"outline_size_mm": outline * 1e3, "outline_sag_um": None if sag is None else sag * 1e6, "n_layers": layers, "rpm_in": rpm, "duration_ms": duration * 1e3,
            "mesh_period_ms": mesh_period * 1e3,
            "layer_passing_period_ms": mesh_period * float(pair.eps_beta) / layers * 1e3, "variants": {}}
    states: dict = {}
    for name in variants:
        figs["variants"][name] = run_variant(pair, meshes, layers, rpm, duration, name, states)
    return figs


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--outline-mm", type=float, default=0.5)
    ap.add_argument("--layers", type=int, default=8)
    ap.add_argument("--rpm", type=float, default=2000.0)
    ap.add_argument("--duration-ms", type=float, default=0.3)
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    ap.add_argument("--sag-um", type=float, default=None,
                    help="refine the outline where it curves (tip-edge roundings) to chords within this of the profile")
    a = ap.parse_args()
    f = main(a.outline_mm * 1e-3, a.layers, a.rpm, a.duration_ms * 1e-3, a.variants,
             None if a.sag_um is None else a.sag_um * 1e-6)
    write_result(f"bench_explicit_helical_energy_{a.outline_mm:g}mm_{a.layers}layers"
                 + ("" if a.sag_um is None else f"_sag{a.sag_um:g}um"), f)
