"""Emulated DAQ records of quadrature encoders: sampled A/B/index signals of simulated runs.

Model of one encoder sampled by a DAQ: the electrical angle is ``lines * theta`` (``theta`` = the
encoder's angle, interpolated from the simulated history at the sample times, each shifted by
Gaussian sampling jitter); A is ``offset + amplitude * (1 + tanh(sharpness sin(lines theta))) / 2``
(a smoothed square wave, high for the first half of each line), B the same a quarter line later
plus ``phase_error_rad`` (electrical), the index high for the first half line of each revolution.
Gaussian noise is added to every sample (threshold noise). With A leading B the forward rotation
counts up. :func:`runup_angle` gives the angle of a start-up, steady part and coast-down.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from gearrom.signal.measurement import write_meta


def runup_angle(t_s: np.ndarray, rpm: float, *, t_rest_s: float = 0.2, t_up_s: float = 0.8,
                t_steady_s: float = 2.0, t_down_s: float = 1.5) -> np.ndarray:
    """Angle (rad) of a run: rest, smooth (raised-cosine) start-up, steady ``rpm``, coast-down to rest.

    The speed is ``rpm * s(t)`` with ``s`` rising from 0 to 1 over ``t_up_s`` and falling back over
    ``t_down_s``; the angle is its exact integral.
    """
    t = np.asarray(t_s, dtype=np.float64)
    w = rpm * 2 * math.pi / 60.0
    a, b, c = t_rest_s, t_rest_s + t_up_s, t_rest_s + t_up_s + t_steady_s
    d = c + t_down_s

    def ramp_int(x, T):  # integral of (1 - cos(pi x/T))/2 from 0 to x
        return 0.5 * x - T / (2 * math.pi) * np.sin(math.pi * x / T)

    th = np.zeros_like(t)
    m = (t > a) & (t <= b)
    th[m] = w * ramp_int(t[m] - a, t_up_s)
    th_b = w * ramp_int(t_up_s, t_up_s)
    m = (t > b) & (t <= c)
    th[m] = th_b + w * (t[m] - b)
    th_c = th_b + w * t_steady_s
    m = (t > c) & (t <= d)
    x = t[m] - c
    th[m] = th_c + w * (x - ramp_int(x, t_down_s))
    th[t > d] = th_c + w * (t_down_s - ramp_int(t_down_s, t_down_s))
    return th


@dataclass(frozen=True)
class DAQSettings:
    """The emulated DAQ and encoder electronics.

    Parameters
    ----------
    sample_rate_hz : float
        Sample rate of every channel, Hz.
    amplitude_V, offset_V : float
        Signal swing and low level, V.
    sharpness : float
        ``tanh`` factor of the wave shape (large: square wave).
    noise_V : float
        Rms of Gaussian noise on every sample, V (threshold noise).
    phase_error_rad : float
        Electrical phase error of B against the nominal quarter line, rad.
    jitter_s : float
        Rms of Gaussian sampling-time jitter, s.
    """

    sample_rate_hz: float = 50e3
    amplitude_V: float = 5.0
    offset_V: float = 0.0
    sharpness: float = 3.0
    noise_V: float = 0.0
    phase_error_rad: float = 0.0
    jitter_s: float = 0.0


@dataclass(frozen=True)
class QuadratureRecord:
    """Sampled channels of both encoders: ``t_s`` and ``channels`` (``input_a``, ``input_b``, ``input_z``, ...)."""

    t_s: np.ndarray
    channels: dict = field(default_factory=dict)
    lines: tuple[int, int] = (1000, 1000)
    sample_rate_hz: float = 50e3


def sample_encoder(t_samples: np.ndarray, t_hist: np.ndarray, theta_hist: np.ndarray, lines: int,
                   daq: DAQSettings, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Sampled A, B and index signals (V) of one encoder for an angle history."""
    ts = t_samples + (rng.normal(0.0, daq.jitter_s, t_samples.size) if daq.jitter_s > 0 else 0.0)
    th = np.interp(ts, t_hist, theta_hist)
    phi = lines * th
    amp, off = daq.amplitude_V, daq.offset_V

    def wave(x):
        return off + amp * 0.5 * (1.0 + np.tanh(daq.sharpness * np.sin(x)))

    out = {"a": wave(phi), "b": wave(phi - math.pi / 2 + daq.phase_error_rad)}
    frac = np.mod(th, 2 * math.pi) * lines / (2 * math.pi)
    out["z"] = off + amp * (frac < 0.5)
    if daq.noise_V > 0:
        for k in out:
            out[k] = out[k] + rng.normal(0.0, daq.noise_V, out[k].size)
    return out


def emulate_quadrature(t_s: np.ndarray, theta_in_rad: np.ndarray, theta_out_rad: np.ndarray, *,
                       lines: int | tuple[int, int] = 1000, daq: DAQSettings | None = None,
                       ratio: tuple[float, float] = (1.0, 1.0), duration_s: float | None = None,
                       rng: np.random.Generator | int | None = None) -> QuadratureRecord:
    """Sampled A/B/index signals of the input and output encoders for simulated shaft angles.

    Parameters
    ----------
    t_s, theta_in_rad, theta_out_rad : ndarray
        Angle histories (rad), finely sampled (linear interpolation to the sample times).
    lines : int or (int, int)
        Lines per encoder revolution.
    daq : DAQSettings
    ratio : (float, float)
        Encoder revolutions per shaft revolution (a sensor gear; 1 on the shaft).
    duration_s : float, optional
        Record length (default: the history's).
    rng : Generator, int or None
    """
    daq = daq or DAQSettings()
    rng = np.random.default_rng(rng)
    n_in, n_out = (lines, lines) if isinstance(lines, int) else lines
    dur = duration_s if duration_s is not None else float(t_s[-1] - t_s[0])
    ts = t_s[0] + np.arange(int(math.floor(dur * daq.sample_rate_hz)) + 1) / daq.sample_rate_hz
    chans = {}
    for name, th, n, r in (("input", theta_in_rad, n_in, ratio[0]), ("output", theta_out_rad, n_out, ratio[1])):
        for k, v in sample_encoder(ts, t_s, np.asarray(th) * r, int(n), daq, rng).items():
            chans[f"{name}_{k}"] = v
    return QuadratureRecord(ts - ts[0], chans, (int(n_in), int(n_out)), daq.sample_rate_hz)


def write_quadrature(path_json: str | Path, rec: QuadratureRecord, *, rpm_in: float,
                     data_format: Literal["csv", "tdms", "hdf5", "mat", "mat73"] = "mat",
                     config: str | None = None, description: str = "", torque_out_Nm: float | None = None,
                     layout: Literal["struct", "variables", "matrix"] = "struct", with_time: bool = True,
                     quadrature: dict | None = None, encoders: dict | None = None) -> Path:
    """Write a sampled record and its measurement JSON (kind ``quadrature``).

    ``data_format``: CSV, TDMS (group ``quadrature``), HDF5 (datasets at the root), MATLAB v5
    (``mat``: ``layout`` a struct ``data``, top-level variables, or a matrix ``data`` with
    ``quadrature.columns``) or MATLAB v7.3 (``mat73``: an HDF5 file with MATLAB's header and
    transposed arrays, the struct ``data`` as a group). ``with_time=False`` writes no time column
    (the JSON then gives ``sample_rate_hz``).
    """
    path_json = Path(path_json)
    suffix = {"csv": ".csv", "tdms": ".tdms", "hdf5": ".h5", "mat": ".mat", "mat73": ".mat"}[data_format]
    data_path = path_json.with_suffix(suffix)
    cols = dict(rec.channels)
    if with_time:
        cols = {"t_s": rec.t_s, **cols}
    q = dict(quadrature or {})
    if data_format == "csv":
        import pandas as pd

        pd.DataFrame(cols).to_csv(data_path, index=False, float_format="%.9g", lineterminator="\n")
    elif data_format == "tdms":
        from nptdms import ChannelObject, TdmsWriter

        with TdmsWriter(str(data_path)) as w:
            w.write_segment([ChannelObject("quadrature", k, np.asarray(v, np.float64)) for k, v in cols.items()])
    elif data_format == "hdf5":
        import h5py

        with h5py.File(data_path, "w") as f:
            for k, v in cols.items():
                f.create_dataset(k, data=v)
    elif data_format == "mat":
        from scipy.io import savemat

        if layout == "struct":
            savemat(data_path, {"data": cols})
        elif layout == "variables":
            savemat(data_path, cols)
        else:
            q["columns"] = list(cols)
            savemat(data_path, {"data": np.column_stack(list(cols.values()))})
            q.setdefault("variable", "data")
    else:
        _write_mat73(data_path, cols, layout)
        if layout == "matrix":
            q["columns"] = list(cols)
            q.setdefault("variable", "data")
    meta_enc = encoders or {ch: {"lines": n} for ch, n in zip(("input", "output"), rec.lines)}
    path = write_meta(path_json, data=data_path.name, kind="quadrature", rpm_in=rpm_in, config=config,
                      description=description, torque_out_Nm=torque_out_Nm)
    import json

    doc = json.loads(path.read_text())
    doc["encoders"] = meta_enc
    if q:
        doc["quadrature"] = q
    if not with_time:
        doc["sample_rate_hz"] = rec.sample_rate_hz
    path.write_text(json.dumps(doc, indent=2) + "\n")
    return path


def _write_mat73(path: Path, cols: dict, layout: str) -> None:
    """A MATLAB v7.3 file as MATLAB writes it: HDF5 with a 512-byte header block, arrays transposed."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        if layout == "matrix":
            f.create_dataset("data", data=np.vstack(list(cols.values())))  # N x C in MATLAB = C x N here
        else:
            g = f.create_group("data") if layout == "struct" else f
            for k, v in cols.items():
                g.create_dataset(k, data=np.asarray(v)[None, :])  # MATLAB N x 1 = 1 x N here
    head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created by: gearrom emulation, HDF5 schema 1.00 ."
    with open(path, "r+b") as fh:
        fh.write(head.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")
