"""Static vs dynamic parts of the ROM-vs-explicit-FE miss ("the same discretised gears").

The pair ROM (:mod:`gearrom.validation.pair_rom`) and the explicit FE differ in two ways: the mesh
table (the quasi-static LTCA on P2 triangles vs the explicit model's Q4 elements and penalty contact:
a *static* difference) and the dynamics (1 DOF vs the full transient FE). This module measures both
with static information of the explicit model only, never fitted to its dynamic runs:

1. tables: the ROM at the FE's speeds with the default LTCA table, the ``explicit_scaled`` table and
   the ``explicit_qs`` table of :mod:`gearrom.validation.explicit_table` (the LTCA at the slow run's
   static compliance level; the slow run's own elastic deflection over its one mesh period), all with
   the outline facets;
2. static window: the explicit FE's static TE from the dynamic-relaxation solves of
   validation/spur_static_points.json (:mod:`gearrom.validation.explicit_static`) on a sub-window of
   whole mesh periods inside the dynamic runs' steady windows, compared with the ROM's quasi-static
   TE (table + facets) at the same input angles, and the dynamic amplification (dynamic / static
   metric on that sub-window) of the FE and of the ROM; its split into the part periodic in the mesh
   and the tooth-specific rest (:func:`periodic_split`);
3. two torques: static solves at 60 and 120 N m on one mesh period separate the explicit model's
   loaded kinematic offset from its compliance (:func:`two_torque_split`);
4. where the dynamic rest sits: the DTE RMS in mesh orders that are not whole numbers, around the
   mesh mode (:func:`mode_band_rms`).
"""
from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.validation.compare import TOLERANCES, compare_metrics, te_metrics

log = logging.getLogger(__name__)

__all__ = ["static_parts", "rom_static_te", "load_static_points", "subwindow", "static_window_analysis", "decomposition",
           "rom_runs", "static_point_check", "periodic_split", "two_torque_split", "mode_band_rms",
           "static_dynamic_summary"]

AMPLITUDES = ("te_mean_um", "dte_ptp_um", "dte_rms_um", "gmf1_amplitude_um", "gmf2_amplitude_um", "gmf3_amplitude_um")


def static_parts(pair, table, theta_in: np.ndarray, outline: float, body: float,
                 torque: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The ROM's quasi-static TE at the input angles ``theta_in`` [rad] in two parts [m]: the table STE
    ``e(phi)`` and the facet kinematic TE ``kin(theta)``.

    The ROM's static equilibrium ``F = k (x - e0 - kin)`` gives ``x = e(phi) + kin(theta)``, the facet
    term of :func:`gearrom.validation.facets.loaded_kinematic_te` at the table's own stiffness and load
    share at ``torque`` [N m] (default: the table's largest).
    """
    from gearrom.fe.explicit.gearmesh import gear_quad_mesh
    from gearrom.validation.facets import faceted_pair_gaps, loaded_kinematic_te, share_rows
    from gearrom.validation.pair_rom import fe_start_mesh_phase

    torque = float(table.torque[-1]) if torque is None else float(torque)
    j = int(np.argmin(np.abs(np.asarray(table.torque) - torque)))
    period = 2 * math.pi / pair.z[0]
    phase0 = fe_start_mesh_phase(pair)
    th = np.asarray(theta_in, float)
    phi = np.mod(phase0 + th, period)
    share = share_rows(np.asarray(table.load_share)[j], phase0 + th, period)
    meshes = [gear_quad_mesh(pair, i, outline, body, project=False) for i in (0, 1)]   # the stored runs' mesh
    gaps = faceted_pair_gaps(pair, meshes, th, share, phase0, pairs=table.pairs)
    k = np.asarray(table.stiffness(phi, torque), float)
    kin = loaded_kinematic_te(gaps, share, torque / pair.rb[1], k, th)
    return np.asarray(table.ste(phi, torque), float), kin


def rom_static_te(pair, table, theta_in: np.ndarray, outline: float, body: float,
                  torque: float | None = None) -> np.ndarray:
    """Quasi-static TE [m] of the ROM at ``theta_in`` [rad]: table STE + facet kinematic TE (:func:`static_parts`)."""
    e, kin = static_parts(pair, table, theta_in, outline, body, torque)
    return e + kin


def load_static_points(path: str | Path) -> tuple[np.ndarray, np.ndarray, dict]:
    """(theta_in [rad], static TE [m], file metadata) of validation/spur_static_points.json, sorted by angle."""
    path = Path(path)
    if not path.is_file():
        raise MeasurementError(f"{path} is missing (run validation/run_explicit_static.py)")
    d = json.loads(path.read_text())
    pts = sorted(d["points"].values(), key=lambda p: p["theta_in_rad"])
    th = np.array([p["theta_in_rad"] for p in pts])
    te = np.array([p["te_um"] for p in pts]) * 1e-6
    return th, te, {k: v for k, v in d.items() if k != "points"}


def subwindow(theta_in: np.ndarray, theta_a: float, periods: int, z1: int) -> np.ndarray:
    """Mask of the samples of a uniform record in ``[theta_a, theta_a + periods * 2 pi / z1)`` (half a
    sample step of slack at the start)."""
    th = np.asarray(theta_in, float)
    step = float(np.median(np.diff(th)))
    end = theta_a + periods * 2 * math.pi / z1
    return (th >= theta_a - 0.5 * step) & (th < end - 0.5 * step)


def _grid_points(theta: np.ndarray, te: np.ndarray, theta_a: float, step: float, n: int):
    """The static points on the grid ``theta_a + i step``, i < n (MeasurementError naming the missing ones)."""
    want = theta_a + step * np.arange(n)
    idx = np.array([int(np.argmin(np.abs(theta - w))) for w in want]) if theta.size else np.zeros(0, int)
    miss = [i for i, w in zip(idx, want) if theta.size == 0 or abs(theta[i] - w) > 1e-6 * step]
    if miss or idx.size != n:
        raise MeasurementError(f"static points: {len(miss) or n} of the {n} grid angles from {theta_a:.5f} rad "
                               f"(step {step:.5g} rad) are missing")
    return want, te[idx]


def static_window_analysis(pair, static_path: str | Path, theta_a: float, per_period: int, periods: int,
                           fe_records: dict, roms: dict, tables: dict, outline: float, body: float) -> dict:
    """Static vs dynamic metrics on a sub-window of whole mesh periods.

    Parameters
    ----------
    pair : GearPair
    static_path : path
        validation/spur_static_points.json.
    theta_a : float
        Sub-window start, input angle from the FE start, rad.
    per_period, periods : int
        Static points per mesh period (uniform) and whole mesh periods of the sub-window.
    fe_records : dict rpm -> FERecord
        Dynamic explicit FE records.
    roms : dict table name -> dict rpm -> SpeedComparison
        The ROM runs per table and speed.
    tables : dict table name -> MeshExcitation
    outline, body : float
        Explicit mesh sizes, m.

    Returns
    -------
    dict (JSON-ready): window, ``fe_static`` metrics, per table the ROM's static metrics and their
    error against the FE's static ones, per speed the FE's and each ROM's dynamic metrics and
    amplifications (dynamic / static) on the window.
    """
    z1 = pair.z[0]
    step = 2 * math.pi / z1 / per_period
    th_all, te_all, _ = load_static_points(static_path)
    th, te_fe = _grid_points(th_all, te_all, theta_a, step, per_period * periods)
    m_fe = te_metrics(th, te_fe, z1)
    out = {"theta_window_rad": [theta_a, theta_a + periods * 2 * math.pi / z1], "mesh_periods": periods,
           "static_points": int(th.size), "fe_static": m_fe, "rom_static": {}, "speeds": []}
    for name, table in tables.items():
        e, kin = static_parts(pair, table, th, outline, body)
        te_rom = e + kin
        metrics, _, _ = compare_metrics(te_metrics(th, te_rom, z1), m_fe)
        out["rom_static"][name] = {"metrics": metrics,
                                   "curve_rms_difference_um": float(np.sqrt(np.mean((te_rom - te_fe) ** 2)) * 1e6),
                                   "periodic_split": periodic_split(te_fe, {"table_ste": e, "facets": kin, "rom": te_rom},
                                                                    per_period)}
    for rpm, fe in fe_records.items():
        w = subwindow(fe.theta_in, theta_a, periods, z1)
        m_dyn = te_metrics(fe.theta_in[w], fe.te[w], z1)
        row = {"rpm_in": rpm, "fe_dynamic": m_dyn, "fe_amplification": _ratios(m_dyn, m_fe), "rom": {}}
        for name, per_rpm in roms.items():
            s = per_rpm[rpm]
            wr = subwindow(s.rom_theta_in, theta_a, periods, z1)
            m_rd = te_metrics(s.rom_theta_in[wr], s.rom_te[wr], z1)
            m_rs = {k: out["rom_static"][name]["metrics"][k]["rom"] for k in AMPLITUDES}
            metrics, _, _ = compare_metrics(m_rd, m_dyn)
            row["rom"][name] = {"metrics": metrics, "amplification": _ratios(m_rd, m_rs)}
        out["speeds"].append(row)
    return out


def _ratios(dynamic: dict, static: dict) -> dict:
    return {k: dynamic[k] / static[k] for k in AMPLITUDES if static[k] != 0}


def decomposition(metrics_ltca: dict, metrics_table: dict) -> dict:
    """Per amplitude metric: the default ROM's relative miss against the FE, the part of it that the table
    change removes (``(ltca - table) / fe``: static) and what is left (``(table - fe) / fe``)."""
    out = {}
    for key in AMPLITUDES:
        a, b = metrics_ltca[key], metrics_table[key]
        fe = a["fe"]
        out[key] = {"total_rel": a["rel_error"], "static_table_rel": (a["rom"] - b["rom"]) / abs(fe),
                    "remaining_rel": b["rel_error"], "tolerance": TOLERANCES.get(key)}
    return out


def rom_runs(pair, tables: dict, records: dict, inertia: tuple[float, str], damping_ratio: float = 0.01) -> dict:
    """The pair ROM with each table (outline facets at the table's own stiffness) at each record's speed.

    Parameters
    ----------
    pair : GearPair
    tables : dict name -> (MeshExcitation, label, provenance)
    records : dict rpm -> FERecord
    inertia : (J2 [kg m^2], label)
    damping_ratio : float

    Returns
    -------
    dict name -> dict rpm -> SpeedComparison
    """
    from gearrom.validation.report import facet_kinematic_te, validate_speed

    out: dict = {}
    for name, (table, label, prov) in tables.items():
        out[name] = {}
        for rpm, fe in records.items():
            torque = float(fe.meta["torque_out_Nm"])
            outline, body = fe.meta["outline_size_mm"] * 1e-3, fe.meta["body_size_mm"] * 1e-3
            kin = facet_kinematic_te(pair, table, torque, outline, body, rpm * 2 * math.pi / 60 * float(fe.t[-1]))
            out[name][rpm] = validate_speed(pair, rpm, fe, table, label, inertia[0], inertia[1], damping_ratio,
                                            kinematic=kin, table_provenance=prov)
            log.info("%s at %g rpm: %s", name, rpm, "pass" if out[name][rpm].passed else "; ".join(out[name][rpm].misses))
    return out


def static_point_check(pair, tables: dict, static_path: str | Path, slow_window: tuple[float, float],
                       outline: float, body: float) -> dict:
    """The ROM's quasi-static TE (each table + facets) at every stored static explicit point.

    ``slow_window`` (rad): input angles of the slow run's steady window; points inside it are the data
    the ``explicit_qs`` table was built from (in-sample), the others are out-of-sample for every table.
    Returns, per table, the error at each point and its mean / RMS in and out of the window [um].
    """
    th, te, _ = load_static_points(static_path)
    inside = (th >= slow_window[0] - 1e-9) & (th <= slow_window[1] + 1e-9)
    out = {"theta_in_rad": th.tolist(), "te_static_um": (te * 1e6).tolist(), "in_slow_window": inside.tolist(),
           "tables": {}}
    for name, (table, _, _) in tables.items():
        err = (rom_static_te(pair, table, th, outline, body) - te) * 1e6
        row = {"error_um": err.tolist()}
        for key, sel in (("in_slow_window", inside), ("outside", ~inside)):
            if sel.any():
                row[key] = {"n": int(sel.sum()), "mean_um": float(err[sel].mean()),
                            "rms_um": float(np.sqrt(np.mean(err[sel] ** 2))),
                            "std_um": float(err[sel].std())}
        out["tables"][name] = row
    return out


def periodic_split(te: np.ndarray, parts: dict, per_period: int) -> dict:
    """Split static TE records on a whole number of mesh periods into the mesh-periodic mean and the rest.

    Parameters
    ----------
    te : ndarray
        Explicit FE static TE [m] (``per_period`` uniform samples per mesh period).
    parts : dict name -> ndarray
        Other records on the same angles [m]: ``table_ste`` (the table's STE) and ``facets`` (the facet
        kinematic TE) enable ``elastic_ratio`` and the regression.
    per_period : int

    Returns
    -------
    dict (um): per record the periodic mean curve, its GMF1-3 amplitudes and the RMS of the
    tooth-specific rest; ``elastic_ratio`` = (FE - facets) / table STE of the periodic curves and the
    regression of the FE's tooth-specific rest on the facet model's (``slope``, ``correlation``).
    """
    def split(x):
        a = np.asarray(x, float).reshape(-1, per_period)
        mean = a.mean(axis=0)
        c = 2 * np.fft.rfft(mean - mean.mean()) / per_period
        return mean, np.abs(c[1:4]), (a - mean).ravel()

    out: dict = {}
    rest = {}
    for name, x in {"fe": te, **parts}.items():
        mean, h, r = split(x)
        rest[name] = r
        out[name] = {"periodic_um": (mean * 1e6).tolist(), "gmf1_3_um": (h * 1e6).tolist(),
                     "mean_um": float(mean.mean() * 1e6), "tooth_specific_rms_um": float(r.std() * 1e6)}
    if "table_ste" in parts and "facets" in parts:
        ratio = (split(te)[0] - split(parts["facets"])[0]) / split(parts["table_ste"])[0]
        out["elastic_ratio"] = {"per_phase": ratio.tolist(), "mean": float(ratio.mean()), "std": float(ratio.std())}
        f, k = rest["fe"], rest["facets"]
        out["tooth_specific_regression"] = {"slope": float(np.dot(f, k) / np.dot(k, k)),
                                            "correlation": float(np.corrcoef(f, k)[0, 1])}
    return out


def two_torque_split(te_hi: np.ndarray, te_lo: np.ndarray, model_hi: np.ndarray, model_lo: np.ndarray,
                     ltca_hi: np.ndarray, ltca_lo: np.ndarray, ratio: float = 2.0) -> dict:
    """Loaded kinematic offset and compliance of the explicit model from static TE at two torques.

    With ``T_hi = ratio T_lo`` and a TE affine in the torque (linear penalty contact, all loaded pairs
    closed at both torques): offset ``= (ratio te_lo - te_hi) / (ratio - 1)``, increment
    ``= te_hi - te_lo``. The same for the ROM's static model (LTCA + facets) and the LTCA alone [m].

    Returns
    -------
    dict (um): per point offsets and increments, the explicit-to-LTCA increment ratio (mean, std),
    the elastic ratio ``(te_hi - offset) / ltca_hi`` (mean) and the RMS difference of the offsets.
    """
    def offset(hi, lo):
        return (ratio * np.asarray(lo, float) - np.asarray(hi, float)) / (ratio - 1.0)

    off_fe, off_model = offset(te_hi, te_lo), offset(model_hi, model_lo)
    inc_fe, inc_ltca = te_hi - te_lo, ltca_hi - ltca_lo
    inc_ratio = inc_fe / inc_ltca
    elastic = (te_hi - off_fe) / ltca_hi
    return {"offset_fe_um": (off_fe * 1e6).tolist(), "offset_model_um": (off_model * 1e6).tolist(),
            "offset_rms_difference_um": float(np.sqrt(np.mean((off_fe - off_model) ** 2)) * 1e6),
            "offset_mean_fe_um": float(off_fe.mean() * 1e6), "offset_mean_model_um": float(off_model.mean() * 1e6),
            "increment_fe_um": (inc_fe * 1e6).tolist(), "increment_ltca_um": (inc_ltca * 1e6).tolist(),
            "increment_model_um": ((model_hi - model_lo) * 1e6).tolist(),
            "increment_ratio": {"per_point": inc_ratio.tolist(), "mean": float(inc_ratio.mean()),
                                "std": float(inc_ratio.std())},
            "elastic_ratio_mean": float(elastic.mean())}


def mode_band_rms(theta_in: np.ndarray, te: np.ndarray, z1: int, band: tuple[float, float]) -> dict:
    """DTE RMS [um] of a record on a whole number of mesh periods, split by mesh order.

    Returns ``total``, ``gmf1_3`` (orders 1-3), ``whole_orders_4_up`` and ``fractional_in_band`` /
    ``fractional_rest``: the bins between whole mesh orders (not periodic in the mesh: free vibration,
    tooth-to-tooth content) inside / outside ``band`` (mesh orders, around the mesh mode).
    """
    th = np.asarray(theta_in, float)
    x = np.asarray(te, float) - np.mean(te)
    periods = int(round(th.size * float(np.median(np.diff(th))) * z1 / (2 * math.pi)))
    p = 2 * np.abs(np.fft.rfft(x) / x.size) ** 2
    p[0] = 0.0
    orders = np.arange(p.size) / periods
    whole = np.arange(p.size) % periods == 0
    inside = (orders >= band[0]) & (orders <= band[1])

    def rms(mask):
        return float(np.sqrt(p[mask].sum()) * 1e6)

    return {"total": rms(np.ones(p.size, bool)), "gmf1_3": rms(whole & (orders >= 1) & (orders <= 3)),
            "whole_orders_4_up": rms(whole & (orders > 3)), "fractional_in_band": rms(~whole & inside),
            "fractional_rest": rms(~whole & ~inside), "band_orders": list(band), "mesh_periods": periods}


def static_dynamic_summary(rom_vs_fe: dict, window: dict, table: str = "ltca") -> dict:
    """Per speed and metric: the ROM's miss on the 10-period window and its two factors on the static window.

    ``static`` = ROM static / FE static - 1 (the mesh table + facets against the explicit model's static
    solves), ``dynamic`` = ROM amplification / FE amplification - 1 (dynamic / static, each model on
    its own), so that ``(1 + static) (1 + dynamic) - 1`` is the miss on the static window.
    """
    out = {}
    static = window["rom_static"][table]["metrics"]
    for row in window["speeds"]:
        rpm = str(int(row["rpm_in"]))
        amp_rom = row["rom"][table]["amplification"]
        out[rpm] = {}
        for key in ("te_mean_um", "dte_rms_um", "gmf1_amplitude_um", "gmf2_amplitude_um", "gmf3_amplitude_um"):
            s, dyn = static[key]["rel_error"], amp_rom[key] / row["fe_amplification"][key] - 1.0
            out[rpm][key] = {"miss_10_periods": rom_vs_fe[table][rpm]["metrics"][key]["rel_error"],
                             "miss_static_window": row["rom"][table]["metrics"][key]["rel_error"],
                             "static": s, "dynamic": dyn, "static_share": _share(s, dyn)}
    return out


def _share(static: float, dynamic: float) -> float:
    """Share of the static factor in the miss, by log-magnitude: |ln(1+s)| / (|ln(1+s)| + |ln(1+d)|)."""
    a, b = abs(math.log1p(static)), abs(math.log1p(dynamic))
    return a / (a + b) if a + b > 0 else float("nan")
