#!/usr/bin/env bash
# The README's test command: make a virtual environment, install hiddpg with every extra, test.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet -e ".[dev]"
.venv/bin/ruff check src tests benchmarks
# two workers (the machine has two cores; most test time is XLA compilation, one core each);
# --dist loadfile keeps each file's module fixtures in one worker
.venv/bin/python -m pytest -q -n 2 --dist loadfile "$@"
