#!/bin/sh
# The helical ROM-vs-FE references (loaded start, calibrated damping, whole bodies): the drawing micro-geometry
# (thesis-helical-drawing) at 2000 rpm first, whose GMF lines stand well above both models' discretization
# ripple (docs/validation.md), then the perfect pair at 2000 and 1250 rpm, each on both cores (the threaded loop:
# on the 3D model it is more than twice the serial speed). Each run checkpoints into validation/checkpoints/
# and resumes when started again; progress, ETA and the energy balance go to
# validation/checkpoints/helical[-<config>]_<rpm>rpm_loaded.log. Needs validation/ringdown_helical.json
# (python validation/run_ringdown.py --pair helical). Extra arguments go to run_explicit_helical.py
# (e.g. --wall-limit-h 2).
set -e
cd "$(dirname "$0")/.."
mkdir -p validation/checkpoints
run() {  # $1: config, $2: rpm, $3: record prefix
    if [ -f "validation/${3}_${2}rpm_loaded.json" ]; then
        return 0
    fi
    python validation/run_explicit_helical.py "$2" --start loaded --parallel --config "$1" $EXTRA \
        >> "validation/checkpoints/${3}_${2}rpm_loaded.log" 2>&1
}
EXTRA="$*"
run thesis-helical-drawing 2000 helical-thesis-helical-drawing
run thesis-helical 2000 helical
run thesis-helical 1250 helical
