#!/usr/bin/env bash
# Does training with the burger's firmware wheel limits (env.wheel_limit) help a policy
# on a burger that has them? Trains configs/paper_no_obstacles.yaml without and with
# the limit, then tests every policy in jaxnav (the run's own settings) and in MuJoCo
# with the limit (python -m jaxnav.sim2sim --wheel-limit), and the policies trained
# without it also in MuJoCo without it (what the limit costs them);
# scripts/publish_realism.py OUT --campaign wheel_limit writes the table.
#
#   scripts/sim2sim_wheel_limit.sh OUT [SEEDS] [EPISODES]
#
# OUT/plain/ and OUT/wheel_limit/ hold the runs, OUT/<arm>/sim2sim/sim2sim.csv the
# tests (OUT/plain_unlimited/ the MuJoCo test without the limit). SEEDS (default 4)
# per strategy, EPISODES (default 3) MuJoCo episodes per policy and maze. A finished
# step is skipped when rerun. Each MuJoCo test runs beside the next step. OUT/commit
# names the code that ran.
set -euo pipefail
cd "$(dirname "$0")/.."

OUT=${1:?usage: scripts/sim2sim_wheel_limit.sh OUT [SEEDS] [EPISODES]}
SEEDS=${2:-4}
EPISODES=${3:-3}
CONFIG=configs/paper_no_obstacles.yaml
mkdir -p "$OUT"
git rev-parse --short HEAD > "$OUT/commit"
seed_list=$(seq -s ' ' 0 $((SEEDS - 1)))
pending=()

train() {  # train NAME [OVERRIDE]
    local run=$OUT/$1
    shift
    if [ -f "$run/summary.json" ]; then
        return
    elif [ -d "$run" ]; then
        python -m jaxnav.train --resume "$run" --quiet
    else
        python -m jaxnav.train "$CONFIG" "seeds=$SEEDS" "$@" --out "$run" --quiet
    fi
}

test_in_mujoco() {  # test_in_mujoco ARM RUN [--wheel-limit], in the background
    local csv=$OUT/$1/sim2sim/sim2sim.csv
    [ -f "$csv" ] && return
    mkdir -p "$(dirname "$csv")"
    # shellcheck disable=SC2086
    python -m jaxnav.sim2sim "$2" --seeds $seed_list --episodes "$EPISODES" --out "$csv" \
        "${@:3}" > "$OUT/$1/sim2sim.log" 2>&1 &
    pending+=($!)
}

train plain
test_in_mujoco plain "$OUT/plain" --wheel-limit
train wheel_limit env.wheel_limit=true
test_in_mujoco wheel_limit "$OUT/wheel_limit" --wheel-limit
test_in_mujoco plain_unlimited "$OUT/plain"
for pid in "${pending[@]}"; do
    wait "$pid"
done
echo "done: python scripts/publish_realism.py $OUT --campaign wheel_limit"
