"""Tolerance scatter study: one ROM speed sweep per sampled set of manufacturing deviations, on dask.

Each sample is an idempotent task (:func:`run_sample`): it builds the mesh excitation of the
sample's flank modifications (helix slope, tip relief, crowning) from the cached quasi-static
compliances (:class:`gearrom.calibrate.microfe.FEMicroModel`, no FE solve; or the analytical slice
model), adds the pitch deviations and runout as ROM kinematic effects, simulates every speed and
writes ``OUT/samples/sample_NNNNNN_<hash>.nc`` through a temporary file and a rename. The hash covers
the run's reuse key (config content, referenced files, torque, revolutions, samples per mesh,
versions), the speeds, the micro-geometry model, the revisions of the models a sample runs on
(:func:`study_key`) and the sample's deviations, so a rerun into the same ``OUT`` reuses exactly
the samples that would come out the same, and a task that runs twice (its worker was lost after the
write) rewrites the same file.
"""
from __future__ import annotations

import hashlib
import json
import logging
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gearrom.errors import ConfigError
from gearrom.excitation.table import netcdf_engine
from gearrom.study.tolerance import Deviations, ToleranceSpec, sample_deviations

log = logging.getLogger(__name__)
MICRO_MODELS = ("fe", "slices", "none")
_CACHE: dict = {}


@dataclass(frozen=True)
class StudySettings:
    """Per-sample simulation settings.

    Attributes
    ----------
    rpm : tuple of float
        Input speeds [rpm].
    torque_out_Nm : float
        Load torque [N m].
    n_output_revs : float
        Recorded output revolutions per speed (short: the study needs the GMF amplitudes and DTE range).
    samples_per_mesh : int
        Samples per mesh period (the sampling is synchronous with the mesh: at 32, harmonics 31 and 33
        of a spur table fold onto GMF x1; 64 costs about the same steps, the step being the smaller).
    micro_model : {"fe", "slices", "none"}
        Flank modifications through the FE contact with cached compliances, the analytical thin-slice
        model, or not at all (pitch and runout only).
    """

    rpm: tuple[float, ...]
    torque_out_Nm: float
    n_output_revs: float = 1.0
    samples_per_mesh: int = 64
    micro_model: str = "fe"

    def __post_init__(self) -> None:
        if self.micro_model not in MICRO_MODELS:
            raise ConfigError(f"micro_model must be one of {', '.join(MICRO_MODELS)}, got {self.micro_model!r}")
        if not (self.n_output_revs > 0 and self.samples_per_mesh >= 4 and self.torque_out_Nm > 0 and self.rpm):
            raise ConfigError("study settings need speeds, n_output_revs > 0, samples_per_mesh >= 4 and a positive torque")


@dataclass(frozen=True)
class SampleTask:
    """Everything one sample needs on a worker (picklable)."""

    config_ref: str
    deviations: Deviations
    settings: StudySettings
    path: str
    stamp: str


def _micro_model(name: str):
    if name == "fe":
        from gearrom.calibrate.microfe import FEMicroModel

        return FEMicroModel()
    from gearrom.excitation.slices import SliceMicroModel

    return SliceMicroModel()


def _model(task: SampleTask):
    """The rig model of the sample: nominal table changed by the sample's flank modifications."""
    from gearrom.config import as_config
    from gearrom.rom.rig import build_rig

    st = task.settings
    key = (task.config_ref, st.torque_out_Nm)
    if key not in _CACHE:
        if len(_CACHE) > 4:
            _CACHE.clear()
        cfg = as_config(task.config_ref, check=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _CACHE[key] = (cfg, build_rig(cfg, torque_out=st.torque_out_Nm))
    cfg, nominal = _CACHE[key]
    mods = task.deviations.mods()
    if st.micro_model == "none" or mods.is_zero:
        return nominal
    from gearrom.calibrate.microfe import with_micro
    from gearrom.excitation.slices import MicroMods

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ex = with_micro(nominal.excitation, _micro_model(st.micro_model), cfg.pair, st.torque_out_Nm, MicroMods(), mods)
        return build_rig(cfg, torque_out=st.torque_out_Nm, excitation=ex)


def read_sample(path: str | Path, stamp: str) -> dict | None:
    """Stored result of a sample, or None when absent, of another key or damaged (then recomputed)."""
    import xarray as xr

    path = Path(path)
    if not path.exists():
        return None
    try:
        with xr.open_dataset(path, engine=netcdf_engine()) as ds:
            if ds.attrs.get("stamp") != stamp:
                return None
            return {"index": int(ds.attrs["index"]), "dte_ptp_um": ds["dte_ptp_um"].values.copy(),
                    "dte_rms_um": ds["dte_rms_um"].values.copy(), "gmf_um": ds["gmf_um"].values.copy(),
                    "features": ds["features"].values.copy(), "cpu_s": float(ds.attrs["cpu_s"]), "reused": True}
    except Exception as exc:  # noqa: BLE001 (an unreadable stored sample is recomputed)
        warnings.warn(f"{path}: stored sample is damaged ({type(exc).__name__}); recomputing it", RuntimeWarning,
                      stacklevel=2)
        return None


def run_sample(task: SampleTask) -> dict:
    """Simulate one sample over all speeds and store it atomically (idempotent); returns its summary."""
    got = read_sample(task.path, task.stamp)
    if got is not None:
        return got
    import time

    import xarray as xr

    from gearrom.rom.simulate import simulate_run
    from gearrom.rom.sweep import write_netcdf_atomic
    from gearrom.study.tolerance import FEATURES

    c0 = time.process_time()
    st = task.settings
    model = _model(task)
    effects = task.deviations.effects()
    z1 = model.pair.z[0]
    ptp, rms, gmf = [], [], []
    for rpm in st.rpm:
        run = simulate_run(model, rpm, st.torque_out_Nm, n_output_revs=st.n_output_revs, effects=effects,
                           sample_rate_hz=st.samples_per_mesh * z1 * rpm / 60.0)
        d = run.dte["sensor"]
        ptp.append(float(np.ptp(d)) * 1e6)
        rms.append(float(np.std(d)) * 1e6)
        gmf.append(run.gmf_amplitudes("sensor", 3) * 1e6)
    cpu = time.process_time() - c0
    feats = task.deviations.features()
    ds = xr.Dataset({"dte_ptp_um": ("rpm", np.array(ptp)), "dte_rms_um": ("rpm", np.array(rms)),
                     "gmf_um": (("rpm", "gmf_order"), np.array(gmf)), "features": ("feature", feats)},
                    coords={"rpm": np.array(st.rpm), "gmf_order": [1, 2, 3], "feature": list(FEATURES)},
                    attrs={"format": "gearrom.ToleranceSample", "index": task.deviations.index, "stamp": task.stamp,
                           "cpu_s": cpu, "deviations_json": json.dumps(task.deviations.to_json())})
    write_netcdf_atomic(ds, task.path)
    return {"index": task.deviations.index, "dte_ptp_um": ds["dte_ptp_um"].values, "dte_rms_um": ds["dte_rms_um"].values,
            "gmf_um": ds["gmf_um"].values, "features": feats, "cpu_s": cpu, "reused": False}


def _micro_revisions(settings: StudySettings) -> dict:
    """Revisions of the micro-geometry model a sample's table comes from, beyond those of the ROM run.

    With ``micro_model="fe"``: ``micro_fe`` (:data:`gearrom.calibrate.microfe.CODE_VERSION`), ``fe_slices``
    (:data:`gearrom.excitation.fe.SLICES_REVISION`, the slice LTCA behind it) and the FE compliances it
    solves with (``compliance_2d``, ``compliance_3d``). The thin-slice model (``micro_model="slices"``, and
    the FE model's fallback) is in the ROM run's revisions already (:func:`gearrom.rom.rig.model_revisions`).
    """
    if settings.micro_model != "fe":
        return {}
    from gearrom.calibrate.microfe import CODE_VERSION
    from gearrom.excitation.fe import SLICES_REVISION
    from gearrom.fe import compliance as c2d, compliance3d as c3d

    return {"micro_fe": CODE_VERSION, "fe_slices": SLICES_REVISION, "compliance_2d": c2d.CODE_VERSION,
            "compliance_3d": c3d.CODE_VERSION}


def study_key(config_ref: str, settings: StudySettings) -> dict:
    """The reuse key shared by all samples of a study.

    Parameters
    ----------
    config_ref : str
        Bundled config name or TOML path.
    settings : StudySettings

    Returns
    -------
    dict
        JSON-serialisable: the run's reuse key (:func:`gearrom.rom.sweep.reuse_key`: config content,
        referenced files, torque, revolutions, samples per mesh, the revisions of the ROM run's models,
        versions), the speeds, the micro-geometry model, and in ``models`` also the revisions of that
        model (:func:`_micro_revisions`). A stored sample is reused only under an equal key.
    """
    from gearrom.config import as_config
    from gearrom.rom.sweep import reuse_key

    cfg = as_config(config_ref, check=True)
    key = reuse_key(cfg, settings.torque_out_Nm, settings.n_output_revs, settings.samples_per_mesh, False)
    key["models"] = {**key["models"], **_micro_revisions(settings)}
    key.update(rpm=[repr(float(r)) for r in settings.rpm], micro_model=settings.micro_model, format=1)
    return key


def sample_path(out: Path, dev: Deviations, key_hash: str) -> tuple[Path, str]:
    """``(path, stamp)`` of a sample: the stamp hashes the study key and the sample's deviations."""
    stamp = hashlib.sha256(f"{key_hash}|{json.dumps(dev.to_json(), sort_keys=True)}".encode()).hexdigest()
    return out / "samples" / f"sample_{dev.index:06d}_{stamp[:16]}.nc", stamp


def run_tolerance_study(config_ref: str | Path, spec: ToleranceSpec, n_samples: int, settings: StudySettings,
                        out_dir: str | Path, *, seed: int = 0, scheduler: str | None = None, n_workers: int = 2,
                        progress: bool = True, client=None, on_result=None):
    """Run (or resume) a tolerance study; returns a :class:`gearrom.study.result.ToleranceResult`.

    Parameters
    ----------
    config_ref : str or Path
        Bundled config name or TOML path.
    spec : ToleranceSpec
        Tolerances to sample within.
    n_samples : int
        Samples 0 .. n_samples - 1 (a larger rerun adds samples, a smaller one reuses a subset).
    settings : StudySettings
    out_dir : str or Path
        Output directory; samples go to ``out_dir/samples``.
    seed : int
        Seed of the sample generator.
    scheduler : str, optional
        Address of a running dask scheduler; default: an embedded LocalCluster of ``n_workers``.
    n_workers : int
        Worker processes of the embedded cluster.
    progress : bool
        Progress bar.
    client : distributed.Client, optional
        Use this client (scheduler and n_workers are then ignored).
    on_result : callable, optional
        ``on_result(client, n_done)`` after each finished sample.
    """
    from gearrom.config import as_config
    from gearrom.study.distributed import cluster_client, run_tasks
    from gearrom.study.result import ToleranceResult

    if isinstance(n_samples, bool) or not isinstance(n_samples, int) or n_samples < 1:
        raise ConfigError(f"n_samples must be a positive integer, got {n_samples!r}")
    cfg = as_config(config_ref, check=True)
    ref = str(cfg.source) if cfg.source else str(config_ref)
    out = Path(out_dir)
    (out / "samples").mkdir(parents=True, exist_ok=True)
    key = study_key(ref, settings)
    key_hash = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()
    tasks, done = [], {}
    for i in range(n_samples):
        dev = sample_deviations(spec, cfg.pair.z, i, seed)
        path, stamp = sample_path(out, dev, key_hash)
        got = read_sample(path, stamp)
        if got is not None:
            done[i] = got
        else:
            tasks.append(SampleTask(ref, dev, settings, str(path), stamp))
    if done:
        log.info("resuming: %d of %d samples already done", len(done), n_samples)
    if tasks:
        keys = [f"sample-{t.deviations.index}-{t.stamp[:12]}" for t in tasks]
        if client is not None:
            res = run_tasks(run_sample, tasks, client, keys=keys, progress=progress, desc="samples", on_result=on_result)
        else:
            with cluster_client(scheduler, n_workers) as cl:
                res = run_tasks(run_sample, tasks, cl, keys=keys, progress=progress, desc="samples",
                                on_result=on_result)
        for r in res:
            done[int(r["index"])] = r
    rows = [done[i] for i in range(n_samples)]
    from gearrom.study.tolerance import FEATURES

    return ToleranceResult(
        config=cfg.name, rpm=np.asarray(settings.rpm, float), index=np.arange(n_samples),
        dte_ptp_um=np.array([r["dte_ptp_um"] for r in rows]), dte_rms_um=np.array([r["dte_rms_um"] for r in rows]),
        gmf_um=np.array([r["gmf_um"] for r in rows]), features=np.array([r["features"] for r in rows]),
        feature_names=FEATURES, cpu_s=np.array([r["cpu_s"] for r in rows]),
        metadata={"spec": spec.to_dict(), "seed": seed, "settings": {**settings.__dict__, "rpm": list(settings.rpm)},
                  "reused": int(sum(bool(r.get("reused")) for r in rows)), "reuse_key": key,
                  "source": spec.source, "config_digest": cfg.digest()})


def default_settings(cfg, rpm, torque: float | None, n_output_revs: float, samples_per_mesh: int,
                     micro_model: str) -> StudySettings:
    """Settings with the config's operating torque by default."""
    t = cfg.operating.torque_out if torque is None else float(torque)
    if not (math.isfinite(t) and t > 0):
        raise ConfigError(f"torque must be positive, got {t!r}")
    return StudySettings(tuple(float(r) for r in np.atleast_1d(rpm)), t, float(n_output_revs), int(samples_per_mesh),
                         micro_model)
