"""Result of one time-domain run: :class:`DynamicRun`."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import ModelError
from gearrom.spectral import line_amplitudes
from gearrom.excitation.table import netcdf_engine, write_netcdf


@dataclass(eq=False)
class DynamicRun:
    """Time histories of one steady-state run (SI units).

    Attributes
    ----------
    time : ndarray (n,)
        Time from the start of the recorded steady state [s].
    encoders : tuple of str
        Encoder names, e.g. ``("in.sensor", "in.clutch", "out.sensor", "out.clutch")``.
    encoder_radius : ndarray (n_enc,)
        Shaft radius at each encoder [m].
    theta : ndarray (n_enc, n)
        Absolute encoder angles in each shaft's drive sense [rad].
    dte : dict of str -> ndarray (n,)
        Dynamic TE along the transverse line of action (base radii) per side (``"sensor"``, ``"clutch"``)
        [m]: ``rb1 theta_in - rb2 theta_out`` minus its nominal rigid part; positive = output lags.
    delta : ndarray (n,)
        Mesh deflection ``delta_t`` [m].
    force : ndarray (n,)
        Transverse mesh force [N] (negative on the back flank).
    ste : ndarray (n,)
        Static TE of the excitation (with the run's effects) at the sampled mesh angles [m].
    rpm_in, torque_out, f_nom : float
        Input speed [rpm], load torque [N m], nominal mesh force ``T_out / rb2`` [N].
    radii : dict
        ``rb1, rb2, r1, r2``: base and pitch radii [m] (for :meth:`dte_at`).
    metadata : dict
        Step size, modes kept, wall time, config digest...
    """

    time: np.ndarray
    encoders: tuple[str, ...]
    encoder_radius: np.ndarray
    theta: np.ndarray
    dte: dict[str, np.ndarray]
    delta: np.ndarray
    force: np.ndarray
    ste: np.ndarray
    rpm_in: float
    torque_out: float
    f_nom: float
    radii: dict[str, float]
    metadata: dict = field(default_factory=dict)
    contact_state: np.ndarray | None = None

    # contact_state (n,) int8: 1 drive flanks loaded, 0 separated or tensile (contact loss), -1 back flanks

    # ------------------------------------------------------------- derived
    @property
    def contact_loss(self) -> bool:
        """True when the mesh force would go negative at some sample: the drive flanks separated, or the
        (linear, viscous) contact force turned tensile just before separating."""
        if self.contact_state is not None and np.any(self.contact_state <= 0):
            return True
        return bool(np.any(self.force < 0.0))

    @property
    def back_contact(self) -> bool:
        """True when the back flanks touched (deflection beyond the backlash)."""
        if self.contact_state is not None:
            return bool(np.any(self.contact_state < 0))
        return bool(np.any(self.force < 0.0))

    @property
    def dynamic_factor(self) -> float:
        """Largest mesh force over the nominal one, ``max F / (T_out / rb2)`` [-]."""
        return float(np.max(self.force) / self.f_nom)

    @property
    def sample_rate(self) -> float:
        """Sample rate of the histories [Hz]."""
        return float(1.0 / np.median(np.diff(self.time)))

    def angle(self, shaft: str, side: str = "sensor") -> np.ndarray:
        """Absolute encoder angle [rad] (drive sense) of ``shaft`` (``"in"``/``"out"``) at ``side``."""
        name = f"{shaft}.{side}"
        if name not in self.encoders:
            raise ModelError(f"DynamicRun has no encoder {name!r} (available: {', '.join(self.encoders)})")
        return self.theta[self.encoders.index(name)]

    def dte_at(self, side: str = "sensor", radius: str = "base") -> np.ndarray:
        """DTE [m] at ``side``; ``radius="pitch"`` scales to the pitch circles as the seed's eqs. 39/40 do."""
        if side not in self.dte:
            raise ModelError(f"DynamicRun has no side {side!r} (available: {', '.join(self.dte)})")
        if radius == "base":
            return self.dte[side]
        if radius == "pitch":
            return self.dte[side] * self.radii["r1"] / self.radii["rb1"]
        raise ModelError(f"radius must be 'base' or 'pitch', got {radius!r}")

    def gmf_amplitudes(self, side: str = "sensor", orders: int = 3) -> np.ndarray:
        """Zero-to-peak DTE amplitudes [m] at mesh orders 1..``orders`` (DFT at the exact frequencies)."""
        z1 = self.metadata.get("z1")
        f_mesh = z1 * self.rpm_in / 60.0
        return line_amplitudes(self.dte_at(side), 2 * np.pi * f_mesh * self.time, range(1, orders + 1))

    # ------------------------------------------------------------------ I/O
    def to_dataset(self):
        import xarray as xr

        data = {"theta": (("encoder", "time"), self.theta, {"units": "rad"}),
                "delta": ("time", self.delta, {"units": "m"}), "force": ("time", self.force, {"units": "N"}),
                "ste": ("time", self.ste, {"units": "m"}),
                "encoder_radius": ("encoder", self.encoder_radius, {"units": "m"})}
        for side, v in self.dte.items():
            data[f"dte_{side}"] = ("time", v, {"units": "m"})
        if self.contact_state is not None:
            data["contact_state"] = ("time", self.contact_state.astype(np.int8), {"units": "1"})
        return xr.Dataset(data, coords={"time": self.time, "encoder": list(self.encoders)},
                          attrs={"format": "gearrom.DynamicRun", "rpm_in": self.rpm_in, "torque_out_Nm": self.torque_out,
                                 "f_nom_N": self.f_nom, "radii_json": json.dumps(self.radii),
                                 "metadata_json": json.dumps(self.metadata, default=str)})

    def save(self, path: str | Path) -> Path:
        """Write to NetCDF."""
        return write_netcdf(self.to_dataset(), path)

    @classmethod
    def load(cls, path: str | Path) -> "DynamicRun":
        """Read a file written by :meth:`save`."""
        import xarray as xr

        with xr.open_dataset(path, engine=netcdf_engine()) as ds:
            if ds.attrs.get("format") != "gearrom.DynamicRun":
                raise ModelError(f"{path}: not a gearrom DynamicRun file")
            dte = {k[4:]: ds[k].values for k in ds.data_vars if k.startswith("dte_")}
            return cls(time=ds["time"].values, encoders=tuple(str(e) for e in ds["encoder"].values),
                       encoder_radius=ds["encoder_radius"].values, theta=ds["theta"].values, dte=dte,
                       delta=ds["delta"].values, force=ds["force"].values, ste=ds["ste"].values,
                       rpm_in=float(ds.attrs["rpm_in"]), torque_out=float(ds.attrs["torque_out_Nm"]),
                       f_nom=float(ds.attrs["f_nom_N"]), radii=json.loads(ds.attrs["radii_json"]),
                       metadata=json.loads(ds.attrs["metadata_json"]),
                       contact_state=ds["contact_state"].values if "contact_state" in ds else None)

    def plot(self):
        """DTE (sensor and clutch side) with the STE, and the mesh force."""
        from gearrom.plotting import subplots

        fig, ax = subplots(2, 1, figsize=(8, 6), sharex=True)
        t = self.time * 1e3
        for side, v in self.dte.items():
            ax[0].plot(t, (v - v.mean()) * 1e6, lw=0.8, label=f"DTE {side} side")
        ax[0].plot(t, (self.ste - self.ste.mean()) * 1e6, "k--", lw=0.8, label="STE (excitation)")
        ax[0].set_ylabel("TE - mean [um]")
        ax[0].legend(fontsize=8)
        ax[1].plot(t, self.force, lw=0.8)
        ax[1].axhline(self.f_nom, color="k", ls=":", lw=0.8)
        ax[1].set_ylabel("mesh force [N]")
        ax[1].set_xlabel("time [ms]")
        ax[0].set_title(f"{self.metadata.get('config', '')} {self.rpm_in:.0f} rpm, {self.torque_out:.0f} N m"
                        f"{', CONTACT LOSS' if self.contact_loss else ''}", fontsize=9)
        fig.tight_layout()
        return fig
