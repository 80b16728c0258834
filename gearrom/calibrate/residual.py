"""Runs, model-vs-measurement mapping, residuals and order-line regression.

A run is read with the signal pipeline (:func:`gearrom.signal.process_measurement`: edges ->
angles -> TE with the linear detrend) and kept on a working grid (FIR decimation to about
``8 x GMF``, at least 16 kHz). Three signals are compared, all along the transverse line of
action in m:

* ``te``: the TE, ``r_b1 theta_1 - r_b2 theta_2``, detrended (the quantity the error is reported on);
* ``u_in``, ``u_out``: each channel's own angle fluctuation ``r_b theta`` about uniform rotation.
  They tell a real motion (the drivetrain moves: gear errors) from a measurement error of one
  encoder (only that channel sees it).

A simulated run is mapped onto a measured run *by input-shaft angle* (the model value at the
sample where the simulated input angle equals the measured one), low-passed like the
measurement, and detrended over the same record, so both go through the same processing.

Angle references: each channel's angle is zero at its first edge. The encoder offsets that matter
are estimated, not fitted: the constant TE offset and slope are removed by the detrend, and the
mesh phase (where the teeth are at encoder zero) by :func:`estimate_mesh_phase` from the nominal
model's own GMF lines only.
"""
from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg
from scipy import signal
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize_scalar

from gearrom.calibrate.simulator import SimHistory
from gearrom.errors import CalibrationError
from gearrom.signal import GearMeshInfo, ReadSettings, TESettings, process_measurement
from gearrom.signal.filters import FilterSettings
from gearrom.signal.runup import steadiness

log = logging.getLogger(__name__)

SIGNALS = ("te", "u_in", "u_out")
EDGE_TRIM = 24  # working-grid samples dropped at each end (decimation filter transients)


@dataclass(frozen=True, eq=False)
class RunData:
    """One measured run on the working grid.

    Attributes
    ----------
    name : str
        Measurement file.
    rpm_in, rpm_in_nominal, torque_out_Nm : float
        Measured and nominal input speed (rpm), load torque (N m).
    t_s, theta_in_rad, theta_out_rad : ndarray
        Working grid and channel angles (zero at each channel's first edge).
    y : ndarray, shape (3, n)
        ``te``, ``u_in``, ``u_out``, m (see module docstring).
    fs_hz : float
        Working rate, Hz.
    mesh : GearMeshInfo
    repairs : tuple of dict
    """

    name: str
    rpm_in: float
    rpm_in_nominal: float
    torque_out_Nm: float
    t_s: np.ndarray
    theta_in_rad: np.ndarray
    theta_out_rad: np.ndarray
    y: np.ndarray
    fs_hz: float
    mesh: GearMeshInfo
    repairs: tuple = ()
    info: dict = field(default_factory=dict)

    @property
    def gmf_hz(self) -> float:
        return self.mesh.z1 * self.rpm_in / 60.0

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0])

    @property
    def revs_out(self) -> float:
        return float(self.theta_out_rad[-1] - self.theta_out_rad[0]) / (2 * math.pi)


def _decimate(x: np.ndarray, q: int) -> np.ndarray:
    out = x
    while q > 1:
        step = next(s for s in (10, 8, 6, 5, 4, 3, 2, q) if q % s == 0)
        out = signal.decimate(out, step, ftype="fir", zero_phase=True)
        q //= step
    return out


def working_factor(fs_hz: float, gmf_hz: float) -> int:
    """Decimation factor to the working rate (about 8 x GMF, at least 16 kHz)."""
    target = max(16e3, 8.0 * gmf_hz)
    return max(1, int(fs_hz // target))


def load_run(path: str | Path, mesh: GearMeshInfo, torque_out_Nm: float | None = None,
             read_settings: ReadSettings | None = None, te_settings: TESettings | None = None) -> RunData:
    """Read a measurement into a :class:`RunData` (signal pipeline, then working grid).

    Parameters
    ----------
    path : str or Path
        ``gearrom.measurement/1`` JSON.
    mesh : GearMeshInfo
    torque_out_Nm : float, optional
        Load torque when the file does not state ``torque_out_Nm``.
    read_settings : ReadSettings, optional
    te_settings : TESettings, optional
        The config's ``[signal]`` TE settings. Their speed-ratio check (``ratio_tolerance``) and
        encoder-scale estimate (``estimate_scale``) apply; the TE is always taken on the line of
        action with the default detrend and no other filter (:func:`diagnosis_te_settings`), since
        the simulated signals go through exactly this processing.

    Raises
    ------
    CalibrationError
        No load torque known, or the record is shorter than one output revolution.
    """
    res = process_measurement(path, mesh, read_settings=read_settings, te_settings=diagnosis_te_settings(te_settings))
    torque = res.torque_out_Nm if res.torque_out_Nm is not None else torque_out_Nm
    if torque is None:
        raise CalibrationError(f"{path}: 'torque_out_Nm' is missing in the measurement and was not given "
                               "(--torque-out-Nm)")
    q = working_factor(res.fs_hz, res.gmf_hz)
    th1, th2, te, t = res.theta_in_rad, res.theta_out_rad, res.te_m, res.t_s
    info = {}
    st = steadiness(t, th1)
    if not st["steady"]:
        # the model is a steady run, and a channel's fluctuation about uniform rotation holds the whole
        # speed change of a start-up or stop: only the steady part is compared
        t0, t1 = st["steady_window_s"]
        keep = (t >= t0) & (t <= t1)
        th1, th2, te, t = th1[keep], th2[keep], te[keep], t[keep]
        th1, th2 = th1 - th1[:1], th2 - th2[:1]  # angles from the window's first sample, as from a first edge
        info["steady_window_s"] = [float(t0), float(t1)]
        info["speed_range_rpm"] = [st["rpm_min"], st["rpm_max"]]
        if t.size < 64 or (th2[-1] - th2[0]) < 2 * math.pi:
            raise CalibrationError(
                f"{path}: not a steady run (input speed {st['rpm_min']:.4g}..{st['rpm_max']:.4g} rpm) and its steady "
                f"part t={t0:.4g}..{t1:.4g} s holds {(th2[-1] - th2[0]) / (2 * math.pi) if t.size else 0:.2f} output "
                "revolutions; the diagnosis compares steady runs and needs at least 1")
    u1 = mesh.rb1_m * signal.detrend(th1)
    u2 = mesh.rb2_m * signal.detrend(th2)
    y = np.vstack([_decimate(v, q) for v in (te, u1, u2)])
    n = y.shape[1]
    th1d, th2d, td = th1[::q][:n], th2[::q][:n], t[::q][:n]
    cut = slice(EDGE_TRIM, n - EDGE_TRIM)  # the decimation filter's start/end transients
    y, th1d, th2d, td = y[:, cut], th1d[cut], th2d[cut], td[cut]
    y = detrend(comparison_lowpass(y, res.fs_hz / q))
    run = RunData(name=str(path), rpm_in=float(res.rpm_in), rpm_in_nominal=float(res.rpm_in_nominal),
                  torque_out_Nm=float(torque), t_s=td - td[0], theta_in_rad=th1d, theta_out_rad=th2d, y=y,
                  fs_hz=res.fs_hz / q, mesh=mesh, repairs=tuple(res.repairs), info=info)
    if run.revs_out < 1.0:
        raise CalibrationError(f"{path}: the record holds {run.revs_out:.2f} output revolutions; the diagnosis "
                               "needs at least 1 (2 recommended)")
    return run


def diagnosis_te_settings(te_settings: TESettings | None) -> TESettings:
    """The TE settings a run is read with: ``te_settings`` without filters and on the line of action.

    The ratio check, its tolerance and the encoder-scale estimate are kept. A low-pass, high-pass or
    a pitch-circle TE of the ``[signal]`` section is not applied: the model is compared on the line
    of action through :func:`comparison_lowpass` and the detrend, identically on both sides, and a
    filter on the measured side only would show up as a model error.
    """
    te = te_settings or TESettings()
    return dataclasses.replace(te, te_on="line", filters=FilterSettings())


LOWPASS_FRAC = 0.38  # comparison band edge, x the working rate (8th-order Butterworth, zero phase)


def comparison_lowpass(y: np.ndarray, fs_hz: float) -> np.ndarray:
    """The band limit applied identically to measured and simulated signals on the working grid.

    The measurement reaches the working grid through FIR decimation, a simulation through
    interpolation; their anti-alias filters differ near the working Nyquist frequency. A common
    zero-phase low-pass at ``LOWPASS_FRAC x fs`` on the *same* samples makes the comparison band
    identical (content above it, e.g. a mesh resonance near the Nyquist frequency, is not compared).
    """
    sos = signal.butter(8, LOWPASS_FRAC * fs_hz, fs=fs_hz, output="sos")
    return signal.sosfiltfilt(sos, y, axis=-1)


def lowpass_gain(f_hz, fs_hz: float) -> np.ndarray:
    """Amplitude gain of :func:`comparison_lowpass` at ``f_hz`` (both passes)."""
    x = (np.asarray(f_hz, float) / (LOWPASS_FRAC * fs_hz)) ** 16
    return 1.0 / (1.0 + x)


def sim_signals(hist: SimHistory, mesh: GearMeshInfo) -> tuple[np.ndarray, np.ndarray]:
    """``(theta_in, [te, u_in, u_out])`` of a simulated history, raw (trend removed per channel)."""
    th1, th2 = hist.theta_in_rad, hist.theta_out_rad
    te = mesh.rb1_m * th1 - mesh.rb2_m * th2
    return th1, np.vstack([te, mesh.rb1_m * signal.detrend(th1), mesh.rb2_m * signal.detrend(th2)])


def map_to_run(hist: SimHistory, run: RunData, angle_shift: float = 0.0) -> np.ndarray:
    """Simulated ``te, u_in, u_out`` at the run's samples, matched by input-shaft angle, same processing.

    ``angle_shift`` (rad): evaluate the simulation at ``theta_in + angle_shift``. For a simulation
    without shaft-order content this equals imposing the mesh phase ``angle_shift`` (the steady
    state is then a function of the mesh phase only), at no extra simulation.

    Raises
    ------
    CalibrationError
        The simulated record does not cover the measured input-angle span.
    """
    th_s, ys = sim_signals(hist, run.mesh)
    fs_sim = 1.0 / float(np.median(np.diff(hist.t_s)))
    fc = 0.48 * run.fs_hz  # anti-alias before sampling at the run's samples
    if fc < 0.5 * fs_sim * 0.95:
        sos = signal.butter(8, fc, fs=fs_sim, output="sos")
        ys = signal.sosfiltfilt(sos, ys, axis=1)
    th_m = run.theta_in_rad
    th_m = th_m + angle_shift
    if th_s[0] > th_m[0] + 1e-3 or th_s[-1] < th_m[-1]:
        raise CalibrationError(f"simulated run covers input angle {th_s[0]:.3f}..{th_s[-1]:.3f} rad, the "
                               f"measurement {run.name} needs {th_m[0]:.3f}..{th_m[-1]:.3f} rad")
    out = CubicSpline(th_s, ys, axis=1)(th_m)  # linear interpolation would low-pass the mesh orders
    return detrend(comparison_lowpass(out, run.fs_hz), axis=1)


# ------------------------------------------------------------------ order lines
def line_design(theta_in: np.ndarray, theta_out: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Columns ``cos(phi), -sin(phi)`` with ``phi = a theta_in + b theta_out`` for each line ``(a, b)``."""
    lines = np.atleast_2d(np.asarray(lines, float))
    ph = np.outer(theta_in, lines[:, 0]) + np.outer(theta_out, lines[:, 1])
    return np.hstack([np.cos(ph), -np.sin(ph)])


def fit_lines(y: np.ndarray, theta_in: np.ndarray, theta_out: np.ndarray, lines, trend: bool = True) -> np.ndarray:
    """Complex amplitudes ``c`` of ``y ~ Re(sum c exp(i phi))`` by joint least squares over the lines.

    ``y`` may be 1-D or (k, n) (k signals at once; the result is then (k, n_lines)). With ``trend``
    an offset and a slope (in input angle) are fitted along as nuisance terms: every compared signal
    went through a linear detrend, which is not orthogonal to the lines over a short record. Lines that
    are the same line (:func:`coinciding_lines`, e.g. order 1 of the input and order 2 of the output of a
    15/30 pair) are fitted as one; each of them gets that line's amplitude.
    """
    lines = np.atleast_2d(np.asarray(lines, float))
    keep, inv = coinciding_lines(theta_in, theta_out, lines)
    A = line_design(theta_in, theta_out, lines[keep])
    L = A.shape[1] // 2
    if trend:
        u = (theta_in - theta_in.mean()) / max(np.ptp(theta_in), 1e-12)
        A = np.hstack([A, np.ones((A.shape[0], 1)), u[:, None]])
    Y = np.atleast_2d(y).T
    x = _solve_ls(A, Y)
    c = (x[:L] + 1j * x[L:2 * L]).T[:, inv]
    return c[0] if np.ndim(y) == 1 else c


#: Two lines whose phases drift apart by less than this over the record are one line, rad.
COINCIDE_RAD = 0.05


def coinciding_lines(theta_in: np.ndarray, theta_out: np.ndarray, lines) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the distinct lines among ``lines`` and, for each line, the index of its distinct line.

    With an integer or small-integer speed ratio two named lines can be the same line (z2 = 2 z1: order
    1 of the input and order 2 of the output). Their design columns then differ only by the TE in the
    angles, and a joint fit would give two huge amplitudes that cancel. Lines whose phases
    ``a theta_in + b theta_out`` drift apart by less than :data:`COINCIDE_RAD` over the record (with the
    measured speed ratio) are taken as one; far below one cycle, so lines that the record resolves are
    never merged.
    """
    lines = np.atleast_2d(np.asarray(lines, float))
    span_in = float(theta_in[-1] - theta_in[0]) if theta_in.size else 0.0
    ratio = float(theta_out[-1] - theta_out[0]) / span_in if span_in else 0.0
    order = lines[:, 0] + lines[:, 1] * ratio
    keep: list[int] = []
    inv = np.empty(len(lines), dtype=np.int64)
    for i, o in enumerate(order):
        for j, k in enumerate(keep):
            if abs(o - order[k]) * abs(span_in) < COINCIDE_RAD:
                inv[i] = j
                break
        else:
            inv[i] = len(keep)
            keep.append(i)
    return np.asarray(keep, dtype=np.int64), inv


def _solve_ls(A: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Least squares ``A x ~ Y``: normal equations of the column-scaled design by Cholesky (fast; the line
    columns are nearly orthogonal), falling back to an SVD solve when the Gram matrix is ill-conditioned
    (lines closer than the record resolves)."""
    s = np.sqrt(np.einsum("ij,ij->j", A, A))
    s[s == 0] = 1.0
    As = A / s
    G = As.T @ As
    try:
        cf = scipy.linalg.cho_factor(G, check_finite=False)
        d = np.abs(np.diag(cf[0]))
        if d.min() > 1e-6 * d.max():  # cond(G) < ~1e12
            return scipy.linalg.cho_solve(cf, As.T @ Y, check_finite=False) / s[:, None]
    except np.linalg.LinAlgError:
        pass
    return scipy.linalg.lstsq(As, Y, lapack_driver="gelsd", cond=1e-10)[0] / s[:, None]


def mesh_lines(z1: int, n: int = 3) -> np.ndarray:
    """Lines of the GMF harmonics 1..n (orders of the input shaft)."""
    return np.array([[h * z1, 0.0] for h in range(1, n + 1)])


def estimate_mesh_phase(meas: np.ndarray, model: np.ndarray, z1: int, noise_um: float) -> tuple[float, bool]:
    """Mesh phase psi (input angle, rad) aligning the model's GMF lines to the measured ones.

    ``model_h exp(i h z1 psi) ~ meas_h`` in least squares over the harmonics h; only the nominal
    model's own GMF content is used, so no residual is fitted away. Returns ``(psi, identifiable)``;
    psi = 0 when the model's GMF lines are below ``3 x noise`` (nothing to align), or when even the best
    alignment leaves more than 20 % of the measured GMF energy (it would then follow an unmodelled effect;
    the micro-geometry fits then estimate psi together with the flank modification, rotating the
    nominal GMF lines consistently).
    """
    sm, sd = float(np.sum(np.abs(model))), float(np.sum(np.abs(meas)))
    if sm < 3 * noise_um * 1e-6 * model.size or sm < sd / 3:
        return 0.0, False
    period = 2 * math.pi / z1
    psi = np.linspace(0, period, 721)[:-1]
    h = np.arange(1, model.size + 1)

    def cost(p):
        rot = np.exp(1j * np.multiply.outer(p, h * z1))
        return np.sum(np.abs(meas - model * rot) ** 2, axis=-1)

    k = int(np.argmin(cost(psi)))
    d = psi[1] - psi[0]
    r = minimize_scalar(cost, bounds=(psi[k] - d, psi[k] + d), method="bounded", options={"xatol": d * 1e-4})
    if float(r.fun) > 0.2 * float(np.sum(np.abs(meas) ** 2)):
        return 0.0, False  # even aligned, the model leaves more than 20 % of the measured GMF energy
    return float(r.x % period), True


def noise_rms(x: np.ndarray, fs_hz: float) -> float:
    """Robust rms of the broadband noise in ``x`` from the median periodogram.

    A Blackman-Harris window (sidelobes below -90 dB) keeps the leakage of strong lines out of the
    band 0.05..0.3 fs used (inside the comparison band), and the median ignores the lines themselves:
    ``E|X_k|^2 = sigma^2 sum(w^2)`` and the median of an exponential variable is ``ln 2`` times its mean.
    """
    x = np.asarray(x, float) - np.mean(x)
    w = signal.get_window("blackmanharris", x.size)
    X = np.fft.rfft(x * w)
    f = np.fft.rfftfreq(x.size, 1 / fs_hz)
    band = (f > 0.05 * fs_hz) & (f < 0.3 * fs_hz)
    if band.sum() < 8:
        band = f > 0
    p = np.abs(X[band]) ** 2
    return float(math.sqrt(np.median(p) / (np.sum(w**2) * math.log(2))))


def detrend(a: np.ndarray, axis: int = -1) -> np.ndarray:
    """Remove offset and slope along ``axis`` (same as ``scipy.signal.detrend(type="linear")``, faster)."""
    a = np.asarray(a, float)
    n = a.shape[axis]
    t = np.linspace(-1.0, 1.0, n)
    e0 = np.full(n, 1 / math.sqrt(n))
    e1 = t / np.linalg.norm(t) if n > 1 else np.zeros(n)
    am = np.moveaxis(a, axis, -1)
    out = am - np.multiply.outer(am @ e0, e0) - np.multiply.outer(am @ e1, e1)
    return np.moveaxis(out, -1, axis)


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))
