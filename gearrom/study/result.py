"""Result of a tolerance study: per-sample DTE and GMF amplitudes vs speed, percentiles, sensitivity."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import ModelError
from gearrom.excitation.table import netcdf_engine

PERCENTILES = (5.0, 50.0, 95.0)


@dataclass(eq=False)
class ToleranceResult:
    """All samples of a tolerance study.

    Attributes
    ----------
    rpm : ndarray (n_rpm,)
        Input speeds [rpm].
    index : ndarray (n,)
        Sample indices.
    dte_ptp_um, dte_rms_um : ndarray (n, n_rpm)
        DTE peak-to-peak and RMS, sensor side [um].
    gmf_um : ndarray (n, n_rpm, 3)
        DTE amplitudes at GMF orders 1-3 [um].
    features : ndarray (n, n_features)
        Sampled inputs [um] named by ``feature_names``.
    cpu_s : ndarray (n,)
        CPU time of each sample's task [s].
    """

    config: str
    rpm: np.ndarray
    index: np.ndarray
    dte_ptp_um: np.ndarray
    dte_rms_um: np.ndarray
    gmf_um: np.ndarray
    features: np.ndarray
    feature_names: tuple[str, ...]
    cpu_s: np.ndarray
    metadata: dict = field(default_factory=dict)

    def percentiles(self, q=PERCENTILES) -> dict[str, np.ndarray]:
        """P5/P50/P95 (or ``q``) over the samples per speed: ``{"dte_ptp_um": (len(q), n_rpm), ..., "gmf_um": (len(q), n_rpm, 3)}``."""
        return {k: np.percentile(getattr(self, k), q, axis=0) for k in ("dte_ptp_um", "dte_rms_um", "gmf_um")}

    def sensitivity(self, metric: str = "gmf1") -> list[tuple[str, float]]:
        """Inputs ranked by |Spearman rank correlation| with a scalar output per sample.

        ``metric``: ``"gmf1"``/``"gmf2"``/``"gmf3"`` (mean over speeds of the GMF amplitude) or
        ``"dte_rms"``/``"dte_ptp"`` (mean over speeds). Inputs that do not vary get 0. Rank correlation
        is used because the responses are monotone but not linear in the inputs (contact loss,
        resonances); it needs no model and is cheap for thousands of samples.
        """
        from scipy.stats import spearmanr

        y = self._metric(metric)
        out = []
        for j, name in enumerate(self.feature_names):
            x = self.features[:, j]
            if np.ptp(x) == 0 or np.ptp(y) == 0 or len(y) < 3:
                out.append((name, 0.0))
                continue
            out.append((name, float(abs(spearmanr(x, y).statistic))))
        return sorted(out, key=lambda t: -t[1])

    def _metric(self, metric: str) -> np.ndarray:
        if metric in ("gmf1", "gmf2", "gmf3"):
            return self.gmf_um[:, :, int(metric[-1]) - 1].mean(axis=1)
        if metric in ("dte_rms", "dte_ptp"):
            return getattr(self, f"{metric}_um").mean(axis=1)
        raise ModelError(f"metric must be gmf1, gmf2, gmf3, dte_rms or dte_ptp, got {metric!r}")

    def summary_json(self) -> dict:
        p = self.percentiles()
        return {"config": self.config, "samples": int(len(self.index)), "rpm": self.rpm.tolist(),
                "percentiles": list(PERCENTILES),
                "dte_ptp_um": p["dte_ptp_um"].tolist(), "dte_rms_um": p["dte_rms_um"].tolist(),
                "gmf1_um": p["gmf_um"][..., 0].tolist(), "gmf2_um": p["gmf_um"][..., 1].tolist(),
                "gmf3_um": p["gmf_um"][..., 2].tolist(),
                "sensitivity_gmf1": self.sensitivity("gmf1"), "sensitivity_dte_rms": self.sensitivity("dte_rms"),
                "cpu_s_per_sample_mean": float(np.mean(self.cpu_s)), "source": self.metadata.get("source", "")}

    def to_dataset(self):
        import xarray as xr

        p = self.percentiles()
        ds = xr.Dataset(
            {"dte_ptp_um": (("sample", "rpm"), self.dte_ptp_um), "dte_rms_um": (("sample", "rpm"), self.dte_rms_um),
             "gmf_um": (("sample", "rpm", "gmf_order"), self.gmf_um), "features": (("sample", "feature"), self.features),
             "cpu_s": ("sample", self.cpu_s),
             "dte_ptp_um_pct": (("percentile", "rpm"), p["dte_ptp_um"]),
             "dte_rms_um_pct": (("percentile", "rpm"), p["dte_rms_um"]),
             "gmf_um_pct": (("percentile", "rpm", "gmf_order"), p["gmf_um"])},
            coords={"sample": self.index, "rpm": ("rpm", self.rpm, {"units": "rpm"}), "gmf_order": [1, 2, 3],
                    "feature": list(self.feature_names), "percentile": list(PERCENTILES)},
            attrs={"format": "gearrom.ToleranceResult", "config": self.config,
                   "metadata_json": json.dumps(self.metadata, default=str)})
        return ds

    def save(self, path: str | Path) -> Path:
        """Write to NetCDF atomically; returns the path."""
        from gearrom.rom.sweep import write_netcdf_atomic

        return write_netcdf_atomic(self.to_dataset(), path)

    @classmethod
    def load(cls, path: str | Path) -> "ToleranceResult":
        import xarray as xr

        with xr.open_dataset(path, engine=netcdf_engine()) as ds:
            if ds.attrs.get("format") != "gearrom.ToleranceResult":
                raise ModelError(f"{path}: not a gearrom tolerance study file")
            return cls(str(ds.attrs["config"]), ds["rpm"].values, ds["sample"].values, ds["dte_ptp_um"].values,
                       ds["dte_rms_um"].values, ds["gmf_um"].values, ds["features"].values,
                       tuple(str(f) for f in ds["feature"].values), ds["cpu_s"].values,
                       json.loads(ds.attrs["metadata_json"]))

    def plot(self):
        """P5-P95 bands and P50 of DTE RMS and GMF 1-3 vs speed, and the sensitivity ranking (GMF 1)."""
        from gearrom.plotting import subplots

        p = self.percentiles()
        fig, axes = subplots(1, 3, figsize=(14, 4.5), gridspec_kw={"width_ratios": [1, 1, 0.8]})
        ax = axes[0]
        ax.fill_between(self.rpm, p["dte_rms_um"][0], p["dte_rms_um"][2], alpha=0.3, label="DTE RMS P5-P95")
        ax.plot(self.rpm, p["dte_rms_um"][1], label="DTE RMS P50")
        ax.fill_between(self.rpm, p["dte_ptp_um"][0], p["dte_ptp_um"][2], alpha=0.2, label="DTE p-p P5-P95")
        ax.plot(self.rpm, p["dte_ptp_um"][1], label="DTE p-p P50")
        ax.set_xlabel("input speed [rpm]")
        ax.set_ylabel("DTE, sensor side [um]")
        ax.legend(fontsize=7)
        ax = axes[1]
        for m in range(3):
            line, = ax.plot(self.rpm, p["gmf_um"][1, :, m], label=f"GMF x{m + 1} P50")
            ax.fill_between(self.rpm, p["gmf_um"][0, :, m], p["gmf_um"][2, :, m], color=line.get_color(), alpha=0.25)
        ax.set_yscale("log")
        ax.set_xlabel("input speed [rpm]")
        ax.set_ylabel("GMF amplitude [um] (band: P5-P95)")
        ax.legend(fontsize=7)
        ax = axes[2]
        rank = self.sensitivity("gmf1")[::-1]
        ax.barh([r[0] for r in rank], [r[1] for r in rank])
        ax.set_xlabel("|Spearman rho| with mean GMF x1")
        ax.tick_params(axis="y", labelsize=7)
        fig.suptitle(f"{self.config}: tolerance scatter, {len(self.index)} samples ({self.metadata.get('source', '')})",
                     fontsize=9)
        fig.tight_layout()
        return fig
