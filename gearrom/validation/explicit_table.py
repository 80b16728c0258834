"""Mesh tables of the explicit FE's own discretised gears, from static information of that model only.

The pair ROM's default table is the quasi-static LTCA of :mod:`gearrom.fe` (P2 triangles, 25 um
flank mesh) plus the rigid TE of the explicit FE's faceted outlines (:mod:`gearrom.validation.facets`).
The explicit FE itself (Q4 elements, 0.15 mm outline, penalty contact, hourglass control) is softer:
its slow run lies ~7 % above that static TE (:mod:`gearrom.validation.quasistatic`). Both tables
here start from the slow run ``spur_60rpm`` (32 Hz mesh frequency, two orders of magnitude below the
mesh mode; one mesh period, 128 samples), whose elastic mesh deflection ``s = F / K`` is what remains
of the recorded TE after the rigid gaps of the faceted outlines
(:func:`gearrom.validation.facets.elastic_deflection`, the inverse of the ROM's own facet model;
stiffness shares from the LTCA, the record holds the total TE only):

* ``explicit_scaled`` (:func:`explicit_scaled_excitation`, offered by
  :func:`gearrom.validation.report.validate` as ``table="explicit_scaled"``): the LTCA table with its
  stiffness scaled by the mean static compliance ratio ``mean(F / k_ltca) / mean(s)`` (one scalar:
  0.932). Sound for the elastic compliance *level*: the quasi-static explicit solves of
  validation/spur_static_points*.json (:mod:`gearrom.validation.explicit_static`) give the same
  ratio from two torques (elastic part 1.079 x the LTCA, double-contact points 1.00-1.15) and over
  three mesh periods (1.077 +- 0.035 over the mesh phase). Not corrected: the shape of the explicit
  model's static TE over the mesh cycle (mesh-periodic part: explicit - (LTCA + facets) = +0.85 um in
  double contact but +0.27 um in single contact, so LTCA + facets overstates GMF1/2/3 by 9/11/42 %),
  see validation/rom_vs_fe_spur_same_discretization.json.
* ``explicit_qs`` (:func:`explicit_qs_excitation`, analysis only, *not* offered as a ROM table): the
  slow run's ``s`` itself over the mesh phase, low-passed to mesh orders ``<= cutoff_order`` (the
  undamped run carries a residual free vibration of +-0.3 um at the mass-scaled mesh mode, aliased by
  its 128-per-period sampling to mesh orders ~27-48). One mesh period is one set of tooth pairs: the
  part of the slow run's TE that the rigid-facet model does not explain on *those* teeth is folded into
  a periodic table. Out of that window its static TE misses the explicit static solves by 0.70 um RMS
  (LTCA + facets: 0.48 um about its mean offset) and its GMF2 / GMF3 by -36 % / +74 %.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import MeasurementError, ModelError

log = logging.getLogger(__name__)

__all__ = ["SlowRunDeflection", "slow_run_deflection", "static_compliance_scale", "explicit_scaled_excitation",
           "explicit_qs_excitation", "lowpass_periodic"]

#: default mesh-order cutoff of the slow run's deflection (the aliased residual vibration starts at ~27)
CUTOFF_ORDER = 16


@dataclass(frozen=True, eq=False)
class SlowRunDeflection:
    """The slow run's steady window split into rigid facets and elastic deflection.

    Attributes
    ----------
    theta_in : ndarray
        Input angle from the FE start, rad (one mesh period, half-open).
    phi : ndarray
        Table mesh phase of each sample, rad.
    te : ndarray
        Recorded TE, m.
    gaps : ndarray (n, n_pairs)
        Rigid gap of each loaded pair of the faceted outlines, m (NaN: not loaded).
    share : ndarray (n, n_pairs)
        Stiffness share of each pair (LTCA), -.
    deflection : ndarray
        Elastic deflection ``F / K`` that reproduces ``te`` with ``gaps``, m.
    meta : dict
        Record metadata.
    """

    theta_in: np.ndarray
    phi: np.ndarray
    te: np.ndarray
    gaps: np.ndarray
    share: np.ndarray
    deflection: np.ndarray
    meta: dict = field(default_factory=dict)


def lowpass_periodic(x: np.ndarray, order: int) -> np.ndarray:
    """Fourier coefficients ``c[0..order]`` (one-sided, ``x ~ Re sum c_m exp(2 pi i m j / n)``) of the
    periodic samples ``x`` (one period, uniform, half-open); higher orders dropped."""
    x = np.asarray(x, float)
    if not 0 < order < x.size // 2:
        raise ModelError(f"lowpass_periodic: cutoff order must lie in 1..{x.size // 2 - 1}, got {order}")
    c = np.fft.rfft(x) / x.size
    c[1:] *= 2.0
    return c[:order + 1]


def _evaluate(c: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``Re sum_m c_m exp(2 pi i m u)`` at the fractions of a period ``u``."""
    m = np.arange(c.size)
    return np.real(np.exp(2j * math.pi * np.outer(u, m)) @ c)


def slow_run_deflection(pair, fe, reference, outline: float | None = None,
                        body: float | None = None) -> SlowRunDeflection:
    """Elastic mesh deflection of the slow explicit run over its steady window (one mesh period).

    Parameters
    ----------
    pair : GearPair
    fe : FERecord
        The slow run (:func:`gearrom.validation.report.load_fe_record`), whose steady window must
        hold a whole number of mesh periods.
    reference : MeshExcitation
        The LTCA table at the run's torque: stiffness shares (and pair labels) of the tooth pairs.
    outline, body : float, optional
        Explicit mesh sizes, m (default: the record's).
    """
    from gearrom.fe.explicit.gearmesh import gear_quad_mesh
    from gearrom.validation.compare import steady_window
    from gearrom.validation.facets import elastic_deflection, faceted_pair_gaps, share_rows
    from gearrom.validation.pair_rom import fe_start_mesh_phase

    z1 = pair.z[0]
    period = 2 * math.pi / z1
    torque = float(fe.meta["torque_out_Nm"])
    w = steady_window(fe.theta_in, fe.t, float(fe.meta["t_steady_from_s"]), z1)
    th, te = fe.theta_in[w], fe.te[w]
    periods = th.size * float(np.median(np.diff(th))) / period
    if abs(periods - round(periods)) > 1e-3:
        raise MeasurementError(f"slow run: steady window spans {periods:.4f} mesh periods, not a whole number")
    outline = outline or fe.meta.get("outline_size_mm", 0.15) * 1e-3
    body = body or fe.meta.get("body_size_mm", 1.5) * 1e-3
    phase0 = fe_start_mesh_phase(pair)
    j = int(np.argmin(np.abs(np.asarray(reference.torque) - torque)))
    share = share_rows(np.asarray(reference.load_share)[j], phase0 + th, period)
    meshes = [gear_quad_mesh(pair, i, outline, body, project=False) for i in (0, 1)]   # the slow run's mesh
    gaps = faceted_pair_gaps(pair, meshes, th, share, phase0, pairs=reference.pairs)
    s = elastic_deflection(te, gaps, share)
    return SlowRunDeflection(theta_in=th, phi=np.mod(phase0 + th, period), te=te, gaps=gaps, share=share,
                             deflection=s, meta=dict(fe.meta, periods=int(round(periods))))


def explicit_qs_excitation(pair, reference, fe_dir: str | Path | None = None, rpm: float = 60.0,
                           cutoff_order: int = CUTOFF_ORDER, slow=None):
    """The slow run's own elastic deflection as a mesh table, a label and its provenance (analysis only).

    Not a sound ROM table (module docstring): it folds the tooth-specific static error of one mesh
    period into the periodic table; :func:`explicit_scaled_excitation` is the one offered.

    Parameters
    ----------
    pair : GearPair
    reference : MeshExcitation
        The LTCA table at the run's torque (load shares, pair labels, theta grid).
    fe_dir : path, optional
        Folder of the stored runs (default: the repository's validation/).
    rpm : float
        Input speed of the stored slow run, rev/min.
    cutoff_order : int
        Highest mesh order kept of the elastic deflection.
    slow : SlowRunDeflection, optional
        Precomputed :func:`slow_run_deflection` (else computed from ``<fe_dir>/spur_<rpm>rpm.*``).

    Returns
    -------
    (MeshExcitation, str, dict)
        Table (one torque, the LTCA's theta grid), label, JSON-ready provenance.
    """
    from dataclasses import replace

    slow = _slow(pair, reference, fe_dir, rpm, slow)
    torque = float(slow.meta["torque_out_Nm"])
    period = 2 * math.pi / pair.z[0]
    n = slow.theta_in.size // int(slow.meta["periods"])
    if slow.meta["periods"] != 1:
        log.warning("slow run spans %d mesh periods: the first one is used", slow.meta["periods"])
    c = lowpass_periodic(slow.deflection[:n], cutoff_order)
    u = np.mod(reference.theta - slow.phi[0], period) / period       # table grid in fractions of the window
    s = _evaluate(c, u)
    if not np.all(s > 0):
        raise ModelError("explicit_qs table: non-positive elastic deflection after the low-pass")
    j = int(np.argmin(np.abs(np.asarray(reference.torque) - torque)))
    f_nom = torque / pair.rb[1]
    raw_at_samples = _evaluate(c, np.arange(n) / n)
    prov = {"table": "explicit_qs",
            "source": f"explicit FE slow run spur_{int(round(rpm))}rpm (steady window, {n} samples, one mesh period)",
            "stiffness_share": "LTCA table (pair labels and shares); total stiffness from the explicit run",
            "kinematic": "none in the table (e0 = 0); the ROM adds the faceted outlines' kinematic TE per tooth",
            "cutoff_mesh_order": int(cutoff_order),
            "theta_in_window_rad": [float(slow.theta_in[0]), float(slow.theta_in[n - 1])],
            "fe_meta": {k: slow.meta.get(k) for k in ("outline_size_mm", "body_size_mm", "dt_s", "mass_scaling_dt_s",
                                                      "added_mass_kg", "energy_error", "wall_s", "ramp_s")},
            "deflection_mean_um": float(c[0].real * 1e6),
            "reference_deflection_mean_um": float(np.mean(f_nom / reference.k[j]) * 1e6),
            "stiffness_mean_N_per_um": float(np.mean(f_nom / s) * 1e-6),
            "reference_stiffness_mean_N_per_um": float(np.mean(reference.k[j]) * 1e-6),
            "lowpass_removed_rms_um": float(np.std(slow.deflection[:n] - raw_at_samples) * 1e6),
            "limit": "one mesh period = one set of tooth pairs: the part of the slow run's TE that the rigid-facet "
                     "model does not explain on those teeth is taken as periodic"}
    meta = dict(reference.metadata, source="explicit FE slow run (gearrom.validation.explicit_table)",
                table_provenance=prov)
    table = replace(reference, torque=np.array([torque]), k=(f_nom / s)[None, :], e=s[None, :],
                    load_share=np.asarray(reference.load_share)[j:j + 1], max_pressure=None,
                    definition=("secant k = F_t / s, s = elastic deflection of the explicit FE slow run (recorded TE "
                                "less the rigid gaps of its faceted outlines, stiffness-share weighted), low-passed to "
                                f"mesh order {cutoff_order}; transverse line of action; Q4 plane strain + penalty contact "
                                "+ hourglass control, rigid bores"),
                    metadata=meta)
    label = f"explicit_qs (spur_{int(round(rpm))}rpm slow run, orders <= {cutoff_order}, {torque:g} N m)"
    log.info("explicit_qs table: mean deflection %.3f um (LTCA %.3f um), mean stiffness %.1f N/um (LTCA %.1f N/um)",
             prov["deflection_mean_um"], prov["reference_deflection_mean_um"], prov["stiffness_mean_N_per_um"],
             prov["reference_stiffness_mean_N_per_um"])
    return table, label, prov


def _slow(pair, reference, fe_dir, rpm: float, slow):
    from gearrom.validation.records import DEFAULT_FE_DIR, load_fe_record

    if slow is not None:
        return slow
    return slow_run_deflection(pair, load_fe_record(Path(fe_dir) if fe_dir is not None else DEFAULT_FE_DIR, rpm),
                               reference)


def static_compliance_scale(pair, slow: SlowRunDeflection, reference) -> float:
    """Stiffness scale [-] that gives the LTCA table ``reference`` the slow run's mean elastic deflection:
    ``mean(F / k_ltca) / mean(s)`` over the slow run's mesh phases (one mesh period)."""
    torque = float(slow.meta["torque_out_Nm"])
    j = int(np.argmin(np.abs(np.asarray(reference.torque) - torque)))
    k_ref = np.asarray(reference.stiffness(slow.phi, float(reference.torque[j])), float)
    return float(np.mean(torque / pair.rb[1] / k_ref) / np.mean(slow.deflection))


def explicit_scaled_excitation(pair, reference, fe_dir: str | Path | None = None, rpm: float = 60.0, slow=None):
    """The LTCA table at the explicit FE's static compliance level: (table, label, provenance).

    Parameters
    ----------
    pair : GearPair
    reference : MeshExcitation
        The LTCA table at the slow run's torque (shape, load shares, ``e0``).
    fe_dir : path, optional
        Folder of the stored runs (default: the repository's validation/).
    rpm : float
        Input speed of the stored slow run, rev/min.
    slow : SlowRunDeflection, optional
        Precomputed :func:`slow_run_deflection`.

    Returns
    -------
    (MeshExcitation, str, dict)
        The table (stiffness x scale at the slow run's torque, ``e0`` kept), a label and the JSON-ready
        provenance (``table``, ``stiffness_scale``, means, the slow run's metadata, ``limit``).
    """
    from gearrom.validation.pair_rom import scaled_excitation
    from gearrom.validation.records import replace_meta

    slow = _slow(pair, reference, fe_dir, rpm, slow)
    torque = float(slow.meta["torque_out_Nm"])
    scale = static_compliance_scale(pair, slow, reference)
    j = int(np.argmin(np.abs(np.asarray(reference.torque) - torque)))
    f_nom = torque / pair.rb[1]
    prov = {"table": "explicit_scaled", "stiffness_scale": scale, "slow_run_torque_Nm": torque,
            "source": f"LTCA table with its stiffness x {scale:.4f}: mean static compliance ratio of the explicit FE "
                      f"slow run spur_{int(round(rpm))}rpm (recorded TE less the rigid facet gaps, one mesh period) "
                      "to the LTCA",
            "deflection_mean_um": float(np.mean(slow.deflection) * 1e6),
            "reference_deflection_mean_um": float(np.mean(f_nom / reference.stiffness(slow.phi, torque)) * 1e6),
            "stiffness_mean_N_per_um": float(np.mean(reference.k[j]) * scale * 1e-6),
            "reference_stiffness_mean_N_per_um": float(np.mean(reference.k[j]) * 1e-6),
            "theta_in_window_rad": [float(slow.theta_in[0]), float(slow.theta_in[-1])],
            "fe_meta": {k: slow.meta.get(k) for k in ("outline_size_mm", "body_size_mm", "dt_s", "mass_scaling_dt_s",
                                                      "added_mass_kg", "energy_error", "wall_s", "ramp_s")},
            "limit": "one scalar: corrects the elastic compliance level (uniform over the mesh cycle within +-5 % "
                     "per the static explicit solves), not the shape of the static TE over the mesh cycle nor the "
                     "rigid-facet kinematic model"}
    table = scaled_excitation(replace_meta(reference, rb2_m=pair.rb[1]), torque, scale)
    table = replace_meta(table, source="LTCA x explicit FE static compliance (gearrom.validation.explicit_table)",
                         table_provenance=prov)
    log.info("explicit_scaled table: stiffness x %.4f (mean deflection %.3f um vs LTCA %.3f um)", scale,
             prov["deflection_mean_um"], prov["reference_deflection_mean_um"])
    return table, f"ltca x {scale:.4f} (explicit FE static compliance, spur_{int(round(rpm))}rpm)", prov
