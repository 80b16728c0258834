"""The README's figures from the README's main job: the DTE waterfall of ``out/sweep`` and the Campbell
diagram of ``out/campbell.json``, drawn by the same plot methods as the main job's PNGs
(:meth:`gearrom.rom.sweep.SweepResult.plot`, :meth:`gearrom.rom.modal.CampbellResult.plot`) at a lower
resolution, into ``docs/images/`` (small PNGs).

Run from the repository root after the main job (the setup command at the top of README.md)::

    python benchmarks/make_readme_figures.py [--sweep out/sweep/sweep.nc] [--campbell out/campbell.json] [--out docs/images]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gearrom.rom.modal import CampbellResult
from gearrom.rom.sweep import SweepResult

DPI = 80


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
    for name, fig in (("waterfall.png", SweepResult.load(args.sweep).plot()),
                      ("campbell.png", CampbellResult.load(args.campbell).plot())):
        path = args.out / name
        fig.savefig(path, dpi=DPI)
        sys.stdout.write(f"{path}: {path.stat().st_size / 1024:.0f} kB\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
