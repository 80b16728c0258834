"""The ``gearrom.measurement/1`` format: JSON metadata, validation, and the writer.

A JSON file describes one run and points to a data file (CSV or NI TDMS, path relative to
the JSON). See ``docs/measurement-format.md`` for the full description. This module reads
and validates the metadata (:func:`read_meta`) and writes complete measurements
(:func:`write_measurement`) from an :class:`EdgeRecord` (encoder edge timestamps) or an
:class:`AngleRecord` (angle histories).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.signal.encoders import CHANNELS, EncoderInfo, encoder_ratio, encoder_table
from gearrom.signal.qmeta import read_quadrature_meta

FORMAT = "gearrom.measurement/1"
Kind = Literal["edges", "angles", "quadrature"]
KINDS = ("edges", "angles", "quadrature")

_TOP_KEYS = {"format", "description", "rpm_in", "torque_out_Nm", "kind", "data", "clock_hz",
             "encoders", "config", "extra", "sample_rate_hz", "quadrature"}
_REQUIRED = {"format", "rpm_in", "kind", "data"}
_ENCODER_KEYS = {"edges_per_rev", "location", "ratio"}
#: Data file suffixes per kind (sampled A/B signals also come from HDF5 and MATLAB files).
SUFFIXES = {"edges": (".csv", ".tdms"), "angles": (".csv", ".tdms"),
            "quadrature": (".csv", ".tdms", ".h5", ".hdf5", ".mat")}


@dataclass(frozen=True)
class MeasurementMeta:
    """Validated metadata of one measurement (the JSON file).

    Attributes
    ----------
    path : Path
        The JSON file.
    data_path : Path
        The data file (absolute), ``.csv`` or ``.tdms``.
    kind : {"edges", "angles"}
    rpm_in : float
        Nominal input speed in rpm.
    clock_hz : float or None
        Timestamp clock of the edge counter in Hz (required for kind "edges").
    encoders : dict
        ``{"input": EncoderInfo, "output": EncoderInfo}`` (required for kind "edges").
    torque_out_Nm, description, config, extra
        Optional information; ``config`` names a gear configuration for the TE: a bundled name as
        written, a file path resolved against the JSON's folder (so the result does not depend on
        the working directory).
    data_inside : bool
        The data file lies in the JSON's folder tree. Readers refuse other data files unless
        ``ReadSettings.allow_outside_data`` is set, and never quote their content in messages.
    sample_rate_hz : float or None
        Sample rate of a sampled record (kind "quadrature") without a time column, Hz.
    quadrature : QuadratureInfo or None
        Decoder settings of kind "quadrature" (:mod:`gearrom.signal.qmeta`).
    """

    path: Path
    data_path: Path
    kind: Kind
    rpm_in: float
    clock_hz: float | None = None
    encoders: dict[str, EncoderInfo] = field(default_factory=dict)
    torque_out_Nm: float | None = None
    description: str = ""
    config: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    data_inside: bool = True
    sample_rate_hz: float | None = None
    quadrature: Any = None

    @property
    def data_format(self) -> Literal["csv", "tdms", "hdf5", "mat"]:
        """``"csv"``, ``"tdms"``, ``"hdf5"`` or ``"mat"``, from the data file extension."""
        suffix = self.data_path.suffix.lower()
        return {".tdms": "tdms", ".h5": "hdf5", ".hdf5": "hdf5", ".mat": "mat"}.get(suffix, "csv")


def _num(doc: dict, key: str, where: str, *, positive: bool = True, required: bool = True) -> float | None:
    val = doc.get(key)
    if val is None:
        if required:
            raise MeasurementError(f"{where}: missing key {key!r}")
        return None
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
        raise MeasurementError(f"{where}: key {key!r} must be a finite number, got {val!r}")
    if positive and val <= 0:
        raise MeasurementError(f"{where}: key {key!r} must be > 0, got {val!r}")
    return float(val)


def read_meta(path: str | Path) -> MeasurementMeta:
    """Read and validate a ``gearrom.measurement/1`` JSON file.

    Parameters
    ----------
    path : str or Path
        The JSON metadata file.

    Returns
    -------
    MeasurementMeta

    Raises
    ------
    MeasurementError
        The file is missing or unreadable, is not JSON, or a key is missing, unknown or of the
        wrong type/value. The message names the file and the key.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
        doc = json.loads(text)
    except FileNotFoundError:
        raise MeasurementError(f"{path}: measurement file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise MeasurementError(f"{path}: cannot read measurement file: {exc}") from None
    except json.JSONDecodeError as exc:
        raise MeasurementError(f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}") from None
    where = str(path)
    if not isinstance(doc, dict):
        raise MeasurementError(f"{where}: top level must be a JSON object, got {type(doc).__name__}")
    unknown = sorted(set(doc) - _TOP_KEYS)
    if unknown:
        raise MeasurementError(f"{where}: unknown key(s) {unknown}; allowed: {sorted(_TOP_KEYS)}")
    missing = sorted(_REQUIRED - set(doc))
    if missing:
        raise MeasurementError(f"{where}: missing key(s) {missing}")
    if doc["format"] != FORMAT:
        raise MeasurementError(f"{where}: key 'format' must be {FORMAT!r}, got {doc['format']!r}")
    kind = doc["kind"]
    if kind not in KINDS:
        raise MeasurementError(f"{where}: key 'kind' must be one of {list(KINDS)}, got {kind!r}")
    data = doc["data"]
    if not isinstance(data, str) or not data.strip():
        raise MeasurementError(f"{where}: key 'data' must be a non-empty file name, got {data!r}")
    try:
        if "\x00" in data:
            raise ValueError("embedded null character")
        data_path = (path.parent / data).resolve()
    except (OSError, ValueError, RuntimeError) as exc:
        raise MeasurementError(f"{where}: key 'data': invalid file name {data!r}: {exc}") from None
    if data_path.suffix.lower() not in SUFFIXES[kind]:
        raise MeasurementError(f"{where}: key 'data': unsupported data file type {data_path.suffix!r} for kind "
                               f"{kind!r} (use {' or '.join(SUFFIXES[kind])})")
    rpm_in = _num(doc, "rpm_in", where)
    torque = _num(doc, "torque_out_Nm", where, positive=False, required=False)
    clock_hz = _num(doc, "clock_hz", where, required=kind == "edges")
    for key in ("description", "config"):
        if key in doc and not isinstance(doc[key], str):
            raise MeasurementError(f"{where}: key {key!r} must be a string, got {doc[key]!r}")
    extra = doc.get("extra", {})
    if not isinstance(extra, dict):
        raise MeasurementError(f"{where}: key 'extra' must be an object, got {extra!r}")
    sample_rate = _num(doc, "sample_rate_hz", where, required=False)
    if kind == "quadrature":
        quad, encoders = read_quadrature_meta(doc, where)
    else:
        for key in ("quadrature", "sample_rate_hz"):
            if key in doc:
                raise MeasurementError(f"{where}: key {key!r} belongs to kind 'quadrature', not {kind!r}")
        quad, encoders = None, _read_encoders(doc.get("encoders"), where, required=kind == "edges")
    config = _resolve_config(doc.get("config"), path, where)
    try:
        inside = data_path.is_relative_to(path.parent.resolve())
    except (OSError, RuntimeError):
        inside = False
    return MeasurementMeta(path=path, data_path=data_path, kind=kind, rpm_in=rpm_in, clock_hz=clock_hz,
                           encoders=encoders, torque_out_Nm=torque, description=doc.get("description", ""),
                           config=config, extra=extra, data_inside=inside, sample_rate_hz=sample_rate,
                           quadrature=quad)


def _resolve_config(value: str | None, path: Path, where: str) -> str | None:
    """The ``config`` key: a bundled name (no path separator, no suffix) stays a name; anything
    else is a file path, taken relative to the JSON's folder like ``data``."""
    if value is None:
        return None
    from gearrom.config import bundled_names

    if not value.strip() or "\x00" in value:
        raise MeasurementError(f"{where}: key 'config' must be a bundled config name or a TOML path, got {value!r}")
    if value in bundled_names() and "/" not in value and "\\" not in value and not Path(value).suffix:
        return value
    try:
        return str((path.parent / value).resolve())
    except (OSError, RuntimeError, ValueError) as exc:
        raise MeasurementError(f"{where}: key 'config': invalid path {value!r}: {exc}") from None


def _read_encoders(enc: Any, where: str, *, required: bool) -> dict[str, EncoderInfo]:
    if enc is None:
        if required:
            raise MeasurementError(f"{where}: missing key 'encoders' (required for kind 'edges')")
        return {}
    if not isinstance(enc, dict):
        raise MeasurementError(f"{where}: key 'encoders' must be an object, got {enc!r}")
    unknown = sorted(set(enc) - set(CHANNELS))
    if unknown:
        raise MeasurementError(f"{where}: 'encoders' has unknown channel(s) {unknown}; allowed: {list(CHANNELS)}")
    out = {}
    for ch in CHANNELS:
        if ch not in enc:
            if required:
                raise MeasurementError(f"{where}: 'encoders' is missing channel {ch!r}")
            continue
        w = f"{where}: encoders.{ch}"
        e = encoder_table(enc[ch], w, _ENCODER_KEYS)
        n = e.get("edges_per_rev")
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise MeasurementError(f"{w}: 'edges_per_rev' must be an integer >= 1, got {n!r}")
        loc = e.get("location", "sensor")
        if not isinstance(loc, str):
            raise MeasurementError(f"{w}: 'location' must be a string, got {loc!r}")
        out[ch] = EncoderInfo(edges_per_rev=n, location=loc, ratio=encoder_ratio(e, w))
    return out


@dataclass(frozen=True)
class EdgeRecord:
    """Encoder edge timestamps of both shafts.

    Parameters
    ----------
    t_input_s, t_output_s : ndarray
        Edge times in s, increasing, one per counted edge.
    edges_per_rev : tuple of int
        ``(input, output)`` counted edges per revolution.
    clock_hz : float
        Timestamp clock in Hz.
    locations : tuple of str
        ``(input, output)`` encoder locations.
    """

    t_input_s: np.ndarray
    t_output_s: np.ndarray
    edges_per_rev: tuple[int, int]
    clock_hz: float
    locations: tuple[str, str] = ("sensor", "sensor")


@dataclass(frozen=True)
class AngleRecord:
    """Angle histories of both shafts on one time base (s, rad)."""

    t_s: np.ndarray
    theta_in_rad: np.ndarray
    theta_out_rad: np.ndarray


def _fmt_decimals(clock_hz: float) -> int:
    return max(6, int(math.ceil(math.log10(clock_hz))) + 2)


def write_measurement(path_json: str | Path, record: EdgeRecord | AngleRecord, *, rpm_in: float,
                      torque_out_Nm: float | None = None, description: str = "", config: str | None = None,
                      data_format: Literal["csv", "tdms"] = "csv", extra: dict | None = None) -> Path:
    """Write a measurement: the JSON metadata and its data file next to it.

    Parameters
    ----------
    path_json : str or Path
        The JSON file to write; the data file gets the same stem with ``.csv`` or ``.tdms``.
    record : EdgeRecord or AngleRecord
        The data.
    rpm_in : float
        Nominal input speed in rpm.
    torque_out_Nm, description, config, extra
        Optional metadata (``config`` names the gear configuration).
    data_format : {"csv", "tdms"}
        Data file format.

    Returns
    -------
    Path
        The JSON file written.
    """
    path_json = Path(path_json)
    data_path = path_json.with_suffix("." + data_format)
    if isinstance(record, EdgeRecord):
        kw = dict(kind="edges", clock_hz=record.clock_hz, edges_per_rev=record.edges_per_rev,
                  locations=record.locations)
    elif isinstance(record, AngleRecord):
        kw = dict(kind="angles")
    else:
        raise TypeError(f"record must be an EdgeRecord or AngleRecord, got {type(record).__name__}")
    if data_format == "csv":
        _write_csv(data_path, record)
    elif data_format == "tdms":
        _write_tdms(data_path, record)
    else:
        raise ValueError(f"data_format must be 'csv' or 'tdms', got {data_format!r}")
    return write_meta(path_json, data=data_path.name, rpm_in=rpm_in, torque_out_Nm=torque_out_Nm,
                      description=description, config=config, extra=extra, **kw)


class EdgeCSVWriter:
    """Write an edges CSV (``channel,t_s``) piece by piece, rows merged in time order per piece.

    For long emulated records that do not fit in memory: feed consecutive time windows of both
    channels (each window's edges later than the previous window's)::

        with EdgeCSVWriter(path, clock_hz) as w:
            for t_in, t_out in windows:
                w.write(t_in, t_out)

    Parameters
    ----------
    path : str or Path
        CSV file to create.
    clock_hz : float
        Counter clock; the time stamps are written with enough decimals to keep every tick.
    """

    def __init__(self, path: str | Path, clock_hz: float):
        self.path = Path(path)
        self.fmt = f"%.{_fmt_decimals(clock_hz)}f"
        self._fh = None

    def __enter__(self) -> EdgeCSVWriter:
        self._fh = open(self.path, "w", newline="\n")
        self._fh.write("channel,t_s\n")
        return self

    def __exit__(self, *exc) -> None:
        self._fh.close()

    def write(self, t_input_s: np.ndarray, t_output_s: np.ndarray, chunk: int = 1_000_000) -> None:
        """Append the edges of one time window of both channels."""
        import pandas as pd

        t = np.concatenate([t_input_s, t_output_s])
        ch = np.concatenate([np.zeros(len(t_input_s), np.int8), np.ones(len(t_output_s), np.int8)])
        order = np.argsort(t, kind="stable")
        names = np.array(CHANNELS, dtype=object)
        for i in range(0, t.size, chunk):
            idx = order[i:i + chunk]
            pd.DataFrame({"channel": names[ch[idx]], "t_s": t[idx]}).to_csv(
                self._fh, index=False, header=False, float_format=self.fmt, lineterminator="\n")


def write_meta(path_json: str | Path, *, data: str, kind: Kind, rpm_in: float, clock_hz: float | None = None,
               edges_per_rev: tuple[int, int] | None = None, locations: tuple[str, str] = ("sensor", "sensor"),
               torque_out_Nm: float | None = None, description: str = "", config: str | None = None,
               extra: dict | None = None) -> Path:
    """Write only the JSON metadata (for data files written separately, e.g. by :class:`EdgeCSVWriter`).

    Parameters
    ----------
    path_json : str or Path
        The JSON file to write.
    data : str
        Data file name, relative to the JSON.
    kind : {"edges", "angles"}
    rpm_in : float
        Nominal input speed, rpm.
    clock_hz : float, optional
        Time-stamp clock (kind "edges").
    edges_per_rev : (int, int), optional
        Input and output edges per revolution (kind "edges").
    locations : (str, str)
        Encoder locations.
    torque_out_Nm, description, config, extra
        Optional metadata.

    Returns
    -------
    Path
    """
    doc: dict[str, Any] = {"format": FORMAT, "description": description, "rpm_in": float(rpm_in)}
    if torque_out_Nm is not None:
        doc["torque_out_Nm"] = float(torque_out_Nm)
    if config is not None:
        doc["config"] = config
    doc.update(kind=kind, data=data)
    if clock_hz is not None:
        doc["clock_hz"] = float(clock_hz)
    if edges_per_rev is not None:
        doc["encoders"] = {ch: {"edges_per_rev": int(n), "location": loc}
                           for ch, n, loc in zip(CHANNELS, edges_per_rev, locations)}
    if extra:
        doc["extra"] = extra
    path_json = Path(path_json)
    path_json.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return path_json


def _write_csv(path: Path, record: EdgeRecord | AngleRecord) -> None:
    if isinstance(record, AngleRecord):
        import pandas as pd

        df = pd.DataFrame({"t_s": record.t_s, "theta_in_rad": record.theta_in_rad,
                           "theta_out_rad": record.theta_out_rad})
        df.to_csv(path, index=False, float_format="%.12g", lineterminator="\n")
        return
    with EdgeCSVWriter(path, record.clock_hz) as w:
        w.write(record.t_input_s, record.t_output_s)


def _write_tdms(path: Path, record: EdgeRecord | AngleRecord) -> None:
    from nptdms import ChannelObject, TdmsWriter

    with TdmsWriter(str(path)) as w:
        if isinstance(record, AngleRecord):
            w.write_segment([ChannelObject("angles", name, np.asarray(arr, np.float64))
                             for name, arr in (("t_s", record.t_s), ("theta_in_rad", record.theta_in_rad),
                                               ("theta_out_rad", record.theta_out_rad))])
        else:
            w.write_segment([ChannelObject("edges", "input", np.asarray(record.t_input_s, np.float64)),
                             ChannelObject("edges", "output", np.asarray(record.t_output_s, np.float64))])
