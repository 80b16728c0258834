"""Run-up: a continuous speed ramp of the ROM drivetrain and order tracking of the DTE, as a rig measures it.

The ramp is built here on the public model objects (:func:`gearrom.rom.rig.build_rig`,
:func:`gearrom.rom.simulate.mesh_law`, :func:`gearrom.rom.reduce.reduce`) in the same way as
:func:`gearrom.rom.simulate.simulate_run` builds a constant-speed run:

* the coordinates are deviations from the nominal rotation, which follows the commanded speed
  profile: ``omega_1(t) = omega_0`` while the run settles (``settle_s``), then
  ``omega_0 + alpha (t - t_s)`` up to ``omega_end``; the mesh angles are the integrals of it;
* the constant angular acceleration ``alpha`` loads the deviation coordinates with ``-alpha M r``
  (``r`` the nominal rigid rotation); the drive supplies the acceleration torque ``alpha r^T M r`` on
  the motor rotor (a speed loop with acceleration feed-forward), so the net load is self-balanced
  and only twists the shafts;
* the reduced basis and the gyroscopic damping are those at the mid speed of the ramp (the
  gyroscopic terms of this rig are small against the mesh and bearing terms);
* the mesh is the constant-speed run's own element (:class:`gearrom.rom.meshstep.MeshStepper`, the
  secant or the load-dependent law, effects included), driven by the ramp's mesh angles.

Order tracking: the sensor-side DTE is resampled onto a uniform grid of the nominal input angle
(``samples_per_mesh`` per mesh period, cubic spline) and cut into blocks of ``block_mesh`` mesh
periods with 50 % overlap. Each block gives an order spectrum (Hann window, amplitude corrected) and
the GMF amplitudes at orders 1-3 from a DFT at the exact orders (rectangular window over whole mesh
periods, the estimator of the stepped sweep), at the block's mean speed.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import ConfigError, ModelError
from gearrom.spectral import line_amplitudes
from gearrom.excitation.table import netcdf_engine


@dataclass(eq=False)
class RunupResult:
    """Order-tracked DTE of a run-up.

    Attributes
    ----------
    rpm : ndarray (n_blocks,)
        Mean input speed of each block [rpm].
    time_s : ndarray (n_blocks,)
        Block centre time from the start of the ramp [s].
    orders : ndarray (n_orders,)
        Input-shaft orders.
    amplitude_um : ndarray (n_blocks, n_orders)
        Zero-to-peak DTE order spectrum, sensor side [um].
    gmf_um : ndarray (n_blocks, 3)
        DTE amplitude at GMF orders 1-3 [um].
    """

    config: str
    rpm: np.ndarray
    time_s: np.ndarray
    orders: np.ndarray
    amplitude_um: np.ndarray
    gmf_um: np.ndarray
    z: tuple[int, int]
    metadata: dict = field(default_factory=dict)

    @property
    def ramp_rate_rpm_per_s(self) -> float:
        return float(self.metadata["ramp_rate_rpm_per_s"])

    def gmf_at(self, rpm, order: int = 1) -> np.ndarray:
        """GMF amplitude [um] of ``order`` interpolated at input speeds ``rpm``."""
        return np.interp(np.asarray(rpm, float), self.rpm, self.gmf_um[:, order - 1])

    def to_dataset(self):
        import xarray as xr

        return xr.Dataset(
            {"amplitude_um": (("rpm", "order"), self.amplitude_um), "gmf_um": (("rpm", "gmf_order"), self.gmf_um),
             "time_s": ("rpm", self.time_s)},
            coords={"rpm": ("rpm", self.rpm, {"units": "rpm"}), "order": self.orders, "gmf_order": [1, 2, 3]},
            attrs={"format": "gearrom.RunupResult", "config": self.config, "z1": self.z[0], "z2": self.z[1],
                   "metadata_json": json.dumps(self.metadata, default=str)})

    def save(self, path: str | Path) -> Path:
        """Write to NetCDF atomically; returns the path."""
        from gearrom.rom.sweep import write_netcdf_atomic

        return write_netcdf_atomic(self.to_dataset(), path)

    @classmethod
    def load(cls, path: str | Path) -> "RunupResult":
        import xarray as xr

        with xr.open_dataset(path, engine=netcdf_engine()) as ds:
            if ds.attrs.get("format") != "gearrom.RunupResult":
                raise ModelError(f"{path}: not a gearrom run-up file")
            return cls(str(ds.attrs["config"]), ds["rpm"].values, ds["time_s"].values, ds["order"].values,
                       ds["amplitude_um"].values, ds["gmf_um"].values, (int(ds.attrs["z1"]), int(ds.attrs["z2"])),
                       json.loads(ds.attrs["metadata_json"]))

    def plot(self, max_order: float | None = None, compare: dict | None = None):
        """Colour map of the DTE order spectrum vs speed; with ``compare`` (see :func:`compare_with_sweep`),
        a second panel with GMF x1-3 of the run-up against the stepped sweep."""
        from gearrom.plotting import subplots
        from matplotlib.colors import LogNorm

        z1 = self.z[0]
        max_order = max_order or 3.5 * z1
        sel = self.orders <= max_order
        fig, axes = subplots(1, 2 if compare else 1, figsize=(13 if compare else 8, 5.5), squeeze=False)
        ax = axes[0, 0]
        a = np.maximum(self.amplitude_um[:, sel], 1e-5)
        pc = ax.pcolormesh(self.orders[sel], self.rpm, a, shading="nearest",
                           norm=LogNorm(vmin=max(a.max() * 1e-4, 1e-5), vmax=a.max()))
        fig.colorbar(pc, ax=ax, label="DTE amplitude, sensor side [um]")
        ax.set_xlabel("input-shaft order")
        ax.set_ylabel("input speed [rpm]")
        ax.set_title(f"{self.config}: run-up {self.rpm[0]:.0f}-{self.rpm[-1]:.0f} rpm at "
                     f"{self.ramp_rate_rpm_per_s:.0f} rpm/s", fontsize=9)
        if compare:
            ax = axes[0, 1]
            for m in range(3):
                line, = ax.plot(self.rpm, self.gmf_um[:, m], lw=0.8, label=f"GMF x{m + 1} run-up")
                ax.plot(compare["rpm"], np.asarray(compare["sweep_gmf_um"])[:, m], "o", ms=3, color=line.get_color(),
                        label=f"GMF x{m + 1} stepped sweep")
            ax.set_yscale("log")
            ax.set_xlabel("input speed [rpm]")
            ax.set_ylabel("DTE amplitude [um]")
            ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        return fig


def _as_model(config_or_model, torque: float | None):
    """A Drivetrain as given, or built from a config / bundled name / path with the public rig builder."""
    from gearrom.rom.model import Drivetrain
    from gearrom.rom.rig import build_rig

    if isinstance(config_or_model, Drivetrain):
        return config_or_model
    return build_rig(config_or_model, torque_out=torque)


def _angle(t: np.ndarray, w0: float, alpha: float, ts: float, t_end: float) -> np.ndarray:
    """Nominal input angle [rad] at times ``t``: constant ``w0`` up to ``ts``, ramp up to ``t_end``, then constant."""
    tr = np.clip(t - ts, 0.0, t_end - ts)
    return w0 * t + 0.5 * alpha * tr**2 + alpha * (t_end - ts) * np.maximum(t - t_end, 0.0)


def simulate_runup(config_or_model, rpm_start: float, rpm_end: float, duration_s: float,
                   torque_out_Nm: float | None = None, *, effects=None, samples_per_mesh: int = 64,
                   block_mesh: int | None = None, settle_s: float | None = None, step_s: float | None = None,
                   theta0: float = 0.0) -> RunupResult:
    """Simulate a linear speed ramp and order-track the DTE (see module docstring).

    Parameters
    ----------
    config_or_model : Drivetrain or GearConfig or str or Path
        Model, loaded config, bundled name or TOML path.
    rpm_start, rpm_end : float
        Input speeds at the start and the end of the ramp [rpm], ``0 < rpm_start < rpm_end``.
    duration_s : float
        Ramp duration [s].
    torque_out_Nm : float, optional
        Load torque [N m] (default: the config's operating torque).
    effects : Effects, optional
        Kinematic effects (default: the config's enabled micro-geometry, as :func:`simulate_run`).
    samples_per_mesh : int
        Samples per mesh period of the angle-domain signal and of the time-domain recording at the
        top speed (>= 8). 64 keeps the mesh harmonics near 32 (table jumps of a spur pair) from
        folding onto GMF x1.
    block_mesh : int, optional
        Mesh periods per order-tracking block (default ``z1``: one input revolution, order resolution 1).
    settle_s : float, optional
        Constant-speed time at ``rpm_start`` before the ramp [s] (default 20 ms).
    step_s : float, optional
        Fixed RK44 step [s] (default as :func:`simulate_run` at ``rpm_end``).
    theta0 : float
        Input angle at ``t = 0`` [rad].

    Raises
    ------
    ConfigError
        Bad speeds, duration or sampling.
    SolverError
        The integration diverged.
    """

    from gearrom.rom.components import RZ
    from gearrom.rom.mesh import Effects
    from gearrom.rom.meshstep import MeshStepper, reduced_system, solve_rk44
    from gearrom.rom.reduce import periodic_initial_state, reduce
    from gearrom.rom.simulate import mesh_law

    if not (0 < rpm_start < rpm_end and math.isfinite(rpm_end)):
        raise ConfigError(f"run-up speeds need 0 < start < end, got {rpm_start!r} -> {rpm_end!r} rpm")
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ConfigError(f"run-up duration must be positive, got {duration_s!r} s")
    if samples_per_mesh < 8:
        raise ConfigError(f"samples_per_mesh must be >= 8, got {samples_per_mesh}")
    model = _as_model(config_or_model, torque_out_Nm)
    torque = float(model.metadata.get("torque_out_Nm", 120.0) if torque_out_Nm is None else torque_out_Nm)
    effects = Effects.from_pair(model.pair) if effects is None else effects
    z1, z2 = model.pair.z
    w0, w1 = rpm_start * math.pi / 30, rpm_end * math.pi / 30
    alpha = (w1 - w0) / duration_s
    settle = 0.02 if settle_s is None else float(settle_s)
    t_mesh_min = 2 * math.pi / (z1 * w1)
    law = mesh_law(model, torque, effects)
    red = reduce(model, 0.5 * (rpm_start + rpm_end), torque)
    h = min(model.max_step, 2.2 / red.omega_max, t_mesh_min / 32) if step_s is None else float(step_s)
    fs = samples_per_mesh / t_mesh_min  # time-domain recording: samples_per_mesh at the top speed
    n_sub = int(math.ceil((1.0 / fs) / h - 1e-9))
    h = 1.0 / (fs * n_sub)
    t_end = settle + duration_s
    n_steps = int(math.ceil(t_end / h))
    n_settle = int(round(settle / h))
    # acceleration load on the deviation coordinates, balanced by the drive's feed-forward
    M = model.structure[0]
    r = model.rigid_mode
    f_acc = -alpha * (M @ r)
    f_acc[model.index(model.motor_station, RZ)] += alpha * float(r @ M @ r)
    F_acc = red.T.T @ (red.phi.T @ f_acc)
    c_mesh = model.mesh_damping(torque)
    e_offset = law.evaluate(theta0, theta0 * z1 / z2)[1] - law.base(theta0)[1]
    y0, v0 = periodic_initial_state(red, model, rpm_start, torque, law.k_grid, law.e_grid, theta0, e_offset=e_offset)

    SC, mbs, node, body, sens = reduced_system(red, y0, v0)
    f_ramp = list(red.F + F_acc)

    def angles(tm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        th1 = theta0 + _angle(tm, w0, alpha, settle, t_end)
        return th1, theta0 * z1 / z2 + (th1 - theta0) * z1 / z2

    mesh = MeshStepper(mbs, node, red.i_delta, law, c_mesh, model.mesh.backlash, h, n_steps, angles)

    def pre_step(mbs_, t):
        n = mesh.step_index(t)
        if n == n_settle:  # the ramp starts: its acceleration load on the deviation coordinates
            mbs_.SetObjectParameter(body, "forceVector", f_ramp)
        mesh.update(n)
        return True

    mbs.SetPreStepUserFunction(pre_step)
    raw, wall, cpu = solve_rk44(mbs, sens, n_steps, n_steps * h, fs, "run-up integration")
    enc = {(e.side, e.shaft): model.index(e.station, RZ) for e in model.encoders}
    if ("sensor", "in") not in enc or ("sensor", "out") not in enc:
        raise ModelError(f"model {model.name!r} needs sensor-side encoders on both shafts for the run-up DTE")
    x = red.to_physical(raw[:, 1:], np.array([enc["sensor", "in"], enc["sensor", "out"]]))
    rb1, rb2 = model.pair.rb
    dte = rb1 * x[:, 0] + rb2 * x[:, 1]
    meta = {"config": model.metadata.get("config", model.name), "config_digest": model.metadata.get("config_digest", ""),
            "rpm_start": rpm_start, "rpm_end": rpm_end, "duration_s": duration_s,
            "ramp_rate_rpm_per_s": (rpm_end - rpm_start) / duration_s, "torque_out_Nm": torque, "step_s": h,
            "n_steps": n_steps, "settle_s": settle, "wall_s": wall, "cpu_s": cpu, "samples_per_mesh": samples_per_mesh,
            "reduced_at_rpm": 0.5 * (rpm_start + rpm_end), "effects": repr(effects) if not effects.empty else ""}
    return order_track(raw[:, 0], dte, w0, alpha, settle, t_end, z1, z2, samples_per_mesh, block_mesh or z1, meta)


def order_track(t: np.ndarray, dte: np.ndarray, w0: float, alpha: float, ts: float, t_end: float, z1: int, z2: int,
                samples_per_mesh: int, block_mesh: int, meta: dict) -> RunupResult:
    """Angle-domain resampling and blockwise order spectra of a ramp's DTE (see module docstring)."""
    from scipy.interpolate import CubicSpline

    theta = _angle(t, w0, alpha, ts, t_end)
    sel = (t >= ts) & (t <= t_end)
    d_th = 2 * math.pi / (z1 * samples_per_mesh)
    grid = np.arange(theta[sel][0], theta[sel][-1], d_th)
    y = CubicSpline(theta[sel], dte[sel])(grid)
    n = block_mesh * samples_per_mesh
    hop = n // 2
    starts = np.arange(0, len(grid) - n + 1, hop)
    if starts.size == 0:
        raise ConfigError(f"the ramp is shorter than one order-tracking block ({block_mesh} mesh periods)")
    win = np.hanning(n)
    k = np.arange(n)
    orders = np.arange(n // 2 + 1) * z1 / block_mesh
    amp, gmf, rpm, tc = [], [], [], []
    # time at each angle-grid point (inverse of the ramp's angle law) for the block speeds
    t_grid = np.interp(grid, theta[sel], t[sel])
    for s0 in starts:
        blk = y[s0:s0 + n] - y[s0:s0 + n].mean()
        amp.append(2 * np.abs(np.fft.rfft(blk * win)) / win.sum())
        gmf.append(line_amplitudes(blk, 2 * np.pi * k / samples_per_mesh, (1, 2, 3)))
        tb = t_grid[s0:s0 + n]
        rpm.append((grid[s0 + n - 1] - grid[s0]) / (tb[-1] - tb[0]) * 30 / math.pi)
        tc.append(0.5 * (tb[0] + tb[-1]) - ts)
    meta = {**meta, "block_mesh_periods": block_mesh, "block_overlap": 0.5}
    return RunupResult(meta.get("config", ""), np.array(rpm), np.array(tc), orders, np.array(amp) * 1e6,
                       np.array(gmf) * 1e6, (z1, z2), meta)


def compare_with_sweep(result: RunupResult, config_or_model, rpms, torque_out_Nm: float | None = None,
                       n_output_revs: float = 2.0, effects=None,
                       samples_per_mesh: int = 64) -> dict:
    """Stepped steady-state runs at ``rpms`` against the run-up's GMF amplitudes at the same speeds.

    The steady-state runs sample synchronously with the mesh at ``samples_per_mesh``; at 32 samples
    per mesh the harmonics 31 and 33 of a spur pair's table fold onto GMF x1 and bias it.

    Returns
    -------
    dict
        ``rpm``, ``sweep_gmf_um`` (n, 3), ``runup_gmf_um`` (n, 3) and ``rel_diff`` (n, 3): run-up / sweep - 1.
    """
    from gearrom.rom.simulate import simulate_run

    model = _as_model(config_or_model, torque_out_Nm)
    rpms = np.asarray(rpms, float)
    z1 = model.pair.z[0]
    sw = np.array([simulate_run(model, r, torque_out_Nm, n_output_revs=n_output_revs, effects=effects,
                                sample_rate_hz=samples_per_mesh * z1 * r / 60).gmf_amplitudes("sensor", 3) * 1e6 for r in rpms])
    ru = np.column_stack([result.gmf_at(rpms, m) for m in (1, 2, 3)])
    return {"rpm": rpms.tolist(), "sweep_gmf_um": sw.tolist(), "runup_gmf_um": ru.tolist(),
            "rel_diff": (ru / sw - 1).tolist(), "ramp_rate_rpm_per_s": result.ramp_rate_rpm_per_s}
