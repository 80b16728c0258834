"""The diagnosis result: JSON summary, readable text, before/after plots, save/load."""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.spectral import spectrum

UM = 1e-6


@dataclass(eq=False)
class RunTraces:
    """Signals of one run for the plots (working grid, m)."""

    name: str
    rpm_in: float
    t_s: np.ndarray
    theta_in_rad: np.ndarray
    measured: np.ndarray
    model_before: np.ndarray
    model_after: np.ndarray
    fs_hz: float


@dataclass(eq=False)
class DiagnosisResult:
    """Result of :func:`gearrom.calibrate.diagnose`.

    Attributes
    ----------
    summary : dict
        The report JSON (``error_before_rms_um``, ``error_after_rms_um``, ``runs``, ``effects``,
        ``unexplained``, ``ambiguities``, ``characterization``, ``selection``, ``model``...).
    traces : list of RunTraces
    """

    summary: dict
    traces: list = field(default_factory=list)

    @property
    def effects(self) -> list[dict]:
        return self.summary["effects"]

    @property
    def unexplained(self) -> list[dict]:
        return self.summary["unexplained"]

    def to_json(self) -> str:
        return json.dumps(self.summary, indent=2, default=_default) + "\n"

    # ---------------------------------------------------------------- text
    def text(self) -> str:
        """A readable summary for engineers."""
        s = self.summary
        lines = [f"gearrom diagnose: {len(s['runs'])} run(s), model {s['model']['simulator']} "
                 f"({s['model']['config']})",
                 f"TE error rms: before {s['error_before_rms_um']:.3g} um, after {s['error_after_rms_um']:.3g} um "
                 f"(noise floor about {s['noise_rms_um']:.2g} um)", ""]
        for r in s["runs"]:
            lines.append(f"  {Path(r['measurement']).name}: {r['rpm_in']:.1f} rpm, {r['torque_out_Nm']:.0f} N m, "
                         f"{r['revs_out']:.2f} output revs: rms {r['error_before_rms_um']:.3g} -> "
                         f"{r['error_after_rms_um']:.3g} um; mesh phase {r['mesh_phase_deg']:.2f} deg "
                         f"({'estimated from the nominal GMF lines' if r['mesh_phase_estimated'] else 'not identifiable'})")
            if r.get("steady_window_s"):
                lo, hi = r["speed_range_rpm"]
                lines.append(f"    not a steady run ({lo:.4g}..{hi:.4g} rpm): compared on its steady part "
                             f"t={r['steady_window_s'][0]:.4g}..{r['steady_window_s'][1]:.4g} s")
        lines.append("")
        if not s["effects"]:
            lines.append("Effects added: none (the residual is not explained significantly by any library effect).")
        for e in s["effects"]:
            par = ", ".join(f"{k}={_fmt(v)}" for k, v in e["parameters"].items())
            tgt = f" of {e['target']}" if e["target"] else ""
            lines.append(f"Effect: {e['effect']}{tgt}: {par}; rms reduction {e['rms_reduction_um']:.3g} um")
            lines.append(f"    evidence: {e['evidence']}")
            if e.get("within_tolerance") is False:
                lines.append("    note: larger than the drawing tolerance")
        for a in s["ambiguities"]:
            if "joint_sizes_um" in a:  # a joint fit refused because its effects cancel in the TE
                sizes = ", ".join(f"{k} {v:.3g} um" for k, v in a["joint_sizes_um"].items())
                lines.append(f"Cannot tell apart: {a['chosen']} alone vs {a['alternative']} (joint sizes {sizes}; "
                             f"their TE contributions largely cancel, so the joint sizes rest on the rig model's "
                             f"shaft motions; the joint fit explains a further {100 * a['alternative_share']:.0f} % "
                             f"of the remaining residual). Extra run: {a['suggested_run']}")
                continue
            lines.append(f"Cannot tell apart: {a['chosen']} vs {a['alternative']} (explained "
                         f"{100 * a['chosen_share']:.0f} % vs {100 * a['alternative_share']:.0f} %). "
                         f"Extra run: {a['suggested_run']}")
        if s["unexplained"]:
            lines.append("Unexplained residual components:")
        for u in s["unexplained"]:
            if u["kind"] == "tooth_local_pulse":
                lines.append(f"    pulse at tooth {u['tooth_index']} of the {u['shaft']} gear, once per its revolution, "
                             f"{u['amplitude_um']:.3g} um p-p (seen in {u['runs_seen']} run(s); out of the library: "
                             "tooth damage or a local flank error)"
                             + (f" [residual misfit of {u['at_lines_of']}]" if u.get("at_lines_of") else ""))
                continue
            o = f"order {u['order']:.3f} (output order {u['order_out']:.3f})" if u["order"] is not None else "no order"
            lines.append(f"    {u['frequency_hz']:.1f} Hz, {o}, {u['kind']}, {u['amplitude_um']:.3g} um"
                         + (f" (at {u['integer_order']})" if u.get("integer_order") else "")
                         + (f" [residual misfit at the lines of {u['at_lines_of']}]" if u.get("at_lines_of") else ""))
        for w in s.get("warnings", []):
            lines.append(f"Warning: {w}")
        return "\n".join(lines) + "\n"

    # ---------------------------------------------------------------- plots
    def plot(self, run: int = 0):
        """Before/after comparison of one run: TE over time, residual order lines, spectra.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from matplotlib.figure import Figure

        tr = self.traces[run]
        r = self.summary["runs"][run]
        fig = Figure(figsize=(10, 10), layout="constrained")
        ax1, ax2, ax3 = fig.subplots(3, 1)
        ax1.plot(tr.t_s, tr.measured / UM, lw=0.7, label="measured", color="k")
        ax1.plot(tr.t_s, tr.model_before / UM, lw=0.7, label="nominal model", color="C0")
        ax1.plot(tr.t_s, tr.model_after / UM, lw=0.7, label="model + effects", color="C3", ls="--")
        ax1.set(xlabel="time [s]", ylabel="TE [um]", title=f"{Path(tr.name).name}: {tr.rpm_in:.0f} rpm, residual rms "
                f"{r['error_before_rms_um']:.3g} -> {r['error_after_rms_um']:.3g} um")
        ax1.legend(fontsize=8, loc="upper right")
        orders = r["orders"]
        x = np.arange(len(orders))
        ax2.bar(x - 0.2, [o["before_um"] for o in orders], 0.4, label="residual before")
        ax2.bar(x + 0.2, [o["after_um"] for o in orders], 0.4, label="residual after")
        ax2.set_xticks(x, [o["label"] for o in orders], rotation=60, fontsize=7)
        ax2.set_yscale("log")
        ax2.set(ylabel="amplitude [um]", title="residual order lines (joint least squares on shaft angles)",
                ylim=(max(1e-4, 0.3 * r["noise_rms_um"] * math.sqrt(2 / max(tr.t_s.size, 1))), None))
        ax2.legend(fontsize=8)
        for y, lab in ((tr.measured - tr.model_before, "residual before"), (tr.measured - tr.model_after, "residual after")):
            sp = spectrum(y - y.mean(), 1 / tr.fs_hz, "hann")
            ax3.semilogy(sp.x, sp.amplitude / UM + 1e-9, lw=0.7, label=lab)
        ax3.set(xlabel="frequency [Hz]", ylabel="amplitude [um]", title="residual spectra (Hann, coherent gain corrected)",
                xlim=(0, 0.4 * tr.fs_hz))
        ax3.legend(fontsize=8)
        return fig

    def write_report(self, directory: str | Path) -> Path:
        """Write ``diagnosis.json``, ``summary.txt`` and ``run_<i>.png`` into ``directory``."""
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        (d / "diagnosis.json").write_text(self.to_json())
        (d / "summary.txt").write_text(self.text())
        for i in range(len(self.traces)):
            self.plot(i).savefig(d / f"run_{i}.png", dpi=110)
        return d

    # ---------------------------------------------------------------- persistence
    def save(self, path: str | Path) -> Path:
        """Save as NPZ (traces) with the JSON summary inside."""
        path = Path(path)
        arrays = {"summary_json": np.array(self.to_json())}
        for i, t in enumerate(self.traces):
            for k in ("t_s", "theta_in_rad", "measured", "model_before", "model_after"):
                arrays[f"r{i}_{k}"] = getattr(t, k)
            arrays[f"r{i}_meta"] = np.array(json.dumps({"name": t.name, "rpm_in": t.rpm_in, "fs_hz": t.fs_hz}))
        np.savez_compressed(path, **arrays)
        return path

    @classmethod
    def load(cls, path: str | Path) -> DiagnosisResult:
        """Load a result written by :meth:`save`."""
        with np.load(path) as z:
            summary = json.loads(str(z["summary_json"]))
            traces = []
            i = 0
            while f"r{i}_meta" in z:
                meta = json.loads(str(z[f"r{i}_meta"]))
                traces.append(RunTraces(meta["name"], meta["rpm_in"], z[f"r{i}_t_s"], z[f"r{i}_theta_in_rad"],
                                        z[f"r{i}_measured"], z[f"r{i}_model_before"], z[f"r{i}_model_after"],
                                        meta["fs_hz"]))
                i += 1
        return cls(summary, traces)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _default(o):
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, float) and not math.isfinite(o):
        return None
    raise TypeError(f"not JSON serializable: {type(o).__name__}")
