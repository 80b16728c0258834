"""Damping ring-down of an explicit gear pair: the relative damping that gives a target ratio at the mesh mode.

Usage: ``python validation/run_ringdown.py [--pair spur|helical] [--zeta 0.02] [--alpha0 2e4] [--duration-ms 0.8]``
(writes validation/ringdown_<pair>.json and .npz).

The pair (the reference model of ``--pair``: :data:`REFERENCE_MESH` for the spur, :data:`REFERENCE_MESH_HELICAL`
for the helical pair) starts from its loaded static state at 120 N m with the input held; at t = 0 the
output torque steps to 132 N m, and the transmission error rings at the mesh mode about the new static
value. A damped sinusoid ``C + A exp(-zeta w t) cos(w_d t + phi)`` (w_d = w sqrt(1 - zeta^2)) is fitted
by least squares to the record after the first 0.05 ms (the higher body modes, which the mass
proportional damping takes out faster, are gone by then). Mass-proportional damping on the velocity
relative to each gear's rigid rotation gives a modal ratio proportional to alpha_r at one mode, so
the run at ``alpha0`` gives ``alpha_r = alpha0 zeta_target / zeta_0``, and a second run at alpha_r
checks it (pass: within 10 % of the target). This alpha_r is used by the reference runs
(``run_explicit_spur.py --start loaded``, ``run_explicit_helical.py``) and the ROM gets the same ratio at
its mesh mode. The spur's loaded state is the dynamic relaxation of its model, the helical one the direct
static solve of its model (:meth:`gearrom.fe.explicit.static3d.StaticPair3D.loaded_state`).
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
from scipy.optimize import curve_fit

from gearrom.config import load_config
from gearrom.fe.explicit.driver import fingerprint, solve
from gearrom.fe.explicit.gearmesh import gear_quad_mesh
from gearrom.fe.explicit.driver import prepare
from gearrom.fe.explicit.gearpair import (GearPairSetup, gear_pair_model, loaded_model, relaxed_state,
                                          stored_meshes, start_state_key, stored_start_state,
                                          transmission_error)
from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model

HERE = Path(__file__).resolve().parent
log = logging.getLogger("ringdown")
#: checkpoints of the ring-down runs (git-ignored, shared with the reference runs)
CHECKPOINTS = HERE / "checkpoints"

#: the reference model's discretization, shared by the ring-down and the reference runs (recorded in
#: ringdown_spur.json, read by run_explicit_spur.py): 0.15 mm outline refined above the base circle to
#: chords within 0.25 um of the profile, 0.75 mm body, contact penalty scale 1, selective mass scaling of
#: the refined outline nodes up to the step of the unrefined 0.15 mm mesh. Chosen by the static
#: consistency study (validation/static_gate_spur_*.json): the finest outline matches the LTCA's static
#: TE curve shape (GMF1-3 within 4 %); with 1.5 mm body elements the fully integrated Q4 are too stiff in
#: tooth bending (mean TE 2.4 % below the LTCA), with 0.75 mm the mean is within 1 % of it. Tooth-periodic
#: (one tooth sector copied around the gear): a whole-gear mesh gives each tooth its own mesh, and the
#: static TE of the same mesh phase then differs from tooth pair to tooth pair
#: (validation/tooth_scatter_spur.json), which the references carry as shaft-order content.
REFERENCE_MESH = {"outline_size_m": 0.15e-3, "body_size_m": 0.75e-3, "sag_m": 0.25e-6, "mass_scaling_dt_s": 3.0e-9,
                  "penalty_scale": 1.0, "periodic": True}


#: the helical reference model (whole gear bodies to the bores), shared by the ring-down and
#: run_explicit_helical.py through ringdown_helical.json: the transverse Q4 section with 0.15 mm outline
#: elements on the generated profile, 2.5 mm body elements from 1 mm below the outline, 16 twisted Hex8
#: layers (1.125 mm) over the face width, fully integrated, contact penalty scale 3, selective mass
#: scaling to a 2.2e-8 s step. Chosen by the static consistency study
#: (validation/static_gate_helical_*.json): with 8 layers or the 0.3 mm outline the mean static TE misses the
#: helical gate against the 3D LTCA at 60 N m; 16 layers of the 0.15 mm outline pass it from penalty scale 3
#: up, and penalty 3 stays close to hard contact there. The mass scaling lifts the step of the thinnest
#: outline elements; the ROM takes the run's polar inertias (scaled masses included). Tooth-periodic
#: sections: the perfect helical pair's mesh-periodic TE is a fraction of a micrometre, so the per-tooth
#: compliance scatter of a whole-gear mesh would dominate the records' non-periodic part and drift.
#: Outline sag 1 um: the tip-edge roundings are refined (chords down to a quarter of the outline size) so
#: that a contact node sliding over them crosses no sharp facet kink, where the node-to-facet gap and
#: force jump and the explicit integration gains or loses energy in steps at speed
#: (benchmarks/bench_explicit_helical_energy.py); the flanks' chords are within 1 um already.
REFERENCE_MESH_HELICAL = {"outline_size_m": 0.15e-3, "body_size_m": 2.5e-3, "grading_m": 1.0e-3, "n_layers": 16,
                          "sag_m": 1.0e-6, "mass_scaling_dt_s": 2.2e-8, "penalty_scale": 3.0,
                          "hourglass_stiffness": 0.1, "max_candidates": 32, "periodic": True}
REFERENCE = {"spur": REFERENCE_MESH, "helical": REFERENCE_MESH_HELICAL}


def calibration(kind: str) -> dict:
    """The stored ring-down of the ``kind`` reference model (``validation/ringdown_<kind>.json``); exits with the
    command to run when it is missing or missed its target ratio."""
    path = HERE / f"ringdown_{kind}.json"
    if not path.is_file():
        sys.exit(f"{path} is missing: run 'python validation/run_ringdown.py --pair {kind}' first (it calibrates "
                 "the damping)")
    d = json.loads(path.read_text())
    if not d.get("within_10_percent"):
        sys.exit(f"{path}: the ring-down did not reach its target damping ratio; rerun it")
    return d


def settling(cal: dict, f_mesh: float, decay_times: float = 5.0) -> tuple[float, float, float, float, int]:
    """``(alpha_r [1/s], zeta, mesh-mode frequency [Hz], decay time 1 / (zeta w) [s], mesh periods covering
    ``decay_times`` decay times)`` of a ring-down calibration at mesh frequency ``f_mesh`` [Hz]: after n decay
    times the start transient is exp(-n) of its size (five: below 1 %; three: below 5 %)."""
    alpha, zeta, f_mode = cal["alpha_r_per_s"], cal["zeta_target"], cal["runs"][-1]["frequency_Hz"]
    tau = 1.0 / (zeta * 2 * math.pi * f_mode)
    return alpha, zeta, f_mode, tau, math.ceil(decay_times * tau * f_mesh)


def reference_meshes(pair, mesh: dict = REFERENCE_MESH, prefix: str | None = None):
    """The two gear meshes of the reference model (transverse sections of a helical pair), stored in
    ``checkpoints/<prefix>_reference_meshes.npz`` on first use and read from there afterwards: a
    checkpointed reference resumed on another machine rebuilds the same model bit for bit, whatever gmsh
    makes there (:func:`gearrom.fe.explicit.gearpair.stored_meshes`). ``prefix``: the records' prefix
    (:func:`gearrom.validation.records.record_prefix`; default ``spur`` / ``helical``), so that pairs with
    micro-geometry keep their own file and never replace the meshes another pair's checkpoint was made on."""
    import hashlib

    def build():
        if pair.is_helical:
            return helical_meshes(pair, mesh["outline_size_m"], mesh["body_size_m"], mesh["grading_m"],
                                  sag=mesh["sag_m"], periodic=mesh.get("periodic", False))
        return [gear_quad_mesh(pair, i, mesh["outline_size_m"], mesh["body_size_m"], sag=mesh["sag_m"],
                               periodic=mesh.get("periodic", False)) for i in (0, 1)]

    key = hashlib.sha1((repr(pair) + repr(sorted(mesh.items()))).encode()).hexdigest()
    kind = prefix or ("helical" if pair.is_helical else "spur")
    return stored_meshes(CHECKPOINTS / f"{kind}_reference_meshes.npz", key, build)


def reference_setup(mesh: dict, **kw) -> GearPairSetup:
    """The reference model's operating point: fully integrated, its mass scaling and penalty, ``kw`` on top."""
    extra = {"hourglass_stiffness": mesh["hourglass_stiffness"]} if "hourglass_stiffness" in mesh else {}
    return GearPairSetup(integration="full", mass_scaling_dt=mesh["mass_scaling_dt_s"],
                         penalty_scale=mesh["penalty_scale"], **extra, **kw)


def reference_model(pair, meshes, setup: GearPairSetup, mesh: dict):
    """``(model, info)`` of the reference pair (helical: whole bodies, ``mesh["n_layers"]`` layers)."""
    if pair.is_helical:
        return helical_pair_model(pair, meshes, setup, mesh["n_layers"])
    return gear_pair_model(pair, meshes, setup)


def loaded_state(pair, model, info, torque: float):
    """The reference model's loaded static state ``(u, theta, value)`` at ``torque`` [N m] (helical: value is
    the state's TE, m; spur: the relaxation's residual)."""
    if pair.is_helical:
        from gearrom.fe.explicit.static3d import StaticPair3D

        return StaticPair3D(model, info, pair).loaded_state(torque)
    return relaxed_state(model, torque)


def fit_ringdown(t: np.ndarray, y: np.ndarray) -> dict:
    """Least-squares damped sinusoid; returns frequency (Hz), damping ratio and the fit's RMS residual."""
    yc = y - y[len(y) // 2:].mean()
    spec = np.abs(np.fft.rfft(yc * np.hanning(len(yc))))
    freqs = np.fft.rfftfreq(len(yc), t[1] - t[0])
    f0 = freqs[1 + np.argmax(spec[1:])]

    def model(tt, c, a, zeta, f, phi):
        w = 2 * np.pi * f
        return c + a * np.exp(-zeta * w * tt) * np.cos(w * np.sqrt(1 - zeta ** 2) * tt + phi)

    tt = t - t[0]
    p0 = [y[len(y) // 2:].mean(), np.abs(yc).max(), 0.02, f0, 0.0]
    best = None
    for phi in np.linspace(-np.pi, np.pi, 8, endpoint=False):
        p0[4] = phi
        try:
            p, _ = curve_fit(model, tt, y, p0=p0, maxfev=20000)
        except RuntimeError:
            continue
        r = float(np.sqrt(np.mean((model(tt, *p) - y) ** 2)))
        if best is None or r < best[1]:
            best = (p, r)
    p, r = best
    return {"frequency_Hz": float(p[3]), "zeta": float(p[2]), "amplitude_um": float(abs(p[1]) * 1e6),
            "final_te_um": float(p[0] * 1e6), "fit_rms_um": r * 1e6, "fft_peak_Hz": float(f0)}


def ringdown(pair, meshes, alpha: float, duration: float, relaxed=None, torque0: float = 120.0,
             torque1: float = 132.0, skip: float = 0.05e-3, parallel: bool = True, mesh: dict = REFERENCE_MESH):
    setup = reference_setup(mesh, rpm_in=1e-4, torque_out=torque1, start="loaded", relative_damping=alpha)
    model, info = reference_model(pair, meshes, setup, mesh)
    # checkpointed (a run takes tens of minutes on one core): running the script again resumes it; the
    # loaded state is stored beside the checkpoint (a resumed run must start from the same state bit for bit)
    CHECKPOINTS.mkdir(exist_ok=True)
    kind = "helical_" if pair.is_helical else ""
    checkpoint = CHECKPOINTS / f"ringdown_{kind}alpha{alpha:.10g}.ckpt.npz"
    if relaxed is None:
        relaxed = stored_start_state(checkpoint, ".loaded.npz", "value", model.nodes.shape, torque0,
                                     lambda: loaded_state(pair, model, info, torque0), key=start_state_key(model))
    run = loaded_model(model, info, setup, relaxed)
    # a finished run keeps its record and fit beside the checkpoint (<name>.done.npz, a few kB): a calibration
    # continued on another machine needs neither the run's checkpoint nor its steps again
    done = checkpoint.with_name(checkpoint.name.replace(".ckpt.npz", ".done.npz"))
    key = fingerprint(run, duration=duration, skip=skip, parallel=parallel)
    if done.is_file():
        with np.load(done) as z:
            if str(z["key"]) == key:
                fit = json.loads(str(z["fit"]))
                log.info("alpha_r %.4g 1/s: zeta %.4f at %.1f Hz (finished run, %s)", alpha, fit["zeta"],
                         fit["frequency_Hz"], done.name)
                return fit, relaxed, z["t_s"].copy(), z["te_m"].copy()
            log.warning("%s belongs to another model or run settings: ignored", done.name)
    res = solve(run, duration, 2e-6, parallel=parallel, chunks=40,
                prepared=prepare(run, 0.9, mesh.get("max_candidates")), checkpoint=checkpoint,
                checkpoint_every=120.0)
    te = transmission_error(res, info["rb"], info["clearance_angle"])
    w = res.t >= skip
    fit = fit_ringdown(res.t[w], te[w])
    fit.update(alpha_r_per_s=alpha, wall_s=res.meta["wall_time_s"], dt_s=res.meta["dt_s"],
               energy_error=res.energy_error, n_elements=res.meta["n_elements"],
               added_mass_kg=res.meta.get("added_mass_kg", 0.0))
    log.info("alpha_r %.4g 1/s: zeta %.4f at %.1f Hz (fit rms %.3f um)", alpha, fit["zeta"], fit["frequency_Hz"],
             fit["fit_rms_um"])
    from gearrom.fe.cache import atomic_path

    with atomic_path(done) as tmp:
        np.savez(tmp, key=np.array(key), fit=np.array(json.dumps(fit)), t_s=res.t, te_m=te)
    return fit, relaxed, res.t, te


def main(zeta: float, alpha0: float, duration: float, parallel: bool = True, kind: str = "spur",
         accept: float = 0.0) -> Path:
    """Ring-down at ``alpha0``, then at the corrected alpha_r; with ``accept`` > 0 a first run whose measured
    ratio is within that relative distance of the target is the calibration itself (no second run)."""
    config = f"thesis-{kind}"
    pair = load_config(config).pair
    mesh = REFERENCE[kind]
    meshes = reference_meshes(pair, mesh)
    fit0, relaxed, t_a, te_a = ringdown(pair, meshes, alpha0, duration, parallel=parallel, mesh=mesh)
    if abs(fit0["zeta"] / zeta - 1) <= accept:
        alpha1, fit1, t_b, te_b, runs = alpha0, fit0, t_a, te_a, [fit0]
    else:
        alpha1 = alpha0 * zeta / fit0["zeta"]
        fit1, _, t_b, te_b = ringdown(pair, meshes, alpha1, duration, relaxed, parallel=parallel, mesh=mesh)
        runs = [fit0, fit1]
    out = {"config": config, "integration": "full", "mesh": mesh,
           "torque_step_Nm": [120.0, 132.0], "zeta_target": zeta, "runs": runs,
           "alpha_r_per_s": alpha1, "zeta_measured": fit1["zeta"],
           "within_10_percent": bool(abs(fit1["zeta"] / zeta - 1) < 0.1),
           "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(),
                       "load_average": os.getloadavg()}}
    stem = HERE / f"ringdown_{kind}"
    np.savez_compressed(stem.with_suffix(".npz"), t0_s=t_a, te0_m=te_a, t1_s=t_b, te1_m=te_b)
    stem.with_suffix(".json").write_text(json.dumps(out, indent=2) + "\n")
    return stem


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pair", choices=("spur", "helical"), default="spur", help="which reference model")
    ap.add_argument("--zeta", type=float, default=0.02, help="target damping ratio at the mesh mode")
    ap.add_argument("--alpha0", type=float, default=2e4, help="relative damping of the first run, 1/s")
    ap.add_argument("--duration-ms", type=float, default=0.8)
    ap.add_argument("--serial", action="store_true", help="one thread (leaves the other core to another job)")
    ap.add_argument("--accept", type=float, default=0.0,
                    help="relative distance from the target zeta within which the first run is the calibration "
                         "(no corrected second run); 0 always runs the second")
    a = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    main(a.zeta, a.alpha0, a.duration_ms * 1e-3, parallel=not a.serial, kind=a.pair, accept=a.accept)
