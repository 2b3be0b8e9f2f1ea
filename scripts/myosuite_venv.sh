#!/usr/bin/env bash
# Creates .venv-myo: hiddpg with the `myosuite` and `plot` extras, plus Stable-Baselines3 on CPU
# torch (the baselines of benchmarks/gym_demo.py), in a virtualenv of its own.
#
# MyoSuite pins gymnasium below the release our main environment (.venv) uses, so it cannot
# live there. Usage, from anywhere:
#
#     bash scripts/myosuite_venv.sh            # creates or updates .venv-myo, then checks it
#     VENV=/tmp/myo PYTHON=python3.11 bash scripts/myosuite_venv.sh
#
# The check at the end makes myoElbowPose1D6MRandom-v0 and steps it headless (MUJOCO_GL=egl
# unless set). Under a busy machine prefix it with `nice -n 15`.
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
VENV=${VENV:-.venv-myo}
start=$(date +%s)

[ -x "$VENV/bin/python" ] || "$PYTHON" -m venv "$VENV"
PIP=("$VENV/bin/pip" install --quiet)
"${PIP[@]}" --upgrade pip
# CPU torch for SB3: the local CPU build where pip finds one, else PyPI's default build
"${PIP[@]}" "torch==2.13.0+cpu" 2>/dev/null || "${PIP[@]}" "torch>=2.8"
"${PIP[@]}" -e ".[myosuite,plot]" "stable-baselines3>=2.3" "pytest>=8"

export MUJOCO_GL=${MUJOCO_GL:-egl}
"$VENV/bin/python" - <<'EOF'
import importlib.metadata as md

import myosuite  # noqa: F401  (registers the myo* ids with gymnasium)
import gymnasium as gym
import numpy as np

env = gym.make("myoElbowPose1D6MRandom-v0")
obs, _ = env.reset(seed=0)
total = 0.0
for _ in range(20):
    obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
    total += float(reward)
assert np.all(np.isfinite(obs)) and np.isfinite(total)
print(f"myoElbowPose1D6MRandom-v0: observation {env.observation_space.shape}, action "
      f"{env.action_space.shape}, horizon {env.spec.max_episode_steps}, 20 steps ok")
print("versions:", {p: md.version(p) for p in
                    ("myosuite", "gymnasium", "mujoco", "stable-baselines3", "torch", "jax")})
env.close()
EOF
echo "$VENV ready in $(( $(date +%s) - start )) s"
