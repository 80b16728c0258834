#!/bin/sh
# The helical ROM-vs-FE references (loaded start, calibrated damping, whole bodies) at 2000 and then 1250 rpm,
# each on both cores (the threaded loop: on the 3D model it is more than twice the serial speed). Each run
# checkpoints into validation/checkpoints/ and resumes when started again; progress, ETA and the energy
# balance go to validation/checkpoints/helical_<rpm>rpm_loaded.log. Needs validation/ringdown_helical.json
# (python validation/run_ringdown.py --pair helical). Extra arguments go to run_explicit_helical.py
# (e.g. --wall-limit-h 2).
set -e
cd "$(dirname "$0")/.."
mkdir -p validation/checkpoints
for rpm in 2000 1250; do
    if [ -f "validation/helical_${rpm}rpm_loaded.json" ]; then
        continue
    fi
    python validation/run_explicit_helical.py "$rpm" --start loaded --parallel "$@" \
        >> "validation/checkpoints/helical_${rpm}rpm_loaded.log" 2>&1
done
