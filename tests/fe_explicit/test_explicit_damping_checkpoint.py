"""Relative (spin-preserving) mass damping, and checkpoint / resume of explicit runs.

References:
* mass-proportional damping c = alpha m gives every mode the ratio zeta_n = alpha / (2 omega_n)
  (Rayleigh damping; Chopra, Dynamics of Structures, sec. 11.4). A cantilever whose clamp is a rigid
  reference at rest sees the relative damping as plain mass damping: its first bending mode (the
  Euler-Bernoulli shape as initial velocity) must decay at alpha / (2 omega_1), omega_1 measured from
  the record. Tolerance 5 %: the initial shape excites a little of the higher modes, and the
  logarithmic decrement is read from peaks of a sampled record.
* the same dashpots leave a rigid motion alone: a ring on a torsional spring (its rigid mode at
  100 Hz, the ring's own modes above 10 kHz) keeps its amplitude, where absolute mass damping of the
  same alpha takes away the share alpha / (2 omega) J_free / J_total per radian.
* the energy balance (kinetic + strain + spring + dissipated = external work) holds within 0.1 %.
* checkpoint: a run stopped at a chunk boundary and resumed gives the uninterrupted run's record bit
  for bit; so does a finished run continued to a later end time with the same chunk length.
"""
from __future__ import annotations

import numpy as np
import pytest
from cantilever import cantilever_strip

from gearrom.errors import ConfigError, RunInterrupted
from gearrom.fe.explicit import ExplicitModel, Material, RigidReference, solve
from gearrom.fe.explicit.meshes import annulus_q4

MAT = Material()


def _cantilever(alpha: float) -> tuple[ExplicitModel, int, float]:
    nodes, elements, clamp, tip, v0, f_eb = cantilever_strip(60, 4, MAT)
    model = ExplicitModel(nodes, elements, MAT, thickness=0.01, node_sets={"clamp": clamp},
                          references=(RigidReference("clamp", speed=0.0, center=(0.0, 0.0)),),
                          initial_velocity=v0, relative_damping=alpha)
    return model, tip, f_eb


def test_relative_damping_ratio_of_a_bending_mode():
    zeta = 0.02
    model0, tip, f_eb = _cantilever(0.0)
    alpha = 2 * zeta * 2 * np.pi * f_eb
    model, _, _ = _cantilever(alpha)
    res = solve(model, 6.2 / f_eb, sample_period=1 / f_eb / 200, probes=[tip])
    y = res.probe_u[:, 0, 1]
    pk = np.nonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:]) & (y[1:-1] > 0))[0] + 1
    assert len(pk) >= 5
    f1 = (len(pk) - 1) / (res.t[pk[-1]] - res.t[pk[0]])
    delta = np.log(y[pk[0]] / y[pk[-1]]) / (len(pk) - 1)
    zeta_measured = delta / np.sqrt(4 * np.pi ** 2 + delta ** 2)
    assert abs(zeta_measured / (alpha / (2 * 2 * np.pi * f1)) - 1) < 0.05, (zeta_measured, f1)
    assert res.energy("damping")[-1] > 0.5 * res.energy("kinetic")[0]
    assert res.energy_error < 1e-3


def _ring(alpha_rel: float = 0.0, alpha_abs: float = 0.0):
    ri, ro, thk = 0.02, 0.04, 0.01
    nodes, elements, inner, _ = annulus_q4(ri, ro, 3, 48)
    j_ring = MAT.rho * thk * np.pi * (ro ** 4 - ri ** 4) / 2
    k = j_ring * (2 * np.pi * 100.0) ** 2
    omega0 = 5.0                                   # rad/s, the whole ring turning rigidly at t = 0
    v0 = omega0 * np.column_stack([-nodes[:, 1], nodes[:, 0]])
    return ExplicitModel(nodes, elements, MAT, thickness=thk, node_sets={"bore": inner},
                         references=(RigidReference("bore", spring_k=k, omega0=omega0),), initial_velocity=v0,
                         relative_damping=alpha_rel, mass_damping=alpha_abs)


def test_relative_damping_leaves_the_rigid_mode_alone():
    alpha = 2 * 0.05 * 2 * np.pi * 100.0          # 5 % of critical at the rigid mode, were it absolute
    free = solve(_ring(), 0.02, sample_period=2e-5)
    rel = solve(_ring(alpha_rel=alpha), 0.02, sample_period=2e-5)
    ab = solve(_ring(alpha_abs=alpha), 0.02, sample_period=2e-5)
    amp = {k: np.abs(r.theta[len(r.t) // 2:, 0]).max() for k, r in (("free", free), ("rel", rel), ("abs", ab))}
    assert abs(amp["rel"] / amp["free"] - 1) < 1e-3, amp
    assert amp["abs"] < 0.8 * amp["free"], amp            # the absolute variant brakes it (control)
    assert rel.energy_error < 1e-3


def test_relative_damping_with_two_references_on_one_body_is_refused():
    nodes, elements, inner, outer = annulus_q4(0.02, 0.04, 3, 48)
    model = ExplicitModel(nodes, elements, MAT, thickness=0.01, node_sets={"bore": inner, "rim": outer},
                          references=(RigidReference("bore"), RigidReference("rim")), relative_damping=10.0)
    with pytest.raises(ConfigError, match="same body"):
        solve(model, 1e-4)


def test_checkpoint_resume_is_bit_for_bit(tmp_path):
    model = _ring(alpha_rel=100.0)
    kw = dict(sample_period=2e-5, chunks=5, parallel=False)
    whole = solve(model, 4e-3, **kw)
    ck = tmp_path / "run.ckpt.npz"
    with pytest.raises(RunInterrupted, match="resume"):
        solve(model, 4e-3, checkpoint=ck, wall_limit=0.0, **kw)
    with np.load(ck) as z:
        assert int(z["chunk"]) == 1                   # stopped after the first of five chunks
    resumed = solve(model, 4e-3, checkpoint=ck, **kw)
    for name in ("t", "theta", "omega", "energies", "torque_body"):
        assert np.array_equal(getattr(whole, name), getattr(resumed, name)), name
    assert np.array_equal(whole.u_final, resumed.u_final)
    # a checkpoint of another model or other settings is refused
    with pytest.raises(ConfigError, match="fingerprint"):
        solve(_ring(alpha_rel=50.0), 4e-3, checkpoint=ck, **kw)
    with pytest.raises(ConfigError, match="checkpoint"):
        solve(model, 4e-3, wall_limit=1.0, **kw)


def test_checkpoint_extends_a_finished_run_bit_for_bit(tmp_path):
    """A finished run continued to a later end time, with the same chunk length, is the run made to that
    end at once; other chunk boundaries or an earlier end are refused by name."""
    model = _ring(alpha_rel=100.0)
    kw = dict(sample_period=2e-5, parallel=False)
    whole = solve(model, 4e-3, chunks=5, **kw)               # 200 rows, 40 per chunk
    ck = tmp_path / "run.ckpt.npz"
    short = solve(model, 2.4e-3, chunks=3, checkpoint=ck, **kw)
    assert short.t[-1] == pytest.approx(2.4e-3) and len(short.t) < len(whole.t)
    with pytest.raises(ConfigError, match="chunk boundaries"):
        solve(model, 4e-3, chunks=4, checkpoint=ck, **kw)     # 50 rows per chunk
    with pytest.raises(ConfigError, match="chunk boundaries"):
        solve(model, 1.6e-3, chunks=2, checkpoint=ck, **kw)   # ends before the stored run
    longer = solve(model, 4e-3, chunks=5, checkpoint=ck, **kw)
    for name in ("t", "theta", "omega", "energies", "torque_body"):
        assert np.array_equal(getattr(whole, name), getattr(longer, name)), name
    assert np.array_equal(whole.u_final, longer.u_final)


def test_checkpoint_of_the_earlier_format_resumes_its_own_run(tmp_path):
    """A checkpoint whose key also covers t_end and the chunk count resumes that same run bit for bit."""
    from gearrom.fe.explicit.driver import fingerprint

    model = _ring(alpha_rel=100.0)
    kw = dict(sample_period=2e-5, chunks=5, parallel=False)
    whole = solve(model, 4e-3, **kw)
    ck = tmp_path / "run.ckpt.npz"
    with pytest.raises(RunInterrupted):
        solve(model, 4e-3, checkpoint=ck, wall_limit=0.0, **kw)
    with np.load(ck) as z:
        arrays = {k: z[k] for k in z.files if k not in ("format", "key", "bounds")}
    legacy = fingerprint(model, t_end=4e-3, sample_period=2e-5, dt=whole.meta["dt_s"], chunks=5,
                         probes=np.zeros(0, np.int64), parallel=False)
    np.savez(ck, format=np.array("gearrom.explicit-checkpoint/1"), key=np.array(legacy), **arrays)
    with pytest.raises(ConfigError, match="fingerprint"):
        solve(model, 4.8e-3, checkpoint=ck, **{**kw, "chunks": 6})
    resumed = solve(model, 4e-3, checkpoint=ck, **kw)
    for name in ("t", "theta", "energies"):
        assert np.array_equal(getattr(whole, name), getattr(resumed, name)), name


def test_stored_start_state_follows_the_model_and_contact_rule(tmp_path, monkeypatch):
    """A static start state stored beside a checkpoint is reused for the same model (mesh and placement) and
    contact rule only: a state solved with another contact rule or placement is solved again, not taken as
    the start of a new run (the helical references restart from a fresh static solve after a contact fix)."""
    from types import SimpleNamespace

    from gearrom.fe.explicit import contact
    from gearrom.fe.explicit.gearpair import start_state_key, stored_start_state

    model = SimpleNamespace(nodes=np.zeros((4, 3)), elements=np.zeros((1, 8), np.int64))
    calls = []

    def compute():
        calls.append(1)
        return np.full((4, 3), float(len(calls))), np.zeros(2), float(len(calls))

    ck = tmp_path / "run.ckpt.npz"

    def state(m):
        return stored_start_state(ck, ".loaded.npz", "te", (4, 3), 120.0, compute, key=start_state_key(m))

    assert state(model)[2] == 1.0 and state(model)[2] == 1.0 and len(calls) == 1
    monkeypatch.setitem(contact.CONTACT_REVISION, 3, "3d-other")
    assert state(model)[2] == 2.0 and len(calls) == 2
    moved = SimpleNamespace(nodes=model.nodes + 1e-12, elements=model.elements)
    assert state(moved)[2] == 3.0 and len(calls) == 3
    assert state(moved)[2] == 3.0 and len(calls) == 3
