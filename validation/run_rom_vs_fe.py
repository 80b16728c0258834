"""The ROM-vs-explicit-FE report files of the stored explicit FE records.

Usage: ``python validation/run_rom_vs_fe.py [--integration {loaded,full,reduced}] [--pair {spur,helical}]``:
writes validation/rom_vs_fe_<pair>[_<integration>].json/.png (``gearrom validate thesis-<pair> --rpm 1250
2000`` on the stored records of that kind, the speeds whose records exist; no suffix for "reduced").

- ``loaded`` (default): the references (loaded static start, calibrated damping) against the exudyn
  drivetrain ROM, the model they are judged with.
- ``full`` / ``reduced``: the earlier ramped-start records against the 1-DOF pair ROM, and the same with
  the exudyn drivetrain ROM in ``..._exudyn.json``; for the spur pair also
  validation/quasistatic_spur_60rpm[_full].json (the slow run against the quasi-static STE).
"""
from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

from gearrom.validation.quasistatic import quasistatic_check
from gearrom.validation.records import FE_INTEGRATIONS
from gearrom.validation.report import record_stem, validate

HERE = Path(__file__).resolve().parent
log = logging.getLogger("run_rom_vs_fe")


def main(integration: str = "loaded", pair: str = "spur") -> list[Path]:
    tag = "" if integration == "reduced" else f"_{integration}"
    rpms = [r for r in (1250, 2000) if record_stem(HERE, r, pair, integration).with_suffix(".npz").is_file()]
    written = []
    if rpms:
        for rom in (("exudyn",) if integration == "loaded" else ("pair", "exudyn")):
            rep = validate(f"thesis-{pair}", rpms, fe_dir=HERE, rom_model=rom, fe_integration=integration)
            plain = rom == "pair" or integration == "loaded"
            stem = HERE / (f"rom_vs_fe_{pair}{tag}" + ("" if plain else "_exudyn"))
            written.append(rep.save(stem.with_suffix(".json")))
            if plain:
                fig = rep.plot()
                fig.savefig(stem.with_suffix(".png"), dpi=110)
                written.append(stem.with_suffix(".png"))
            for s in rep.speeds:
                log.info("%s ROM, %g rpm: %s", rom, s.rpm_in, "pass" if s.passed else "; ".join(s.misses))
    if pair == "spur" and integration != "loaded" and record_stem(HERE, 60, integration=integration).with_suffix(".npz").is_file():
        q = quasistatic_check("thesis-spur", 60.0, fe_dir=HERE, integration=integration)
        out = HERE / f"quasistatic_spur_60rpm{tag}.json"
        out.write_text(json.dumps(q, indent=2) + "\n")
        written.append(out)
        log.info("60 rpm vs quasi-static STE: mean %+.2f %%, RMS %.2f %% (%s)", 100 * q["te_mean_um"]["rel_error"],
                 100 * q["rms_difference_rel"], "pass" if q["passed"] else "; ".join(q["misses"]))
    return written


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--integration", choices=FE_INTEGRATIONS, default="loaded")
    ap.add_argument("--pair", choices=("spur", "helical"), default="spur")
    a = ap.parse_args()
    main(a.integration, a.pair)
