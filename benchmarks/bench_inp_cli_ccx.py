"""Benchmark: the decks that ``gearrom stiffness --inp`` writes, solved by CalculiX as written.

For each pair (thesis-spur: plane-strain slab of C3D15 on the deck mesh; thesis-helical: the 3D
sector model of C3D10 on the 3D LTCA's mesh) the command line writes the deck at theta = 0 and the
first torque, ``ccx -i`` solves it (contact-closure step, then the moment), and ``gearrom ccx-te``
reads the static TE and the LTCA's value that the deck records. Printed and written per pair: the
ccx wall time, deck size, both static TEs and their ratio (acceptance: within 5 %).

Run: python benchmarks/bench_inp_cli_ccx.py [spur] [helical]   (needs ccx: apt-get install calculix-ccx)
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from _common import write_result

from gearrom.cli import main as gearrom

CONFIGS = {"spur": "thesis-spur", "helical": "thesis-helical"}


def main() -> None:
    which = [a for a in sys.argv[1:] if a in CONFIGS] or list(CONFIGS)
    figures = {}
    with tempfile.TemporaryDirectory() as tmp:
        for key in which:
            deck = Path(tmp) / key / f"{key}.inp"
            t0 = time.perf_counter()
            if gearrom(["stiffness", CONFIGS[key], "--positions", "4", "--inp", str(deck)]) != 0:
                raise SystemExit(f"gearrom stiffness {CONFIGS[key]} --inp failed")
            t1 = time.perf_counter()
            out = deck.with_suffix(".json")
            if gearrom(["ccx-te", str(deck), "--run", "--threads", "2", "--json", str(out)]) != 0:
                raise SystemExit(f"ccx on the {key} deck failed")
            r = json.loads(out.read_text())
            text = deck.read_text()
            r.update(config=CONFIGS[key], gearrom_stiffness_s=t1 - t0, deck_MB=len(text) / 1e6,
                     deck_nodes=text.split("*ELEMENT")[0].count("\n") - 3, within_5_percent=abs(r["ratio_to_ltca"] - 1) < 0.05)
            for k in ("deck", "dat"):
                r.pop(k)
            figures[key] = r
            print(f"{key}: ccx {r['ste_um']:.4f} um at {r['torque_out_Nm']:.2f} N m, LTCA {r['ltca_ste_um']:.4f} um, "
                  f"ratio {r['ratio_to_ltca']:.4f}; ccx {r['ccx_wall_s']:.0f} s wall", flush=True)
    write_result("bench_inp_cli_ccx" + ("" if len(which) == len(CONFIGS) else "_" + "_".join(which)), figures)


if __name__ == "__main__":
    main()
