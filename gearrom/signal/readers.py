"""Chunked readers for the data files of ``gearrom.measurement/1`` (CSV and NI TDMS).

They yield bounded chunks so that records with tens of millions of edges are read in bounded
memory. Every element carries its row number (``line`` in a CSV file, 1-based, header = line 1;
``sample`` index in a TDMS channel, 0-based) so that later checks can name it. Any parser failure
is turned into :class:`~gearrom.errors.MeasurementError` naming the file, the line and the column.

A data file outside the measurement JSON's folder tree is read only when the caller allows it
(``allow_outside_data``), and messages about such a file never quote its content: a measurement
JSON from elsewhere must not turn the reader into a way of displaying arbitrary files.
"""
from __future__ import annotations

import csv
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.signal.measurement import CHANNELS, MeasurementMeta

EDGE_COLUMNS = ("channel", "t_s")
EDGE_OPTIONAL = ("direction",)
ANGLE_COLUMNS = ("t_s", "theta_in_rad", "theta_out_rad")


@dataclass(frozen=True)
class EdgeChunk:
    """Edges of one channel from one chunk: times (s), row numbers, optional direction (+1/-1)."""

    channel: str
    t: np.ndarray
    row: np.ndarray
    direction: np.ndarray | None = None


@dataclass(frozen=True)
class AngleChunk:
    """Rows of an angles file: time (s), input and output angle (rad), row numbers."""

    t: np.ndarray
    theta_in: np.ndarray
    theta_out: np.ndarray
    row: np.ndarray


def row_label(meta: MeasurementMeta) -> str:
    """``"line"`` for CSV files, ``"sample"`` for TDMS channels."""
    return "sample" if meta.data_format == "tdms" else "line"


HIDDEN = "<not shown: data file outside the measurement folder>"


def shown(meta: MeasurementMeta, value: object) -> str:
    """``repr(value)`` for messages, or a placeholder when the data file lies outside the JSON's folder."""
    return repr(value) if meta.data_inside else HIDDEN


def iter_chunks(meta: MeasurementMeta, chunk_rows: int = 2_000_000, *,
                allow_outside_data: bool = False) -> Iterator[EdgeChunk | AngleChunk]:
    """Yield the data of a measurement in chunks of at most ``chunk_rows`` rows.

    Parameters
    ----------
    meta : MeasurementMeta
        The measurement.
    chunk_rows : int
        Rows per chunk.
    allow_outside_data : bool
        Read a data file outside the JSON's folder tree (otherwise an error).

    Raises
    ------
    MeasurementError
        Missing file, header, column, channel or group; unparsable value; a data file outside the
        measurement folder that is not allowed. Names file and line.
    """
    if not meta.data_inside and not allow_outside_data:
        raise MeasurementError(f"{meta.path}: key 'data' = {meta.data_path} lies outside the measurement's folder "
                               f"{meta.path.parent.resolve()}; move the data file there, or allow it explicitly "
                               "(gearrom te/diagnose --allow-outside-data, ReadSettings(allow_outside_data=True))")
    try:
        found = meta.data_path.is_file()
    except OSError as exc:
        raise MeasurementError(f"{meta.path}: key 'data': cannot access data file: {exc.strerror}") from None
    if not found:
        raise MeasurementError(f"{meta.path}: data file {meta.data_path} not found (key 'data')")
    if meta.data_format == "tdms":
        yield from _iter_tdms(meta, chunk_rows)
    else:
        yield from _iter_csv(meta, chunk_rows)


def _read_header(path: Path, kind: str, meta: MeasurementMeta) -> list[str]:
    try:
        with open(path, encoding="utf-8-sig", newline="") as fh:
            first = fh.readline()
    except (OSError, UnicodeDecodeError) as exc:
        raise MeasurementError(f"{path}: line 1: cannot read header: {exc}") from None
    cols = [c.strip() for c in first.rstrip("\r\n").split(",")]
    required = EDGE_COLUMNS if kind == "edges" else ANGLE_COLUMNS
    allowed = set(required) | (set(EDGE_OPTIONAL) if kind == "edges" else set())
    if not first.strip():
        raise MeasurementError(f"{path}: line 1: empty file or missing header; expected columns {list(required)}")
    missing = [c for c in required if c not in cols]
    unknown = [c for c in cols if c not in allowed]
    if missing or unknown or len(set(cols)) != len(cols):
        raise MeasurementError(f"{path}: line 1: header {cols if meta.data_inside else HIDDEN} must name the "
                               f"columns {list(required)}"
                               + (f" (optional {list(EDGE_OPTIONAL)})" if kind == "edges" else "")
                               + (f"; missing {missing}" if missing else "")
                               + (f"; unknown {unknown if meta.data_inside else HIDDEN}" if unknown else "")
                               + ("; duplicated column" if len(set(cols)) != len(cols) else ""))
    return cols


def _diagnose_csv(path: Path, cols: list[str], first_line: int, max_lines: int, meta: MeasurementMeta) -> str | None:
    """Scan from ``first_line`` for the first line that does not parse; describe it or return None."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace", newline="") as fh:
            reader = csv.reader(fh)
            for lineno, fields in enumerate(reader, start=1):
                if lineno < first_line:
                    continue
                if lineno > first_line + max_lines:
                    break
                if len(fields) != len(cols):
                    return f"line {lineno}: expected {len(cols)} fields {cols}, found {len(fields)}"
                chan = f", channel {shown(meta, fields[cols.index('channel')])}" if "channel" in cols else ""
                for name, val in zip(cols, fields):
                    if name == "channel":
                        if val not in CHANNELS:
                            return (f"line {lineno}: column 'channel': unknown channel {shown(meta, val)} "
                                    f"(use {list(CHANNELS)})")
                        continue
                    try:
                        float(val)
                    except ValueError:
                        return f"line {lineno}{chan}: column {name!r}: not a number: {shown(meta, val[:40])}"
    except (OSError, csv.Error) as exc:
        return f"cannot scan file: {exc}"
    return None


def _iter_csv(meta: MeasurementMeta, chunk_rows: int) -> Iterator[EdgeChunk | AngleChunk]:
    import pandas as pd

    path = meta.data_path
    cols = _read_header(path, meta.kind, meta)
    dtype = {c: "float64" for c in cols}
    if meta.kind == "edges":
        dtype["channel"] = "category"
    line0 = 2  # file line number of the first data row
    try:
        reader = pd.read_csv(path, dtype=dtype, chunksize=chunk_rows, engine="c", skip_blank_lines=False,
                             quoting=csv.QUOTE_NONE, encoding="utf-8-sig", header=0, names=cols)
    except Exception as exc:  # noqa: BLE001 - any parser failure becomes a MeasurementError
        raise MeasurementError(f"{path}: cannot parse CSV: {type(exc).__name__}: "
                               f"{exc if meta.data_inside else HIDDEN}") from None
    with reader:
        while True:
            try:
                df = next(reader)
            except StopIteration:
                return
            except Exception as exc:  # noqa: BLE001 - pandas raises many types on malformed input
                where = _diagnose_csv(path, cols, line0, chunk_rows + 10, meta)
                detail = str(exc)[:200] if meta.data_inside else HIDDEN
                raise MeasurementError(f"{path}: {where or f'near line {line0}'} "
                                       f"(parser: {type(exc).__name__}: {detail})") from None
            n = len(df)
            if meta.kind == "angles":
                yield AngleChunk(df["t_s"].to_numpy(np.float64), df["theta_in_rad"].to_numpy(np.float64),
                                 df["theta_out_rad"].to_numpy(np.float64), np.arange(line0, line0 + n, dtype=np.int64))
            else:
                yield from _split_edges(path, df, line0, meta)
            line0 += n


def _split_edges(path: Path, df, line0: int, meta: MeasurementMeta) -> Iterator[EdgeChunk]:
    cat = df["channel"]
    codes = cat.cat.codes.to_numpy()
    cats = list(cat.cat.categories)
    bad = [i for i, c in enumerate(cats) if c not in CHANNELS]
    if (codes < 0).any() or bad:
        where = np.flatnonzero((codes < 0) | np.isin(codes, bad))[0]
        val = cat.iloc[where]
        raise MeasurementError(f"{path}: line {line0 + where}: column 'channel': unknown or empty channel "
                               f"{shown(meta, val if isinstance(val, str) else '')} (use {list(CHANNELS)})")
    t = df["t_s"].to_numpy(np.float64)
    direction = df["direction"].to_numpy(np.float64) if "direction" in df.columns else None
    for name in CHANNELS:
        if name not in cats:
            continue
        idx = np.flatnonzero(codes == cats.index(name))
        if idx.size:
            yield EdgeChunk(name, t[idx], idx + line0, None if direction is None else direction[idx])


def _iter_tdms(meta: MeasurementMeta, chunk_rows: int) -> Iterator[EdgeChunk | AngleChunk]:
    from nptdms import TdmsFile

    path = meta.data_path
    try:
        fh = TdmsFile.open(str(path))
    except Exception as exc:  # noqa: BLE001 - npTDMS raises many types on corrupt files
        raise MeasurementError(f"{path}: cannot open TDMS file: {type(exc).__name__}: {exc}") from None
    with fh:
        groups = fh.groups()
        want = meta.kind
        group = next((g for g in groups if g.name == want), groups[0] if len(groups) == 1 else None)
        if group is None:
            raise MeasurementError(f"{path}: TDMS group {want!r} not found (groups: "
                                   f"{[g.name for g in groups] if meta.data_inside else HIDDEN})")
        names = [c.name for c in group.channels()]
        needed = CHANNELS if want == "edges" else ANGLE_COLUMNS
        for ch in needed:
            if ch not in names:
                raise MeasurementError(f"{path}: TDMS group {shown(meta, group.name)}: channel {ch!r} missing "
                                       f"(channels: {names if meta.data_inside else HIDDEN})")
        try:
            if want == "angles":
                chans = [group[c] for c in ANGLE_COLUMNS]
                n = min(len(c) for c in chans)
                if len({len(c) for c in chans}) != 1:
                    raise MeasurementError(f"{path}: TDMS channels {list(ANGLE_COLUMNS)} differ in length "
                                           f"({[len(c) for c in chans]})")
                for off in range(0, n, chunk_rows):
                    m = min(chunk_rows, n - off)
                    arrs = [_tdms_float(c.read_data(off, m), path, c.name, off, None) for c in chans]
                    yield AngleChunk(*arrs, np.arange(off, off + m, dtype=np.int64))
                return
            for ch in CHANNELS:
                c = group[ch]
                for off in range(0, len(c), chunk_rows):
                    m = min(chunk_rows, len(c) - off)
                    t = _tdms_float(c.read_data(off, m), path, ch, off, meta.clock_hz)
                    yield EdgeChunk(ch, t, np.arange(off, off + m, dtype=np.int64))
        except MeasurementError:
            raise
        except Exception as exc:  # noqa: BLE001
            raise MeasurementError(f"{path}: cannot read TDMS data: {type(exc).__name__}: {exc}") from None


def _tdms_float(data, path: Path, ch: str, off: int, clock_hz: float | None) -> np.ndarray:
    arr = np.asarray(data)
    if arr.dtype.kind in "iu":
        if clock_hz is None:
            raise MeasurementError(f"{path}: channel {ch!r}: integer data need 'clock_hz'")
        return arr.astype(np.float64) / clock_hz  # integer clock ticks
    if arr.dtype.kind != "f":
        raise MeasurementError(f"{path}: channel {ch!r}, sample {off}: data type {arr.dtype} is not numeric")
    return arr.astype(np.float64, copy=False)


def first_bad(arr: np.ndarray) -> int | None:
    """Index of the first non-finite value, or None."""
    ok = np.isfinite(arr)
    if ok.all():
        return None
    return int(np.argmin(ok))


def fmt_t(t: float) -> str:
    """Format a time stamp for messages."""
    return "nan" if not math.isfinite(t) else f"{t:.9g} s"
