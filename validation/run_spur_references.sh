#!/bin/sh
# The spur ROM-vs-FE references (loaded start, calibrated damping) at 2000 and 1250 rpm, side by side,
# one core each (the serial loop: the threaded loop synchronizes at every element colour, which two
# jobs on two cores turn into waiting). Each run checkpoints into validation/checkpoints/ and resumes
# when started again; progress, ETA and the energy balance go to
# validation/checkpoints/spur_<rpm>rpm_loaded.log. Needs validation/ringdown_spur.json
# (python validation/run_ringdown.py).
set -e
cd "$(dirname "$0")/.."
mkdir -p validation/checkpoints
for rpm in 2000 1250; do
    # a stored record of the current reference mesh (ringdown_spur.json) is done; another mesh's is redone
    if [ -f "validation/spur_${rpm}rpm_loaded.json" ] && python - "$rpm" <<'PY'
import json, sys
rec = json.load(open(f"validation/spur_{sys.argv[1]}rpm_loaded.json"))
mesh = json.load(open("validation/ringdown_spur.json"))["mesh"]
same = (abs(rec["body_size_mm"] - mesh["body_size_m"] * 1e3) < 1e-9 and abs(rec["outline_size_mm"] - mesh["outline_size_m"] * 1e3) < 1e-9
        and rec.get("periodic_mesh", False) == mesh.get("periodic", False))
sys.exit(0 if same else 1)
PY
    then
        continue
    fi
    python validation/run_explicit_spur.py "$rpm" --start loaded --integration full "$@" \
        >> "validation/checkpoints/spur_${rpm}rpm_loaded.log" 2>&1 &
done
wait
