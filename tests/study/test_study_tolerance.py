"""Tolerance sampling and the dask study on a real LocalCluster with 2 worker processes.

References: the tolerance bounds themselves (every sample must lie inside them), the sample files on
disk (one per sample index, counted independently of the study's own bookkeeping), and a direct
in-process call of the per-sample task for the same deviations.
"""
import os
import re
import signal
import warnings

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.errors import ConfigError
from gearrom.study.scatter import SampleTask, StudySettings, read_sample, run_sample, run_tolerance_study
from gearrom.study.tolerance import ToleranceSpec, sample_deviations

UM = 1e-6
SETTINGS = StudySettings((3000.0, 4500.0), 120.0, 0.25, 32, "none")


@pytest.fixture(scope="module")
def pair():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-rig").pair


@pytest.fixture(scope="module")
def spec(pair):
    return ToleranceSpec.from_grade(pair, 6, tip_relief=((8 * UM, 4 * UM), (15 * UM, 5 * UM)),
                                    lead_crowning=(4 * UM, 3 * UM))


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
            Client(cl) as c:
        yield c


def test_samples_within_tolerance(pair, spec):
    for i in range(50):
        d = sample_deviations(spec, pair.z, i, seed=3)
        for g in range(2):
            fp = np.asarray(d.pitch[g])
            assert np.max(np.abs(fp)) <= spec.f_pT[g] * (1 + 1e-12)
            assert np.ptp(np.cumsum(fp - fp.mean())) <= spec.F_pT[g] * (1 + 1e-12)
            assert 0 <= d.runout[g] <= spec.F_rT[g]
            assert abs(d.tip_relief[g] - spec.tip_relief[g][0]) <= spec.tip_relief[g][1]
        assert abs(d.helix_slope) <= sum(spec.f_HbT)
        assert abs(d.lead_crowning - 4 * UM) <= 3 * UM
    # reproducible per (seed, index), different across indices
    assert sample_deviations(spec, pair.z, 7, 3) == sample_deviations(spec, pair.z, 7, 3)
    assert sample_deviations(spec, pair.z, 7, 3) != sample_deviations(spec, pair.z, 8, 3)


def test_drawing_file(tmp_path, pair):
    f = tmp_path / "tol.toml"
    f.write_text("[tolerance]\ngrade = 6\nF_rT_um = [22, 30]\ntip_relief_um = [[8, 4], [15, 5]]\n")
    s = ToleranceSpec.from_toml(f, pair)
    assert s.F_rT == pytest.approx((22 * UM, 30 * UM)) and s.tip_relief[1] == pytest.approx((15 * UM, 5 * UM))
    f.write_text("[tolerance]\nF_rT = [22, 30]\n")
    with pytest.raises(ConfigError, match="tolerance.F_rT"):
        ToleranceSpec.from_toml(f, pair)


def test_study_completes_and_resumes(tmp_path, spec, client, pair):
    res = run_tolerance_study("thesis-rig", spec, 4, SETTINGS, tmp_path, client=client, progress=False)
    assert res.gmf_um.shape == (4, 2, 3) and np.all(np.isfinite(res.gmf_um)) and res.metadata["reused"] == 0
    # the distributed result equals an in-process run of the same sample's task
    d = sample_deviations(spec, pair.z, 2, 0)
    ref = run_sample(SampleTask(str(load_config("thesis-rig").source), d, SETTINGS, str(tmp_path / "ref.nc"), "ref"))
    assert np.allclose(res.gmf_um[2], ref["gmf_um"], rtol=1e-9)
    # runout scatters the DTE range: samples differ
    assert np.ptp(res.dte_ptp_um[:, 0]) > 0
    again = run_tolerance_study("thesis-rig", spec, 6, SETTINGS, tmp_path, client=client, progress=False)
    assert again.metadata["reused"] == 4 and np.allclose(again.gmf_um[:4], res.gmf_um)
    p = again.percentiles()["gmf_um"]
    assert p.shape == (3, 2, 3) and np.all(p[0] <= p[1]) and np.all(p[1] <= p[2])
    again.save(tmp_path / "s.nc")
    from gearrom.study.result import ToleranceResult

    back = ToleranceResult.load(tmp_path / "s.nc")
    assert np.array_equal(back.gmf_um, again.gmf_um) and back.feature_names == again.feature_names


def test_worker_killed_mid_study(tmp_path, spec, client):
    n = 8
    state = {"killed": None}

    def kill_one(cl, done):
        if done == 2 and state["killed"] is None:
            pids = cl.run(os.getpid)  # {worker address: pid}
            addr, pid = sorted(pids.items())[0]
            state["killed"] = pid
            os.kill(pid, signal.SIGKILL)

    res = run_tolerance_study("thesis-rig", spec, n, SETTINGS, tmp_path, client=client, progress=False,
                              on_result=kill_one, seed=5)
    assert state["killed"] is not None
    files = sorted((tmp_path / "samples").glob("sample_*.nc"))
    idx = [int(re.match(r"sample_(\d+)_", f.name).group(1)) for f in files]
    assert sorted(idx) == list(range(n))  # every sample once, no duplicates
    # every stored sample is complete (a worker killed while writing leaves at most a hidden .part
    # temporary file, which is never read as a sample)
    for f in files:
        assert read_sample(f, xr_stamp(f)) is not None
    assert list(res.index) == list(range(n)) and np.all(np.isfinite(res.gmf_um))
    client.wait_for_workers(2, timeout=60)


def xr_stamp(path):
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return ds.attrs["stamp"]


def test_unreachable_scheduler(tmp_path, spec):
    from gearrom.study import distributed

    old = distributed.CONNECT_TIMEOUT_S
    distributed.CONNECT_TIMEOUT_S = 2.0
    try:
        with pytest.raises(ConfigError, match="--scheduler"):
            run_tolerance_study("thesis-rig", spec, 1, SETTINGS, tmp_path, scheduler="tcp://127.0.0.1:9", progress=False)
    finally:
        distributed.CONNECT_TIMEOUT_S = old


def _store_sample(task):
    """Stand-in for :func:`gearrom.study.scatter.run_sample` that stores a sample under the task's stamp
    in the same format without simulating (the reuse decision reads only the stamp)."""
    import json

    import xarray as xr

    from gearrom.rom.sweep import write_netcdf_atomic
    from gearrom.study.tolerance import FEATURES

    n = len(task.settings.rpm)
    feats = task.deviations.features()
    ds = xr.Dataset({"dte_ptp_um": ("rpm", np.ones(n)), "dte_rms_um": ("rpm", np.ones(n)),
                     "gmf_um": (("rpm", "gmf_order"), np.ones((n, 3))), "features": ("feature", feats)},
                    coords={"rpm": np.array(task.settings.rpm), "gmf_order": [1, 2, 3], "feature": list(FEATURES)},
                    attrs={"format": "gearrom.ToleranceSample", "index": task.deviations.index, "stamp": task.stamp,
                           "cpu_s": 0.0, "deviations_json": json.dumps(task.deviations.to_json())})
    write_netcdf_atomic(ds, task.path)
    return {"index": task.deviations.index, "dte_ptp_um": np.ones(n), "dte_rms_um": np.ones(n),
            "gmf_um": np.ones((n, 3)), "features": feats, "cpu_s": 0.0, "reused": False}


@pytest.mark.parametrize("module,name,micro,still_reused", [
    ("gearrom.excitation.slices", "MODEL_REVISION", "none", False),  # the ROM's pitch curves use the slices
    ("gearrom.excitation.slices", "MODEL_REVISION", "slices", False),
    ("gearrom.calibrate.microfe", "CODE_VERSION", "fe", False),
    ("gearrom.excitation.fe", "SLICES_REVISION", "fe", False),  # the slice LTCA behind the FE micro model
    ("gearrom.fe.compliance", "CODE_VERSION", "fe", False),
    ("gearrom.excitation.fe", "TABLE_REVISION", "none", False),  # the nominal FE table of thesis-rig
    ("gearrom.calibrate.microfe", "CODE_VERSION", "none", True),  # a model the samples do not use
])
def test_samples_of_another_model_revision_are_not_reused(tmp_path, spec, monkeypatch, module, name, micro,
                                                          still_reused):
    """A rerun into the same folder reuses the stored samples only while the revisions of the models they
    were computed with are unchanged.

    Reference: the files on disk and the tasks submitted. A study of 3 samples is stored, rerun (all 3
    reused, nothing submitted), then the revision constant of one model is changed (as a code change
    of that model does) and the study rerun: every sample is computed again when the samples use that
    model, and reused when they do not (the FE micro-geometry model's revision with ``micro_model="none"``).
    The per-sample simulation is replaced by a stand-in that stores a sample under the task's stamp.
    """
    import importlib

    from gearrom.study import distributed

    settings = StudySettings((3000.0,), 120.0, 0.25, 32, micro)
    submitted = []

    def fake_run_tasks(fn, tasks, client, **kw):
        submitted.append(len(tasks))
        return [_store_sample(t) for t in tasks]

    monkeypatch.setattr(distributed, "run_tasks", fake_run_tasks)

    def run():
        return run_tolerance_study("thesis-rig", spec, 3, settings, tmp_path, client=object(), progress=False)

    assert run().metadata["reused"] == 0 and submitted == [3]
    assert run().metadata["reused"] == 3 and submitted == [3]
    mod = importlib.import_module(module)
    old = getattr(mod, name)
    monkeypatch.setattr(mod, name, f"{old}-changed" if isinstance(old, str) else old + 1)
    res = run()
    if still_reused:
        assert res.metadata["reused"] == 3 and submitted == [3]
    else:
        assert res.metadata["reused"] == 0 and submitted == [3, 3]
        assert len(list((tmp_path / "samples").glob("sample_*.nc"))) == 6  # the new key's files next to the old
