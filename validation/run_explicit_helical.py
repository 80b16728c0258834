"""Reference explicit FE runs of the seed's helical pair (3D Hex8), 120 N m on the output.

Usage: ``python validation/run_explicit_helical.py RPM [PERIODS] [--start loaded|gap] [--settle N] [--parallel]
[--wall-limit-h H]``.

``--start loaded`` (the validation reference, default): the reference model of
``validation/ringdown_helical.json`` (whole gear bodies to the bores, the mesh, layers, penalty and mass
scaling of the static consistency study, see ``run_ringdown.REFERENCE_MESH_HELICAL``) starts from its
loaded static state at the start position (direct static solve of the same model on its deformed contact
geometry, :meth:`gearrom.fe.explicit.static3d.StaticPair3D.loaded_state`), each gear at its rigid-body speed,
the full output torque from t = 0, with the ring-down's relative damping (damping ratio zeta at the mesh
mode, on the velocity relative to each gear's rigid rotation). It settles for ``--settle`` mesh periods
(default: the periods covering :data:`SETTLE_DECAY_TIMES` time constants 1 / (zeta w_mesh-mode)) and records
PERIODS (default 10). It writes ``helical_<rpm>rpm_loaded.npz/.json``. The run checkpoints into
``validation/checkpoints/`` every few minutes; the same command resumes it bit for bit (``--wall-limit-h``
stops a sitting cleanly after a checkpoint, exit code 3). This is a job of hours on two cores
(``--parallel``). A finished record whose steady-state gate fails is continued to a longer settle from its
checkpoint: delete its ``.json`` and rerun with a larger ``--settle`` (the run extended to the later end is bit
for bit the run made to that end at once).

``--start gap`` (the older records ``helical_<rpm>rpm_full.*``): both gears at speed from a 1 um gap, the
output torque ramped in over 0.3 ms, one settling mesh period, no damping; transverse mesh with 0.3 mm
outline elements, 8 twisted layers, each gear cut to the sector that meshes during the run (the removed
inertia added to its reference node), contact penalty 0.1.

Frictionless flanks (mu = 0), fully integrated Hex8 (2x2x2 Gauss), no extra inertia on the reference nodes.
"""
from __future__ import annotations

import json
import logging
import os
import platform
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from gearrom.config import load_config
from gearrom.errors import RunInterrupted
from gearrom.fe.explicit.gearpair import GearPairSetup
from gearrom.fe.explicit.helicalpair import helical_meshes, run_helical_pair
from gearrom.fe.explicit.result import ENERGY_NAMES
from gearrom.validation.records import pair_key, record_prefix, record_stem

HERE = Path(__file__).resolve().parent
log = logging.getLogger("run_explicit_helical")

#: mesh and step of the gap-start records (the validation report rebuilds the output inertia from them)
OUTLINE, BODY, GRADING, LAYERS, MASS_SCALING_DT = 0.3e-3, 2.5e-3, 1.0e-3, 8, 2.2e-8
#: 3D contact penalty and hourglass stiffness (the spur's 0.3 penalty made the 3D node-to-facet contact
#: pump energy in bursts under load; 0.1 keeps the energy balance, with little change of the TE)
PENALTY, HOURGLASS = 0.1, 0.1
#: output layer planes half a layer off the input's: with matching planes every contact node sits on a master
#: facet crease, and switching between the two facets' normals pumped energy into the run in bursts
STAGGER = False
#: decay times 1 / (zeta w) of the mesh mode settled before the record of a loaded start: the start from the
#: loaded static state at rigid-body speed leaves only the dynamic part of the response as free vibration,
#: a fraction of the DTE, which three decay times bring to 5 % of its size, well inside the steady-state gate
#: (non-periodic rest below 10 % of the DTE RMS); the size and decay measured on the 2000 rpm record are in
#: docs/validation.md
SETTLE_DECAY_TIMES = 3.0


def loaded_case(rpm: float, periods: int = 10, settle_periods: int | None = None, cal: dict | None = None,
                out_dir: Path = HERE, config: str = "thesis-helical") -> SimpleNamespace:
    """Everything that defines the loaded-start reference of ``config`` at ``rpm``, without running it: the
    pair, the model's meshes and set-up, the damping and settling (:func:`run_ringdown.settling`), ``t_end``,
    the record's stem and its checkpoint path. ``cal``: a ring-down calibration (default: the stored
    ``ringdown_helical.json``, whose ``mesh`` is the model)."""
    from run_ringdown import calibration, reference_meshes, reference_setup, settling

    stored = cal is None
    cal = calibration("helical") if stored else cal
    mesh = cal["mesh"]
    cfg = load_config(config)
    pair = cfg.pair
    if not pair.is_helical:
        sys.exit(f"{config}: not a helical pair (run_explicit_spur.py makes the spur references)")
    prefix = record_prefix(pair, cfg.name)
    meshes = reference_meshes(pair, mesh, prefix) if stored else helical_meshes(
        pair, mesh["outline_size_m"], mesh["body_size_m"], mesh["grading_m"], sag=mesh["sag_m"],
        periodic=mesh.get("periodic", False))
    f_mesh = rpm / 60 * pair.z[0]
    alpha, zeta, f_mode, tau, settle_default = settling(cal, f_mesh, SETTLE_DECAY_TIMES)
    if settle_periods is None:
        settle_periods = settle_default
    setup = reference_setup(mesh, rpm_in=rpm, torque_out=120.0, mu=0.0, start="loaded", relative_damping=alpha)
    stem = record_stem(out_dir, rpm, prefix, "loaded")
    return SimpleNamespace(cfg=cfg, pair=pair, cal=cal, stored=stored, mesh=mesh, meshes=meshes, f_mesh=f_mesh,
                           alpha=alpha, zeta=zeta, f_mode=f_mode, tau=tau, settle_periods=settle_periods,
                           periods=periods, t_end=(settle_periods + periods) / f_mesh, setup=setup, stem=stem,
                           checkpoint=Path(out_dir) / "checkpoints" / (stem.name + ".ckpt.npz"))


def main_loaded(rpm: float, periods: int = 10, settle_periods: int | None = None, parallel: bool = False,
                wall_limit: float | None = None, cal: dict | None = None, out_dir: Path = HERE,
                config: str = "thesis-helical") -> Path:
    """Run one speed from the loaded static state; write ``helical_<rpm>rpm_loaded.npz/.json`` into ``out_dir``
    (checkpoints in its ``checkpoints/``). ``cal``: a ring-down calibration (default: the stored
    ``ringdown_helical.json``, whose ``mesh`` is the model); a coarse one makes a dry run of the whole chain."""
    case = loaded_case(rpm, periods, settle_periods, cal, out_dir, config)
    cfg, pair, cal, mesh, meshes, f_mesh = case.cfg, case.pair, case.cal, case.mesh, case.meshes, case.f_mesh
    alpha, zeta, f_mode, tau, settle_periods = case.alpha, case.zeta, case.f_mode, case.tau, case.settle_periods
    t_end, setup, stem, checkpoint = case.t_end, case.setup, case.stem, case.checkpoint
    checkpoint.parent.mkdir(parents=True, exist_ok=True)
    if case.stored and pair_key(pair) == pair_key(load_config("thesis-helical").pair):   # the ring-down's pair
        _seed_loaded_state(checkpoint, cal)
    t0 = time.perf_counter()
    try:
        res, te, info = run_helical_pair(pair, meshes, setup, t_end=t_end, sample_period=1.0 / (f_mesh * 128),
                                         n_layers=mesh["n_layers"], max_candidates=mesh["max_candidates"],
                                         sector=False, parallel=parallel, checkpoint=checkpoint,
                                         chunks=8 * (settle_periods + periods), checkpoint_every=300.0,
                                         wall_limit=wall_limit)
    except RunInterrupted as exc:
        log.info("%s", exc)
        sys.exit(3)
    np.savez_compressed(stem.with_suffix(".npz"), t_s=res.t, te_m=te, theta_rad=res.theta,
                        **{f"energy_{k}": res.energies[:, j] for j, k in enumerate(ENERGY_NAMES)})
    meta = {
        "config": cfg.name, "pair_key": pair_key(pair), "rpm_in": rpm, "torque_out_Nm": 120.0, "mu": 0.0,
        "start": "loaded",
        "mesh_frequency_Hz": f_mesh, "ramp_s": 0.0, "t_steady_from_s": settle_periods / f_mesh, "t_end_s": t_end,
        "settle_periods": settle_periods, "mesh_periods_recorded": periods, "integration": "full",
        "threads": 2 if parallel else 1, "outline_size_mm": mesh["outline_size_m"] * 1e3,
        "body_size_mm": mesh["body_size_m"] * 1e3, "grading_mm": mesh["grading_m"] * 1e3,
        "n_layers": mesh["n_layers"], "layer_mm": info["layer_m"] * 1e3, "face_width_mm": info["width_m"] * 1e3,
        "flank_spacing_mm": info["flank_spacing_m"] * 1e3, "sector_model": False,
        "loaded_te_um": info["loaded_te_m"] * 1e6, "penalty_scale": mesh["penalty_scale"],
        "n_elements": res.meta["n_elements"], "n_nodes": res.meta["n_nodes"], "dt_s": res.meta["dt_s"],
        "n_steps": res.meta["n_steps"], "wall_s": res.meta["wall_time_s"],
        "wall_this_sitting_s": time.perf_counter() - t0, "mass_scaling_dt_s": mesh["mass_scaling_dt_s"],
        "added_mass_kg": res.meta.get("added_mass_kg", 0.0), "energy_error": res.energy_error,
        "relative_damping_per_s": alpha, "zeta_target": zeta, "zeta_measured": cal["zeta_measured"],
        "mesh_mode_Hz": f_mode, "decay_time_s": tau,
        "inertia_out_kgm2": res.meta.get("inertia_out_kgm2"), "inertia_in_kgm2": res.meta.get("inertia_in_kgm2"),
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()},
        "te_definition": "rb1*theta1 - rb2*theta2 on the transverse line of action (transverse base radii), m, "
                         "positive when the output lags",
    }
    stem.with_suffix(".json").write_text(json.dumps(meta, indent=2, default=float) + "\n")
    return stem


def _seed_loaded_state(checkpoint: Path, cal: dict) -> None:
    """Start a new reference from the ring-down's loaded static state when it has none of its own.

    The direct static solve depends on the model's mesh, contact and output torque only (not on the speed
    or the damping), and the ring-down solved the same model at the same 120 N m: its stored state saves a
    solve of about a quarter of an hour and 10 GB. The run's own check (displacement shape, torque, and the
    model and contact rule the state was solved for, :func:`gearrom.fe.explicit.gearpair.stored_start_state`)
    still applies: a state of another contact rule is solved again.
    """
    target = Path(str(checkpoint) + ".loaded.npz")
    alpha = cal["runs"][0]["alpha_r_per_s"]
    source = HERE / "checkpoints" / f"ringdown_helical_alpha{alpha:.10g}.ckpt.npz.loaded.npz"
    if target.is_file() or not source.is_file():
        return
    from gearrom.fe.cache import atomic_path

    with np.load(source) as z:
        if "value" not in z or float(z["value"]) == 0.0:
            return                      # a ring-down state without its TE
        with atomic_path(target) as tmp:
            np.savez(tmp, u=z["u"], theta=z["theta"], torque=z["torque"], te=z["value"],
                     key=z["key"] if "key" in z else np.array(""))
    log.info("loaded start taken from the ring-down's static solve (%s)", source.name)


def main(rpm: float, periods: int = 5, settle_periods: int = 1, out_dir: Path = HERE,
         t_end: float | None = None, integration: str = "full", parallel: bool = False) -> Path:
    """The gap-start record: run one speed and write ``helical_<rpm>rpm[_full].npz/.json`` into ``out_dir``;
    ``t_end`` overrides the length."""
    pair = load_config("thesis-helical").pair
    meshes = helical_meshes(pair, OUTLINE, BODY, GRADING)
    f_mesh = rpm / 60 * pair.z[0]
    ramp = 0.3e-3
    t_end = t_end or ramp + (settle_periods + periods) / f_mesh
    setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, torque_ramp_time=ramp, mu=0.0,
                          mass_scaling_dt=MASS_SCALING_DT, penalty_scale=PENALTY, hourglass_stiffness=HOURGLASS,
                          integration=integration)
    t0 = time.perf_counter()
    res, te, info = run_helical_pair(pair, meshes, setup, t_end=t_end, sample_period=1.0 / (f_mesh * 128),
                                     n_layers=LAYERS, parallel=parallel, stagger=STAGGER)
    wall = time.perf_counter() - t0
    stem = Path(out_dir) / (f"helical_{int(rpm)}rpm" + ("" if integration == "reduced" else f"_{integration}"))
    t_start = ramp + settle_periods / f_mesh
    np.savez_compressed(stem.with_suffix(".npz"), t_s=res.t, te_m=te, theta_rad=res.theta,
                        **{f"energy_{k}": res.energies[:, j] for j, k in enumerate(ENERGY_NAMES)})
    meta = {
        "config": "thesis-helical", "rpm_in": rpm, "torque_out_Nm": 120.0, "mu": 0.0,
        "mesh_frequency_Hz": f_mesh, "ramp_s": ramp, "t_steady_from_s": t_start, "t_end_s": float(res.t[-1]),
        "mesh_periods_recorded": periods, "outline_size_mm": OUTLINE * 1e3, "body_size_mm": BODY * 1e3,
        "grading_mm": GRADING * 1e3, "n_layers": LAYERS, "layer_mm": info["layer_m"] * 1e3,
        "face_width_mm": info["width_m"] * 1e3, "flank_spacing_mm": info["flank_spacing_m"] * 1e3,
        "layer_rigid_slack_spread_um": float(np.ptp(info["layer_slack_m"]) * 1e6),
        "n_elements": res.meta["n_elements"], "n_nodes": res.meta["n_nodes"], "dt_s": res.meta["dt_s"],
        "dt_stable_s": res.meta["dt_stable_s"], "mass_scaling_dt_s": MASS_SCALING_DT,
        "added_mass_kg": res.meta["added_mass_kg"], "total_mass_kg": res.meta["total_mass_kg"],
        "n_steps": res.meta["n_steps"], "wall_s": wall, "penalty_scale": PENALTY, "hourglass_stiffness": HOURGLASS,
        "staggered_layers": STAGGER,
        "sector_model": True, "removed_inertia_kgm2": info["removed_inertia_kgm2"],
        "ns_per_element_step": wall / (res.meta["n_steps"] * res.meta["n_elements"]) * 1e9,
        "integration": integration, "threads": 2 if parallel else 1,
        "start_gap_loa_um": float(info["start_gap_loa_m"][-1] * 1e6),
        "hourglass_ratio": res.hourglass_ratio, "energy_error": res.energy_error,
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()},
        "te_definition": "rb1*theta1 - rb2*theta2 on the transverse line of action (transverse base radii), m, "
                         "positive when the output lags",
    }
    stem.with_suffix(".json").write_text(json.dumps(meta, indent=2, default=float) + "\n")
    return stem


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rpm", type=float)
    ap.add_argument("periods", type=int, nargs="?", default=None,
                    help="recorded mesh periods (default 10 for the loaded start, 5 for the gap start)")
    ap.add_argument("--start", choices=("loaded", "gap"), default="loaded", help="initial state (module docstring)")
    ap.add_argument("--settle", type=int, default=None, help="mesh periods discarded before the record")
    ap.add_argument("--integration", choices=("reduced", "full"), default="full",
                    help="gap start: element integration; 'full' (default) writes helical_<rpm>rpm_full.*")
    ap.add_argument("--parallel", action="store_true", help="multi-threaded loop (both cores)")
    ap.add_argument("--config", default="thesis-helical",
                    help="loaded start: the helical pair (e.g. thesis-helical-drawing: the drawing micro-geometry; "
                         "its records are named helical-<config>_<rpm>rpm_loaded.*)")
    ap.add_argument("--wall-limit-h", type=float, default=None,
                    help="stop after a checkpoint once this many hours have passed (exit code 3); rerun to resume")
    a = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    if a.start == "loaded":
        main_loaded(a.rpm, periods=a.periods or 10, settle_periods=a.settle, parallel=a.parallel,
                    wall_limit=None if a.wall_limit_h is None else a.wall_limit_h * 3600, config=a.config)
    else:
        main(a.rpm, periods=a.periods or 5, settle_periods=1 if a.settle is None else a.settle,
             integration=a.integration, parallel=a.parallel)
