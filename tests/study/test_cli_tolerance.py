"""``gearrom tolerance``: a small study end to end (embedded LocalCluster, 1 worker) and option checks.

Reference for the outputs: the per-sample files on disk, counted independently of the summary.
"""
import json

import pytest

from gearrom.cli import main


def test_cli_tolerance_small(tmp_path):
    out = tmp_path / "tol"
    argv = ["tolerance", "thesis-rig", "--samples", "3", "--out", str(out), "--rpm", "3000,4000", "--revs", "0.25",
            "--micro", "none", "--workers", "1", "--no-progress"]
    assert main(argv) == 0
    s = json.loads((out / "tolerance_summary.json").read_text())
    assert s["samples"] == 3 and len(s["gmf1_um"]) == 3 and len(s["gmf1_um"][0]) == 2
    assert len(list((out / "samples").glob("sample_*.nc"))) == 3
    assert (out / "tolerance.png").stat().st_size > 1000
    assert [n for n, _ in s["sensitivity_gmf1"]][:1] != []


@pytest.mark.parametrize("extra,opt", [(["--samples", "0"], "--samples"), (["--grade", "12"], "--grade"),
                                       (["--rpm", "5:1:1"], "--rpm"), (["--revs", "0.001"], "--revs"),
                                       (["--scheduler", " "], "--scheduler")])
def test_cli_tolerance_bad_options(tmp_path, capsys, extra, opt):
    args = {"--samples": "2", "--out": str(tmp_path)}
    for i in range(0, len(extra), 2):
        args[extra[i]] = extra[i + 1]
    assert main(["tolerance", "thesis-rig", *[x for kv in args.items() for x in kv]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and opt in err[0]
