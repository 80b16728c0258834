"""Read gear and rig numbers from gearrom's bundled TOML files (numbers only, no gearrom code).

The files live in ``gearrom/data/configs`` of the repository; they are read with :mod:`tomllib`
and merged along their ``extends`` key. Lengths in the files are mm; callers convert to SI.
"""
from __future__ import annotations

import tomllib
from pathlib import Path

#: folder of the bundled gear configurations (read as data files)
CONFIG_DIR = Path(__file__).resolve().parents[2] / "gearrom" / "data" / "configs"

#: gear pair name -> (TOML holding the gears, name written to the measurement's ``config`` key)
PAIRS = {"helical": ("thesis-rig", "thesis-rig"), "spur": ("thesis-spur", "thesis-spur")}

#: the rig sections ([rig.*]) are always those of this file
RIG_CONFIG = "thesis-rig"


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, val in over.items():
        if isinstance(val, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], val)
        else:
            out[key] = val
    return out


def load_toml(name: str) -> dict:
    """The merged content of bundled config ``name`` (``extends`` followed recursively).

    Parameters
    ----------
    name : str
        File stem in :data:`CONFIG_DIR`, e.g. ``"thesis-rig"``.

    Returns
    -------
    dict
        Merged tables; the ``extends`` key removed.
    """
    with open(CONFIG_DIR / f"{name}.toml", "rb") as fh:
        doc = tomllib.load(fh)
    parent = doc.pop("extends", None)
    return _merge(load_toml(parent), doc) if parent else doc


def pair_config(pair: str) -> dict:
    """Gear tables (``pair``, ``input_gear``, ``output_gear``, ``operating``) of ``"helical"`` or ``"spur"``."""
    if pair not in PAIRS:
        raise ValueError(f"pair must be one of {sorted(PAIRS)}, got {pair!r}")
    return load_toml(PAIRS[pair][0])


def rig_config() -> dict:
    """The ``[rig]`` tables of thesis-rig.toml (used for both pairs)."""
    return load_toml(RIG_CONFIG)["rig"]
