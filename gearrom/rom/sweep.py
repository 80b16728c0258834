"""Speed sweep: one steady-state run per speed, in parallel processes, resumable.

Each speed is written to ``OUT/speeds/rpm_XXXXX.XX.nc`` as soon as it finishes (with the config
digest); a rerun skips speeds whose file exists with the same digest and settings. Every run records
``n_output_revs`` output revolutions (an integer number of mesh periods) at ``samples_per_mesh`` samples
per mesh period, so all speeds share one sample axis (``mesh_cycle``) and one order axis.
"""
from __future__ import annotations

import json
import logging
import math
import multiprocessing as mp
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import ConfigError, ModelError
from gearrom.excitation.table import netcdf_engine, write_netcdf

log = logging.getLogger(__name__)
CHANNELS = ("dte_sensor", "dte_clutch", "delta", "force", "ste")
_MODEL_CACHE: dict = {}
_BLAS_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def parse_rpm(spec: str | float | list) -> np.ndarray:
    """Speeds from ``"A:B:STEP"`` (inclusive of B when on the grid), ``"A,B,C"`` or a number [rpm]."""
    try:
        if isinstance(spec, (int, float)):
            vals = [float(spec)]
        elif isinstance(spec, (list, tuple)):
            vals = [float(v) for v in spec]
        elif ":" in spec:
            a, b, s = (float(v) for v in spec.split(":"))
            if s <= 0 or b < a:
                raise ValueError
            n = int(math.floor((b - a) / s + 1e-9)) + 1
            vals = list(a + s * np.arange(n))
        else:
            vals = [float(v) for v in spec.split(",")]
    except ValueError:
        raise ConfigError(f"rpm specification {spec!r} is not 'START:STOP:STEP', a comma list or a number") from None
    arr = np.array(vals)
    if arr.size == 0 or np.any(~np.isfinite(arr)) or np.any(arr <= 0):
        raise ConfigError(f"rpm specification {spec!r} must give positive speeds")
    return arr


def _model(config_ref: str, torque: float):
    key = (config_ref, torque)
    if key not in _MODEL_CACHE:
        from gearrom.rom.rig import build_rig

        _MODEL_CACHE[key] = build_rig(config_ref, torque_out=torque)
    return _MODEL_CACHE[key]


def _point_summary(run, orders: int = 3) -> dict:
    d = run.dte["sensor"]
    ac = d - d.mean()
    return {"rpm_in": run.rpm_in, "dte_ptp_um": float(np.ptp(d) * 1e6), "dte_rms_um": float(np.sqrt(np.mean(ac**2)) * 1e6),
            "gmf_amplitude_um": [float(v * 1e6) for v in run.gmf_amplitudes("sensor", orders)],
            "contact_loss": run.contact_loss, "dynamic_factor": run.dynamic_factor,
            "dte_clutch_ptp_um": float(np.ptp(run.dte["clutch"]) * 1e6) if "clutch" in run.dte else None,
            "wall_s": run.metadata.get("wall_s"), "cpu_s": run.metadata.get("cpu_s"),
            "simulated_s": run.metadata.get("simulated_s")}


def _run_one(task: tuple) -> dict:
    config_ref, rpm, torque, n_revs, spm, path, stamp, linear = task
    import xarray as xr

    from gearrom.rom.frf import gmf_estimate
    from gearrom.rom.simulate import simulate_run

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = _model(config_ref, torque)
    z1 = model.pair.z[0]
    fs = spm * z1 * rpm / 60.0
    run = simulate_run(model, rpm, torque, n_output_revs=n_revs, sample_rate_hz=fs)
    n = int(round(n_revs * model.pair.z[1])) * spm
    summary = _point_summary(run)
    if linear:
        summary["linear_gmf_amplitude_um"] = [float(v * 1e6) for v in gmf_estimate(model, [rpm], torque)[0]]
    data = {"dte_sensor": run.dte["sensor"], "dte_clutch": run.dte.get("clutch", np.full_like(run.delta, np.nan)),
            "delta": run.delta, "force": run.force, "ste": run.ste}
    ds = xr.Dataset({k: ("sample", np.asarray(v[:n], dtype=float)) for k, v in data.items()},
                    attrs={"rpm_in": rpm, "stamp": stamp, "summary_json": json.dumps(summary)})
    tmp = Path(str(path) + ".part")
    ds.to_netcdf(tmp, engine=netcdf_engine())
    tmp.replace(path)
    return summary


def _read_point(path: Path, stamp: str):
    import xarray as xr

    try:
        with xr.open_dataset(path, engine=netcdf_engine()) as ds:
            if ds.attrs.get("stamp") != stamp:
                return None
            return json.loads(ds.attrs["summary_json"]), {k: ds[k].values.copy() for k in CHANNELS}
    except (OSError, KeyError, ValueError):
        return None


@dataclass(eq=False)
class SweepResult:
    """All speeds of a sweep.

    Attributes
    ----------
    rpm : ndarray (n_rpm,)
    data : dict of channel -> ndarray (n_rpm, n_samples)
        ``dte_sensor``, ``dte_clutch``, ``delta``, ``ste`` [m], ``force`` [N].
    samples_per_mesh : int
    summary : list of dict
        One entry per speed (see :func:`run_sweep`).
    """

    config: str
    rpm: np.ndarray
    data: dict[str, np.ndarray]
    samples_per_mesh: int
    z: tuple[int, int]
    summary: list[dict]
    metadata: dict = field(default_factory=dict)

    def spectrum(self, channel: str = "dte_sensor") -> tuple[np.ndarray, np.ndarray]:
        """``(orders, amplitude)``: zero-to-peak amplitude [m] vs input-shaft order, shape (n_rpm, n_bins)."""
        x = self.data[channel]
        x = x - x.mean(axis=1, keepdims=True)
        n = x.shape[1]
        amp = 2 * np.abs(np.fft.rfft(x, axis=1)) / n
        n_mesh = n / self.samples_per_mesh
        orders = np.arange(amp.shape[1]) * self.z[0] / n_mesh
        return orders, amp

    def to_dataset(self):
        import xarray as xr

        n = next(iter(self.data.values())).shape[1]
        ds = xr.Dataset({k: (("rpm", "sample"), v, {"units": "N" if k == "force" else "m"}) for k, v in self.data.items()},
                        coords={"rpm": ("rpm", self.rpm, {"units": "rpm"}),
                                "mesh_cycle": ("sample", np.arange(n) / self.samples_per_mesh)})
        ds["gmf_amplitude"] = (("rpm", "gmf_order"), np.array([s["gmf_amplitude_um"] for s in self.summary]) * 1e-6,
                               {"units": "m"})
        ds["dynamic_factor"] = ("rpm", np.array([s["dynamic_factor"] for s in self.summary]))
        ds["contact_loss"] = ("rpm", np.array([s["contact_loss"] for s in self.summary], dtype=np.int8))
        ds.attrs.update({"format": "gearrom.SweepResult", "config": self.config, "samples_per_mesh": self.samples_per_mesh,
                         "z1": self.z[0], "z2": self.z[1], "metadata_json": json.dumps(self.metadata, default=str),
                         "summary_json": json.dumps(self.summary)})
        return ds

    def save(self, path: str | Path) -> Path:
        return write_netcdf(self.to_dataset(), path)

    @classmethod
    def load(cls, path: str | Path) -> "SweepResult":
        import xarray as xr

        with xr.open_dataset(path, engine=netcdf_engine()) as ds:
            if ds.attrs.get("format") != "gearrom.SweepResult":
                raise ModelError(f"{path}: not a gearrom sweep file")
            return cls(str(ds.attrs["config"]), ds["rpm"].values, {k: ds[k].values for k in CHANNELS if k in ds},
                       int(ds.attrs["samples_per_mesh"]), (int(ds.attrs["z1"]), int(ds.attrs["z2"])),
                       json.loads(ds.attrs["summary_json"]), json.loads(ds.attrs["metadata_json"]))

    def summary_json(self) -> dict:
        return {"config": self.config, "side": "sensor", **{k: self.metadata[k] for k in
                ("config_digest", "torque_out_Nm") if k in self.metadata}, "speeds": self.summary}

    def plot(self, channel: str = "dte_sensor", fmax: float | None = None):
        """Waterfall (colour map) of the DTE spectrum vs frequency and speed, with GMF orders 1-3."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.colors import LogNorm

        orders, amp = self.spectrum(channel)
        f = orders[None, :] * self.rpm[:, None] / 60
        fmax = fmax or 3.5 * self.z[0] * self.rpm.max() / 60
        fig, ax = plt.subplots(figsize=(8, 6))
        a = np.maximum(amp * 1e6, 1e-4)
        if len(self.rpm) > 1:
            rp = np.repeat(self.rpm[:, None], len(orders), axis=1)
            pc = ax.pcolormesh(f, rp, a, shading="nearest", norm=LogNorm(vmin=max(a.max() * 1e-4, 1e-4), vmax=a.max()))
            fig.colorbar(pc, ax=ax, label="DTE amplitude [um]")
        for m in (1, 2, 3):
            ax.plot(m * self.z[0] * self.rpm / 60, self.rpm, "w--", lw=0.7)
        ax.set_xlim(0, fmax)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("input speed [rpm]")
        ax.set_title(f"DTE spectrum ({channel}) vs speed, {self.config}; dashed: GMF x1-3", fontsize=9)
        fig.tight_layout()
        return fig

    def linear_gmf(self) -> np.ndarray | None:
        """The python-control linear GMF estimate per speed [m] (n_rpm, 3), when the sweep computed it."""
        if not all("linear_gmf_amplitude_um" in s for s in self.summary):
            return None
        return np.array([s["linear_gmf_amplitude_um"] for s in self.summary]) * 1e-6

    def plot_gmf(self, linear: np.ndarray | None = None):
        """GMF harmonic amplitudes vs speed (time domain), with the linear state-space estimate overlaid."""
        linear = self.linear_gmf() if linear is None else linear
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        g = np.array([s["gmf_amplitude_um"] for s in self.summary])
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for m in range(g.shape[1]):
            line, = ax.plot(self.rpm, g[:, m], "o-", ms=2.5, lw=0.8, label=f"GMF x{m + 1} time domain")
            if linear is not None:
                ax.plot(self.rpm, linear[:, m] * 1e6, "-", color=line.get_color(), alpha=0.5, lw=2,
                        label=f"GMF x{m + 1} linear (python-control)")
        ax.set_yscale("log")
        ax.set_xlabel("input speed [rpm]")
        ax.set_ylabel("DTE amplitude, sensor side [um]")
        ax.legend(fontsize=7, ncol=2)
        ax.set_title(f"{self.config}: GMF harmonics of the DTE", fontsize=9)
        fig.tight_layout()
        return fig


def run_sweep(config_ref: str | Path, rpms, out_dir: str | Path, *, torque_out: float | None = None,
              processes: int = 2, n_output_revs: float = 2.0, samples_per_mesh: int = 32,
              progress: bool = True, linear: bool = True) -> SweepResult:
    """Run (or resume) a sweep and write ``OUT/speeds/*.nc``; returns the collected :class:`SweepResult`.

    Parameters
    ----------
    config_ref : str or Path
        Bundled config name or TOML path.
    rpms : array_like
        Input speeds [rpm].
    processes : int
        Worker processes (1 runs in this process). Workers are *spawned* (fresh interpreters with
        single-threaded BLAS), so a script calling this with ``processes > 1`` needs the usual
        ``if __name__ == "__main__":`` guard.
    linear : bool
        Also evaluate the python-control linear GMF estimate per speed (``linear_gmf_amplitude_um``).
    """
    from gearrom.config import load_config

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config(config_ref)
    ref = str(cfg.source) if cfg.source else str(config_ref)
    torque = cfg.operating.torque_out if torque_out is None else float(torque_out)
    if samples_per_mesh < 4 or n_output_revs <= 0:
        raise ConfigError(f"samples_per_mesh must be >= 4 and n_output_revs > 0 (got {samples_per_mesh}, {n_output_revs})")
    out = Path(out_dir)
    (out / "speeds").mkdir(parents=True, exist_ok=True)
    stamp = f"{cfg.digest()}|T={torque}|revs={n_output_revs}|spm={samples_per_mesh}|linear={linear}"
    rpms = np.asarray(rpms, dtype=float)
    paths = [out / "speeds" / f"rpm_{r:08.2f}.nc" for r in rpms]
    done = {}
    for r, p in zip(rpms, paths):
        if p.exists():
            got = _read_point(p, stamp)
            if got is not None:
                done[r] = got[0]
    todo = [(ref, float(r), torque, n_output_revs, samples_per_mesh, p, stamp, linear)
            for r, p in zip(rpms, paths) if r not in done]
    if done:
        log.info("resuming: %d of %d speeds already done", len(done), len(rpms))
    from tqdm import tqdm

    bar = tqdm(total=len(todo), desc=f"sweep {cfg.name}", unit="speed", disable=not progress or not todo)
    if processes > 1 and len(todo) > 1:
        # fresh worker processes with single-threaded BLAS: the per-speed linear algebra is small, and
        # multi-threaded BLAS in several processes on few cores slows it down many times
        ctx = mp.get_context("spawn")
        saved = {k: os.environ.get(k) for k in _BLAS_ENV}
        os.environ.update({k: "1" for k in _BLAS_ENV})
        try:
            with ctx.Pool(min(processes, len(todo))) as pool:
                for s in pool.imap_unordered(_run_one, todo):
                    done[s["rpm_in"]] = s
                    bar.update()
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
    else:
        for t in todo:
            s = _run_one(t)
            done[s["rpm_in"]] = s
            bar.update()
    bar.close()
    data = {k: [] for k in CHANNELS}
    summary = []
    for r, p in zip(rpms, paths):
        got = _read_point(p, stamp)
        if got is None:
            raise ModelError(f"sweep point {p} is missing or unreadable")
        summary.append(got[0])
        for k in CHANNELS:
            data[k].append(got[1][k])
    return SweepResult(cfg.name, rpms, {k: np.array(v) for k, v in data.items()}, samples_per_mesh, cfg.pair.z,
                       summary, {"config_digest": cfg.digest(), "torque_out_Nm": torque, "n_output_revs": n_output_revs})
