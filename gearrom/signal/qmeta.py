"""Metadata of kind ``quadrature``: sampled A/B (and index) signals of both encoders.

The JSON of such a measurement names the sampled channels per encoder and, in the optional
``quadrature`` object, how they are decoded::

    "kind": "quadrature", "data": "run.mat", "sample_rate_hz": 50000,
    "quadrature": {"threshold": 2.5, "hysteresis": 0.5, "decoding": 4, "time": "t_s"},
    "encoders": {"input":  {"lines": 1000, "a": "A1", "b": "B1", "z": "Z1"},
                 "output": {"lines": 1000, "a": "A2", "b": "B2", "ratio": 1.0}}

See ``docs/measurement-format.md`` for every key.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

from gearrom.errors import MeasurementError
from gearrom.signal.encoders import CHANNELS, EncoderInfo, encoder_ratio, encoder_table

_QUAD_KEYS = {"threshold", "hysteresis", "decoding", "time", "variable", "columns", "edge_time"}
_ENC_KEYS = {"lines", "a", "b", "z", "location", "ratio"}


@dataclass(frozen=True)
class QuadratureInfo:
    """How sampled A/B signals are turned into counts.

    Parameters
    ----------
    threshold : float or None
        Logic threshold in the unit of the samples (e.g. V). None: per channel, the middle between
        the 1st and 99th percentile of the first chunk of samples.
    hysteresis : float or None
        Width of the hysteresis band around the threshold (a channel switches high above
        ``threshold + hysteresis/2`` and low below ``threshold - hysteresis/2``). None: 10 % of
        the channel's swing.
    decoding : {1, 2, 4}
        Counted edges per line: x1 (one edge of A per line), x2 (both edges of A), x4 (every
        edge of A and B).
    time : str or None
        Name of the time column in s; None: ``"t_s"`` when the file has it, else the samples are
        taken as uniform at ``sample_rate_hz``.
    variable : str or None
        MATLAB/HDF5 variable or group holding the channels (None: the channels are top-level
        variables, or the file's only struct/group).
    columns : tuple of str or None
        Names of the columns of a matrix variable (MATLAB/HDF5 ``variable`` is a 2-D array).
    edge_time : {"interpolate", "sample"}
        Time of an edge: where the sampled signal crosses the switching level, interpolated
        linearly between the two samples around it, or the time of the first sample past it.
    """

    threshold: float | None = None
    hysteresis: float | None = None
    decoding: int = 4
    time: str | None = None
    variable: str | None = None
    columns: tuple[str, ...] | None = None
    edge_time: Literal["interpolate", "sample"] = "interpolate"


def _opt_num(d: dict, key: str, where: str, *, positive: bool = False) -> float | None:
    val = d.get(key)
    if val is None:
        return None
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val) \
            or (positive and val < 0):
        raise MeasurementError(f"{where}: key {key!r} must be a finite number{' >= 0' if positive else ''}, "
                               f"got {val!r}")
    return float(val)


def _opt_str(d: dict, key: str, where: str) -> str | None:
    val = d.get(key)
    if val is None:
        return None
    if not isinstance(val, str) or not val.strip():
        raise MeasurementError(f"{where}: key {key!r} must be a non-empty string, got {val!r}")
    return val


def read_quadrature_meta(doc: dict[str, Any], where: str) -> tuple[QuadratureInfo, dict[str, EncoderInfo]]:
    """Validate the ``quadrature`` object and the ``encoders`` of a kind-``quadrature`` JSON.

    Raises
    ------
    MeasurementError
        Unknown key, wrong type or value; names the file and the key.
    """
    q = doc.get("quadrature", {})
    if not isinstance(q, dict):
        raise MeasurementError(f"{where}: key 'quadrature' must be an object, got {q!r}")
    bad = sorted(set(q) - _QUAD_KEYS)
    if bad:
        raise MeasurementError(f"{where}: 'quadrature' has unknown key(s) {bad}; allowed: {sorted(_QUAD_KEYS)}")
    w = f"{where}: quadrature"
    dec = q.get("decoding", 4)
    if dec not in (1, 2, 4) or isinstance(dec, bool):
        raise MeasurementError(f"{w}: key 'decoding' must be 1, 2 or 4, got {dec!r}")
    edge_time = q.get("edge_time", "interpolate")
    if edge_time not in ("interpolate", "sample"):
        raise MeasurementError(f"{w}: key 'edge_time' must be 'interpolate' or 'sample', got {edge_time!r}")
    cols = q.get("columns")
    if cols is not None:
        if not (isinstance(cols, list) and cols and all(isinstance(c, str) and c for c in cols)) \
                or len(set(cols)) != len(cols):
            raise MeasurementError(f"{w}: key 'columns' must be a list of distinct column names, got {cols!r}")
        cols = tuple(cols)
    info = QuadratureInfo(threshold=_opt_num(q, "threshold", w), hysteresis=_opt_num(q, "hysteresis", w, positive=True),
                          decoding=int(dec), time=_opt_str(q, "time", w), variable=_opt_str(q, "variable", w),
                          columns=cols, edge_time=edge_time)
    enc = doc.get("encoders")
    if not isinstance(enc, dict):
        raise MeasurementError(f"{where}: key 'encoders' must be an object with 'input' and 'output' "
                               f"(kind 'quadrature'), got {enc!r}")
    unknown = sorted(set(enc) - set(CHANNELS))
    missing = [c for c in CHANNELS if c not in enc]
    if unknown or missing:
        raise MeasurementError(f"{where}: 'encoders' must have exactly the channels {list(CHANNELS)}"
                               + (f"; unknown {unknown}" if unknown else "") + (f"; missing {missing}" if missing else ""))
    out = {}
    for ch in CHANNELS:
        we = f"{where}: encoders.{ch}"
        e = encoder_table(enc[ch], we, _ENC_KEYS, " for kind 'quadrature'")
        lines = e.get("lines")
        if isinstance(lines, bool) or not isinstance(lines, int) or lines < 1:
            raise MeasurementError(f"{we}: 'lines' must be an integer >= 1 (pulses per revolution), got {lines!r}")
        names = {k: _opt_str(e, k, we) for k in ("a", "b", "z", "location")}
        out[ch] = EncoderInfo(edges_per_rev=lines * info.decoding, location=names["location"] or "sensor",
                              ratio=encoder_ratio(e, we), lines=lines, a=names["a"] or f"{ch}_a",
                              b=names["b"] or f"{ch}_b", z=names["z"])
    return info, out
