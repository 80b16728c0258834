"""Speed sweep: one steady-state run per speed, in parallel processes, resumable.

Each speed is written to ``OUT/speeds/rpm_XXXXX.XXXX_<hash>.nc`` as soon as it finishes. The hash is
taken from the reuse key of the run (:func:`reuse_key`: merged config content, contents of the files
the config refers to, load torque, revolutions, samples per mesh, the linear flag, the revisions of the
models the run is built from and the package versions) together with the exact speed, so a rerun into
the same ``OUT`` reuses a stored speed only when nothing it depends on has changed, and runs that
differ in any of these keep separate files.
Every file is written to a temporary file in the same directory and renamed into place, so an
interrupted run never leaves a partial file that a resume would trust. Every run records
``n_output_revs`` output revolutions (an integer number of mesh periods) at ``samples_per_mesh`` samples
per mesh period, so all speeds share one sample axis (``mesh_cycle``) and one order axis.
"""
from __future__ import annotations

import hashlib
import json
import logging
import math
import multiprocessing as mp
import os
import threading
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gearrom.errors import ConfigError, ModelError
from gearrom.spectral import spectrum
from gearrom.excitation.table import netcdf_engine

if TYPE_CHECKING:
    from gearrom.config import GearConfig
    from gearrom.rom.model import Drivetrain

log = logging.getLogger(__name__)
CHANNELS = ("dte_sensor", "dte_clutch", "delta", "force", "ste")
_MODEL_CACHE: dict = {}
_BLAS_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


#: bounds of a speed list: count of speeds, and the fastest input speed [rpm] (beyond any gear drive)
MAX_SPEEDS = 100_000
#: layout of the stored per-speed file (part of the reuse key: a file of another layout is recomputed)
POINT_FORMAT = "channels-2d/1"
MAX_RPM = 1e6


def parse_rpm(spec: str | float | list) -> np.ndarray:
    """Speeds from ``"A:B:STEP"`` (inclusive of B when on the grid), ``"A,B,C"`` or a number [rpm].

    At most :data:`MAX_SPEEDS` speeds, each in (0, :data:`MAX_RPM`] rpm (checked before a grid is expanded).
    """
    try:
        if isinstance(spec, (int, float)):
            vals = [float(spec)]
        elif isinstance(spec, (list, tuple)):
            vals = [float(v) for v in spec]
        elif ":" in spec:
            a, b, s = (float(v) for v in spec.split(":"))
            if not (s > 0 and b >= a and math.isfinite(b) and math.isfinite(a)):
                raise ValueError
            n = int(math.floor((b - a) / s + 1e-9)) + 1
            vals = list(a + s * np.arange(n)) if n <= MAX_SPEEDS else [math.nan] * (MAX_SPEEDS + 1)
        else:
            vals = [float(v) for v in spec.split(",")]
    except ValueError:
        raise ConfigError(f"rpm specification {spec!r} is not 'START:STOP:STEP', a comma list or a number") from None
    except (TypeError, AttributeError):
        raise ConfigError(f"rpm specification {spec!r} is not text, a number or a list of numbers") from None
    arr = np.array(vals)
    if arr.size > MAX_SPEEDS:
        raise ConfigError(f"rpm specification {spec!r} gives more than {MAX_SPEEDS} speeds")
    if arr.size == 0 or np.any(~np.isfinite(arr)) or np.any(arr <= 0) or np.any(arr > MAX_RPM):
        raise ConfigError(f"rpm specification {spec!r} must give speeds in (0, {MAX_RPM:g}] rpm")
    return arr


def _model(config_ref: str, torque: float, key: str) -> "Drivetrain":
    """The rig model of ``config_ref`` at ``torque``, cached per process by the run's reuse key.

    The key covers the contents of the files the config refers to, so a rewritten excitation table
    builds a new model instead of returning the one built from the earlier table.
    """
    cache_key = (config_ref, torque, key)
    if cache_key not in _MODEL_CACHE:
        from gearrom.rom.rig import build_rig

        if len(_MODEL_CACHE) >= 4:
            _MODEL_CACHE.clear()
        _MODEL_CACHE[cache_key] = build_rig(config_ref, torque_out=torque)
    return _MODEL_CACHE[cache_key]


def write_netcdf_atomic(dataset, path: str | Path) -> Path:
    """Write an xarray ``dataset`` to ``path`` through a temporary file in the same directory.

    The temporary file has a unique name (several writers of one target never open the same file)
    and replaces ``path`` in one :func:`os.replace` step once it is complete, so ``path`` holds
    either its previous content or the whole new file, never a partial one.

    Parameters
    ----------
    dataset : xarray.Dataset
        Dataset to write.
    path : str or Path
        Target file; its parent directories are created.

    Returns
    -------
    Path
        ``path``.
    """
    from gearrom.fe.cache import atomic_path

    with atomic_path(path) as tmp:
        dataset.to_netcdf(tmp, engine=netcdf_engine())
    return Path(path)


def write_bytes_atomic(data: bytes, path: str | Path) -> Path:
    """Write ``data`` to ``path`` through a uniquely named temporary file and :func:`os.replace`."""
    from gearrom.fe.cache import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text_atomic(text: str, path: str | Path) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`write_bytes_atomic`)."""
    return write_bytes_atomic(text.encode("utf-8"), path)


def _file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def referenced_files(cfg: "GearConfig") -> dict[str, Path]:
    """Files the config refers to: every string value that names an existing file.

    Paths are resolved as :func:`gearrom.rom.rig.load_excitation` resolves ``[rom] excitation``:
    absolute, or relative to the directory of the config file. The ``extends`` chain needs no entry
    here: its merged content is part of :meth:`gearrom.config.GearConfig.digest`.

    Returns
    -------
    dict of str -> Path
        Dotted config key (``"rom.excitation"``) -> resolved file.
    """
    base = Path(cfg.source).parent if cfg.source is not None else Path.cwd()
    found: dict[str, Path] = {}

    def walk(node: object, where: str) -> None:
        if isinstance(node, Mapping):
            for k, v in node.items():
                walk(v, f"{where}.{k}" if where else str(k))
        elif isinstance(node, (list, tuple)):
            for i, v in enumerate(node):
                walk(v, f"{where}[{i}]")
        elif isinstance(node, str) and where not in ("name", "description") and node.strip():
            path = Path(node)
            if not path.is_absolute():
                path = base / path
            try:
                if path.is_file():
                    found[where] = path.resolve()
            except (OSError, ValueError):
                pass

    walk(cfg.raw, "")
    return found


def _distribution_version(name: str) -> str:
    from importlib import metadata

    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "not installed"


def reuse_key(cfg: "GearConfig", torque: float, n_output_revs: float, samples_per_mesh: int, linear: bool) -> dict:
    """Everything a stored per-speed result depends on, apart from the speed itself.

    Parameters
    ----------
    cfg : GearConfig
        Loaded config.
    torque : float
        Load torque [N m].
    n_output_revs : float
        Recorded output revolutions per speed.
    samples_per_mesh : int
        Samples per mesh period.
    linear : bool
        Whether the linear GMF estimate is stored.

    Returns
    -------
    dict
        JSON-serialisable key: the config digest (merged content, ``extends`` chain included), the
        SHA-256 of the bytes of every referenced file (:func:`referenced_files`), the run settings,
        the layout of the stored file (``POINT_FORMAT``), the revisions of the models the run is built
        from (``models``, :func:`gearrom.rom.rig.model_revisions`: the thin-slice model behind the pitch
        deviations, the ``"fe"`` excitation table's cache key and its FE compliances) and the versions
        of gearrom (module and installed distribution) and exudyn.
    """
    import gearrom
    from gearrom.rom.rig import model_revisions

    return {"config_digest": cfg.digest(),
            "files_sha256": {k: _file_sha256(p) for k, p in sorted(referenced_files(cfg).items())},
            "torque_out_Nm": repr(float(torque)), "n_output_revs": repr(float(n_output_revs)),
            "samples_per_mesh": int(samples_per_mesh), "linear": bool(linear), "point_format": POINT_FORMAT,
            "models": model_revisions(cfg, torque), "gearrom_version": str(gearrom.__version__),
            "gearrom_distribution": _distribution_version("gearrom"),
            "exudyn_version": _distribution_version("exudyn")}


def _key_hash(key: dict) -> str:
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()


def point_path(out_dir: str | Path, rpm: float, key_hash: str) -> Path:
    """Stored file of one speed: ``OUT/speeds/rpm_XXXXX.XXXX_<hash>.nc``.

    The hash covers the reuse key and the exact speed (``repr``), so speeds that print alike and
    runs with different keys (another torque, table, version...) never share a file.
    """
    h = hashlib.sha256(f"{key_hash}|{float(rpm)!r}".encode()).hexdigest()[:16]
    return Path(out_dir) / "speeds" / f"rpm_{float(rpm):010.4f}_{h}.nc"


def repeated_speeds(rpms) -> list[float]:
    """Speeds [rpm] that occur more than once in ``rpms`` (exact repeats), sorted."""
    vals, counts = np.unique(np.asarray(rpms, dtype=float), return_counts=True)
    return [float(v) for v in vals[counts > 1]]


def _point_summary(run, orders: int = 3) -> dict:
    d = run.dte["sensor"]
    ac = d - d.mean()
    return {"rpm_in": run.rpm_in, "dte_ptp_um": float(np.ptp(d) * 1e6), "dte_rms_um": float(np.sqrt(np.mean(ac**2)) * 1e6),
            "gmf_amplitude_um": [float(v * 1e6) for v in run.gmf_amplitudes("sensor", orders)],
            "contact_loss": run.contact_loss, "dynamic_factor": run.dynamic_factor,
            "dte_clutch_ptp_um": float(np.ptp(run.dte["clutch"]) * 1e6) if "clutch" in run.dte else None,
            "wall_s": run.metadata.get("wall_s"), "cpu_s": run.metadata.get("cpu_s"),
            "simulated_s": run.metadata.get("simulated_s")}


def _warm(config_ref: str, torque: float, key: str) -> None:
    """Build the model and the parts of a run that do not depend on the speed, in this process."""
    import gearrom.rom.frf  # noqa: F401 (imported here for the forked workers)
    import gearrom.rom.simulate as simulate
    from gearrom.rom.reduce import reduce

    model = _model(config_ref, torque, key)
    simulate.mesh_law(model, torque)
    reduce(model, 1000.0, torque)


def _single_thread_blas() -> None:
    """Pool initializer: BLAS and OpenMP on one thread in this worker."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def _run_one(task: tuple) -> tuple[float, dict, dict[str, np.ndarray]]:
    """Simulate one speed, store it atomically; returns ``(rpm, summary, channels)``."""
    config_ref, rpm, torque, n_revs, spm, path, key_hash, key_json, linear = task

    import gearrom.rom.simulate as simulate
    from gearrom.rom.frf import gmf_estimate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = _model(config_ref, torque, key_hash)
    z1 = model.pair.z[0]
    fs = spm * z1 * rpm / 60.0
    run = simulate.simulate_run(model, rpm, torque, n_output_revs=n_revs, sample_rate_hz=fs)
    n = int(round(n_revs * model.pair.z[1])) * spm
    summary = _point_summary(run)
    if linear:
        summary["linear_gmf_amplitude_um"] = [float(v * 1e6) for v in gmf_estimate(model, [rpm], torque)[0]]
    data = {"dte_sensor": run.dte["sensor"], "dte_clutch": run.dte.get("clutch", np.full_like(run.delta, np.nan)),
            "delta": run.delta, "force": run.force, "ste": run.ste}
    data = {k: np.asarray(v[:n], dtype=float) for k, v in data.items()}
    _write_point(path, data, {"rpm_in": rpm, "stamp": key_hash, "reuse_key_json": key_json,
                              "summary_json": json.dumps(summary)})
    return rpm, summary, data


def _write_point(path: Path, data: dict[str, np.ndarray], attrs: dict) -> None:
    """One speed as a NetCDF-4 file: variable ``channels`` (channel, sample), the channel names in
    the attribute ``channel_names``; written atomically with h5netcdf directly, since the per-speed
    files are many and small and xarray's writer costs several times more than the data."""
    import h5netcdf

    from gearrom.fe.cache import atomic_path

    # not flushed to disk: a file that a crash leaves damaged is found unreadable and recomputed
    with atomic_path(path, durable=False) as tmp, h5netcdf.File(tmp, "w") as f:
        f.dimensions = {"channel": len(CHANNELS), "sample": len(data[CHANNELS[0]])}
        f.create_variable("channels", ("channel", "sample"), data=np.array([data[k] for k in CHANNELS]))
        f.attrs.update(attrs, channel_names=",".join(CHANNELS))


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _read_point(path: Path, key_hash: str, rpm: float) -> tuple[dict, dict[str, np.ndarray]] | None:
    """``(summary, data)`` of a stored speed, or None when it is absent, of another key or damaged.

    A file that cannot be read (empty, truncated, not NetCDF) is reported in one warning and
    left to be recomputed.
    """
    import h5netcdf

    if not path.exists():
        return None
    try:
        with h5netcdf.File(path, "r") as ds:
            if ds.attrs.get("stamp") != key_hash or float(ds.attrs.get("rpm_in", math.nan)) != rpm:
                log.info("%s: stored for another run key or speed; recomputing", path)
                return None
            if ds.attrs["channel_names"] != ",".join(CHANNELS):
                raise ValueError(f"channels {ds.attrs['channel_names']!r}, expected {','.join(CHANNELS)!r}")
            arr = np.asarray(ds["channels"][...], dtype=float)
            return json.loads(ds.attrs["summary_json"]), dict(zip(CHANNELS, arr))
    except Exception as exc:  # noqa: BLE001 (any unreadable stored file is recomputed)
        warnings.warn(f"{path}: stored sweep point is damaged ({_one_line(exc)}); recomputing it",
                      RuntimeWarning, stacklevel=3)
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
        n = x.shape[1]
        amp = spectrum(x - x.mean(axis=1, keepdims=True), 1.0).amplitude
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
        """Write the sweep to NetCDF atomically (see :func:`write_netcdf_atomic`); returns the path."""
        return write_netcdf_atomic(self.to_dataset(), path)

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
                ("config_digest", "torque_out_Nm", "excitation") if k in self.metadata}, "speeds": self.summary}

    def plot(self, channel: str = "dte_sensor", fmax: float | None = None, decades: float = 3.0):
        """Waterfall of the DTE spectrum over frequency [Hz] and input speed [rpm], GMF harmonics 1-3 and
        both shaft orders drawn and labelled.

        The colour scale (logarithmic, um) spans the data: from its largest line down ``decades``
        decades, or to the median amplitude where that is higher (the noise floor of the spectra
        then stays dark instead of taking most of the scale).
        """
        from matplotlib.colors import LogNorm

        from gearrom.plotting import subplots

        z1, z2 = self.z
        orders, amp = self.spectrum(channel)
        a = amp * 1e6
        fmax = fmax or 3.4 * z1 * self.rpm.max() / 60
        fig, ax = subplots(figsize=(8, 5.5))
        positive = a[a > 0]
        if len(self.rpm) > 1 and positive.size:
            vmax = float(positive.max())
            vmin = max(vmax * 10.0 ** -decades, float(np.median(positive)))
            rp = np.repeat(self.rpm[:, None], len(orders), axis=1)
            pc = ax.pcolormesh(orders[None, :] * self.rpm[:, None] / 60, rp, np.clip(a, vmin, None), shading="nearest",
                               norm=LogNorm(vmin=vmin, vmax=vmax))
            fig.colorbar(pc, ax=ax, label=f"DTE amplitude ({channel}) [um]")
        for m, c in zip((1, 2, 3), ("w", "lightgrey", "silver")):
            ax.plot(m * z1 * self.rpm / 60, self.rpm, "--", color=c, lw=0.8, label=f"GMF x{m} (order {m * z1})")
        for o, lab, c in ((1.0, "input shaft (order 1)", "orange"), (z1 / z2, f"output shaft (order {z1}/{z2})", "red")):
            ax.plot(o * self.rpm / 60, self.rpm, ":", color=c, lw=1.2, label=lab)
        ax.legend(fontsize=7, loc="lower right", facecolor="0.85")
        torque = self.metadata.get("torque_out_Nm")
        ax.set_xlim(0, fmax)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("input speed [rpm]")
        ax.set_title(f"{self.config}: DTE waterfall ({len(self.rpm)} speeds" + (f", {torque:g} N m)" if torque else ")"),
                     fontsize=9)
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
        from gearrom.plotting import subplots

        g = np.array([s["gmf_amplitude_um"] for s in self.summary])
        fig, ax = subplots(figsize=(8, 4.5))
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

    A speed whose stored file in ``OUT/speeds`` carries the same reuse key (:func:`reuse_key`) is
    read instead of simulated; a damaged stored file is reported in one warning and recomputed.

    Parameters
    ----------
    config_ref : str or Path
        Bundled config name or TOML path.
    rpms : array_like
        Input speeds [rpm], positive, each at most once.
    out_dir : str or Path
        Output directory; per-speed results go to ``out_dir/speeds``.
    torque_out : float, optional
        Load torque [N m] (default: the config's operating torque).
    n_output_revs : float
        Recorded output revolutions per speed.
    samples_per_mesh : int
        Samples per mesh period (>= 4).
    progress : bool
        Show a progress bar.
    processes : int
        Worker processes (1 runs in this process). Workers are *spawned* (fresh interpreters with
        single-threaded BLAS), so a script calling this with ``processes > 1`` needs the usual
        ``if __name__ == "__main__":`` guard.
    linear : bool
        Also evaluate the python-control linear GMF estimate per speed (``linear_gmf_amplitude_um``).

    Raises
    ------
    ConfigError
        A repeated speed, a non-positive torque, ``samples_per_mesh < 4`` or ``n_output_revs <= 0``.
    ModelError
        A file the config refers to changed while the speeds ran (the new results are discarded).
    """
    from gearrom.config import as_config

    cfg = as_config(config_ref, check=True)
    ref = str(cfg.source) if cfg.source else str(config_ref)
    torque = cfg.operating.torque_out if torque_out is None else float(torque_out)
    if not (math.isfinite(torque) and torque > 0):
        raise ConfigError(f"torque_out must be a positive, finite load torque, got {torque:g} N m")
    if samples_per_mesh < 4 or n_output_revs <= 0:
        raise ConfigError(f"samples_per_mesh must be >= 4 and n_output_revs > 0 (got {samples_per_mesh}, {n_output_revs})")
    rpms = np.asarray(rpms, dtype=float).ravel()
    repeats = repeated_speeds(rpms)
    if repeats:
        raise ConfigError(f"speeds must not repeat: {', '.join(f'{r:g}' for r in repeats)} rpm given more than once")
    out = Path(out_dir)
    (out / "speeds").mkdir(parents=True, exist_ok=True)
    key = reuse_key(cfg, torque, n_output_revs, samples_per_mesh, linear)
    key_hash = _key_hash(key)
    key_json = json.dumps(key, sort_keys=True)
    paths = [point_path(out, r, key_hash) for r in rpms]
    points: dict[int, tuple[dict, dict]] = {}
    for i, (r, p) in enumerate(zip(rpms, paths)):
        got = _read_point(p, key_hash, float(r))
        if got is not None:
            points[i] = got
    todo = [(ref, float(rpms[i]), torque, n_output_revs, samples_per_mesh, paths[i], key_hash, key_json, linear)
            for i in range(len(rpms)) if i not in points]
    index = {float(rpms[i]): i for i in range(len(rpms))}
    from gearrom.rom.rig import excitation_info

    # in this process first: an FE table is computed once (progress bar) and cached for the workers
    excitation = excitation_info(cfg, torque, progress=progress and bool(todo))
    if points:
        log.info("resuming: %d of %d speeds already done", len(points), len(rpms))
    from tqdm import tqdm

    def new_bar():
        return tqdm(total=len(todo), desc=f"sweep {cfg.name}", unit="speed", disable=not progress or not todo)

    if processes > 1 and len(todo) > 1:
        # worker processes with single-threaded BLAS: the per-speed linear algebra is small, and
        # multi-threaded BLAS in several processes on few cores slows it down many times. Where the
        # platform forks and this process runs no other thread (a fork copies only the calling
        # thread, so a lock held by another one would stay locked in the workers), the model is
        # built here first and the workers start from a copy of this process (modules imported,
        # model and its speed-independent reduction cached); otherwise they are spawned fresh and
        # build it themselves. The progress bar (a monitor thread) starts after the workers.
        fork = "fork" in mp.get_all_start_methods() and threading.active_count() == 1
        if fork:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                _warm(ref, torque, key_hash)
        ctx = mp.get_context("fork" if fork else "spawn")
        saved = {k: os.environ.get(k) for k in _BLAS_ENV}
        os.environ.update({k: "1" for k in _BLAS_ENV})
        try:
            with ctx.Pool(min(processes, len(todo)), initializer=_single_thread_blas) as pool:
                bar = new_bar()
                for r, s, d in pool.imap_unordered(_run_one, todo):
                    points[index[r]] = (s, d)
                    bar.update()
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
    else:
        bar = new_bar()
        for t in todo:
            r, s, d = _run_one(t)
            points[index[r]] = (s, d)
            bar.update()
    bar.close()
    if todo and _key_hash(reuse_key(cfg, torque, n_output_revs, samples_per_mesh, linear)) != key_hash:
        # a referenced file (or the package) changed while the speeds ran: the new results may come
        # from either version, so they are not kept under the key taken at the start
        for t in todo:
            Path(t[5]).unlink(missing_ok=True)
        raise ModelError(f"{cfg.source}: a file the config refers to changed during the sweep; run it again")
    summary = [points[i][0] for i in range(len(rpms))]
    data = {k: np.array([points[i][1][k] for i in range(len(rpms))]) for k in CHANNELS}
    return SweepResult(cfg.name, rpms, data, samples_per_mesh, cfg.pair.z, summary,
                       {"config_digest": cfg.digest(), "torque_out_Nm": torque, "n_output_revs": n_output_revs,
                        "reuse_key": key, "excitation": excitation})
