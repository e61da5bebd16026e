#!/usr/bin/env bash
# The 16-seed run of docs/worlds.md: EBE and epsilon-greedy trained on grid4 (a new
# 4 x 4 grid maze every episode, train layouts), then tested on the train and the test
# layouts with the navigation metrics. Writes docs/worlds/grid4/{results.csv,tables.md}.
#   bash scripts/worlds_run.sh [RUN_DIR] [SEEDS]
set -euo pipefail
cd "$(dirname "$0")/.."
run=${1:-runs/worlds-grid4}
seeds=${2:-16}
python -m jaxnav train grid4 --out "$run" --overwrite --yes "seeds=$seeds" \
  "run.test_mazes=[]" run.test_episodes=10
python -m jaxnav evaluate "$run"
mkdir -p docs/worlds/grid4
cp "$run/eval/results.csv" "$run/eval/tables.md" docs/worlds/grid4/
echo "wrote docs/worlds/grid4/results.csv and tables.md"
python scripts/publish_worlds_run.py
