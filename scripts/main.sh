#!/usr/bin/env bash
# The README's main job: install hiddpg, train HI-DDPG on PuckTrajectory1 (quick preset, one
# seed, about a minute after installation), replay the learned policy into a GIF, print the result.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet -e ".[dev]"
name="quick-hi-ddpg-$(date +%Y%m%d-%H%M%S)"
.venv/bin/hiddpg train hi-ddpg hiddpg/PuckTrajectory1-v0 --preset quick --seeds 0 \
  --out runs --name "$name"
.venv/bin/hiddpg eval "runs/$name" --gif "runs/$name/policy.gif"
echo "GIF of the learned policy: runs/$name/policy.gif"
