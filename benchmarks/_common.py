"""Shared helpers for benchmark scripts: machine description and result files.

Every benchmark prints its figures and writes them, with the machine it ran on, to
``benchmarks/results/<name>.json`` (committed).
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import resource
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"


def machine_info() -> dict:
    """Describe the machine: CPU model, core count, memory, Python and numpy versions."""
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem_gb = None
    try:
        mem_gb = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 1e9
    except (ValueError, OSError):
        pass
    import numpy

    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "memory_GB": round(mem_gb, 1) if mem_gb else None,
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "numpy": numpy.__version__,
        "date_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "load_average_1_5_15min_at_write": [round(x, 2) for x in os.getloadavg()],
    }


def peak_memory_MB() -> float:
    """Peak resident set size of this process and its finished children, in MB."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(own, kids) / 1024.0


def write_result(name: str, figures: dict) -> Path:
    """Write ``figures`` plus machine info to ``benchmarks/results/<name>.json`` and echo it."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    payload = {"benchmark": name, "machine": machine_info(), "figures": figures}
    path.write_text(json.dumps(payload, indent=2, default=float) + "\n")
    sys.stdout.write(json.dumps(figures, indent=2, default=float) + "\n")
    sys.stdout.write(f"written {path}\n")
    return path
