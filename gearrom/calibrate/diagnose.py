"""Close the loop: measured runs in, traced effects out, error before and after (:func:`diagnose`).

Steps: (1) simulate the nominal model at each run's measured speed and load and map it
onto the run through the same TE processing; (2) residual, with the mesh phase estimated from the
nominal GMF lines (never fitted to the residual); (3) characterize it (order lines, sidebands
AM/PM, fixed-frequency vs order-tracking peaks, impulsive once-per-rev content, speed/load
dependence); (4) rank the library candidates by the residual energy each explains alone;
(5) fit the best ones (bounded least squares, drawing tolerances as plausibility limits);
(6) add them, re-simulate, report the error before and after, and list what stays unexplained.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import gearrom.calibrate.characterize as chz
from gearrom.calibrate.candidates import make_candidates
from gearrom.calibrate.fit import Context, FitSettings, Trial
from gearrom.calibrate.microfe import FEMicroModel
from gearrom.calibrate.model import build_run_model, index_mesh_phase
from gearrom.calibrate.report import DiagnosisResult, RunTraces
from gearrom.calibrate.registry import LIBRARY, PLUGINS, effect_label
from gearrom.calibrate.residual import load_run, rms
from gearrom.calibrate.select import select_effects, verify
from gearrom.calibrate.simulator import default_simulator
from gearrom.errors import CalibrationError
from gearrom.excitation.slices import MicroMods
from gearrom.signal import GearMeshInfo, ReadSettings, TESettings

log = logging.getLogger(__name__)
UM = 1e-6
UNEXPLAINED_SHARE = 0.05  # an unexplained line must exceed 5 % of the largest residual line before the fit
UNEXPLAINED_BAND = 0.1    # ... among those within 10 % of its frequency (leakage and modulation products of a
                          # large misfit line lie near it; a line far from it is not masked by it)
UNEXPLAINED_NOISE = 3.0  # ... and 3 x the broadband noise rms (lines at noise level are not reported)


def _unexplained_peaks(after: np.ndarray, before_peaks: list[tuple[float, float]], fs_hz: float,
                       noise_m: float) -> list[tuple[float, float]]:
    """Lines of the after-residual ``after`` above :data:`UNEXPLAINED_NOISE` x the noise and above
    :data:`UNEXPLAINED_SHARE` of the largest before-fit residual line within :data:`UNEXPLAINED_BAND`
    of their frequency (``before_peaks``: (Hz, m))."""
    out = []
    for f, a in chz.spectral_peaks(after, fs_hz, noise_m, floor_m=UNEXPLAINED_NOISE * noise_m):
        near = [b for g, b in before_peaks if abs(g - f) <= UNEXPLAINED_BAND * g]
        if a >= UNEXPLAINED_SHARE * max(near, default=0.0):
            out.append((f, a))
    return out


def diagnose(config: str | Path, measurements: Sequence[str | Path], *, simulator=None,
             settings: FitSettings | None = None, read_settings: ReadSettings | None = None,
             te_settings: TESettings | None = None, torque_out_Nm: float | None = None, micro_model=None) -> DiagnosisResult:
    """Diagnose which library effects the nominal model misses, from one or more measured runs.

    Parameters
    ----------
    config : str or Path
        Gear/rig configuration name or file (the nominal model).
    measurements : sequence of str or Path
        ``gearrom.measurement/1`` files of the same rig (different speeds/loads welcome).
    simulator : Simulator, optional
        Default: :func:`~gearrom.calibrate.simulator.default_simulator` (exudyn ROM when it has the
        hooks, else the torsional rig model).
    settings : FitSettings, optional
    read_settings : ReadSettings, optional
        Reader and edge checks (default: the config's ``[signal]`` section).
    te_settings : TESettings, optional
        Speed-ratio tolerance and encoder-scale estimate (default: the config's ``[signal]``
        section); filters and ``te_on`` are not applied (see :func:`~gearrom.calibrate.residual.load_run`).
    torque_out_Nm : float, optional
        Load for files that do not state it.
    micro_model : MicroGeometryModel, optional
        Micro-geometry -> STE change (default: the simulator's, else the quasi-static FE tables through
        :class:`~gearrom.calibrate.microfe.FEMicroModel`, with the analytical slice model as fallback).

    Returns
    -------
    DiagnosisResult

    Raises
    ------
    CalibrationError
        No measurement given, or a run cannot be compared with the model.
    """
    if not measurements:
        raise CalibrationError("diagnose needs at least one measurement file")
    from gearrom.config import GearConfig, as_config

    settings = settings or FitSettings()
    cfg = as_config(config)  # loaded once; every part below takes the object
    label = cfg.name if isinstance(config, GearConfig) else str(config)
    pair = cfg.pair
    mesh = GearMeshInfo.from_config(cfg, name=label)
    if read_settings is None or te_settings is None:
        from gearrom.signal.config import settings_from_config

        te_cfg, read_cfg = settings_from_config(cfg)
        read_settings = read_settings or read_cfg
        te_settings = te_settings or te_cfg
    runs = [load_run(p, mesh, torque_out_Nm, read_settings, te_settings) for p in measurements]
    sim = simulator or default_simulator(cfg)
    psi0 = index_mesh_phase(cfg)
    models = [build_run_model(sim, r, psi_default=psi0) for r in runs]
    micro_model = micro_model or getattr(sim, "micro_model", None) or FEMicroModel()
    micro_nominal = getattr(sim, "micro", None) or MicroMods.from_pair(pair)
    ctx = Context(models, sim, settings, pair, micro_model, micro_nominal)
    D = [m.run.y - m.nominal for m in models]
    candidates = make_candidates(ctx)
    accepted, steps = select_effects(ctx, candidates, D)
    after = verify(ctx, accepted)
    res = _assemble(ctx, label, sim, D, accepted, steps, after)
    wanted = settings.candidates or tuple(LIBRARY)
    missing = sorted(set(wanted) - {c.name for c in candidates})
    res.summary["not_evaluated"] = [{"effect": n, "reason": PLUGINS[n].not_evaluated} for n in missing]
    for n in missing:
        res.summary["warnings"].append(f"{n} was not evaluated ({res.summary['not_evaluated'][missing.index(n)]['reason']})")
    return res


def _wrap_deg(psi: float, z1: int) -> float:
    """Mesh phase in deg of input angle, wrapped to (-period/2, period/2]."""
    period = 360.0 / z1
    d = math.degrees(psi) % period
    return d - period if d > period / 2 else d


def _evidence(ctx: Context, t: Trial, D: list) -> str:
    share = t.info.get("explained_share", 0.0)
    ru = t.info.get("runner_up")
    txt = f"explains {100 * share:.0f} % of the residual energy"
    if t.info.get("joint_with"):
        txt += (f" fitted jointly with {', '.join(t.info['joint_with'])}, which it re-sizes (alone "
                f"{100 * t.info.get('alone_share', 0.0):.0f} %)")
    if ru:
        txt += f" (next: {ru['effect']}{'/' + ru['target'] if ru['target'] else ''} {100 * ru['explained_share']:.0f} %)"
    return txt + PLUGINS[t.cand.name].evidence(ctx, t, D)


def _assemble(ctx: Context, config, sim, D, accepted, steps, after) -> DiagnosisResult:
    models = ctx.models
    runs_json, traces, tables = [], [], []
    res_b, res_a = [], []
    for m, mod_after in zip(models, after):
        r = m.run
        rb = r.y[0] - m.nominal[0]
        ra = r.y[0] - mod_after[0]
        res_b.append(rb)
        res_a.append(ra)
        tab = chz.order_table(r, rb, ra)
        tables.append(tab)
        runs_json.append({"measurement": r.name, "rpm_in": r.rpm_in, "rpm_in_nominal": r.rpm_in_nominal,
                          "torque_out_Nm": r.torque_out_Nm, "revs_out": r.revs_out, "duration_s": r.duration_s,
                          "error_before_rms_um": rms(rb) / UM, "error_after_rms_um": rms(ra) / UM,
                          "noise_rms_um": m.noise_m / UM, "mesh_phase_deg": _wrap_deg(m.psi, r.mesh.z1),
                          "mesh_phase_estimated": m.psi_identifiable, "mesh_phase_model_rad": m.psi, "repairs": len(r.repairs), "orders": tab, **r.info})
        traces.append(RunTraces(r.name, r.rpm_in, r.t_s, r.theta_in_rad, r.y[0], m.nominal[0], mod_after[0], r.fs_hz))
    before = rms(np.concatenate(res_b)) / UM
    after_rms = rms(np.concatenate(res_a)) / UM
    # effects, with their share of the (linearized) rms reduction
    te_res = [d[0] for d in D]
    full = rms(np.concatenate([d - sum((t.contrib[i][0] for t in accepted), 0 * d) for i, d in enumerate(te_res)]))
    effects, ambiguities = [], []
    for t in accepted:
        without = rms(np.concatenate([d - sum((u.contrib[i][0] for u in accepted if u is not t), 0 * d)
                                      for i, d in enumerate(te_res)]))
        params = t.cand.report(t.x, t.info)
        e = {"effect": t.cand.name, "target": t.cand.target or None, "parameters": params,
             "evidence": _evidence(ctx, t, D), "rms_reduction_um": (without - full) / UM,
             "explained_share": t.info.get("explained_share")}
        e["parameters"].update(PLUGINS[t.cand.name].report_extra(params, t.info))
        spec = LIBRARY[t.cand.name]
        size = abs(params[spec.size_key]) if spec.size_key in params else None
        tol = spec.tolerance.get(t.cand.target)
        if size is not None and tol is not None:
            e["within_tolerance"] = bool(size <= tol)
            e["drawing_tolerance_um"] = tol
        sigma = t.cand.size_sigma(t.info)
        if size is not None and sigma is not None:
            e["uncertainty_um"] = {spec.size_key: sigma}
        effects.append(e)
        for rv in t.info.get("rivals", []):
            ambiguities.append({"chosen": effect_label(t.key), "alternative": effect_label((rv["effect"], rv["target"])),
                                "chosen_share": t.info.get("explained_share"), "alternative_share": rv["explained_share"],
                                "suggested_run": rv["suggested_run"]})
        for jr in t.info.get("joint_rivals", []):
            ambiguities.append({"chosen": effect_label(t.key),
                                "alternative": f"{effect_label(t.key)} together with {effect_label(jr['alternative'])}",
                                "chosen_share": t.info.get("explained_share"), "alternative_share": jr["explained_share"],
                                "joint_sizes_um": jr["sizes_um"], "suggested_run": jr["suggested_run"]})
    # unexplained: lines left in the after-residual, grouped across runs
    peaks_b = [chz.spectral_peaks(rb, m.run.fs_hz, m.noise_m) for rb, m in zip(res_b, models)]
    peaks = [_unexplained_peaks(ra, pb, m.run.fs_hz, m.noise_m) for ra, pb, m in zip(res_a, peaks_b, models)]
    unexplained = chz.classify_peaks([m.run for m in models], peaks)
    for u in unexplained:  # a leftover at the lines of a fitted effect is a misfit of it, not a new effect
        labs = (u.get("integer_order") or "").split(" = ")  # an integer ratio names a line for both shafts
        for t in accepted:
            if any(PLUGINS[t.cand.name].explains_line(t.cand.target, lab) for lab in labs):
                u["at_lines_of"] = t.cand.name
    # tooth-local pulses (out-of-library tooth damage) in the after-residual; at a gear with a fitted
    # tooth-local effect they are its misfit
    for u in chz.tooth_local_pulses([m.run for m in models], res_a, ctx.pair.eps_gamma):
        for t in accepted:
            if PLUGINS[t.cand.name].explains_line(t.cand.target, u["integer_order"]):
                u["at_lines_of"] = t.cand.name
        unexplained.append(u)
    noise_line = [m.noise_m * math.sqrt(2 / m.run.t_s.size) for m in models]
    characterization = {
        "peaks_before": chz.classify_peaks([m.run for m in models], peaks_b),
        "sidebands": [chz.sideband_modulation(m.run, m.run.y[0], nl) for m, nl in zip(models, noise_line)],
        "impulsiveness": [chz.impulsiveness(m.run, rb) for m, rb in zip(models, res_b)],
        "speed_load_dependence": chz.dependence([m.run for m in models], tables),
    }
    warnings = []
    if after_rms > before * 1.02 and accepted:
        warnings.append("the re-simulated model with the effects is worse than the nominal one: the linearized fit "
                        "did not carry over (strong non-linearity or contact loss)")
    unaligned = [m.run.name for m in models if not m.psi_identifiable]
    if unaligned:
        warnings.append(
            f"mesh phase not identifiable on {', '.join(map(str, unaligned))} (GMF lines of the nominal model or the "
            "measurement at noise level): flank-modification candidates fit the mesh phase as a free parameter, "
            "pitch_error searches the tooth position on 1/8-pitch steps (no mesh phase needed), once-per-rev "
            "effects do not depend on it; the GMF lines of the before/after traces are not aligned")
    lin_after = full / UM
    if accepted and after_rms > 1.5 * lin_after + 3 * np.mean([m.noise_m for m in models]) / UM:
        warnings.append(f"re-simulated error {after_rms:.3g} um exceeds the linearized prediction {lin_after:.3g} um")
    summary = {
        "format": "gearrom.diagnosis/1",
        "error_before_rms_um": before, "error_after_rms_um": after_rms,
        "noise_rms_um": float(np.mean([m.noise_m for m in models])) / UM,
        "runs": runs_json, "effects": effects, "unexplained": unexplained, "ambiguities": ambiguities,
        "characterization": characterization, "selection": steps, "warnings": warnings,
        "model": {"config": str(config), "simulator": getattr(sim, "name", type(sim).__name__),
                  "modes_hz": [list(x) for x in (sim.modes_hz() if hasattr(sim, "modes_hz") else [])],
                  "conventions": "amplitudes are TE equivalents on the transverse line of action (um); phases refer "
                                 "to each channel's first edge; order = input-shaft order"},
    }
    return DiagnosisResult(summary, traces)
