#!/usr/bin/env bash
# The README's test command: make a virtual environment, install hiddpg with every extra, test.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet -e ".[dev]"
.venv/bin/ruff check src tests benchmarks
# JAX's persistent compilation cache, empty at the start of every run and removed after it:
# the tests that train in a fresh process (resumes after a kill, the CLI, the README) compile
# the same programs again, and read them back from here instead
JAX_COMPILATION_CACHE_DIR="$(mktemp -d)"
export JAX_COMPILATION_CACHE_DIR JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS=0.5
trap 'rm -rf "$JAX_COMPILATION_CACHE_DIR"' EXIT
# a lowered XLA level, without its expensive passes and (tests/conftest.py) with its older CPU
# fusion emitters: most tests compile far more than they run; the tests that train long or
# compare recorded numbers are marked xla_optimized and run at the default level.
# JAX_DISABLE_MOST_OPTIMIZATIONS=0 runs every test at XLA's default level
export JAX_DISABLE_MOST_OPTIMIZATIONS="${JAX_DISABLE_MOST_OPTIMIZATIONS:-1}"
# the tests marked heavy (long end-to-end checks: a Ray worker killed, CPU devices, faults at
# random moments, two trainings racing for a writer lock, three golden runs, a 3000-episode
# learning run, the hindsight learning run, a Huber-schedule equivalence run, h-DDPG through
# the CLI in a fresh process) only with --heavy as the first argument; without it, what CI runs
marks=(-m "not heavy")
if [[ "${1:-}" == "--heavy" ]]; then marks=(); shift; fi
# two workers (the machine has two cores; most test time is XLA compilation, one core each);
# --dist loadfile keeps each file's module fixtures in one worker
.venv/bin/python -m pytest -q -n 2 --dist loadfile ${marks[@]+"${marks[@]}"} "$@"
