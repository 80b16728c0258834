"""Transmission error from two shaft angles, and the whole measurement pipeline.

TE along the line of action (default)::

    TE = r_b1 * theta_1 - r_b2 * theta_2        [m], positive when the output lags

with the angles counted in each shaft's direction of rotation from the first edge. With
``te_on="pitch"`` the base radii are replaced by the pitch radii, ``TE = r_1 theta_1 - r_2 theta_2``:
the arc-length difference on the pitch circles of the seed's eqs. 37-40 (there written with the
shaft-end velocities, ``r/r_s * integral(v_s dt) = r * theta``). Pitch TE = line TE / cos(alpha_t).

The unknown angle offsets and the nominal slope (the residual of ``r_b1 - r_b2 z1/z2`` and of any
ratio rounding) are removed by a least-squares line in the input angle (``FilterSettings.detrend =
"angle"``, valid for run-ups as well as steady runs).

An encoder that does not give its nominal counts per shaft revolution (a sensor gear, a belt,
a wrong line count) shows as a speed ratio off z1/z2. ``TESettings.estimate_scale`` names the
encoder whose scale is then estimated from the data (the measured ratio over z1/z2) and
corrected; the estimate is reported (``TEResult.info["encoder_scale"]``).
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Literal

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.signal.angles import AngleData, load_angles
from gearrom.signal.edges import ReadSettings
from gearrom.signal.filters import apply_filters
from gearrom.signal.measurement import MeasurementMeta, read_meta
from gearrom.signal.result import TEResult
from gearrom.signal.settings import DEFAULT_CONFIG, GearMeshInfo, TESettings

log = logging.getLogger(__name__)

def te_from_angles(theta_in_rad: np.ndarray, theta_out_rad: np.ndarray, mesh: GearMeshInfo,
                   te_on: Literal["line", "pitch"] = "line") -> np.ndarray:
    """Raw TE ``r_in*theta_in - r_out*theta_out`` in m (offsets and slope not removed).

    Parameters
    ----------
    theta_in_rad, theta_out_rad : ndarray
        Shaft angles, rad, each positive in its direction of rotation.
    mesh : GearMeshInfo
        Gear data.
    te_on : {"line", "pitch"}
        Base radii (line of action) or pitch radii.

    Returns
    -------
    ndarray
        TE in m, positive when the output lags.
    """
    r_in, r_out = mesh.radii(te_on)
    return r_in * np.asarray(theta_in_rad) - r_out * np.asarray(theta_out_rad)


def compute_te(data: AngleData, mesh: GearMeshInfo, settings: TESettings | None = None):
    """TE of a measurement already read into angles.

    Parameters
    ----------
    data : AngleData
        From :func:`~gearrom.signal.angles.load_angles`.
    mesh : GearMeshInfo
    settings : TESettings, optional

    Returns
    -------
    TEResult

    Raises
    ------
    MeasurementError
        The measured speed ratio does not match z1/z2 (wrong config or edges_per_rev).
    """
    settings = settings or TESettings()
    th1, th2 = data.theta_in_rad, data.theta_out_rad
    span1 = th1[-1] - th1[0]
    if not span1 > 0:
        raise MeasurementError(f"{data.meta.data_path}: channel 'input' does not rotate")
    ratio = (th2[-1] - th2[0]) / span1
    info = dict(getattr(data, "info", {}) or {})
    if settings.estimate_scale != "none":
        f = ratio / mesh.ratio
        if settings.estimate_scale == "output":
            th2 = th2 / f
        else:
            th1 = th1 * f
        ch = settings.estimate_scale
        enc = data.meta.encoders.get(ch)
        info["encoder_scale"] = {
            "channel": ch, "measured_ratio": ratio, "nominal_ratio": mesh.ratio,
            "scale": f if ch == "output" else 1.0 / f,
            "counts_per_shaft_rev": (enc.counts_per_shaft_rev * (f if ch == "output" else 1.0 / f)) if enc else None,
            "detail": f"the {ch} encoder counts {f if ch == 'output' else 1 / f:.6g} x its nominal edges per shaft "
                      f"revolution (set encoders.{ch}.ratio accordingly); its angle was corrected"}
        log.warning("%s: %s", data.meta.path, info["encoder_scale"]["detail"])
    elif abs(ratio / mesh.ratio - 1) > settings.ratio_tolerance:
        raise MeasurementError(
            f"{data.meta.data_path}: measured speed ratio output/input = {ratio:.6f} (t={data.t_s[0]:.6g}.."
            f"{data.t_s[-1]:.6g} s) does not match z1/z2 = {mesh.z1}/{mesh.z2} = {mesh.ratio:.6f} of "
            f"{mesh.name or 'the gear data'} (tolerance {100 * settings.ratio_tolerance:g} %): wrong config "
            "or wrong edges_per_rev? (an encoder scale or sensor ratio: encoders.<channel>.ratio, or estimate it: "
            "gearrom te --estimate-scale output; tolerance: --ratio-tolerance)")
    te = apply_filters(te_from_angles(th1, th2, mesh, settings.te_on), data.fs_hz, settings.filters, angle_rad=th1)
    meta = data.meta
    from gearrom.signal.runup import plateau_rpm, speed_profile

    rpm = plateau_rpm(speed_profile(data.t_s, th1)[1])
    return TEResult(
        t_s=data.t_s, te_m=te, theta_in_rad=th1, theta_out_rad=th2, fs_hz=data.fs_hz, mesh=mesh,
        settings=settings, rpm_in=rpm, rpm_in_nominal=meta.rpm_in,
        repairs=tuple(r.to_dict() for r in data.repairs), source=str(meta.path), description=meta.description,
        torque_out_Nm=meta.torque_out_Nm, n_edges=dict(data.n_edges), info=info)


def resolve_mesh(meta: MeasurementMeta, mesh: GearMeshInfo | None = None,
                 config: str | Path | None = None) -> GearMeshInfo:
    """Gear data for a measurement: explicit ``mesh``, else ``config``, else the JSON's ``config``, else the default."""
    if mesh is not None:
        return mesh
    name = config or meta.config or DEFAULT_CONFIG
    log.info("gear data from config %s", name)
    return GearMeshInfo.from_config(name)


def process_measurement(path: str | Path, mesh: GearMeshInfo | None = None, *, config: str | Path | None = None,
                        te_settings: TESettings | None = None, read_settings: ReadSettings | None = None):
    """Read a ``gearrom.measurement/1`` file and compute its TE (the ``gearrom te`` pipeline).

    Parameters
    ----------
    path : str or Path
        Measurement JSON.
    mesh : GearMeshInfo, optional
        Gear data; default from ``config`` / the JSON's ``config`` key / ``"thesis-helical"``.
    config : str or Path, optional
        Gear configuration name or file.
    te_settings, read_settings : optional

    Returns
    -------
    TEResult
    """
    meta = read_meta(path)
    mesh = resolve_mesh(meta, mesh, config)
    data = load_angles(meta, read_settings)
    return compute_te(data, mesh, te_settings)
