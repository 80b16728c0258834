"""Forward selection of effects, joint refit, ambiguity statements, and the verification re-simulation."""
from __future__ import annotations

import logging
import math

import numpy as np
from scipy.optimize import lsq_linear

from gearrom.calibrate.fit import Context, ShaftOrder, Trial, size_uncertainty
from gearrom.calibrate.fit_mesh import FlankModification
from gearrom.excitation.slices import MicroMods
from gearrom.calibrate.model import realigned
from gearrom.calibrate.residual import map_to_run
from gearrom.calibrate.registry import LIBRARY, effect_label, suggestion
from gearrom.calibrate.simulator import ModelChanges

log = logging.getLogger(__name__)

REFINE_TOP = 4  # flank-modification candidates among the top 4 of the linearized ranking ...
REFINE_SHARE = 0.2  # ... that explain at least 20 % of what the best explains are refined by re-simulation
MICRO_AMBIGUITY = 0.1  # a flank-modification rival within 10 % of the best's explained energy: ambiguous
SPLIT_REAL = 0.03  # other-channel motion above this share of the TE line: the shaft really moves
SPLIT_NONE = 0.01  # below this share: nothing moves, a measurement error
#: jointly fitted effects whose separate TE energies sum to more than 3 x the energy of their summed TE
#: largely cancel: their sizes rest on fine details of the rig model's shaft motions, not on the TE
JOINT_CANCELLATION = 3.0


def split_test(ctx: Context, R: np.ndarray, shaft: str) -> tuple[str, float]:
    """Does the *other* shaft move at order 1 of ``shaft``? Decides runout vs encoder eccentricity.

    Returns ``("real", share)``, ``("none", share)`` or ``("unclear", share)``, with ``share`` the
    largest ratio over the runs of the other channel's line to the TE line at that order (joint line
    fit on the residual). Model-free: only the measured channels are used.
    """
    from gearrom.calibrate.residual import fit_lines

    sizes = [m.run.y.shape[1] for m in ctx.models]
    blocks = np.split(R, np.cumsum([3 * n for n in sizes])[:-1])
    share, decisive = 0.0, True
    for m, b in zip(ctx.models, blocks):
        y = b.reshape(3, -1) / ctx.w[:, None]
        lines = np.array([[1.0, 0.0], [0.0, 1.0]])  # both shafts' order 1 jointly (0.22 orders apart)
        c = np.abs(fit_lines(y, m.run.theta_in_rad, m.run.theta_out_rad, lines)[:, 0 if shaft == "input" else 1])
        other = c[2] if shaft == "input" else c[1]
        noise_line = m.noise_m * math.sqrt(2.0 / y.shape[1])
        if c[0] < 20 * noise_line:
            decisive = False
            continue
        share = max(share, float((other - 3 * noise_line) / c[0]))
    if not decisive and share == 0.0:
        return "unclear", share
    return ("real" if share > SPLIT_REAL else "none" if share < SPLIT_NONE else "unclear"), share


def _runout_or_encoder(a: Trial, b: Trial) -> bool:
    """``a`` and ``b`` are the same shaft's order 1, one through the drivetrain and one measurement-only."""
    return (isinstance(a.cand, ShaftOrder) and isinstance(b.cand, ShaftOrder) and a.cand.order == b.cand.order == 1
            and {a.cand.measurement_only, b.cand.measurement_only} == {True, False}
            and a.cand.target.split("_")[0] == b.cand.target.split("_")[0])


def _apply_split_test(ctx: Context, R: np.ndarray, trials: list[Trial]) -> None:
    """Reorder a close call between runout and encoder eccentricity of one shaft by :func:`split_test`."""
    if len(trials) < 2:
        return
    a, b = trials[0], trials[1]
    if not _runout_or_encoder(a, b) or b.dss < 0.9 * a.dss or "joint_ambiguity" in b.info:
        return
    shaft = "input" if a.cand.target.startswith("input") else "output"
    verdict, share = split_test(ctx, R, shaft)
    for t in (a, b):
        t.info["split_test"] = {"verdict": verdict, "other_channel_share": share}
    if verdict in ("real", "none"):
        if a.cand.measurement_only != (verdict == "none"):
            trials[0], trials[1] = b, a
        trials[0].info["split_decided"] = True


def _te(t: Trial) -> np.ndarray:
    """The TE contribution of ``t`` over all runs (m, unweighted)."""
    return np.concatenate([c[0] for c in t.contrib])


def _cancelling(a: Trial, b: Trial) -> bool:
    """The TE contributions of ``a`` and ``b`` largely cancel: their separate energies sum to more than
    :data:`JOINT_CANCELLATION` times the energy of their sum."""
    ta, tb = _te(a), _te(b)
    return float(ta @ ta + tb @ tb) > JOINT_CANCELLATION * float((ta + tb) @ (ta + tb))


def _joint_trial(ctx: Context, t: Trial, lin: list[Trial], base: tuple, R_lin: np.ndarray, ss: float,
                 margin: float) -> Trial:
    """Candidate ``t`` (fitted alone) scored jointly with the accepted linear effects ``lin``.

    One bounded least squares over the columns of ``lin`` (``base``, :func:`_columns`) and of ``t`` on
    ``R_lin`` (the initial residual less the accepted non-linear effects): an accepted effect that absorbed
    a line ``t`` shares is re-sized. The joint gain is the residual energy ``ss`` (what all accepted effects
    leave) less what the joint fit leaves. Where it exceeds ``t``'s alone gain by more than ``margin``, the
    joint result replaces ``t`` (its contribution at the joint size, its gain the joint gain, the re-sized
    accepted effects in ``info["joint"]``), unless ``t`` and a re-sized effect largely cancel in the TE
    (:func:`_cancelling`): their sizes then rest on the rig model's shaft motions, and ``t`` keeps its alone
    fit with the joint result in ``info["joint_ambiguity"]``.
    """
    cols = _columns(ctx, [t])
    if not np.all(np.isfinite(cols[1])):  # a degenerate alone fit (zero secant) has no joint column
        return t
    columns = (base[0] + cols[0], np.hstack([base[1], cols[1]]), np.concatenate([base[2], cols[2]]),
               np.concatenate([base[3], cols[3]]))
    fitted, rest = _solve(ctx, lin + [t], columns, R_lin)
    gain = ss - float(rest @ rest)
    if gain <= t.dss + margin:
        return t
    new, resized = fitted[-1], fitted[:-1]
    partners = [a for a in resized if _cancelling(new, a)]
    if partners:
        sizes = {effect_label(u.key): abs(u.cand.report(u.x, u.info).get(LIBRARY[u.cand.name].size_key, math.nan))
                 for u in [*partners, new]}
        t.info["joint_ambiguity"] = {"partner": partners[0].key, "dss": gain, "sizes_um": sizes}
        return t
    sig = size_uncertainty(ctx, rest, columns[1])
    out, j = [], 0
    for u, b in zip(fitted, columns[0]):
        n = len(b[0])
        out.append(Trial(u.cand, u.x, u.contrib, u.dss, u.n_par, {**u.info, "sigma_um": sig[j:j + n]}))
        j += n
    new = out[-1]
    new.dss = gain
    new.info.update(joint=out[:-1], alone_dss=t.dss)
    return new


def _rank(trials: list[Trial]) -> None:
    """Sort ``trials`` by explained energy, those whose joint fit was refused (:func:`_joint_trial`) last:
    accepting one would let the joint refit of the accepted effects reach that refused joint result."""
    trials.sort(key=lambda t: ("joint_ambiguity" in t.info, -t.dss))


def joint_scores(ctx: Context, trials: list[Trial], accepted: list[Trial], R0: np.ndarray, R: np.ndarray) -> list[Trial]:
    """The linear candidates among ``trials`` scored jointly with the accepted linear effects
    (:func:`_joint_trial`), the others as they are. ``R0``: the initial stacked, weighted residual (m);
    ``R``: what the accepted effects leave of it (m). Nothing changes before a linear effect is accepted, or once a rig parameter that
    refits the accepted effects on its re-tuned rig is (their columns then belong to that rig)."""
    lin = [t for t in accepted if hasattr(t.cand, "linear_columns")]
    if not lin or any(t.info.get("profiled") for t in accepted):
        return trials
    R_lin = R0 - sum((ctx.stack(t.contrib) for t in accepted if t not in lin), np.zeros_like(R0))
    base = _columns(ctx, lin)
    ss = float(R @ R)
    return [_joint_trial(ctx, t, lin, base, R_lin, ss, ctx.s.kappa * ctx.noise_var * t.n_par)
            if hasattr(t.cand, "linear_columns") else t for t in trials]


def _threshold(ctx: Context, n_par: int, ss: float, R0: np.ndarray) -> float:
    """Residual energy an effect with ``n_par`` parameters must explain to be added (``ss``: what is left)."""
    s = ctx.s
    return max(s.kappa * ctx.noise_var * n_par, s.min_fraction * ss, s.min_total_fraction * float(R0 @ R0))


def _joint_ambiguity(t: Trial, ss: float) -> dict:
    """The ambiguity entry of a guarded joint fit of candidate ``t`` (:func:`_joint_trial`)."""
    ja = t.info["joint_ambiguity"]
    return {"partner": ja["partner"], "alternative": t.key, "sizes_um": ja["sizes_um"],
            "explained_share": ja["dss"] / ss if ss > 0 else 0.0,
            "suggested_run": suggestion(ja["partner"], t.key)}


def select_effects(ctx: Context, candidates: list, D: list[np.ndarray]) -> tuple[list[Trial], list[dict]]:
    """Forward selection on the residual ``D`` (per run (3, n): measured minus nominal).

    Once a linear effect is accepted, each linear candidate is also scored jointly with the accepted linear
    effects (:func:`joint_scores`): an accepted effect that took a line both share is re-sized, and the
    candidate counts with the joint gain. A joint fit whose effects cancel in the TE is refused and, where
    it would have been significant, reported as an ambiguity with the accepted effect it re-sized
    (``info["joint_rivals"]``).

    Returns
    -------
    accepted : list of Trial
        Jointly refitted effects, in the order they were selected.
    steps : list of dict
        Per step: residual energy, threshold, the ranking (candidate, explained share) and rivals.
    """
    s = ctx.s
    R0 = ctx.stack(D)
    accepted: list[Trial] = []
    steps: list[dict] = []
    screened: set = set()  # expensive (re-simulating) candidates that explained nothing significant
    joint_rivals: dict = {}  # candidate key -> its last refused joint fit (:func:`_joint_ambiguity`)
    for _ in range(s.max_effects):
        R = R0 - sum((ctx.stack(t.contrib) for t in accepted), np.zeros_like(R0))
        ss = float(R @ R)
        done = {t.key for t in accepted}
        ctx.accepted = list(accepted)
        trials = []
        for c in candidates:
            if (c.name, c.target) in done or repr(c) in screened or \
                    (c.exclusive and any(k[0] == c.name for k in done)):
                continue
            try:
                t = c.fit(ctx, R)
            except Exception as exc:  # a candidate that cannot be evaluated must not stop the diagnosis
                log.warning("candidate %r could not be fitted: %s", c, exc)
                continue
            if t is not None:
                trials.append(t)
        if not trials:
            break
        trials = joint_scores(ctx, trials, accepted, R0, R)
        _rank(trials)
        floor = _threshold(ctx, 1, ss, R0)
        # the leading flank-modification candidates get re-simulated sizes: the linearized ranking of
        # modifications that also change the mean mesh stiffness (lead crowning of a spur pair) can put
        # the right one behind a look-alike, so every modification near the top is refined before ranking
        top = trials[0].dss
        for i, t in enumerate(trials[:REFINE_TOP]):
            if isinstance(t.cand, FlankModification) and t.dss > 0.1 * floor and t.dss > REFINE_SHARE * top:
                trials[i] = t.cand.refine(ctx, R, t)
        _rank(trials)
        _apply_split_test(ctx, R, trials)
        best = trials[0]
        thresh = _threshold(ctx, best.n_par, ss, R0)
        # a joint fit refused for cancelling TE contributions that would have been significant is reported
        for t in trials:
            joint_rivals.pop(t.key, None)
            if "joint_ambiguity" in t.info and t.info["joint_ambiguity"]["dss"] >= _threshold(ctx, t.n_par, ss, R0):
                joint_rivals[t.key] = _joint_ambiguity(t, ss)
        screened |= {repr(t.cand) for t in trials if t.cand.expensive
                     and (t.dss < 0.25 * thresh or t.info.get("screened"))}
        step = {"residual_energy": ss, "threshold": thresh,
                "ranking": [{"candidate": repr(t.cand), "effect": t.cand.name, "target": t.cand.target,
                             "explained_share": t.dss / ss if ss > 0 else 0.0} for t in trials[:6]]}
        steps.append(step)
        te_rms = math.sqrt(np.mean([np.mean(c[0] ** 2) for c in best.contrib]))
        noise = math.sqrt(ctx.noise_var)
        step["best_te_rms_um"] = te_rms / 1e-6
        if best.dss < thresh or te_rms < max(s.min_effect_noise * noise, s.model_floor_um * 1e-6):
            step["accepted"] = None
            if te_rms < s.model_floor_um * 1e-6:
                step["below_model_floor"] = True
            break
        margin = max(2 * s.kappa * ctx.noise_var * best.n_par, s.ambiguity * best.dss)
        # flank modifications act through the same GMF lines; a look-alike modification within 10 % of the
        # best is not told apart by this data (the flank model's own error is of that order)
        micro_margin = MICRO_AMBIGUITY * best.dss if isinstance(best.cand, FlankModification) else 0.0
        rivals = [t for t in trials[1:] if (abs(best.dss - t.dss) < margin or (
                  isinstance(t.cand, FlankModification) and best.dss - t.dss < micro_margin)) and t.key != best.key
                  and not (best.info.get("split_decided") and _runout_or_encoder(best, t))]
        best.info["rivals"] = [{"effect": t.cand.name, "target": t.cand.target or None,
                                "explained_share": t.dss / ss, "suggested_run": suggestion(best.key, t.key)}
                               for t in rivals]
        best.info["explained_share"] = best.dss / ss
        best.info["runner_up"] = ({"effect": trials[1].cand.name, "target": trials[1].cand.target or None,
                                   "explained_share": trials[1].dss / ss} if len(trials) > 1 else None)
        step["accepted"] = repr(best.cand)
        if "joint" in best.info:  # scored jointly: the accepted effects it re-sized take their joint sizes
            resized = {u.key: u for u in best.info.pop("joint")}
            accepted = [resized.get(t.key, t) for t in accepted]
            best.info["joint_with"] = [effect_label(k) for k in resized]
            best.info["alone_share"] = best.info.pop("alone_dss") / ss
        accepted.append(best)
        accepted = adopt_refit(accepted, best)
        accepted = joint_refit(ctx, accepted, R0)
        # a rig candidate also changes how the accepted effects pass through the drivetrain: screen it anew
        screened -= {repr(c) for c in candidates if getattr(c, "interacts", False)}
    for key, amb in joint_rivals.items():  # reported with the accepted effect the refused joint fit re-sized
        holder = next((t for t in accepted if t.key == amb["partner"]), None)
        if holder is not None and key not in {t.key for t in accepted}:
            holder.info.setdefault("joint_rivals", []).append(amb)
    return accepted, steps


def adopt_refit(accepted: list[Trial], rig: Trial) -> list[Trial]:
    """The accepted effects with those that ``rig`` (a rig parameter fitted by a profile) refitted on its
    re-tuned rig replaced by their refits; the rig's contribution becomes its model change alone, so that
    the sum of all contributions is unchanged."""
    refit = rig.info.get("refit")
    if not refit:
        return accepted
    by_key = {u.key: u for u in refit}
    replaced = [t for t in accepted if t is not rig and t.key in by_key]
    contrib = [rig.contrib[r] + sum(t.contrib[r] for t in replaced) - sum(by_key[t.key].contrib[r] for t in replaced)
               for r in range(len(rig.contrib))]
    new_rig = Trial(rig.cand, rig.x, contrib, rig.dss, rig.n_par, {**rig.info, "refit": None, "profiled": True})
    out = []
    for t in accepted:
        if t is rig:
            out.append(new_rig)
        elif t.key in by_key:
            u = by_key[t.key]
            u.info = {**t.info, **u.info}
            out.append(u)
        else:
            out.append(t)
    return out


def _columns(ctx: Context, trials: list[Trial]) -> tuple[list, np.ndarray, np.ndarray, np.ndarray]:
    """The trials' linear columns (:meth:`linear_columns`, evaluated on ``ctx``'s models): per trial its
    (per-run columns, lower, upper bounds), the stacked column matrix and the bounds of all columns."""
    blocks = [t.cand.linear_columns(ctx, t.info) for t in trials]
    cols = [c for b in blocks for c in b[0]]
    lo = np.concatenate([np.broadcast_to(b[1], (len(b[0]),)) for b in blocks])
    hi = np.concatenate([np.broadcast_to(b[2], (len(b[0]),)) for b in blocks])
    return blocks, np.column_stack([ctx.stack(c) for c in cols]), lo, hi


def _solve(ctx: Context, trials: list[Trial], columns: tuple, R: np.ndarray) -> tuple[list[Trial], np.ndarray]:
    """The trials' sizes fitted together on ``R`` by one bounded least squares over ``columns``
    (:func:`_columns`); returns the re-sized trials (shapes, positions and info kept) and the stacked
    residual they leave."""
    blocks, A, lo, hi = columns
    x = lsq_linear(A, R, bounds=(lo, hi)).x
    out, j = [], 0
    for t, b in zip(trials, blocks):
        n = len(b[0])
        xi = x[j:j + n]
        contrib = [sum(xi[q] * b[0][q][r] for q in range(n)) for r in range(len(ctx.models))]
        out.append(Trial(t.cand, xi, contrib, t.dss, t.n_par, t.info))
        j += n
    return out, R - A @ x


def linear_refit(ctx: Context, trials: list[Trial], R: np.ndarray) -> list[Trial]:
    """The effects' sizes fitted together on ``R`` by one bounded least squares over their linear columns
    (:meth:`linear_columns`, evaluated on ``ctx``'s models), shapes and positions kept."""
    return _solve(ctx, trials, _columns(ctx, trials), R)[0]


def joint_refit(ctx: Context, accepted: list[Trial], R0: np.ndarray, sweeps: int = 3) -> list[Trial]:
    """Refit all accepted effects together: one bounded least squares over the linear ones, alternated
    with refits of the non-linear ones (micro-geometry, rig parameters) on what the others leave."""
    accepted = list(accepted)
    if len(accepted) < 2:  # a single effect was fitted on exactly this residual already
        return accepted
    zero = np.zeros_like(R0)
    prof = next((t for t in accepted if t.info.get("profiled")), None)
    if prof is not None:  # its profile refits the other effects on the re-tuned rig: that is the joint fit
        others = [t for t in accepted if t is not prof]
        ctx.accepted = others
        new = prof.cand.refit(ctx, R0 - sum((ctx.stack(t.contrib) for t in others), zero), prof)
        new.info = {**prof.info, **new.info}
        return adopt_refit([new if t is prof else t for t in accepted], new)
    for _ in range(sweeps):
        lin = [i for i, t in enumerate(accepted) if hasattr(t.cand, "linear_columns")]
        non = [i for i in range(len(accepted)) if i not in lin]
        if lin:
            R = R0 - sum((ctx.stack(accepted[i].contrib) for i in non), zero)
            for i, t in zip(lin, linear_refit(ctx, [accepted[i] for i in lin], R)):
                accepted[i] = t
        for i in non:
            others = sum((ctx.stack(u.contrib) for j2, u in enumerate(accepted) if j2 != i), zero)
            t = accepted[i]
            ctx.accepted = [u for j2, u in enumerate(accepted) if j2 != i]
            new = t.cand.refit(ctx, R0 - others, t)
            new.info = {**accepted[i].info, **new.info}
            accepted[i] = new
            if new.info.get("refit"):  # a rig parameter that refitted the others on its re-tuned rig
                return adopt_refit(accepted, new)
        if not non:
            break
    return accepted


def verification_changes(ctx: Context, accepted: list[Trial], run: int = 0) -> tuple[dict, list]:
    """Model changes of all accepted effects together (for run ``run``), and the measurement-only terms per run."""
    kin = {"kinematic_in": None, "kinematic_out": None}
    micro = ctx.micro_nominal
    rig = []
    meas = [np.zeros_like(m.nominal) for m in ctx.models]
    psi_free = None
    psi_runs = None
    dpsi = 0.0
    # one mesh phase for all flank modifications: that of the one that explains most (a weaker one fitted
    # later estimates its own phase offset on a small residual; letting it override rotates every GMF line)
    micros = [t for t in accepted if isinstance(t.cand, FlankModification)]
    lead = max(micros, key=lambda t: t.dss) if micros else None
    for t in accepted:
        ch = t.cand.changes(t.x, t.info, ctx, run)
        for k in kin:
            if k in ch:
                kin[k] = ch[k] if kin[k] is None else kin[k] + ch[k]
        if "micro" in ch:
            new = ch["micro"]
            d = lambda a, b: tuple(x - y for x, y in zip(a, b))  # noqa: E731
            micro = MicroMods(tuple(x + y for x, y in zip(micro.tip_relief, d(new.tip_relief, ctx.micro_nominal.tip_relief))),
                              micro.tip_relief_start_diameter,
                              micro.lead_crowning + new.lead_crowning - ctx.micro_nominal.lead_crowning,
                              micro.helix_slope + new.helix_slope - ctx.micro_nominal.helix_slope)
            if t is lead and t.info.get("psi_rad") is not None:
                psi_free = t.info["psi_rad"]
            if t is lead and t.info.get("dpsi_rad") is not None:
                dpsi = t.info["dpsi_rad"]
        if "rig_scale" in ch:
            rig.extend(ch["rig_scale"])
            psi_runs = t.info.get("psi_runs")
        mt = t.cand.measurement_term(t.x, t.info, ctx)
        if mt is not None:
            meas = [a + b for a, b in zip(meas, mt)]
    changes = dict(kin, micro=None if micro == ctx.micro_nominal else micro, rig_scale=tuple(rig))
    realign = lead is not None and lead.info.get("psi_runs_realigned") is not None
    return {"changes": changes, "psi_free": psi_free, "psi_runs": psi_runs, "dpsi": dpsi, "realigned": realign}, meas


def verify(ctx: Context, accepted: list[Trial]) -> list[np.ndarray]:
    """Re-simulate every run with all accepted effects; model signals (3, n) per run on the run's grid."""
    if not accepted:
        return [m.nominal.copy() for m in ctx.models]
    out = []
    for r, m in enumerate(ctx.models):
        spec, meas = verification_changes(ctx, accepted, r)
        mt = meas[r]
        psi = m.psi
        if spec["psi_runs"] is not None:
            psi = spec["psi_runs"][r]
        elif spec["psi_free"] is not None and not m.psi_identifiable:
            psi = spec["psi_free"]
        elif m.psi_identifiable:
            psi = m.psi + spec["dpsi"]
        ch = ModelChanges(mesh_phase_rad=psi, **spec["changes"])
        kinematic = ch.kinematic_in is not None or ch.kinematic_out is not None
        if not kinematic and ch.micro is None and not ch.rig_scale and math.isclose(psi, m.psi):
            out.append(m.nominal + mt)
            continue
        if not kinematic and (ch.micro is not None or ch.rig_scale) and m.psi_identifiable and spec["realigned"]:
            # the changed mesh excitation: mesh phase re-estimated from the changed model's own GMF lines,
            # as in the re-simulated fits (no shaft-order effect to carry along)
            mapped, _ = realigned(m, ctx.sim.simulate(m.cond, ModelChanges(**spec["changes"])))
            out.append(mapped + mt)
            continue
        out.append(map_to_run(ctx.sim.simulate(m.cond, ch), m.run) + mt)
    return out
