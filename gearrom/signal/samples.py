"""Chunked readers of sampled signals (kind ``quadrature``): CSV, NI TDMS, HDF5 and MATLAB files.

Every format is reduced to named columns of equal length that can be read slice by slice, so the
decoder sees bounded chunks of samples whatever the file (:func:`iter_samples`). MATLAB v5 files
are read with :func:`scipy.io.loadmat` (whole file in memory: the format has no partial reads),
MATLAB v7.3 and HDF5 files with h5py (read slice by slice), TDMS with npTDMS.

Supported layouts (the names are those of the measurement JSON, see ``docs/measurement-format.md``):

- CSV: a header naming the columns; one row per sample.
- TDMS: the channels in the group ``quadrature`` (or the file's only group).
- HDF5 / MATLAB v7.3: one dataset per channel at the root or in the group ``variable`` (a MATLAB
  struct saved with ``-v7.3`` is such a group); or a matrix dataset ``variable`` with ``columns``.
- MATLAB v5: one variable per channel; or a struct ``variable`` (or the file's only struct) with
  one field per channel; or a matrix ``variable`` with ``columns``.

A MATLAB ``timetable`` is a MATLAB object whose content cannot be read outside MATLAB; it is
converted in MATLAB to one of the forms above (the one-line conversion is in the docs).
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.signal.measurement import MeasurementMeta
from gearrom.signal.readers import HIDDEN, first_bad


@dataclass(frozen=True)
class SampleChunk:
    """Consecutive samples: index of the first one, times (s) and the named columns.

    ``t`` is None when the file has no time column: sample ``row0 + j`` is then at
    ``(row0 + j) / rate_hz`` (see :meth:`times`), and no time array is built.
    """

    row0: int
    t: np.ndarray | None
    cols: dict[str, np.ndarray]
    rate_hz: float | None = None

    def times(self) -> np.ndarray:
        """Sample times (s)."""
        if self.t is not None:
            return self.t
        m = len(next(iter(self.cols.values())))
        return (self.row0 + np.arange(m)) / self.rate_hz


class _Table:
    """Named columns of one length, each read as ``read(name, start, stop)`` -> numeric array.

    The stored type is kept (an int16 DAQ record stays int16: a quarter of the memory of float64
    and no conversion pass); booleans become uint8.
    """

    def __init__(self, n: int, names: list[str], read: Callable[[str, int, int], np.ndarray], close=None):
        self.n, self.names, self._read, self.close = n, names, read, close or (lambda: None)

    def read(self, name: str, a: int, b: int) -> np.ndarray:
        arr = np.asarray(self._read(name, a, b)).ravel()
        return arr.view(np.uint8) if arr.dtype == np.bool_ else arr


def _numeric(arr, path: Path, name: str) -> np.ndarray:
    arr = np.asarray(arr)
    if arr.dtype.kind not in "fiub":
        raise MeasurementError(f"{path}: channel {name!r}: data type {arr.dtype} is not numeric")
    return arr


def _from_arrays(arrays: dict[str, np.ndarray], path: Path) -> _Table:
    lens = {k: np.asarray(v).size for k, v in arrays.items()}
    n = max(lens.values()) if lens else 0
    return _Table(n, list(arrays), lambda k, a, b: _numeric(np.asarray(arrays[k]).ravel()[a:b], path, k))


def _matrix(arr: np.ndarray, columns: tuple[str, ...] | None, path: Path, var: str, *, matlab_h5: bool) -> _Table:
    if columns is None:
        raise MeasurementError(f"{path}: variable {var!r} is a matrix; name its columns in the measurement JSON "
                               "(quadrature.columns)")
    shape = arr.shape
    if len(shape) != 2 or len(columns) not in shape:
        raise MeasurementError(f"{path}: variable {var!r} has shape {shape}; quadrature.columns names "
                               f"{len(columns)} columns")
    # MATLAB v7.3 stores arrays transposed (column-major): an N x C matrix appears as C x N
    axis = 0 if (shape[0] == len(columns) and (matlab_h5 or shape[1] != len(columns))) else 1
    n = shape[1 - axis]

    def read(name: str, a: int, b: int) -> np.ndarray:
        j = columns.index(name)
        return _numeric(arr[j, a:b] if axis == 0 else arr[a:b, j], path, name)

    return _Table(n, list(columns), read)


def _h5_table(path: Path, variable: str | None, columns, needed: list[str], matlab: bool) -> _Table:
    import h5py

    fh = h5py.File(path, "r")
    try:
        if variable is not None:
            if variable not in fh:
                raise MeasurementError(f"{path}: variable/group {variable!r} not found (top level: {sorted(fh)})")
            node = fh[variable]
        else:
            node = fh
            if not all(k in fh for k in needed):
                groups = [g for g in fh.values() if isinstance(g, h5py.Group) and not g.name.startswith("/#")]
                if len(groups) == 1:
                    node = groups[0]
        if isinstance(node, h5py.Dataset):
            tab = _matrix(node, columns, path, variable or "", matlab_h5=matlab)
            tab.close = fh.close
            return tab
        dsets = {k: v for k, v in node.items() if isinstance(v, h5py.Dataset)}

        def read(name: str, a: int, b: int) -> np.ndarray:
            ds = dsets[name]
            if ds.ndim == 2 and 1 in ds.shape:
                return _numeric(ds[0, a:b] if ds.shape[0] == 1 else ds[a:b, 0], path, name)
            return _numeric(ds[a:b], path, name)

        n = max((max(d.shape) if d.ndim else 1) for d in dsets.values()) if dsets else 0
        return _Table(n, list(dsets), read, fh.close)
    except Exception:
        fh.close()
        raise


def _mat5_table(path: Path, variable: str | None, columns, needed: list[str]) -> _Table:
    from scipy.io import loadmat

    try:
        doc = loadmat(path, simplify_cells=True)
    except Exception as exc:  # noqa: BLE001 - scipy raises many types on corrupt files
        raise MeasurementError(f"{path}: cannot read MATLAB file: {type(exc).__name__}: {exc}") from None
    doc = {k: v for k, v in doc.items() if not k.startswith("__")}
    if variable is not None:
        if variable not in doc:
            raise MeasurementError(f"{path}: variable {variable!r} not found (variables: {sorted(doc)})")
        obj = doc[variable]
    elif all(k in doc for k in needed):
        obj = doc
    else:
        structs = [v for v in doc.values() if isinstance(v, dict)]
        mats = [k for k, v in doc.items() if isinstance(v, np.ndarray) and v.ndim == 2]
        if len(structs) == 1:
            obj = structs[0]
        elif len(mats) == 1 and columns is not None:
            variable, obj = mats[0], doc[mats[0]]
        else:
            raise MeasurementError(f"{path}: channels {needed} not found as variables (variables: {sorted(doc)}); "
                                   "name the struct or matrix that holds them (quadrature.variable)")
    if isinstance(obj, dict):
        return _from_arrays({k: v for k, v in obj.items() if isinstance(v, np.ndarray) and v.dtype.kind in "fiub"},
                            path)
    if isinstance(obj, np.ndarray) and obj.ndim == 2:
        return _matrix(obj, columns, path, variable or "", matlab_h5=False)
    raise MeasurementError(f"{path}: variable {variable!r} is neither a struct nor a numeric matrix "
                           f"(a MATLAB timetable/table object cannot be read outside MATLAB; see "
                           "docs/measurement-format.md for the conversion)")


def _tdms_table(path: Path, needed: list[str]) -> tuple[_Table, float | None]:
    from nptdms import TdmsFile

    try:
        fh = TdmsFile.open(str(path))
    except Exception as exc:  # noqa: BLE001
        raise MeasurementError(f"{path}: cannot open TDMS file: {type(exc).__name__}: {exc}") from None
    groups = fh.groups()
    group = next((g for g in groups if g.name == "quadrature"), groups[0] if len(groups) == 1 else None)
    if group is None:
        fh.close()
        raise MeasurementError(f"{path}: TDMS group 'quadrature' not found (groups: {[g.name for g in groups]})")
    chans = {c.name: c for c in group.channels()}
    inc = None
    for name in needed:
        if name in chans and "wf_increment" in chans[name].properties:
            inc = float(chans[name].properties["wf_increment"])
            break
    n = max((len(c) for c in chans.values()), default=0)
    tab = _Table(n, list(chans), lambda k, a, b: _numeric(chans[k].read_data(a, b - a), path, k), fh.close)
    return tab, (1.0 / inc if inc else None)


def _open(meta: MeasurementMeta, needed: list[str]) -> tuple[_Table | None, float | None]:
    q = meta.quadrature
    path = meta.data_path
    fmt = meta.data_format
    if fmt == "csv":
        return None, None
    if fmt == "tdms":
        return _tdms_table(path, needed)
    if fmt == "hdf5":
        return _h5_table(path, q.variable, q.columns, needed, matlab=False), None
    import h5py

    if h5py.is_hdf5(path):  # MATLAB v7.3
        return _h5_table(path, q.variable, q.columns, needed, matlab=True), None
    return _mat5_table(path, q.variable, q.columns, needed), None


def _csv_header(path: Path, meta: MeasurementMeta) -> list[str]:
    try:
        with open(path, encoding="utf-8-sig", newline="") as fh:
            first = fh.readline()
    except (OSError, UnicodeDecodeError) as exc:
        raise MeasurementError(f"{path}: line 1: cannot read header: {exc}") from None
    return [c.strip() for c in first.rstrip("\r\n").split(",")]


def iter_samples(meta: MeasurementMeta, needed: list[str], optional: list[str], chunk_rows: int = 2_000_000,
                 ) -> Iterator[SampleChunk]:
    """Yield the sampled channels ``needed`` (and those of ``optional`` that exist) chunk by chunk.

    Parameters
    ----------
    meta : MeasurementMeta
        A kind-``quadrature`` measurement.
    needed, optional : list of str
        Channel names that must exist / are read when present.
    chunk_rows : int
        Samples per chunk.

    Raises
    ------
    MeasurementError
        File unreadable, channel missing, no time base, non-numeric or non-finite samples, time not
        increasing. Names the file, channel and sample.
    """
    q = meta.quadrature
    path = meta.data_path
    tab, rate_file = _open(meta, needed)
    names = _csv_header(path, meta) if tab is None else tab.names
    time_col = q.time or ("t_s" if "t_s" in names else None)
    if time_col is not None and time_col not in names:
        raise MeasurementError(f"{path}: time column {time_col!r} not found (quadrature.time)")
    rate = meta.sample_rate_hz or rate_file
    if time_col is None and rate is None:
        raise MeasurementError(f"{meta.path}: no time base: the data file has no time column 't_s' "
                               "(quadrature.time) and the JSON gives no 'sample_rate_hz'")
    missing = [c for c in needed if c not in names]
    if missing:
        shown = names if meta.data_inside else HIDDEN
        raise MeasurementError(f"{path}: channel(s) {missing} not found (columns: {shown}); name them in the "
                               "measurement JSON (encoders.<channel>.a/b/z)")
    want = needed + [c for c in optional if c in names]
    read_cols = want + ([time_col] if time_col else [])
    label = "line" if meta.data_format == "csv" else "sample"
    first_row = 2 if meta.data_format == "csv" else 0
    t_last = -np.inf

    def finish(row0: int, t: np.ndarray | None, cols: dict[str, np.ndarray]) -> SampleChunk:
        nonlocal t_last
        # integer samples are finite by construction; times from the rate increase by construction
        checked = ([("time", t)] if t is not None else []) + [(k, v) for k, v in cols.items() if v.dtype.kind == "f"]
        for k, v in checked:
            i = first_bad(v)
            if i is not None:
                raise MeasurementError(f"{path}: {label} {row0 + i + first_row}, channel {k!r}: not a finite number")
        if t is None:
            return SampleChunk(row0, None, cols, rate)
        if t.size and not t[0] > t_last:
            i = 0
        else:
            bad = np.flatnonzero(t[1:] <= t[:-1])
            i = int(bad[0]) + 1 if bad.size else -1
        if i >= 0:
            raise MeasurementError(f"{path}: {label} {row0 + i + first_row}: time {t[i]:.9g} s does not increase")
        if t.size:
            t_last = float(t[-1])
        return SampleChunk(row0, t, cols)

    if tab is None:
        import pandas as pd

        try:
            reader = pd.read_csv(path, usecols=read_cols, dtype="float64", chunksize=chunk_rows, engine="c",
                                 encoding="utf-8-sig")
            row0 = 0
            with reader:
                for df in reader:
                    cols = {c: df[c].to_numpy(np.float64) for c in want}
                    yield finish(row0, df[time_col].to_numpy(np.float64) if time_col else None, cols)
                    row0 += len(df)
        except (ValueError, pd.errors.ParserError) as exc:
            raise MeasurementError(f"{path}: cannot parse CSV near sample {row0}: {type(exc).__name__}: "
                                   f"{exc if meta.data_inside else HIDDEN}") from None
        return
    try:
        for a in range(0, tab.n, chunk_rows):
            b = min(tab.n, a + chunk_rows)
            cols = {c: tab.read(c, a, b) for c in want}
            lens = {c: v.size for c, v in cols.items()}
            if len(set(lens.values())) != 1:
                raise MeasurementError(f"{path}: channels differ in length at samples {a}..{b}: {lens}")
            yield finish(a, tab.read(time_col, a, b) if time_col else None, cols)
    finally:
        tab.close()
