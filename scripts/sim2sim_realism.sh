#!/usr/bin/env bash
# Which of jaxnav's realism options narrow the sim-to-sim gap (docs/sim2sim.md)?
# Trains the no-obstacle paper config once per option, then tests every policy in
# jaxnav and in MuJoCo (python -m jaxnav.sim2sim); scripts/publish_realism.py turns
# the per-seed CSVs into the table.
#
#   scripts/sim2sim_realism.sh OUT [SEEDS] [EPISODES]
#
# OUT/<option>/ holds each run and OUT/<option>/sim2sim/sim2sim.csv its test;
# OUT/plain/ is the config unchanged. SEEDS (default 16) per strategy, EPISODES
# (default 5) MuJoCo episodes per policy and maze. Set PLAIN=RUN_DIR to test an
# existing run of configs/paper_no_obstacles.yaml as the plain arm (its first SEEDS
# seeds) instead of training one. A finished step is skipped when rerun, so an
# interrupted campaign resumes. Each MuJoCo test runs beside the next training: it
# uses one core, training uses both. OUT/commit names the code that ran.
set -euo pipefail
cd "$(dirname "$0")/.."

OUT=${1:?usage: scripts/sim2sim_realism.sh OUT [SEEDS] [EPISODES]}
SEEDS=${2:-16}
EPISODES=${3:-5}
mkdir -p "$OUT"
git rev-parse --short HEAD > "$OUT/commit"  # the code that trains and tests

OPTIONS=(
    "plain"
    "env.action_delay=true"
    "env.maze_scale=[0.75,1.5]"
    "env.random_start=true"
    "env.odom_noise=[0.02,0.02]"
    "env.beam_dropout=0.05"
    "env.lidar_noise_std=0.02"
)

seed_list=$(seq -s ' ' 0 $((SEEDS - 1)))
pending=()

for opt in "${OPTIONS[@]}"; do
    name=${opt%%=*}
    name=${name#env.}
    run=$OUT/$name
    if [ "$opt" = plain ] && [ -n "${PLAIN:-}" ]; then
        run=$PLAIN
    elif [ ! -f "$run/summary.json" ]; then
        extra=()
        [ "$opt" = plain ] || extra=("$opt")
        if [ -d "$run" ]; then
            python -m jaxnav.train --resume "$run" --quiet
        else
            python -m jaxnav.train configs/paper_no_obstacles.yaml "seeds=$SEEDS" "${extra[@]}" \
                --out "$run" --quiet
        fi
    fi
    csv=$OUT/$name/sim2sim/sim2sim.csv
    if [ ! -f "$csv" ]; then
        mkdir -p "$(dirname "$csv")"
        # shellcheck disable=SC2086
        python -m jaxnav.sim2sim "$run" --seeds $seed_list --episodes "$EPISODES" --out "$csv" \
            > "$OUT/$name/sim2sim.log" 2>&1 &
        pending+=($!)
    fi
done
for pid in "${pending[@]}"; do
    wait "$pid"
done
echo "done: python scripts/publish_realism.py $OUT"
