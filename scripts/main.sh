#!/usr/bin/env bash
# The README's main job: install hiddpg, then a short run on the embedded defaults.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet -e ".[dev]"
mkdir -p out
.venv/bin/hiddpg envs list
.venv/bin/hiddpg envs demo PuckTrajectory2 --out out/PuckTrajectory2.gif
.venv/bin/hiddpg envs demo ArmObstacle --out out/ArmObstacle.gif
