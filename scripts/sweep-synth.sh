#!/usr/bin/env bash
# Confusion sweep of the diagnosis on the second record generator (tactile_ident::synth): four
# seeds (or SEEDS="…": try seeds the design was not tuned on) × clean records at three rates and
# each effect at two strengths and rates (PAIRS=1: fourteen pairs of effects in one record
# instead, right when both are named). Prints one line per record (OK or XX, expected <-
# verdict) and the count of right verdicts.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p tactile-ident --example try
T=target/release/examples/try
right=0 total=0
run() {
    local expected=$1; shift
    local verdict
    verdict=$($T synth "$@" | grep -E '^verdict' | sed 's/verdict: //; s/found //; s/[;:].*//')
    total=$((total + 1))
    if [ "$verdict" = "$expected" ]; then right=$((right + 1)); echo "OK $expected  [$*]"; else echo "XX $expected <- $verdict  [$*]"; fi
}
# Two effects at once (PAIRS=1): right when both are named, in either order.
run_pair() {
    local a=$1 b=$2; shift 2
    local verdict
    verdict=$($T synth "$@" | grep -E '^verdict' | sed 's/verdict: //; s/found //; s/[;:].*//')
    total=$((total + 1))
    if [ "$verdict" = "$a, then $b" ] || [ "$verdict" = "$b, then $a" ]; then
        right=$((right + 1)); echo "OK $a + $b  [$*]"
    else
        echo "XX $a + $b <- $verdict  [$*]"
    fi
}
for seed in ${SEEDS:-21 22 23 24}; do
    if [ -n "${PAIRS:-}" ]; then
        run_pair hysteresis baseline_drift $seed 200 180 hysteresis=0.05 drift=0.04
        run_pair hysteresis baseline_drift $seed 100 240 hysteresis=0.08 drift=0.06
        run_pair load_dependent_stiffness baseline_drift $seed 200 180 stiffening=0.5 drift=0.04
        run_pair time_delay hysteresis $seed 200 180 delay=3 hysteresis=0.05
        run_pair periodic_interference load_dependent_stiffness $seed 1000 120 interference=0.01@123 stiffening=0.5
        run_pair slow_relaxation hysteresis $seed 200 300 slow=0.3@60 hysteresis=0.05
        run_pair sensitivity_drift periodic_interference $seed 100 240 sag=0.1 interference=0.01@17.3
        run_pair time_delay load_dependent_stiffness $seed 100 180 delay=3 stiffening=0.5
        run_pair time_delay load_dependent_stiffness $seed 200 240 delay=8 stiffening=0.3
        run_pair sensitivity_drift baseline_drift $seed 40 600 sag=0.1 drift=0.03
        run_pair sensitivity_drift baseline_drift $seed 100 300 sag=0.15 drift=0.05
        run_pair sensitivity_drift baseline_drift $seed 40 1140 gaincycle=0.03@600 zerocycle=0.005@600
        run_pair time_delay hysteresis $seed 100 240 delay=5 hysteresis=0.08
        run_pair periodic_interference load_dependent_stiffness $seed 200 180 interference=0.005@17.3 stiffening=0.8
        continue
    fi
    for rate in 50 200 1000; do run none $seed $rate 180; done
    run load_dependent_stiffness $seed 200 180 stiffening=0.3
    run load_dependent_stiffness $seed 100 240 stiffening=0.8
    run hysteresis $seed 200 180 hysteresis=0.03
    run hysteresis $seed 100 240 hysteresis=0.08
    run baseline_drift $seed 200 180 drift=0.02
    run baseline_drift $seed 50 300 drift=0.06
    run periodic_interference $seed 200 180 interference=0.005@17.3
    run periodic_interference $seed 1000 120 interference=0.01@123
    run time_delay $seed 200 180 delay=2
    run time_delay $seed 100 240 delay=5
    run slow_relaxation $seed 200 300 slow=0.2@60
    run slow_relaxation $seed 100 240 slow=0.4@30
    run sensitivity_drift $seed 200 180 sag=0.05
    run sensitivity_drift $seed 100 240 sag=0.15
done
echo "$right of $total right"
