"""Write a simulated run as a ``gearrom.measurement/1`` file pair (kind ``edges``) and cache case files.

``<name>.json`` holds the metadata (see docs/measurement-format.md) and the truth under
``extra.truth``; ``<name>.csv`` the rows ``channel,t_s`` in time order, time stamps with 10 decimals
(``ceil(log10(80e6)) + 2``), written from integer clock counts so every tick survives exactly.
"""
from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from .data import PAIRS
from .effects import Case
from .simulate import CLOCK_HZ, EDGES_PER_REV, VERSION, SimResult, simulate

log = logging.getLogger(__name__)


def format_edges(edges: dict[str, np.ndarray], clock_hz: float = CLOCK_HZ) -> str:
    """CSV text ``channel,t_s`` of the edges of all channels merged in time order.

    Parameters
    ----------
    edges : dict
        Channel name -> time stamps [s], multiples of ``1/clock_hz``.
    clock_hz : float
        Counter clock [Hz]; ``10**decimals / clock_hz`` must be an integer.
    """
    dec = math.ceil(math.log10(clock_hz)) + 2
    unit = 10 ** dec / clock_hz
    if abs(unit - round(unit)) > 1e-9:
        raise ValueError(f"clock {clock_hz} Hz: ticks are not whole units of 1e-{dec} s")
    names = list(edges)
    counts = np.concatenate([np.rint(edges[c] * clock_hz).astype(np.int64) for c in names])
    chan = np.concatenate([np.full(len(edges[c]), i) for i, c in enumerate(names)])
    order = np.argsort(counts, kind="stable")
    counts, chan = counts[order], chan[order]
    v = counts * int(round(unit))
    whole = (v // 10 ** dec).astype(str)
    frac = np.char.zfill((v % 10 ** dec).astype(str), dec)
    label = np.array([f"{c}," for c in names])[chan]
    rows = np.char.add(np.char.add(np.char.add(label, whole), "."), np.char.add(frac, "\n"))
    return "channel,t_s\n" + "".join(rows.tolist())


def write_measurement(folder, name: str, case: Case, rpm_in: float, torque_out_Nm: float = 120.0, *,
                      output_revs: float = 6.0, pair: str = "helical", seed: int = 0,
                      result: SimResult | None = None, **sim_kw) -> Path:
    """Simulate (unless ``result`` is given) and write ``<folder>/<name>.json`` + ``.csv``.

    Parameters
    ----------
    folder : path-like
        Output folder (created).
    name : str
        File stem.
    case : Case
    rpm_in : float
        Nominal input speed [rpm], written as ``rpm_in``; the motor runs at ``rpm_in * case.speed_factor``.
    torque_out_Nm : float
        Brake torque [N m].
    output_revs, pair, seed, **sim_kw
        Passed to :func:`datasim.simulate.simulate`.
    result : SimResult, optional
        An existing simulation of exactly these settings.

    Returns
    -------
    Path
        The JSON file.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    res = result or simulate(case, rpm_in, torque_out_Nm, output_revs=output_revs, pair=pair, seed=seed, **sim_kw)
    csv = folder / f"{name}.csv"
    csv.write_text(format_edges(res.edges))
    meta = {"format": "gearrom.measurement/1",
            "description": f"datasim (independent simulator) case {case.name!r}, {pair} pair, {rpm_in:g} rpm nominal",
            "rpm_in": float(rpm_in), "torque_out_Nm": float(torque_out_Nm), "kind": "edges", "data": csv.name,
            "clock_hz": int(CLOCK_HZ), "config": PAIRS[pair][1],
            "encoders": {ch: {"edges_per_rev": EDGES_PER_REV, "location": "sensor"} for ch in ("input", "output")},
            "extra": {"truth": res.truth}}
    path = folder / f"{name}.json"
    path.write_text(json.dumps(meta, indent=1))
    log.info("datasim: wrote %s (%d + %d edges)", path, len(res.edges["input"]), len(res.edges["output"]))
    return path


def source_digest() -> str:
    """Digest of the simulator's sources (a model change invalidates cached files)."""
    h = hashlib.sha256()
    for p in sorted(Path(__file__).parent.glob("*.py")):
        if not p.name.startswith("test_"):
            h.update(p.name.encode() + p.read_bytes())
    return h.hexdigest()


def make_case_files(folder, case: Case, rpms=(1250, 2000), torque_out_Nm: float = 120.0, *,
                    output_revs: float = 6.0, pair: str = "helical", seed: int = 0, **sim_kw) -> list[Path]:
    """Measurement files of ``case`` at each speed of ``rpms``, cached by content.

    The files go to ``<folder>/<case.name>-<key>/<case.name>_<rpm>rpm.json`` where ``key`` hashes the
    case, the run settings and the simulator sources; an existing complete folder is reused. The
    folder is built under a temporary name and renamed, so concurrent callers never see half a case.

    Returns
    -------
    list of Path
        The JSON files, in the order of ``rpms``.
    """
    folder = Path(folder)
    key_src = json.dumps({"case": case.to_dict(), "rpms": [float(r) for r in rpms], "torque": torque_out_Nm,
                          "revs": output_revs, "pair": pair, "seed": seed, "sim": sim_kw, "version": VERSION,
                          "source": source_digest()}, sort_keys=True, default=str)
    key = hashlib.sha256(key_src.encode()).hexdigest()[:16]
    final = folder / f"{case.name}-{key}"
    names = [f"{case.name}_{float(r):g}rpm" for r in rpms]
    paths = [final / f"{n}.json" for n in names]
    if (final / "DONE").exists():
        log.info("datasim: cached %s", final)
        return paths
    folder.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{case.name}-", dir=folder))
    try:
        for n, r in zip(names, rpms, strict=True):
            write_measurement(tmp, n, case, float(r), torque_out_Nm, output_revs=output_revs, pair=pair,
                              seed=seed, **sim_kw)
        (tmp / "DONE").write_text(key_src)
        try:
            os.rename(tmp, final)
        except OSError:  # another process finished first (or a stale incomplete folder)
            if not (final / "DONE").exists():
                shutil.rmtree(final, ignore_errors=True)
                os.rename(tmp, final)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return paths
