#!/usr/bin/env bash
# Draws the pictures of docs/worlds.md: each built-in stage and each maze family.
#   bash scripts/publish_worlds.sh
set -euo pipefail
cd "$(dirname "$0")/.."
out=docs/worlds
mkdir -p "$out"
for maze in stage3 stage4 stage3_humble stage4_humble; do
  python -m jaxnav render "$maze" --out "$out/$maze.png" --overwrite
done
for family in grid4 cylinders rooms; do
  python -m jaxnav render "$family" --seed 3 --out "$out/$family.png" --overwrite
done
python -m jaxnav render grid4 --samples 8 --out "$out/grid4_samples.png" --overwrite
