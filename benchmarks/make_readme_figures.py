"""The README's figures from the README's main job: the DTE waterfall of ``out/sweep`` and the Campbell
diagram of ``out/campbell.json``, written to ``docs/images/`` (small PNGs).

Run from the repository root after the main job (the setup command at the top of README.md)::

    python benchmarks/make_readme_figures.py [--sweep out/sweep/sweep.nc] [--campbell out/campbell.json] [--out docs/images]

The waterfall's colour scale spans the data (three decades below its largest line); the Campbell diagram
draws the modes with at least 1 % mesh strain energy thick and coloured by that share, the others thin.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

from gearrom.rom.modal import CampbellResult  # noqa: E402
from gearrom.rom.sweep import SweepResult  # noqa: E402

SHARE_THRESHOLD = 0.01
DPI = 80


def waterfall(res: SweepResult, path: Path) -> Path:
    """DTE spectra (sensor side) over frequency and speed, GMF and shaft orders labelled."""
    z1, z2 = res.z
    orders, amp = res.spectrum("dte_sensor")
    a = amp * 1e6
    vmax = a.max()
    vmin = max(vmax * 1e-3, np.percentile(a[a > 0], 50))
    fmax = 3.4 * z1 * res.rpm.max() / 60
    fig, ax = plt.subplots(figsize=(8, 5))
    pc = ax.pcolormesh(orders[None, :] * res.rpm[:, None] / 60, np.repeat(res.rpm[:, None], len(orders), axis=1),
                       np.clip(a, vmin, None), shading="nearest", norm=LogNorm(vmin=vmin, vmax=vmax))
    fig.colorbar(pc, ax=ax, label="DTE amplitude, sensor side [um]")
    for m, c in zip((1, 2, 3), ("w", "lightgrey", "silver")):
        ax.plot(m * z1 * res.rpm / 60, res.rpm, "--", color=c, lw=0.8, label=f"GMF x{m} (order {m * z1})")
    for o, lab, c in ((1.0, "input shaft (order 1)", "orange"), (z1 / z2, f"output shaft (order {z1}/{z2})", "red")):
        ax.plot(o * res.rpm / 60, res.rpm, ":", color=c, lw=1.2, label=lab)
    ax.legend(fontsize=7, loc="lower right", facecolor="0.85")
    torque = res.metadata.get("torque_out_Nm")
    ax.set(xlim=(0, fmax), xlabel="frequency [Hz]", ylabel="input speed [rpm]",
           title=f"{res.config}: DTE waterfall ({len(res.rpm)} speeds"
                 + (f", {torque:g} N m)" if torque else ")"))
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def campbell_plot(c: CampbellResult, path: Path) -> Path:
    """Campbell diagram: modes that matter (mesh share >= 1 %) thick and coloured, crossings marked."""
    gmf = [v for k, v in c.orders.items() if k.startswith("GMF")]
    fmax = 1.05 * max(gmf) * c.rpm[-1] / 60
    fig, ax = plt.subplots(figsize=(8, 5.5))
    cmap = plt.get_cmap("plasma_r")
    share_max = float(c.mesh_share.max())
    for j in range(c.freqs.shape[1]):
        if c.freqs[:, j].min() > fmax:
            continue
        s = float(c.mesh_share[:, j].max())
        if s >= SHARE_THRESHOLD:
            ax.plot(c.rpm, c.freqs[:, j], "-", lw=2.5, color=cmap(0.15 + 0.85 * s / share_max))
            ax.annotate(f"mode {j + 1}", (c.rpm[0], c.freqs[0, j]), fontsize=7, xytext=(3, 3), textcoords="offset points")
        else:
            ax.plot(c.rpm, c.freqs[:, j], "-", lw=0.6, color="0.7")
    styles = {"GMF1": ("C0", "--"), "GMF2": ("C1", "--"), "GMF3": ("C2", "--"), "input shaft": ("k", ":"),
              "output shaft": ("C3", ":")}
    for name, o in c.orders.items():
        col, ls = styles.get(name, ("k", "-"))
        ax.plot(c.rpm, o * c.rpm / 60, ls, color=col, lw=1.2, label=f"{name} (order {o:.3g})")
    for x in c.crossings:
        if x["mesh_energy_share"] >= SHARE_THRESHOLD and x["frequency_Hz"] <= fmax:
            ax.plot(x["rpm_in"], x["frequency_Hz"], "kx", ms=6, mew=1.5)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0, share_max))
    fig.colorbar(sm, ax=ax, label="mesh strain-energy share [-] (thick lines)")
    ax.set(ylim=(0, fmax), xlim=(c.rpm[0], c.rpm[-1]), xlabel="input speed [rpm]", ylabel="frequency [Hz]",
           title=f"{c.config}: Campbell diagram (thick: >= 1 % mesh energy; x: their crossings)")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=5)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def load_campbell(path: Path) -> CampbellResult:
    """The Campbell result of ``path``: a file written by ``CampbellResult.save``, or the JSON of
    ``gearrom campbell --json`` (modes at the lowest speed and the crossings only), whose frequencies over
    speed are recomputed here from its config and speed grid, as the command computed them."""
    import json

    from gearrom.errors import ModelError

    try:
        return CampbellResult.load(path)
    except ModelError:
        from gearrom.rom.modal import campbell
        from gearrom.rom.rig import build_rig

        d = json.loads(path.read_text())
        return campbell(build_rig(d["config"]), np.asarray(d["rpm_in"], float))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sweep", type=Path, default=Path("out/sweep/sweep.nc"), help="sweep.nc of the main job")
    p.add_argument("--campbell", type=Path, default=Path("out/campbell.json"), help="campbell JSON of the main job")
    p.add_argument("--out", type=Path, default=Path("docs/images"), help="folder of the PNGs")
    args = p.parse_args(argv)
    for f in (args.sweep, args.campbell):
        if not f.is_file():
            sys.stderr.write(f"{f} is missing: run the README's setup command (the main job) first\n")
            return 2
    args.out.mkdir(parents=True, exist_ok=True)
    for path in (waterfall(SweepResult.load(args.sweep), args.out / "waterfall.png"),
                 campbell_plot(load_campbell(args.campbell), args.out / "campbell.png")):
        sys.stdout.write(f"{path}: {path.stat().st_size / 1024:.0f} kB\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
