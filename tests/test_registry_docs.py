"""docs/usage.md, "HI-DDPG on your own environment": its environment block is
tests/user_env/slider.py, and its Python and shell blocks run in fresh interpreters."""

from __future__ import annotations

import csv
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
SECTION = "## HI-DDPG on your own environment"


def blocks() -> list[tuple[str, str]]:
    """The section's fenced code blocks as ``(language, code)``."""
    text = (ROOT / "docs" / "usage.md").read_text()
    section = text[text.index(SECTION):]
    end = re.search(r"^## ", section[len(SECTION):], re.M)
    section = section[: len(SECTION) + end.start()] if end else section
    return re.findall(r"^```(\w+)\n(.*?)^```", section, re.M | re.S)


def run(argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(cwd)}
    done = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"{argv}: {done.stderr[-3000:]}"
    return done


def test_the_environment_block_is_the_tested_user_environment():
    language, code = blocks()[0]
    assert language == "python"
    assert code == (ROOT / "tests" / "user_env" / "slider.py").read_text()


@pytest.mark.slow
def test_the_python_and_shell_blocks_run(tmp_path):
    found = blocks()
    package = tmp_path / "mypackage"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "slider.py").write_text(found[0][1])
    python = [code for language, code in found[1:] if language == "python"]
    shell = [line for language, code in found if language == "bash"
             for line in code.splitlines() if line.startswith("hiddpg ")]
    assert len(python) == 1 and [line.split()[1] for line in shell] == ["train", "ilqr"]
    (tmp_path / "example.py").write_text(python[0])
    printed = run([sys.executable, "example.py"], tmp_path).stdout
    assert printed.startswith("[") and "nan" not in printed  # the evaluation returns
    for line in shell:
        run([sys.executable, "-m", "hiddpg.cli", *shlex.split(line)[1:]], tmp_path)
    (run_dir,) = (tmp_path / "runs").iterdir()
    with open(run_dir / "metrics.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert run_dir.name.startswith("h-ddpg-Slider-") and len(rows) == 2 * 20
