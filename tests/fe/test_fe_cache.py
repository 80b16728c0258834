"""The on-disk FE cache (:mod:`gearrom.fe.cache`): damaged entries, unwritable directories, keys,
atomic writes, for the 2D compliances (real FE on a very coarse mesh) and the 3D ones (the shared
helper, with a synthetic compliance in place of the 3D FE solve).

A damaged entry must be reported in one warning log line naming the file, deleted and recomputed,
and the run must give the result of a clean run; an unwritable cache directory must be reported in
one warning log line naming it, and the run must still return its result.
"""
from __future__ import annotations

import logging
import os
import zipfile

import numpy as np
import pytest

from gearrom.fe import cache as fecache
from gearrom.fe import compliance, compliance3d
from gearrom.fe.cache import CacheEntryError, FECache, atomic_path, read_arrays, write_arrays
from gearrom.fe.mesh2d import MeshSettings
from gearrom.fe.mesh3d import Mesh3DSettings
from gearrom.fe.sweep import build_ltca, mesh_cycle

MESH = MeshSettings(flank_size=0.12e-3, tooth_size=1.35e-3, body_size=9e-3)  # ~0.5 s per gear
TORQUES = [120.0]
N_POS = 8


@pytest.fixture(scope="module")
def pair(spur):
    return spur.pair


@pytest.fixture(scope="module")
def clean(pair):
    """Compliances and a short mesh cycle of a run without any cache."""
    ltca = build_ltca(pair, MESH, cache_dir=None)
    return ltca.c, mesh_cycle(ltca, TORQUES, N_POS, tangent=False)


def _entry(pair, cache_dir, i):
    return cache_dir / f"flank2d-{compliance.gear_key(pair, i, MESH, MESH.flank_size, 2)}.npz"


@pytest.fixture
def filled(pair, clean, tmp_path):
    """A cache directory holding the clean run's entries of both gears."""
    for i in range(2):
        clean[0][i].save(_entry(pair, tmp_path, i))
    return tmp_path


@pytest.fixture
def fe_calls(monkeypatch):
    """Counts the FE solves (2D compliance computations)."""
    calls = []
    real = compliance.compute_compliance

    def counted(pair, i, *a, **k):
        calls.append(i)
        return real(pair, i, *a, **k)

    monkeypatch.setattr(compliance, "compute_compliance", counted)
    return calls


def _flip_middle(path):
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x10
    path.write_bytes(bytes(data))


def _tamper_keeping_digest(path):
    """A valid NPZ whose G differs in one value from the stored digest (numpy loads it without error)."""
    with np.load(path) as d:
        arrays = {k: d[k] for k in d.files}
    arrays["G"] = arrays["G"].copy()
    arrays["G"].flat[arrays["G"].size // 2] *= 1.5
    np.savez(path, **arrays)


DAMAGE = {
    "empty": lambda p: p.write_bytes(b""),
    "truncated": lambda p: p.write_bytes(p.read_bytes()[: p.stat().st_size // 2]),
    "bit_flip_middle": _flip_middle,
    "data_changed_digest_kept": _tamper_keeping_digest,
    "not_npz": lambda p: p.write_text("not a cache entry\n"),
}


def _reports(caplog):
    """Warning lines of the cache logger since the last ``caplog.clear()``."""
    return [r.getMessage() for r in caplog.records if r.name == fecache.log.name and r.levelno == logging.WARNING]


def _same_as_clean(ltca, clean):
    for i in range(2):
        np.testing.assert_allclose(ltca.c[i].G, clean[0][i].G, rtol=1e-9, atol=0)
        np.testing.assert_array_equal(ltca.c[i].sigma, clean[0][i].sigma)
    res = mesh_cycle(ltca, TORQUES, N_POS, tangent=False)
    np.testing.assert_allclose(res.ste, clean[1].ste, rtol=1e-9, atol=0)


@pytest.mark.parametrize("damage", sorted(DAMAGE))
def test_damaged_entry_is_reported_deleted_and_recomputed(pair, clean, filled, fe_calls, damage, caplog):
    path = _entry(pair, filled, 0)
    DAMAGE[damage](path)
    caplog.clear()
    ltca = build_ltca(pair, MESH, cache_dir=filled)
    msgs = _reports(caplog)
    assert len(msgs) == 1 and str(path) in msgs[0] and "damaged" in msgs[0] and "\n" not in msgs[0], msgs
    assert fe_calls == [0]  # only the damaged gear is recomputed
    if damage == "data_changed_digest_kept":
        assert "digest" in msgs[0]
    _same_as_clean(ltca, clean)
    # the recomputed entry replaced the damaged one: the next run reads both without FE or warning
    read_arrays(path)
    caplog.clear()
    build_ltca(pair, MESH, cache_dir=filled)
    assert not _reports(caplog) and fe_calls == [0]


def test_intact_entries_are_used(pair, clean, filled, fe_calls, caplog):
    caplog.clear()
    ltca = build_ltca(pair, MESH, cache_dir=filled)
    assert not _reports(caplog) and fe_calls == []
    _same_as_clean(ltca, clean)


def test_digest_detects_changes_numpy_loads_silently(pair, clean, tmp_path):
    path = clean[0][0].save(tmp_path / "c.npz")
    _tamper_keeping_digest(path)
    with np.load(path) as d:
        assert d["G"].shape == clean[0][0].G.shape  # numpy sees a valid file
    with pytest.raises(CacheEntryError, match="digest"):
        compliance.FlankCompliance.load(path)


def test_cache_dir_is_a_file(pair, clean, tmp_path, fe_calls, caplog):
    blocker = tmp_path / "cache"
    blocker.write_text("a file where the cache directory should be\n")
    caplog.clear()
    ltca = build_ltca(pair, MESH, cache_dir=blocker)
    msgs = _reports(caplog)
    assert len(msgs) == 1 and str(blocker) in msgs[0] and "is a file" in msgs[0], msgs
    assert fe_calls == [0, 1]
    _same_as_clean(ltca, clean)


def test_cache_dir_below_a_file(pair, clean, tmp_path, caplog):
    (tmp_path / "f").write_text("x\n")
    caplog.clear()
    ltca = build_ltca(pair, MESH, cache_dir=tmp_path / "f" / "fe")
    msgs = _reports(caplog)
    assert len(msgs) == 1 and str(tmp_path / "f" / "fe") in msgs[0] and "is a file" in msgs[0], msgs
    _same_as_clean(ltca, clean)


def test_cache_dir_not_writable(pair, clean, tmp_path, monkeypatch, caplog):
    """Permission denied on the write (simulated: the tests may run as root, which ignores modes)."""
    def denied(src, dst):
        raise PermissionError(13, "Permission denied", str(dst))

    monkeypatch.setattr(fecache.os, "replace", denied)
    caplog.clear()
    ltca = build_ltca(pair, MESH, cache_dir=tmp_path)
    msgs = _reports(caplog)
    assert len(msgs) == 1 and str(tmp_path) in msgs[0] and "permission denied" in msgs[0], msgs
    assert list(tmp_path.iterdir()) == []  # no temporary files left behind
    _same_as_clean(ltca, clean)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root ignores directory modes")
def test_cache_dir_read_only(pair, clean, tmp_path, caplog):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        ltca = build_ltca(pair, MESH, cache_dir=ro)
    finally:
        ro.chmod(0o700)
    msgs = _reports(caplog)
    assert len(msgs) == 1 and str(ro) in msgs[0], msgs
    _same_as_clean(ltca, clean)


def test_interrupted_write_keeps_the_old_entry(tmp_path, monkeypatch):
    path = write_arrays(tmp_path / "e.npz", {"a": np.arange(3.0)})

    def partial(f, **arrays):
        f.write(b"PK\x03\x04 partial")
        raise KeyboardInterrupt

    monkeypatch.setattr(fecache.np, "savez", partial)
    with pytest.raises(KeyboardInterrupt):
        write_arrays(path, {"a": np.arange(4.0)})
    assert [p.name for p in tmp_path.iterdir()] == ["e.npz"]
    np.testing.assert_array_equal(read_arrays(path)["a"], np.arange(3.0))


def test_atomic_path_with_a_path_writer(tmp_path):
    """A writer that takes a path (as NetCDF or JSON writers do) gets a same-suffix temporary file."""
    target = tmp_path / "t.json"
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".json" and tmp != target
        tmp.write_text("{}")
        assert not target.exists()
    assert target.read_text() == "{}" and [p.name for p in tmp_path.iterdir()] == ["t.json"]
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("{half")
        raise RuntimeError("writer failed")
    assert target.read_text() == "{}" and [p.name for p in tmp_path.iterdir()] == ["t.json"]


def test_entry_roundtrip_is_exact(tmp_path):
    arrays = {"x": np.linspace(0, 1, 7), "n": np.arange(-2, 3), "s": np.array(2.5), "info": np.array('{"a": 1}')}
    back = read_arrays(write_arrays(tmp_path / "sub" / "e.npz", arrays))
    assert set(back) == set(arrays)
    for k, v in arrays.items():
        np.testing.assert_array_equal(back[k], v)
        assert back[k].dtype == v.dtype
    with zipfile.ZipFile(tmp_path / "sub" / "e.npz") as z:
        assert fecache.DIGEST_FIELD + ".npy" in z.namelist()
    mask = os.umask(0o022)
    os.umask(mask)
    assert (tmp_path / "sub" / "e.npz").stat().st_mode & 0o777 == 0o666 & ~mask  # readable like any new file


def test_key_covers_version_material_geometry_mesh_not_micro(pair, monkeypatch):
    import dataclasses

    import gearrom

    key = compliance.gear_key(pair, 0, MESH, MESH.flank_size, 2)
    g = pair.gears[0]

    def with_gear(**kw):
        return dataclasses.replace(pair, gears=(dataclasses.replace(g, **kw), pair.gears[1]))

    others = {
        "material": compliance.gear_key(with_gear(material=dataclasses.replace(g.material, youngs_modulus=200e9)),
                                        0, MESH, MESH.flank_size, 2),
        "bore": compliance.gear_key(with_gear(bore_diameter=g.bore_diameter * 1.1), 0, MESH, MESH.flank_size, 2),
        "mesh": compliance.gear_key(pair, 0, dataclasses.replace(MESH, near_teeth=2), MESH.flank_size, 2),
    }
    assert all(k != key for k in others.values()), others
    micro = with_gear(micro=dataclasses.replace(g.micro, enabled=True, profile_crowning=5e-6))
    assert compliance.gear_key(micro, 0, MESH, MESH.flank_size, 2) == key
    monkeypatch.setattr(gearrom, "__version__", gearrom.__version__ + ".post1")
    assert compliance.gear_key(pair, 0, MESH, MESH.flank_size, 2) != key


# ---------------------------------------------------------------- 3D: same helper, synthetic compliance
def _synthetic3d(pair, i, settings=None, n_sigma=3, n_zeta=2, **kw):
    rng = np.random.default_rng(i)
    n = n_sigma * n_zeta
    G = rng.random((3, n, n))
    return compliance3d.FlankCompliance3D(
        rb=pair.rb[i], sigma=np.linspace(1e-3, 2e-3, n_sigma), zeta=np.linspace(-5e-3, 5e-3, n_zeta),
        d_sigma=0.5e-3, d_zeta=10e-3, offsets=np.arange(-1, 2), G=G, B=0.5 * G, depth=np.full(n, 0.6e-3),
        youngs_modulus=206e9, poisson_ratio=0.3, face_width=18e-3, info={"gear": i})


@pytest.mark.parametrize("damage", sorted(DAMAGE))
def test_3d_damaged_entry_recomputed(pair, tmp_path, monkeypatch, damage, caplog):
    calls = []

    def fake(pair, i, settings=None, **kw):
        calls.append(i)
        return _synthetic3d(pair, i, settings, **kw)

    monkeypatch.setattr(compliance3d, "compute_compliance3d", fake)
    s = Mesh3DSettings()
    first = compliance3d.cached_compliance3d(pair, 1, s, cache_dir=tmp_path)
    path = tmp_path / f"flank3d-{compliance3d.gear_key3d(pair, 1, s)}.npz"
    assert path.is_file() and calls == [1]
    DAMAGE[damage](path)
    caplog.clear()
    again = compliance3d.cached_compliance3d(pair, 1, s, cache_dir=tmp_path)
    msgs = _reports(caplog)
    assert len(msgs) == 1 and str(path) in msgs[0], msgs
    assert calls == [1, 1]
    for k in ("G", "B", "sigma", "zeta", "depth"):
        np.testing.assert_array_equal(getattr(again, k), getattr(first, k))
    assert again.info == first.info
    third = compliance3d.cached_compliance3d(pair, 1, s, cache_dir=tmp_path)
    assert calls == [1, 1]
    np.testing.assert_array_equal(third.B, first.B)


def test_3d_unwritable_dir_warns_once_per_cache(pair, tmp_path, monkeypatch, caplog):
    monkeypatch.setattr(compliance3d, "compute_compliance3d", _synthetic3d)
    blocker = tmp_path / "cache"
    blocker.write_text("x\n")
    cache = FECache(blocker)
    caplog.clear()
    comps = [compliance3d.cached_compliance3d(pair, i, cache_dir=cache) for i in range(2)]
    msgs = _reports(caplog)
    assert len(msgs) == 1 and str(blocker) in msgs[0], msgs
    assert [c.info["gear"] for c in comps] == [0, 1]


@pytest.mark.parametrize("damage", ["empty", "truncated"])
def test_damaged_micro_geometry_table_is_reported_and_refetched(tmp_path, damage, caplog):
    """The calibrate package's micro-geometry tables (NetCDF entries of the same cache object): a
    damaged entry is one warning naming the file and a miss, not a traceback; an intact one loads."""
    from gearrom.config import load_config
    from gearrom.excitation.analytical import analytical_excitation
    from gearrom.excitation.table import MeshExcitation

    ex = analytical_excitation(load_config("thesis-spur").pair, [60.0, 120.0], n_theta=32)
    cache = FECache(tmp_path)

    def save(path):
        with atomic_path(path) as tmp:
            ex.save(tmp)

    assert cache.store("micro-x.nc", save)
    np.testing.assert_allclose(cache.fetch("micro-x.nc", MeshExcitation.load).e, ex.e)
    path = tmp_path / "micro-x.nc"
    data = path.read_bytes()
    path.write_bytes(b"" if damage == "empty" else data[: len(data) // 2])
    with caplog.at_level(logging.WARNING, logger="gearrom.fe.cache"):
        assert cache.fetch("micro-x.nc", MeshExcitation.load) is None
    lines = [r.getMessage() for r in caplog.records if "damaged" in r.getMessage()]
    assert len(lines) == 1 and str(path) in lines[0] and not path.exists()
