"""Candidate effects: their predicted signatures, bounded least-squares fits, ranking and selection.

Every candidate (library effect x target) predicts the three compared signals (te, u_in, u_out)
of every run from its parameters, through the run's model sensitivities (:mod:`.model`). The
candidate classes of the effects are in their modules (:mod:`gearrom.calibrate.effects`); this
module holds the base class, the shared shaft-order fit (:class:`ShaftOrder`) and the settings.

The stacked, weighted residual of all runs (te weight 1, channels ``channel_weight``) is fitted
by each candidate alone (bounded least squares: :func:`scipy.optimize.lsq_linear` for the linear
ones, bounded scalar search for the others). Forward selection adds the candidate that removes the
most residual energy while it is significant (``kappa`` noise variances per parameter, at least
``min_fraction`` of what is left and ``min_total_fraction`` of the initial residual, and its TE
contribution at least ``min_effect_noise`` times the noise rms and ``model_floor_um``); a candidate whose explained energy falls short of the best by
less than ``max(2 kappa noise variances per parameter, ambiguity x best)`` is reported as not
separable from it by these data.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import lsq_linear

from gearrom.calibrate.registry import LIBRARY, amp_phase
from gearrom.excitation.slices import MicroMods
from gearrom.calibrate.model import N_TABLE, RunModel
from gearrom.calibrate.residual import detrend

log = logging.getLogger(__name__)
UM = 1e-6
N_MESH_HARMONICS = 6  # GMF harmonics a flank modification is fitted on (where the sensitivity exists)


@dataclass(frozen=True)
class FitSettings:
    """Settings of ranking and selection (see module docstring)."""

    channel_weight: float = 0.5
    max_effects: int = 3
    min_fraction: float = 0.25
    min_total_fraction: float = 0.002
    min_effect_noise: float = 0.5
    #: smallest TE contribution (rms, um) an effect must explain to be added: independent mesh models of one
    #: pair (FE tables, thin slices) differ in their mesh-order lines by a few tenths of a um, so a residual
    #: explained by less lies within the nominal model's own uncertainty
    model_floor_um: float = 0.15
    kappa: float = 25.0
    ambiguity: float = 0.002
    shared_shaft_phase: bool = False  # True only for runs recorded from a common index (same angle zero)
    rig_parameters: tuple[str, ...] = ("k_clutch", "J_motor", "J_load", "k_shaft_in", "mesh_stiffness", "k_support")
    candidates: tuple[str, ...] | None = None


@dataclass(eq=False)
class Trial:
    """A candidate fitted alone on a residual."""

    cand: Candidate
    x: np.ndarray
    contrib: list  # per run (3, n)
    dss: float
    n_par: int
    info: dict = field(default_factory=dict)

    @property
    def key(self) -> tuple[str, str]:
        return self.cand.name, self.cand.target


class Context:
    """Runs, weights, stacking and caches shared by the candidates."""

    def __init__(self, models: list[RunModel], sim, settings: FitSettings, pair, micro_model, micro_nominal: MicroMods):
        self.models = models
        self.sim = sim
        self.s = settings
        self.pair = pair
        self.micro_model = micro_model
        self.micro_nominal = micro_nominal
        self.w = np.array([1.0, settings.channel_weight, settings.channel_weight])
        self._ste: dict = {}
        #: effects accepted so far (set by the selection; a rig candidate re-simulates their kinematic errors)
        self.accepted: list = []
        self.noise_var = float(np.mean([m.noise_m ** 2 for m in models]))

    def stack(self, per_run: list) -> np.ndarray:
        return np.concatenate([(self.w[:, None] * a).ravel() for a in per_run])

    def ste_lines(self, torque: float, mods: MicroMods) -> np.ndarray:
        """Complex GMF harmonics ``c_h`` (h = 1..N) of the STE with ``mods``, ``STE = Re sum c_h e^{i h z1 theta}``,
        in the nominal table's angle origin (the micro-geometry model's ``theta_shift`` removed)."""
        key = (round(torque, 6), mods)
        if key not in self._ste:
            ex = self.micro_model.excitation(self.pair, [torque], mods)
            n = 64
            th = np.arange(n) * ex.period / n
            shift = self.micro_model.theta_shift(self.pair) if hasattr(self.micro_model, "theta_shift") else 0.0
            c = 2.0 * np.fft.rfft(ex.ste(th - shift, torque)) / n
            self._ste[key] = c[1:N_MESH_HARMONICS + 1]
        return self._ste[key]


class Candidate:
    """A (library effect, target) pair; subclasses implement :meth:`fit`, :meth:`report` and the model change.

    Class attributes
    ----------------
    exclusive : bool
        At most one candidate of this effect is accepted per diagnosis (e.g. one re-tuned rig parameter).
    expensive : bool
        The fit re-simulates; once it explains nothing significant it is not tried again in later steps.
    interacts : bool
        The fit refits the accepted effects too (their response depends on it): an expensive candidate
        that explained nothing is tried again once another effect is accepted.
    """

    exclusive = False
    expensive = False
    interacts = False

    def __init__(self, name: str, target: str):
        self.name, self.target = name, target
        self.spec = LIBRARY[name]

    @property
    def bound(self) -> float:
        return self.spec.bound.get(self.target, 0.0)

    def fit(self, ctx: Context, R: np.ndarray) -> Trial | None:  # pragma: no cover
        raise NotImplementedError

    def report(self, x: np.ndarray, info: dict) -> dict:  # pragma: no cover
        raise NotImplementedError

    def refit(self, ctx: Context, R: np.ndarray, previous: Trial) -> Trial:
        """Fit again on ``R`` (the joint refit), starting from a previous fit of this candidate."""
        return self.fit(ctx, R)

    def changes(self, x: np.ndarray, info: dict, ctx: Context, run: int = 0) -> dict:
        """Keyword changes for the verification simulation (kinematic tables, micro, rig scale)."""
        return {}

    def measurement_term(self, x: np.ndarray, info: dict, ctx: Context) -> list | None:
        """Measurement-only contribution per run (encoder errors), else None."""
        return None

    def size_sigma(self, info: dict) -> float | None:
        """Standard deviation of the reported size, um (None when the fit gives none)."""
        if "sigma_size_um" in info:
            return float(info["sigma_size_um"])
        if info.get("sigma_um") is None:
            return None
        return float(np.atleast_1d(np.asarray(info["sigma_um"], float))[0])

    def __repr__(self) -> str:
        return f"{self.name}[{self.target}]"


def _linear_fit(cand, ctx: Context, cols: list, R: np.ndarray, lo, hi, info=None) -> Trial:
    """Bounded linear least squares of stacked columns (each a per-run list of (3, n) arrays)."""
    A = np.column_stack([ctx.stack(c) for c in cols])
    res = lsq_linear(A, R, bounds=(lo, hi))
    x = res.x
    contrib_stacked = A @ x
    dss = float(R @ R - (R - contrib_stacked) @ (R - contrib_stacked))
    per_run = [sum(x[j] * cols[j][r] for j in range(len(cols))) for r in range(len(ctx.models))]
    info = dict(info or {})
    info["sigma_um"] = size_uncertainty(ctx, R - contrib_stacked, A)
    return Trial(cand, x, per_run, dss, len(x), info)


def correlation_factor(r: np.ndarray, max_lag: int = 4096) -> float:
    """Samples per independent sample of a residual: ``1 + 2 sum rho_k`` up to the first lag with
    ``rho_k <= 0`` (an oversampled or line-dominated residual is far from white noise)."""
    r = np.asarray(r, float) - np.mean(r)
    n = r.size
    if n < 4 or not np.any(r):
        return 1.0
    f = np.fft.rfft(r, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[:min(n, max_lag)]
    rho = ac[1:] / ac[0]
    stop = np.argmax(rho <= 0) if np.any(rho <= 0) else rho.size
    return float(max(1.0, 1.0 + 2.0 * rho[:stop].sum()))


def size_uncertainty(ctx: Context, rest: np.ndarray, A: np.ndarray) -> np.ndarray | float:
    """Standard deviation of fitted parameters, um, from the stacked residual left by the fit.

    ``sqrt(diag((A^T A)^-1) s^2 c)`` with ``s^2`` the residual variance per stacked sample and ``c``
    the correlation factor of the TE residual of the first run (:func:`correlation_factor`): the
    residual holds whatever the model still misses, so the figure covers that misfit, not only noise.
    """
    A2 = np.asarray(A, float).reshape(len(A), -1)  # one column per parameter
    n0 = ctx.models[0].run.t_s.size
    s2 = float(rest @ rest) / max(rest.size - A2.shape[1], 1)
    c = correlation_factor(rest[:n0])
    try:
        cov = np.linalg.pinv(A2.T @ A2) * s2 * c
    except np.linalg.LinAlgError:
        return np.full(A2.shape[1], np.nan) if np.ndim(A) > 1 else float("nan")
    sig = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return sig if np.ndim(A) > 1 else float(sig[0])


def detrend_like_data(a: np.ndarray, axis: int = -1) -> np.ndarray:
    """The linear detrend every measured signal went through (offset and slope over the record)."""
    return detrend(a, axis=axis)


def shaft_of(target: str) -> str:
    """``"input"`` or ``"output"``: the shaft of an effect target (gear or encoder)."""
    return "input" if target.startswith("input") else "output"


def shaft_angle(m: RunModel, shaft: str) -> np.ndarray:
    """Record angle of ``shaft`` on the run's working grid, rad."""
    return m.run.theta_in_rad if shaft == "input" else m.run.theta_out_rad


class ShaftOrder(Candidate):
    """A line at order :attr:`order` of the target's shaft, fitted as a cos/sin pair per run (or one pair for
    runs recorded from a common index): the base of once-per-rev effects.

    A measurement-only line (:attr:`measurement_only`) sits in the TE and the encoder's own channel; any
    other line is a kinematic error whose per-run signals (te, u_in, u_out) a subclass gives in
    :meth:`unit_line` and which the verification re-simulates as a kinematic table (:meth:`changes`).
    """

    order = 1
    measurement_only = False

    def unit_line(self, m: RunModel, shaft: str, basis: complex) -> np.ndarray:
        """Signals (3, n) of run ``m`` for the line ``Re(basis e^{i order theta})`` of 1 um: a measurement-only
        line by default (:func:`measured_line`); effects through the drivetrain override it."""
        if not self.measurement_only:  # pragma: no cover - a subclass contract
            raise NotImplementedError(f"{type(self).__name__} must define unit_line")
        return measured_line(m, shaft, basis, self.order)

    def _cols(self, ctx: Context) -> list:
        shaft = shaft_of(self.target)
        shared = ctx.s.shared_shaft_phase
        nr = len(ctx.models)
        cols = []
        for basis in (1.0, 1j):
            per = [detrend_like_data(self.unit_line(m, shaft, basis)) for m in ctx.models]
            if shared:
                cols.append(per)
            else:
                for r in range(nr):
                    cols.append([p if i == r else np.zeros_like(p) for i, p in enumerate(per)])
        if not shared:  # reorder to (cos_r, sin_r) pairs
            cols = [c for r in range(nr) for c in (cols[r], cols[nr + r])]
        return cols

    def fit(self, ctx, R):
        cols = self._cols(ctx)
        return _linear_fit(self, ctx, cols, R, -self.bound, self.bound)

    def linear_columns(self, ctx, info) -> tuple[list, np.ndarray, np.ndarray]:
        """Columns (per-run lists) and bounds for a joint linear refit."""
        cols = self._cols(ctx)
        return cols, np.full(len(cols), -self.bound), np.full(len(cols), self.bound)

    def _amp_phase(self, x):
        pairs = [amp_phase(x[i], x[i + 1]) for i in range(0, len(x), 2)]
        a = float(np.mean([p[0] for p in pairs]))
        return a, pairs[0][1], pairs

    def report(self, x, info):
        a, ph, pairs = self._amp_phase(x)
        out = {"amplitude_um": a, "phase_deg": ph}
        if len(pairs) > 1:
            out["phase_deg_per_run"] = [p[1] for p in pairs]
        return out

    def changes(self, x, info, ctx, run: int = 0):
        if self.measurement_only:
            return {}
        a, ph, pairs = self._amp_phase(x)
        if len(pairs) > 1:  # phases per run (files not started at the encoder index)
            a, ph = pairs[run]
        th = np.arange(N_TABLE) * 2 * math.pi / N_TABLE
        tab = a * UM * np.cos(self.order * th + math.radians(ph))
        return {"kinematic_in" if shaft_of(self.target) == "input" else "kinematic_out": tab}

    def measurement_term(self, x, info, ctx):
        if not self.measurement_only:
            return None
        cols = self._cols(ctx)
        return [sum(x[j] * cols[j][r] for j in range(len(cols))) for r in range(len(ctx.models))]

    def size_sigma(self, info: dict) -> float | None:
        """Amplitude of cos/sin pairs: the rms of the two components' deviations (Rayleigh scale); per-run
        pairs: their mean over the runs, as the reported amplitude is their mean."""
        if "sigma_size_um" in info:
            return float(info["sigma_size_um"])
        if info.get("sigma_um") is None:
            return None
        s = np.atleast_1d(np.asarray(info["sigma_um"], float))
        if s.size % 2:
            return float(s[0])
        pairs = np.sqrt(0.5 * (s[0::2] ** 2 + s[1::2] ** 2))
        return float(np.sqrt(np.sum(pairs ** 2)) / pairs.size)


def measured_line(m: RunModel, shaft: str, basis: complex, order: int = 1) -> np.ndarray:
    """Signals (3, n) of an angle error of one encoder whose TE equivalent is ``Re(basis 1um e^{i order theta})``:
    it appears in the TE and in the encoder's own channel only (no shaft moves)."""
    v = (basis * UM * np.exp(1j * order * shaft_angle(m, shaft))).real
    z = np.zeros_like(v)
    return np.vstack([v, v, z]) if shaft == "input" else np.vstack([v, z, -v])
