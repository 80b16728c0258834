"""The TE result object: signal, spectra, averages, summary, plot, save/load."""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Literal

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.signal.filters import FilterSettings
from gearrom.signal.spectra import Peak, Spectrum, amplitude_spectrum, annotate_gmf, order_spectrum, synchronous_average
from gearrom.signal.settings import GearMeshInfo, TESettings

UM = 1e-6


@dataclass(frozen=True, eq=False)
class TEResult:
    """Transmission error of one run, on a uniform time grid.

    Attributes
    ----------
    t_s : ndarray
        Time, s.
    te_m : ndarray
        Processed TE (detrended, filtered), m, positive when the output lags.
    theta_in_rad, theta_out_rad : ndarray
        Shaft angles from the first edge, rad.
    fs_hz : float
        Sampling rate, Hz.
    mesh : GearMeshInfo
    settings : TESettings
    rpm_in : float
        Measured input speed, rpm: the plateau speed (the speed the record spends most time at;
        the mean speed of a steady run).
    rpm_in_nominal : float
        ``rpm_in`` of the metadata.
    repairs : tuple of dict
        Repairs made while reading (kind, channel, where, t_s, count, detail).
    source, description : str
    torque_out_Nm : float or None
    n_edges : dict
    info : dict
        Reader and processing reports: decoding and trimming of sampled records, time window,
        timing resolution, estimated encoder scale.
    """

    t_s: np.ndarray
    te_m: np.ndarray
    theta_in_rad: np.ndarray
    theta_out_rad: np.ndarray
    fs_hz: float
    mesh: GearMeshInfo
    settings: TESettings
    rpm_in: float
    rpm_in_nominal: float
    repairs: tuple = ()
    source: str = ""
    description: str = ""
    torque_out_Nm: float | None = None
    n_edges: dict = dataclasses.field(default_factory=dict)
    info: dict = dataclasses.field(default_factory=dict)

    # -- derived quantities -------------------------------------------------------------------
    @property
    def gmf_hz(self) -> float:
        """Gear mesh frequency z1 * n_in / 60 at the measured (plateau) speed, Hz (seed eq. 4)."""
        return self.mesh.z1 * self.rpm_in / 60.0

    @cached_property
    def speed(self) -> dict:
        """Speed profile and steadiness (:func:`gearrom.signal.runup.steadiness`)."""
        from gearrom.signal.runup import steadiness

        return steadiness(self.t_s, self.theta_in_rad)

    def order_map(self, revs_per_block: int = 1) -> dict:
        """Order tracking: GMF harmonics and shaft orders 1-2 per block of input revolutions
        (:func:`gearrom.signal.runup.order_map`)."""
        from gearrom.signal.runup import order_map

        orders = [1.0, 2.0, self.mesh.ratio, 2 * self.mesh.ratio] + \
            [h * self.mesh.z1 for h in range(1, self.settings.n_harmonics + 1)]
        return order_map(self.te_m, self.theta_in_rad, self.t_s, orders, revs_per_block=revs_per_block,
                         samples_per_rev=min(self.samples_per_rev, 4096))

    @property
    def revs_in(self) -> float:
        """Input revolutions in the record."""
        return float(self.theta_in_rad[-1] - self.theta_in_rad[0]) / (2 * math.pi)

    @property
    def samples_per_rev(self) -> int:
        """Angle-grid points per input revolution for order spectra and averages."""
        if self.settings.samples_per_rev:
            return int(self.settings.samples_per_rev)
        per_rev = self.fs_hz / (self.rpm_in / 60.0)
        return int(2 ** math.ceil(math.log2(max(256.0, per_rev))))

    def order_spectrum(self, whole: Literal["auto", "hunting", "rev"] = "auto", window: str = "rect") -> Spectrum:
        """Order spectrum of the TE (orders of the input shaft).

        ``whole="hunting"`` transforms whole hunting-tooth periods (all mesh and shaft orders on bins),
        ``"rev"`` whole input revolutions, ``"auto"`` the former when the record holds one period.
        """
        hunt = self.mesh.hunting_revs_in
        if whole == "auto":
            whole = "hunting" if self.revs_in + 1e-9 >= hunt else "rev"
        if whole == "hunting":
            n = int(math.floor(self.revs_in / hunt + 1e-9)) * hunt
            if n < 1:
                raise MeasurementError(f"{self.source}: record holds {self.revs_in:.2f} input revolutions, "
                                       f"fewer than one hunting-tooth period ({hunt})")
        else:
            n = None
        return order_spectrum(self.te_m, self.theta_in_rad, self.samples_per_rev, n_revs=n, window=window)

    @cached_property
    def _orders(self) -> Spectrum:
        return self.order_spectrum()

    def spectrum(self, window: str | None = None) -> Spectrum:
        """Amplitude spectrum of the TE in Hz (window default: ``settings.window``)."""
        return amplitude_spectrum(self.te_m, self.fs_hz, window or self.settings.window)

    def tsa(self, period: Literal["input", "output", "hunting"] = "input",
            samples_per_period: int | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """Time-synchronous average of the TE per input revolution, output revolution or hunting period.

        Returns
        -------
        angle_rad, te_m, n_periods
            Angle within the period (of the input shaft for "input"/"hunting", of the output shaft
            for "output"), averaged TE in m, number of periods averaged.
        """
        spr = self.samples_per_rev
        if period == "input":
            return synchronous_average(self.te_m, self.theta_in_rad, 2 * math.pi, samples_per_period or spr)
        if period == "output":
            return synchronous_average(self.te_m, self.theta_out_rad, 2 * math.pi, samples_per_period or spr)
        if period == "hunting":
            hunt = self.mesh.hunting_revs_in
            return synchronous_average(self.te_m, self.theta_in_rad, 2 * math.pi * hunt,
                                       samples_per_period or spr * hunt)
        raise ValueError(f"period={period!r} must be 'input', 'output' or 'hunting'")

    def gmf_lines(self) -> list[tuple[float, float]]:
        """``(amplitude_m, phase_rad)`` of GMF harmonics 1..n_harmonics from the order spectrum."""
        sp = self._orders
        return [sp.at(h * self.mesh.z1)[:2] for h in range(1, self.settings.n_harmonics + 1)]

    def peaks(self) -> list[Peak]:
        """GMF harmonics and shaft-order sidebands, annotated in the order spectrum (orders of the input)."""
        return annotate_gmf(self._orders, self.mesh.z1, 1.0, self.mesh.ratio,
                            n_harmonics=self.settings.n_harmonics, n_sidebands=self.settings.n_sidebands)

    @property
    def te_rms_m(self) -> float:
        """Rms of the processed TE, m."""
        return float(np.sqrt(np.mean((self.te_m - self.te_m.mean()) ** 2)))

    @property
    def te_ptp_m(self) -> float:
        """Peak-to-peak of the processed TE, m."""
        return float(np.ptp(self.te_m))

    def to_json_dict(self) -> dict:
        """Summary for the CLI: speeds, TE rms/ptp, GMF, harmonic amplitudes (um), sidebands, repairs."""
        lines = self.gmf_lines()
        sp = self._orders
        return {
            "source": self.source,
            "description": self.description,
            "te_on": self.settings.te_on,
            "gear": dataclasses.asdict(self.mesh),
            "rpm_in": self.rpm_in,
            "rpm_in_nominal": self.rpm_in_nominal,
            "torque_out_Nm": self.torque_out_Nm,
            "duration_s": float(self.t_s[-1] - self.t_s[0]),
            "fs_hz": self.fs_hz,
            "revs_in": self.revs_in,
            "te_rms_um": self.te_rms_m / UM,
            "te_ptp_um": self.te_ptp_m / UM,
            "gmf_hz": self.gmf_hz,
            "gmf_amplitude_um": [a / UM for a, _ in lines],
            "gmf_phase_deg": [math.degrees(p) for _, p in lines],
            "order_spectrum": {"revs": sp.n / self.samples_per_rev, "resolution_orders": sp.resolution,
                               "window": sp.window},
            "peaks": [{"label": p.label, "order": p.x, "freq_hz": p.x * self.rpm_in / 60.0,
                       "amplitude_um": p.amplitude / UM} for p in self.peaks()],
            "filters": dataclasses.asdict(self.settings.filters),
            "n_edges": self.n_edges,
            "repairs": list(self.repairs),
            "speed": self.speed,
            "order_tracking": None if self.speed["steady"] else self.order_map(),
            **{k: v for k, v in self.info.items() if k in ("quadrature", "trimmed", "window_s", "encoder_scale",
                                                           "timing_resolution_s")},
        }

    # -- plot -------------------------------------------------------------------------------------
    def plot(self, fmax_hz: float | None = None):
        """TE over the whole record with the speed profile, amplitude spectrum with GMF marks, TSA per
        input/output rev, and for a non-steady record the order tracks (GMF harmonics vs time).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from matplotlib.figure import Figure

        steady = self.speed["steady"]
        fig = Figure(figsize=(10, 9 if steady else 12), layout="constrained")
        axes = fig.subplots(3 if steady else 4, 1)
        ax1, ax2, ax3 = axes[:3]
        step = max(1, self.t_s.size // 20000)
        ax1.plot(self.t_s[::step], self.te_m[::step] / UM, lw=0.6)
        ax1.set(xlabel="time [s]", ylabel=f"TE ({self.settings.te_on}) [um]",
                title=f"{Path(self.source).name}: {self.rpm_in:.0f} rpm"
                      f"{'' if steady else ' plateau (not steady)'}, rms {self.te_rms_m / UM:.3g} um, "
                      f"ptp {self.te_ptp_m / UM:.3g} um")
        axs = ax1.twinx()
        prof = self.speed["profile"]
        axs.plot(prof["t_s"], prof["rpm_in"], color="C3", lw=0.8)
        axs.set_ylabel("input speed [rpm]", color="C3")
        sp = self.spectrum()
        fmax = fmax_hz or min(self.fs_hz / 2, 4.5 * self.gmf_hz)
        m = sp.x <= fmax
        ax2.plot(sp.x[m], sp.amplitude[m] / UM, lw=0.8)
        for p in self.peaks():
            f = p.x * self.rpm_in / 60.0
            if f > fmax:
                continue
            if "+" not in p.label and "-" not in p.label:
                ax2.axvline(f, color="C3", lw=0.6, ls="--")
                ax2.annotate(p.label, (f, p.amplitude / UM), fontsize=8, color="C3")
            elif p.label.split("GMF")[1][1] == "1":  # first sidebands of each shaft
                ax2.axvline(f, color="0.6", lw=0.5, ls=":")
        ax2.set(xlabel="frequency [Hz]", ylabel="amplitude [um]", title=f"amplitude spectrum ({sp.window}, coherent-"
                "gain corrected): GMF harmonics red, +-1 shaft-order sidebands grey")
        for kind, color in (("input", "C0"), ("output", "C1")):
            try:
                ang, avg, n = self.tsa(kind)
            except MeasurementError:
                continue
            ax3.plot(np.degrees(ang), avg / UM, color=color, lw=0.8, label=f"per {kind} rev ({n} revs)")
        ax3.set(xlabel="shaft angle [deg]", ylabel="TSA of TE [um]", title="time-synchronous averages")
        ax3.legend(loc="upper right", fontsize=8)
        if not steady:
            om = self.order_map()
            amp = np.array(om["amplitude_m"])
            for j, order in enumerate(om["orders"]):
                if order >= self.mesh.z1 and amp.size:
                    axes[3].plot(om["t_s"], amp[:, j] / UM, marker=".", lw=0.8, label=f"order {order:g}")
            axes[3].set(xlabel="time [s]", ylabel="amplitude [um]", title="order tracking (per input revolution)")
            axes[3].legend(loc="upper right", fontsize=8)
        return fig

    # -- persistence --------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Save as one ``.npz`` file: the arrays plus the metadata as a JSON string (``meta_json``)."""
        path = Path(path)
        meta = {"gearrom": "TEResult/1", "fs_hz": self.fs_hz, "mesh": dataclasses.asdict(self.mesh),
                "settings": dataclasses.asdict(self.settings), "rpm_in": self.rpm_in,
                "rpm_in_nominal": self.rpm_in_nominal, "repairs": list(self.repairs), "source": self.source,
                "description": self.description, "torque_out_Nm": self.torque_out_Nm, "n_edges": self.n_edges,
                "info": self.info}
        with open(path, "wb") as fh:  # a file handle keeps numpy from appending ".npz"
            np.savez_compressed(fh, t_s=self.t_s, te_m=self.te_m, theta_in_rad=self.theta_in_rad,
                                theta_out_rad=self.theta_out_rad, meta_json=np.array(json.dumps(meta)))
        return path

    @classmethod
    def load(cls, path: str | Path) -> TEResult:
        """Load a result written by :meth:`save`."""
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in ("t_s", "te_m", "theta_in_rad", "theta_out_rad")}
                meta = json.loads(str(z["meta_json"]))
        except (OSError, KeyError, ValueError) as exc:
            raise MeasurementError(f"{path}: not a readable gearrom TEResult file ({exc})") from None
        if meta.get("gearrom") != "TEResult/1":
            raise MeasurementError(f"{path}: not a gearrom TEResult file")
        st = meta["settings"]
        st["filters"] = FilterSettings(**st["filters"])
        return cls(**arrays, fs_hz=float(meta["fs_hz"]), mesh=GearMeshInfo(**meta["mesh"]), settings=TESettings(**st),
                   rpm_in=float(meta["rpm_in"]), rpm_in_nominal=float(meta["rpm_in_nominal"]),
                   repairs=tuple(meta["repairs"]), source=meta["source"], description=meta["description"],
                   torque_out_Nm=meta["torque_out_Nm"], n_edges=meta["n_edges"], info=meta.get("info", {}))
