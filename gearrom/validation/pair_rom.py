"""Reduced model of the *same* system as the explicit FE gear-pair run (1 DOF, numba).

The explicit FE of :mod:`gearrom.fe.explicit.gearpair` drives the input bore at a prescribed speed
and loads the free output gear (its own mass only) with a resisting torque ramped in by a cosine
ramp. The ROM here describes exactly that system and nothing of the test rig:

* input gear angle prescribed: ``theta1 = Omega t`` (both gears start at speed, as in the FE);
* output gear: one rotational DOF with the polar inertia ``J2`` of the FE's output-gear mesh
  (:func:`polar_inertia`, exact integral of ``rho b r^2`` over the meshed area);
* the mesh force law of :mod:`gearrom.rom.mesh` (a :class:`~gearrom.rom.mesh.MeshLaw`, evaluated by
  the compiled :func:`gearrom.rom.lawkernel.law_force` that the diagnosis' torsional model uses too)
  on the transverse line of action: secant ``F = k(phi) (delta - e0(phi)) + c d(delta)/dt`` while
  ``delta > e0`` (else 0: contact loss, no back flank because the FE uses drive-flank contact only),
  ``e0 = e - F_nom / k``, or the load-dependent map (``mesh_law``), with
  ``delta = TE = rb1 theta1 - rb2 theta2`` (positive when the output lags) and
  ``c = 2 zeta sqrt(k_mean m_eq)``, ``m_eq = J2 / rb2^2``;
* ``k(phi), e(phi)`` from a :class:`~gearrom.excitation.table.MeshExcitation` at the nominal torque,
  evaluated at the mesh phase ``phi = phi0 + theta1`` where ``phi0`` is the table phase of the FE
  start position (:func:`fe_start_mesh_phase`).

Equation of motion (output gear, clockwise positive): ``m_eq delta'' = T(t)/rb2 - F``, integrated by
a fixed-step classical Runge-Kutta scheme compiled with numba (not exudyn: a single DOF with a
prescribed input needs no multibody system; the physics is the one of :mod:`gearrom.rom.mesh`).
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from gearrom.errors import ModelError
from gearrom.rom.lawkernel import LawTables, law_force
from gearrom.rom.mesh import Effects, MeshLaw

log = logging.getLogger(__name__)

__all__ = [
    "PairRomResult",
    "PairRomSetup",
    "fe_start_mesh_phase",
    "REFERENCE_FLANK_SIZE",
    "mesh_excitation",
    "polar_inertia",
    "reference_settings",
    "REFERENCE_SLICES",
    "scaled_excitation",
    "simulate_pair_rom",
    "table_samples",
]


def polar_inertia(nodes: np.ndarray, quads: np.ndarray, center, density: float, width: float) -> float:
    """Polar moment of inertia [kg m^2] of a 2D mesh about ``center``: ``rho b int r^2 dA`` (exact per quad).

    Each quad is split into two triangles; for a triangle ``int r^2 dA = A/6 (sum |p_i|^2 + sum_{i<j} p_i.p_j)``.
    """
    p = np.asarray(nodes, float) - np.asarray(center, float)
    q = np.asarray(quads, np.int64)
    total = 0.0
    for a, b, c in ((0, 1, 2), (0, 2, 3)):
        p0, p1, p2 = p[q[:, a]], p[q[:, b]], p[q[:, c]]
        area = 0.5 * np.abs((p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (p2[:, 0] - p0[:, 0]))
        s = (np.sum(p0 * p0, 1) + np.sum(p1 * p1, 1) + np.sum(p2 * p2, 1)
             + np.sum(p0 * p1, 1) + np.sum(p1 * p2, 1) + np.sum(p0 * p2, 1))
        total += float(np.sum(area * s / 6.0))
    return density * width * total


def fe_start_mesh_phase(pair) -> float:
    """Table mesh phase [rad] (``theta = 0``: a pair enters contact at the input's start of active profile)
    of the explicit FE's start position.

    In the FE the input gear has tooth 0 centred on +x (towards the output gear) at t = 0. Its drive
    (+y) flank is the involute whose base-circle point lies at ``psi_b = s_t/d + inv(alpha_t)``;
    it meets the line of action at the roll length ``rb1 (psi_b + alpha_wt)`` measured from the
    tangent point on the input base circle, while a pair enters contact at the roll length
    ``roll_start_active[0]``. The phase is the difference over ``rb1``, modulo the mesh period.
    """
    from gearrom.geometry.pair import inv

    rb1 = pair.rb[0]
    psi_b = pair.s_t[0] / pair.d[0] + float(inv(pair.alpha_t))
    roll = rb1 * (psi_b + pair.alpha_wt)
    return float(np.mod((roll - pair.roll_start_active[0]) / rb1, 2 * math.pi / pair.z[0]))


#: Flank element size [m] of the spur LTCA tables that are judged against the explicit references (the
#: static gate and the ROM of the loaded-start comparison): the grid on which the static TE's GMF
#: harmonics have converged (``validation/run_ltca_flank_convergence.py``: halving it again moves GMF1 by
#: less than the gate's resolution). The default ``MeshSettings.flank_size`` is four times coarser; it
#: resolves the mean TE and the stiffness but not the tip-edge rounding at the start and end of contact,
#: which sets the harmonics.
REFERENCE_FLANK_SIZE = 0.00625e-3
#: Strips over the face width of the helical 3D LTCA tables judged against the explicit references: the
#: perfect helical pair's static TE harmonics converge slowly in the strip count
#: (``validation/run_ltca_slice_convergence.py``), and the orders next to the mesh mode at the validation
#: speeds decide its DTE; the sweep's default resolves the mean TE, the stiffness and the drawing
#: micro-geometry's GMF lines but not those orders.
REFERENCE_SLICES = 96


def reference_settings(pair, settings=None):
    """The 2D LTCA mesh settings of the validation tables: ``settings`` (default ``MeshSettings()``) with
    the flank grid refined to :data:`REFERENCE_FLANK_SIZE` (``None`` for helical pairs, whose table is
    the 3D model's own mesh)."""
    if pair.is_helical:
        return None
    from dataclasses import replace

    from gearrom.fe.mesh2d import MeshSettings

    s = MeshSettings() if settings is None else settings
    return s if s.flank_size <= REFERENCE_FLANK_SIZE else replace(s, flank_size=REFERENCE_FLANK_SIZE)


def mesh_excitation(pair, torque: float, source: str = "fe", n_positions: int = 64, config_name: str = "",
                    torque_map: bool = False, settings=None, n_slices: int | None = None):
    """The MeshExcitation for the ROM and a label of where it came from.

    ``source``: ``"fe"`` (quasi-static FE LTCA sweep, cached on disk), ``"analytical"`` (ISO-shaped
    table) or ``"auto"`` (FE, falling back to the analytical table if the FE sweep fails).
    ``torque_map``: the FE table over the sweep's torque map about ``torque``
    (:func:`gearrom.excitation.fe.fe_excitation`, the table ``gearrom sweep`` runs), so that the ROM's
    mesh law is the load-dependent force-deflection map; otherwise the table at ``torque`` only (secant law).
    ``settings``: 2D LTCA mesh settings (:class:`gearrom.fe.mesh2d.MeshSettings`; default the sweep's),
    e.g. :func:`reference_settings`. ``n_slices``: strips over the face width of a helical table (with
    ``torque_map``; default the sweep's), e.g. :data:`REFERENCE_SLICES`.
    """
    if source not in ("fe", "analytical", "auto"):
        raise ModelError(f"excitation source must be 'fe', 'analytical' or 'auto', got {source!r}")
    if source in ("fe", "auto"):
        grid = "" if settings is None else f", flank {settings.flank_size * 1e3:g} mm"
        try:
            if torque_map:
                from gearrom.excitation.fe import fe_excitation
                from gearrom.excitation.fe import torque_map as torques_about

                torques = torques_about(float(torque))
                ex = fe_excitation(pair, torques, n_positions, settings, n_slices=n_slices)
                strips = f", {n_slices} strips" if pair.is_helical and n_slices is not None else ""
                return ex, (f"fe_ltca ({n_positions} positions, torque map {', '.join(f'{t:g}' for t in torques)} "
                            f"N m{grid}{strips})")
            from gearrom.fe.sweep import stiffness_sweep

            ex = stiffness_sweep(pair, [float(torque)], n_positions, settings).to_excitation()
            return ex, f"fe_ltca ({n_positions} positions, {float(torque):g} N m{grid})"
        except Exception as exc:
            if source == "fe":
                raise
            log.warning("FE stiffness sweep failed (%s): using the analytical mesh table", exc)
    from gearrom.excitation.analytical import analytical_excitation

    return analytical_excitation(pair, [float(torque)], config_name=config_name), "analytical (ISO 6336 shaped)"


def scaled_excitation(excitation, torque: float, scale: float):
    """The table with its stiffness multiplied by ``scale`` at ``torque`` and the separation point
    ``e0 = e - F_nom / k`` kept (same kinematic part, static deflection ``F_nom / k`` divided by ``scale``).

    Used by the stiffness-matched diagnostic of :func:`gearrom.validation.report.validate_speed` (fitted
    to the FE's mean TE: a diagnostic only) and by the ``explicit_scaled`` table
    (:func:`gearrom.validation.explicit_table.explicit_scaled_excitation`, scale from static data only).
    """
    from dataclasses import replace

    if not scale > 0:
        raise ModelError(f"stiffness scale must be > 0, got {scale}")
    k = np.asarray(excitation.k, float)
    e = np.asarray(excitation.e, float)
    f_nom = np.asarray(excitation.torque, float)[:, None] / 1.0
    rb2 = excitation.metadata.get("rb2_m")
    if rb2 is None:
        raise ModelError("scaled_excitation needs metadata['rb2_m'] (output base radius)")
    f_nom = f_nom / rb2
    e0 = e - f_nom / k
    meta = dict(excitation.metadata, stiffness_scale=float(scale))
    return replace(excitation, k=k * scale, e=e0 + f_nom / (k * scale), metadata=meta)


@dataclass(frozen=True)
class PairRomSetup:
    """Operating point and options of the pair ROM (SI units), mirroring ``GearPairSetup``.

    Parameters
    ----------
    rpm_in : float
        Input speed, rev/min.
    torque_out : float
        Output resisting torque, N m.
    torque_ramp_time : float
        Cosine ramp of the output torque, s (as the FE).
    inertia_out : float
        Output gear polar inertia, kg m^2.
    damping_ratio : float
        Mesh damping ratio zeta (the FE has none besides hourglass viscosity: keep it small).
    dt : float
        Integration step, s (0: 1/200 of the mesh period or 1/40 of the mesh mode period, whichever is smaller).
    mesh_law : {"secant", "load-dependent"}
        The mesh law (:class:`~gearrom.rom.mesh.MeshLaw`): the table's secant at ``torque_out``, or
        its force-deflection map over the table's torques.
    """

    rpm_in: float
    torque_out: float = 120.0
    torque_ramp_time: float = 0.3e-3
    inertia_out: float = 1e-4
    damping_ratio: float = 0.01
    dt: float = 0.0
    mesh_law: str = "secant"

    def __post_init__(self) -> None:
        for name in ("rpm_in", "torque_out", "inertia_out"):
            if not getattr(self, name) > 0:
                raise ModelError(f"PairRomSetup.{name} must be > 0, got {getattr(self, name)}")
        if not (self.damping_ratio >= 0 and self.torque_ramp_time >= 0 and self.dt >= 0):
            raise ModelError("PairRomSetup.damping_ratio, torque_ramp_time and dt must be >= 0")
        if self.mesh_law not in ("secant", "load-dependent"):
            raise ModelError(f"PairRomSetup.mesh_law must be 'secant' or 'load-dependent', got {self.mesh_law!r}")


@dataclass(frozen=True, eq=False)
class PairRomResult:
    """Time history of the pair ROM: ``t`` [s], ``theta_in`` [rad] (input angle from the FE origin),
    ``te`` [m] (rb1 theta1 - rb2 theta2, positive = output lags), ``force`` [N]; ``meta`` run data."""

    t: np.ndarray
    theta_in: np.ndarray
    te: np.ndarray
    force: np.ndarray
    meta: dict = field(default_factory=dict)


@njit(cache=True)
def _rhs(t, x, v, om, u0, du, E, f, c, meq, T, tr, rb2, kin, kin_step):
    # the kinematic TE (facets) shifts the contact: the law sees the deflection minus it
    xk = x
    if kin.size > 1:
        s = min(om * t / kin_step, kin.size - 1.000001)
        i = int(s)
        xk = x - (kin[i] + (s - i) * (kin[i + 1] - kin[i]))
    force = law_force(E, f, u0 + du * t, xk, v, c)
    tq = T
    if tr > 0 and t < tr:
        tq = T * 0.5 * (1.0 - math.cos(math.pi * t / tr))
    return (tq / rb2 - force) / meq, force


@njit(cache=True)
def _integrate(n_steps, dt, every, om, u0, du, E, f, c, meq, T, tr, rb2, kin, kin_step):
    n_out = n_steps // every + 1
    xs = np.empty(n_out)
    fs = np.empty(n_out)
    ts = np.empty(n_out)
    x = 0.0
    v = 0.0
    j = 0
    for s in range(n_steps + 1):
        t = s * dt
        if s % every == 0:
            ts[j] = t
            xs[j] = x
            fs[j] = _rhs(t, x, v, om, u0, du, E, f, c, meq, T, tr, rb2, kin, kin_step)[1]
            j += 1
        if s == n_steps:
            break
        a1 = _rhs(t, x, v, om, u0, du, E, f, c, meq, T, tr, rb2, kin, kin_step)[0]
        a2 = _rhs(t + 0.5 * dt, x + 0.5 * dt * v, v + 0.5 * dt * a1, om, u0, du, E, f, c, meq, T, tr, rb2, kin,
                  kin_step)[0]
        a3 = _rhs(t + 0.5 * dt, x + 0.5 * dt * (v + 0.5 * dt * a1), v + 0.5 * dt * a2, om, u0, du, E, f, c, meq, T, tr,
                  rb2, kin, kin_step)[0]
        a4 = _rhs(t + dt, x + dt * (v + 0.5 * dt * a2), v + dt * a3, om, u0, du, E, f, c, meq, T, tr, rb2, kin,
                  kin_step)[0]
        x = x + dt * (v + dt / 6.0 * (a1 + a2 + a3))
        v = v + dt / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
    return ts[:j], xs[:j], fs[:j]


def table_samples(pair, excitation, torque: float, n_table: int = 1024) -> tuple[np.ndarray, np.ndarray]:
    """Mesh stiffness k [N/m] and static TE e [m] of ``excitation`` at ``torque`` [N m] on ``n_table``
    equal steps of one mesh period (the lookup grid of :func:`simulate_pair_rom`)."""
    th = np.arange(n_table) * (2 * math.pi / pair.z[0]) / n_table
    return (np.asarray(excitation.stiffness(th, torque), float), np.asarray(excitation.ste(th, torque), float))


def simulate_pair_rom(pair, excitation, setup: PairRomSetup, t_end: float, sample_period: float,
                      phase0: float | None = None, n_table: int = 1024,
                      kinematic: tuple[float, np.ndarray] | None = None) -> PairRomResult:
    """Integrate the pair ROM from t = 0 (rigid contact, TE = 0, both gears at speed) to ``t_end``.

    Parameters
    ----------
    pair : GearPair
    excitation : MeshExcitation
        Mesh table; evaluated at ``setup.torque_out``.
    setup : PairRomSetup
    t_end, sample_period : float
        End time and output sampling period, s.
    phase0 : float, optional
        Table mesh phase at t = 0 [rad]; default :func:`fe_start_mesh_phase` (the FE's start).
    n_table : int
        Points per mesh period of the k / e0 lookup (linear interpolation of the Fourier-interpolated table).
    kinematic : (step, values), optional
        Extra kinematic TE [m] added to ``e`` (e.g. the FE outline facets, :mod:`gearrom.validation.facets`),
        sampled at input angles ``0, step, 2 step...`` [rad] (linear; held beyond the end).
    """
    if not (t_end > 0 and sample_period > 0):
        raise ModelError(f"t_end and sample_period must be > 0 s, got {t_end}, {sample_period}")
    rb2 = pair.rb[1]
    z1 = pair.z[0]
    period = 2 * math.pi / z1
    om = setup.rpm_in * 2 * math.pi / 60
    phi0 = fe_start_mesh_phase(pair) if phase0 is None else float(phase0)
    k, e = table_samples(pair, excitation, setup.torque_out, n_table)
    f_nom = setup.torque_out / rb2
    fmap = None
    if setup.mesh_law == "load-dependent":
        from gearrom.rom.mesh import ForceMap

        fmap = ForceMap.from_table(excitation, rb2, setup.torque_out, n_table)
    law = MeshLaw(pair, np.arange(n_table) * period / n_table, k, e, f_nom, Effects(), fmap)
    tab = LawTables.from_law(law)
    meq = setup.inertia_out / rb2**2
    kmean = float(k.mean())
    c = 2 * setup.damping_ratio * math.sqrt(kmean * meq)
    f_mode = math.sqrt(kmean / meq) / (2 * math.pi)
    f_mesh = om / period
    dt = setup.dt or min(1 / (200 * f_mesh), 1 / (40 * f_mode))
    every = max(1, int(round(sample_period / dt)))
    dt = sample_period / every
    n_steps = int(math.ceil(t_end / dt))
    t0 = time.perf_counter()
    kin_step, kin = (1.0, np.zeros(1)) if kinematic is None else (float(kinematic[0]), np.asarray(kinematic[1], float))
    if kin.size > 1 and not kin_step > 0:
        raise ModelError(f"kinematic TE step must be > 0 rad, got {kin_step}")
    n_grid = tab.E.shape[1]  # the law's phase in grid steps: u = (phi0 + om t) / period * n_grid
    ts, xs, fs = _integrate(n_steps, dt, every, om, phi0 / period * n_grid, om / period * n_grid, tab.E, tab.f, c,
                            meq, setup.torque_out, setup.torque_ramp_time, rb2, kin, kin_step)
    wall = time.perf_counter() - t0
    meta = {"model": "1-DOF pair ROM (prescribed input speed, free output inertia), RK4/numba",
            "rpm_in": setup.rpm_in, "torque_out_Nm": setup.torque_out, "inertia_out_kgm2": setup.inertia_out,
            "damping_ratio": setup.damping_ratio, "damping_Ns_per_m": c, "mesh_mode_Hz": f_mode,
            "mesh_frequency_Hz": f_mesh, "dt_s": dt, "n_steps": n_steps, "wall_s": wall,
            "phase0_rad": phi0, "k_mean_N_per_m": kmean, "ste_mean_m": float(e.mean()),
            "excitation_definition": excitation.definition,
            "kinematic_te_ptp_m": float(np.ptp(kin)) if kin.size > 1 else 0.0,
            "excitation_theta_origin": excitation.metadata.get("theta_origin", "")}
    return PairRomResult(t=ts, theta_in=om * ts, te=xs, force=fs, meta=meta)
