"""Stored explicit FE reference records: where they are, their file names, and how they are read.

A record is a pair of files ``<prefix>_<rpm>rpm[_loaded|_full].npz`` (arrays ``t_s``, ``te_m``,
``theta_rad`` and ``energy_<name>``) and ``.json`` (run metadata: ``t_steady_from_s``, ``torque_out_Nm``,
the mesh, the start and the damping), written by the scripts in the repository's ``validation/``
folder. :data:`DEFAULT_FE_DIR` is that folder of the source checkout, or the folder named by the
environment variable ``GEARROM_FE_DIR``.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gearrom.errors import ConfigError, MeasurementError

__all__ = ["DEFAULT_FE_DIR", "FE_INTEGRATIONS", "FERecord", "check_record_pair", "load_fe_record", "pair_key",
           "record_prefix", "record_stem", "replace_meta"]

#: folder of the stored records: ``$GEARROM_FE_DIR``, else ``validation/`` of the source checkout
DEFAULT_FE_DIR = Path(os.environ.get("GEARROM_FE_DIR") or Path(__file__).resolve().parents[2] / "validation")


@dataclass(frozen=True, eq=False)
class FERecord:
    """One explicit FE run: time [s], input angle from the start [rad], TE [m] and its metadata."""

    t: np.ndarray
    theta_in: np.ndarray
    te: np.ndarray
    meta: dict
    source: str = "stored"
    energies: dict | None = None      # name -> J over the run (:data:`gearrom.fe.explicit.result.ENERGY_NAMES`)


def replace_meta(excitation, **extra):
    """The excitation with ``extra`` added to its metadata."""
    from dataclasses import replace

    return replace(excitation, metadata=dict(excitation.metadata, **extra))


#: kinds of stored explicit FE records, best first: "loaded" (loaded static start, calibrated damping,
#: fully integrated elements, outline nodes on the profile), "full" (gap start, fully integrated, no
#: damping), "reduced" (gap start, one-point elements with hourglass control)
FE_INTEGRATIONS = ("loaded", "full", "reduced")
_SUFFIX = {"loaded": "_loaded", "full": "_full", "reduced": ""}


def pair_key(pair) -> str:
    """SHA-1 of the pair's full definition (geometry, tools, materials, micro-geometry): a record states the
    key of the pair it was run on."""
    import hashlib

    return hashlib.sha1(repr(pair).encode()).hexdigest()


def record_prefix(pair, config_name: str) -> str:
    """File prefix of the records of ``pair``: ``spur`` or ``helical`` for perfect flanks, ``<kind>-<config>``
    when either gear's micro-geometry is switched on (its records are of another pair)."""
    kind = "helical" if pair.is_helical else "spur"
    if any(g.micro.enabled for g in pair.gears):
        return f"{kind}-{config_name}"
    return kind


def check_record_pair(record: "FERecord", pair, where: str) -> None:
    """ConfigError when ``record`` states a pair key (``pair_key`` in its metadata) other than ``pair``'s."""
    key = record.meta.get("pair_key")
    if key is not None and key != pair_key(pair):
        raise ConfigError(f"{where}: the record was run on another pair (config {record.meta.get('config', '?')!r}, "
                          "pair key differs): its gear data or micro-geometry are not this config's")


def record_stem(fe_dir: str | Path, rpm: float, prefix: str = "spur", integration: str = "reduced") -> Path:
    """``<fe_dir>/<prefix>_<rpm>rpm`` plus ``_loaded``, ``_full`` or nothing (:data:`FE_INTEGRATIONS`)."""
    if integration not in FE_INTEGRATIONS:
        raise ConfigError(f"FE record kind must be one of {FE_INTEGRATIONS}, got {integration!r}")
    return Path(fe_dir) / (f"{prefix}_{int(round(rpm))}rpm" + _SUFFIX[integration])


def load_fe_record(fe_dir: str | Path, rpm: float, prefix: str = "spur", integration: str = "reduced") -> FERecord:
    """Load ``<fe_dir>/<prefix>_<rpm>rpm[_full].npz/.json`` (:func:`record_stem`); MeasurementError naming a
    missing/broken file."""
    stem = record_stem(fe_dir, rpm, prefix, integration)
    npz, js = stem.with_suffix(".npz"), stem.with_suffix(".json")
    flag = {"full": " --integration full", "loaded": " --start loaded --integration full", "reduced": ""}[integration]
    for p in (npz, js):
        if not p.is_file():
            kind, _, config = prefix.partition("-")
            extra = f" --config {config}" if config else ""
            raise MeasurementError(f"stored explicit FE result {p} is missing (run validation/run_explicit_{kind}.py "
                                   f"{int(round(rpm))}{flag}{extra}{' or use --fresh' if prefix == 'spur' else ''})")
    meta = json.loads(js.read_text())
    with np.load(npz) as d:
        for key in ("t_s", "te_m", "theta_rad"):
            if key not in d:
                raise MeasurementError(f"{npz}: array {key!r} missing")
        t, te, th = d["t_s"], d["te_m"], d["theta_rad"]
        energies = {k[len("energy_"):]: d[k] for k in d.files if k.startswith("energy_")} or None
    for key in ("t_steady_from_s", "torque_out_Nm"):
        if key not in meta:
            raise MeasurementError(f"{js}: key {key!r} missing")
    meta.setdefault("integration", "full" if integration == "loaded" else integration)
    meta.setdefault("record", integration)
    return FERecord(t=t, theta_in=th[:, 0] - th[0, 0], te=te, meta=meta, source="stored", energies=energies)
