#!/usr/bin/env bash
# The README's test command: make a virtual environment, install hiddpg with every extra, test.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet -e ".[dev]"
.venv/bin/ruff check src tests benchmarks
.venv/bin/python -m pytest -q "$@"
