"""The bearing support as a diagnosed rig parameter, on data gearrom did not make.

Case (as ``tests/calibrate/test_diagnose_independent.py``): the independent simulator ``tests/datasim``
records the helical thesis-rig pair with a 22 um output-gear runout at 120 deg and input tooth 5 standing
32 um proud, at 1250, 2000 and 1600 rpm. datasim's rig is purely torsional: its gears sit on rigid
supports. The diagnosis sees 1250 and 2000 rpm; the written config is then the nominal model of the
1600 rpm record (the forecast).

Three settings are compared in one run: the default rig parameters without ``k_support``, the default
(``k_support``, the three bearing stiffnesses scaled together over 0.1-100, re-tuned with the accepted
kinematic errors through the linearized drivetrain), and the default with ``k_support`` profiled by
full re-simulation of every scale (:data:`gearrom.calibrate.simulator.ROM_TUNABLE`). For each: the
effects found, the error before and after, the written config's error on the diagnosed records
(``reproduced``) and on the 1600 rpm record (the forecast), and the wall time of the diagnosis.

Usage::

    python benchmarks/bench_diagnose_support.py
"""
from __future__ import annotations

import logging
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_result  # noqa: E402

RPMS = (1250.0, 2000.0, 1600.0)


def main() -> int:
    import datasim

    from gearrom.calibrate import FitSettings, diagnose
    from gearrom.calibrate.writeconfig import write_config

    logging.basicConfig(level=logging.WARNING)
    warnings.simplefilter("ignore")
    log = logging.getLogger("bench")
    case = datasim.Case("ecc_out+proud_in", (datasim.Eccentricity("output_gear", 22.0, 120.0),
                                             datasim.PitchError("input_gear", 5, -32.0)))
    import dataclasses

    from gearrom.calibrate import simulator

    default = FitSettings().rig_parameters
    linear_support = simulator.ROM_TUNABLE["k_support"]
    variants = {"without_k_support": (tuple(p for p in default if p != "k_support"), linear_support),
                "default": (default, linear_support),
                "k_support_full_profile": (default, dataclasses.replace(linear_support, linear=False))}
    out = {"case": {"runout_output_gear_um": 22.0, "runout_phase_deg": 120.0, "proud_input_tooth": 5,
                    "proud_deviation_um": -32.0},
           "diagnosed_rpm": list(RPMS[:2]), "forecast_rpm": RPMS[2], "variants": {}}
    with tempfile.TemporaryDirectory() as tmp:
        files = datasim.make_case_files(Path(tmp), case, rpms=RPMS)
        for name, (params, support) in variants.items():
            simulator.ROM_TUNABLE["k_support"] = support
            t0 = time.perf_counter()
            s = diagnose("thesis-rig", files[:2], settings=FitSettings(rig_parameters=params)).summary
            wall = time.perf_counter() - t0
            cfg = write_config(s, "thesis-rig", Path(tmp) / f"{name}.toml")
            simulator.ROM_TUNABLE["k_support"] = linear_support
            seen = diagnose(str(cfg), files[:2], settings=FitSettings(max_effects=0)).summary
            fc = diagnose(str(cfg), files[2:], settings=FitSettings(max_effects=0)).summary
            out["variants"][name] = {
                "rig_parameters": list(params), "diagnosis_wall_s": round(wall, 1),
                "effects": [{"effect": e["effect"], "target": e["target"],
                             **{k: (round(v, 3) if isinstance(v, float) else v) for k, v in e["parameters"].items()
                                if isinstance(v, (int, float, str))}} for e in s["effects"]],
                "error_before_rms_um": round(s["error_before_rms_um"], 3),
                "error_after_rms_um": round(s["error_after_rms_um"], 3),
                "reproduced_error_rms_um": round(seen["error_before_rms_um"], 3),
                "forecast_error_rms_um": round(fc["error_before_rms_um"], 3),
                "forecast_over_after": round(fc["error_before_rms_um"] / s["error_after_rms_um"], 3)}
            log.warning("%s: %s", name, out["variants"][name])
    v = out["variants"]
    out["wall_ratio_default_over_without_k_support"] = round(v["default"]["diagnosis_wall_s"]
                                                             / v["without_k_support"]["diagnosis_wall_s"], 2)
    out["wall_ratio_full_profile_over_default"] = round(v["k_support_full_profile"]["diagnosis_wall_s"]
                                                        / v["default"]["diagnosis_wall_s"], 2)
    write_result("bench_diagnose_support", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
