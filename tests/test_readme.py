"""The README's commands and Python snippet, read from README.md and run as written (in a
temporary directory, with this environment's ``hiddpg``): each exits 0 and does what the
README says. A command too slow to run here is listed in ``SKIPPED`` with the reason; a
README command that is in neither ``RUN`` nor ``SKIPPED`` fails the test."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
HIDDPG = Path(sys.executable).parent / "hiddpg"
#: a command that runs longer than this on 2 cores belongs in SKIPPED
TIMEOUT_S = 240
SHELL_LANGUAGES = {"bash", "sh", "shell", "console"}
OTHER_LANGUAGES = {"python", "bibtex"}


@dataclass(frozen=True)
class Outcome:
    """What a command leaves behind: its stdout matches ``prints``, the ``files`` exist
    (relative to the working directory) and each run directory in ``runs`` has finished
    ``episodes`` episodes of ``preset`` on ``seeds``."""

    prints: str = ""
    files: tuple[str, ...] = ()
    runs: tuple[tuple[str, str, int, tuple[int, ...]], ...] = ()
    after: tuple[str, ...] = ()
    """Commands whose output this one reads (run first, in this session's directory)."""
    slow: bool = False


QUICK_SEEDS = (0, 1, 2, 3, 4)
DDPG = ("hiddpg train ddpg PuckObstacle --episodes 100 --set agent.actor_lr=3e-4 "
        "--name ddpg-PuckObstacle")
HI_DDPG = "hiddpg train hi-ddpg PuckObstacle --episodes 100 --name hi-ddpg-PuckObstacle"

RUN: dict[str, Outcome] = {
    "hiddpg envs list": Outcome(prints=r"hiddpg/PuckObstacle-v0"),
    "hiddpg envs demo ArmObstacle --out arm.gif": Outcome(prints=r"wrote arm\.gif",
                                                          files=("arm.gif",)),
    "hiddpg ilqr PuckTrajectory2 --gif ilqr.gif": Outcome(prints=r"wrote ilqr\.gif",
                                                          files=("ilqr.gif",)),
    # no --preset, no --seeds: the quick preset on seeds 0-4
    DDPG: Outcome(prints=r"over 5 seeds", slow=True,
                  runs=(("runs/ddpg-PuckObstacle", "quick", 100, QUICK_SEEDS),)),
    HI_DDPG: Outcome(prints=r"over 5 seeds", slow=True,
                     runs=(("runs/hi-ddpg-PuckObstacle", "quick", 100, QUICK_SEEDS),)),
    "hiddpg plot runs/ddpg-PuckObstacle runs/hi-ddpg-PuckObstacle --out compare":
        Outcome(prints=r"wrote compare\.png", files=("compare.png", "compare.pdf"),
                after=(DDPG, HI_DDPG), slow=True),
    "hiddpg eval runs/hi-ddpg-PuckObstacle --seed 3 --gif policy.gif":
        Outcome(prints=r"wrote policy\.gif", files=("policy.gif",), after=(HI_DDPG,), slow=True),
    "hiddpg train --resume runs/ddpg-PuckObstacle --episodes 300":
        Outcome(prints=r"over 5 seeds", after=(DDPG,), slow=True,
                runs=(("runs/ddpg-PuckObstacle", "quick", 300, QUICK_SEEDS),)),
    "hiddpg sweep --algos ddpg --tasks PuckObstacle --seeds 0-4 --presets quick "
    "--grid agent.tau=0.01,0.005 --out sweeps/tau --dry-run":
        Outcome(prints=r"new .*agent\.tau=0\.01.*\n.*new .*agent\.tau=0\.005"),
}

SKIPPED: dict[str, str] = {
    "bash scripts/main.sh": "makes .venv with pip (network) and trains; this test runs in "
                            "the environment it would make",
    "bash scripts/test.sh": "runs the whole test suite, this file included",
    "hiddpg train hi-ddpg PuckTrajectory2 --preset paper --name paper-hi-ddpg-PuckTrajectory2":
        "the paper preset: 15 seeds x 3000 episodes, hours on 2 cores",
    "hiddpg train --resume runs/paper-hi-ddpg-PuckTrajectory2":
        "continues the paper-preset run above (hours)",
    "hiddpg reproduce all --scale quick": "trains 12 runs, about 20 minutes on 2 cores",
    "hiddpg report results/quick/quick": "reads the artifacts of `hiddpg reproduce all --scale "
                                         "quick` above (tests/experiments/test_artifacts.py "
                                         "runs it on a tiny reproduction)",
    "hiddpg sweep --algos ddpg --tasks PuckObstacle --seeds 0-4 --presets quick "
    "--grid agent.tau=0.01,0.005 --out sweeps/tau":
        "trains 2 runs of the full quick budget (5 seeds x 1500 episodes), minutes",
    "hiddpg train ddpg InvertedPendulum-v5 --episodes 200":
        "MuJoCo, 5 seeds x 200 episodes on the host loop, minutes",
    "hiddpg train hi-ddpg gym:Reacher-v5 --goal 8:-0.3:0.3 --goal 9:-0.3:0.3 --seeds 0-4 "
    "--episodes 300 --name reacher":
        "MuJoCo, 5 seeds x 300 episodes on the host loop, minutes (tests/host/"
        "test_host_mujoco.py trains, resumes and evaluates it on a tiny budget)",
    "hiddpg train --resume runs/reacher --episodes 600": "continues the Reacher run above",
    "hiddpg eval runs/reacher --gif reacher.gif":
        "reads the Reacher run above; MuJoCo frames need an OpenGL context (tests/host/"
        "test_host_cli.py draws a Gymnasium env's own frames)",
}

#: per Python snippet of the README, in order: what its output matches
PYTHON_PRINTS = [r"rewards: \[(\s*-?[\d.e+-]+){8}\s*\]\s+"
                 r"final evaluation return per seed: \[(\s*-?[\d.e+-]+){4}\s*\]"]


def fenced_blocks(text: str) -> list[tuple[str, str]]:
    """``(language, body)`` of every fenced code block."""
    return re.findall(r"^```(\w*)\n(.*?)^```", text, flags=re.S | re.M)


def commands(body: str) -> list[str]:
    """The commands of a shell block, one per line (``\\`` continues a line), comments
    dropped and spaces normalised."""
    out = []
    for line in body.replace("\\\n", " ").splitlines():
        words = shlex.split(line, comments=True)
        if words:
            out.append(" ".join(words))
    return out


def readme_commands() -> list[str]:
    return [c for lang, body in fenced_blocks(README.read_text()) if lang in SHELL_LANGUAGES
            for c in commands(body)]


def readme_snippets() -> list[str]:
    return [body for lang, body in fenced_blocks(README.read_text()) if lang == "python"]


class Session:
    """One working directory for the README's commands: each runs at most once, after the
    commands it reads the output of."""

    def __init__(self, cwd: Path):
        self.cwd = cwd
        self.done: dict[str, subprocess.CompletedProcess] = {}

    def run(self, command: str) -> subprocess.CompletedProcess:
        if command not in self.done:
            for earlier in RUN[command].after:
                result = self.run(earlier)
                assert result.returncode == 0, f"{earlier!r} failed:\n{result.stderr}"
            words = shlex.split(command)
            assert words[0] == "hiddpg", command
            self.done[command] = subprocess.run(
                [str(HIDDPG), *words[1:]], cwd=self.cwd, capture_output=True, text=True,
                timeout=TIMEOUT_S)
        return self.done[command]


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    return Session(tmp_path_factory.mktemp("readme"))


def test_every_readme_command_is_run_or_skipped_with_a_reason():
    found = readme_commands()
    assert found, "no shell block found in README.md"
    unknown = [c for c in found if c not in RUN and c not in SKIPPED]
    assert not unknown, f"README commands this test neither runs nor skips: {unknown}"
    stale = [c for c in [*RUN, *SKIPPED] if c not in found]
    assert not stale, f"listed here but no longer in README.md: {stale}"
    assert not set(RUN) & set(SKIPPED)
    assert len(readme_snippets()) == len(PYTHON_PRINTS)


def test_every_code_block_has_a_known_language():
    languages = {lang for lang, _ in fenced_blocks(README.read_text())}
    assert languages <= SHELL_LANGUAGES | OTHER_LANGUAGES, languages


def test_the_parser_reads_continued_lines_and_drops_comments():
    body = "# a comment\nhiddpg a --b 'x y'   # why\nhiddpg c \\\n   --d 1\n\n"
    assert commands(body) == ["hiddpg a --b x y", "hiddpg c --d 1"]


def _marks(command: str):
    return [pytest.mark.slow] if RUN[command].slow else []


@pytest.mark.parametrize("command", [pytest.param(c, marks=_marks(c), id=c[7:60])
                                     for c in RUN])
def test_readme_command(command, session):
    if command not in readme_commands():
        pytest.fail(f"{command!r} is no longer in README.md; remove it from RUN")
    result = session.run(command)
    assert result.returncode == 0, f"{command}\nstdout:\n{result.stdout}\nstderr:\n{result.stderr}"
    outcome = RUN[command]
    assert re.search(outcome.prints, result.stdout), result.stdout
    for name in outcome.files:
        path = session.cwd / name
        assert path.is_file() and path.stat().st_size > 0, name
    for run_dir, preset, episodes, seeds in outcome.runs:
        written = json.loads((session.cwd / run_dir / "config.json").read_text())
        progress = json.loads((session.cwd / run_dir / "progress.json").read_text())
        assert written["config"]["preset"] == preset
        assert tuple(written["seeds"]) == seeds
        assert progress["status"] == "finished" and progress["episodes"] == episodes


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(PYTHON_PRINTS)))
def test_readme_python_snippet(index, tmp_path):
    snippet = readme_snippets()[index]
    result = subprocess.run([sys.executable, "-c", snippet], cwd=tmp_path, capture_output=True,
                            text=True, timeout=TIMEOUT_S)
    assert result.returncode == 0, result.stderr
    assert re.search(PYTHON_PRINTS[index], result.stdout), result.stdout
