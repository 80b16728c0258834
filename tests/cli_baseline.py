"""Command-line outputs for the bundled configs, saved from the code before a restructuring and compared after.

``COMMANDS`` lists the runs: every bundled config's geometry, the TE of the bundled edge recording, the
Campbell data and a two-speed sweep of ``thesis-rig``, a diagnosis of the bundled recording, and the
stored-reference validation of ``thesis-spur``. ``python tests/cli_baseline.py DIR`` runs them with the
``gearrom`` it imports and writes ``DIR/<name>.json`` plus ``DIR/baseline.json`` (the commit it ran on);
run it with ``PYTHONPATH`` on a checkout of the baseline commit. ``tests/test_cli_outputs.py`` runs the
same commands with the current code and compares.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "gearrom" / "data" / "examples" / "measurements"

#: name -> (argv with {out} for the output path, where the JSON is: "stdout" or a path relative to {out})
COMMANDS: dict[str, tuple[list[str], str]] = {
    **{f"geometry_{c}": (["geometry", c, "--json"], "stdout")
       for c in ("thesis-spur", "thesis-helical", "thesis-rig")},
    "te_1250rpm": (["te", str(EXAMPLES / "sim_1250rpm_edges.json"), "--json", "{out}/te.json"], "te.json"),
    "campbell_rig": (["campbell", "thesis-rig", "--json", "{out}/campbell.json"], "campbell.json"),
    "sweep_rig": (["sweep", "thesis-rig", "--rpm", "1000,2000", "--out", "{out}/sweep", "--no-progress"],
                  "sweep/summary.json"),
    "diagnose_1250rpm": (["diagnose", "thesis-rig", str(EXAMPLES / "sim_1250rpm_edges.json"),
                          "--effects", "eccentricity,encoder_eccentricity,pitch_error", "--json", "{out}/diag.json"],
                         "diag.json"),
    "validate_spur": (["validate", "thesis-spur", "--rpm", "2000", "--json", "{out}/validate.json"], "validate.json"),
}

#: keys whose values depend on the machine, the time or the checkout (not compared)
VOLATILE = {"wall_time_s", "wall_s", "cpu_s", "elapsed_s", "created", "timestamp", "machine", "host", "version", "python",
            "gearrom_version", "path", "config_path", "out", "file", "files", "measurement", "source_file",
            "cache_dir", "cache_path", "date", "git_commit", "speeds_dir", "extends"}

#: keys the outputs gained after the baseline was written (not in the baseline, so not compared):
#: ``gearrom campbell --json`` carries the whole diagram, so that ``CampbellResult.load`` reads it
ADDED = {"freqs_Hz", "mesh_share"}


def run(name: str, out: Path) -> dict:
    """Run command ``name`` with the imported gearrom, return its JSON output."""
    from gearrom.cli import main

    argv, where = COMMANDS[name]
    out.mkdir(parents=True, exist_ok=True)
    argv = [a.replace("{out}", str(out)) for a in argv]
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(argv)
    if code not in (0, 1, None):  # validate exits 1 when a speed misses a tolerance; the JSON is still written
        raise RuntimeError(f"gearrom {' '.join(argv)} exited {code}")
    return json.loads(buf.getvalue() if where == "stdout" else (out / where).read_text())


def differences(a, b, path: str = "", rtol: float = 1e-5, atol: float = 1e-3) -> list[str]:
    """Where two JSON values differ beyond numerical noise (floats within ``rtol``/``atol``; file paths by
    their file name, as the checkout's location differs)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k in VOLATILE:
                continue
            if k in a and k not in b and k in ADDED:
                continue
            if k not in a or k not in b:
                out.append(f"{path}.{k}: only in {'new' if k not in a else 'baseline'}")
                continue
            out += differences(a[k], b[k], f"{path}.{k}", rtol, atol)
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} vs {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{path}[{i}]", rtol, atol)]
    if isinstance(a, str) and isinstance(b, str) and "/" in a and "/" in b:  # file paths: the checkout differs
        return [] if Path(a).name == Path(b).name else [f"{path}: {a!r} vs {b!r}"]
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
        return [] if a == b else [f"{path}: {a!r} vs {b!r}"]
    if math.isnan(a) and math.isnan(b):
        return []
    return [] if abs(a - b) <= atol + rtol * max(abs(a), abs(b)) else [f"{path}: {a!r} vs {b!r}"]


def main(argv: list[str]) -> int:
    import tempfile

    dest = Path(argv[0])
    dest.mkdir(parents=True, exist_ok=True)
    import gearrom

    root = Path(gearrom.__file__).resolve().parents[1]
    commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    names = argv[1:] or list(COMMANDS)
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            (dest / f"{name}.json").write_text(json.dumps(run(name, Path(tmp) / name), indent=1, sort_keys=True))
    (dest / "baseline.json").write_text(json.dumps({"commit": commit}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
