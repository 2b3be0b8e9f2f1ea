"""The ``hiddpg`` command: a thin dispatcher over lazily imported sub-commands.

Each command is a ``"module:function"`` whose function takes the remaining ``argv`` (a list of
strings) and returns an exit code (or ``None`` for 0). Modules are imported only when their
command runs, so ``hiddpg --help`` is fast and optional dependencies stay optional.

To add a command, add one line to :data:`COMMANDS`.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence

#: name -> ("module:function", one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "envs": ("hiddpg.commands.envs:main", "list the environments, write a demo GIF of one"),
    "train": ("hiddpg.commands.train:main", "train an algorithm on a task, many seeds at once"),
    "eval": ("hiddpg.commands.eval:main", "replay a run's learned policies, optionally as a GIF"),
    "sweep": ("hiddpg.commands.sweep:main",
              "train a grid of algorithms x tasks x seeds x overrides, locally or on Ray"),
    "ilqr": ("hiddpg.commands.ilqr:main", "solve a task with iLQR, the standard controller"),
    "reproduce": ("hiddpg.commands.reproduce:main", "reproduce the paper's Figs. 3-8 and a report"),
    "report": ("hiddpg.commands.report:main",
               "redraw the figures and report of `reproduce` from its artifacts, no training"),
    "claims": ("hiddpg.commands.report:claims",
               "which of the paper's claims the outputs of `reproduce` bear out, no training"),
    "plot": ("hiddpg.commands.plot:main", "compare runs: return curves and t-test tiles"),
}


def _usage() -> str:
    width = max(len(name) for name in COMMANDS)
    lines = [
        "usage: hiddpg [--help] [--version] COMMAND [ARGS ...]",
        "",
        "Hierarchical Intermittent DDPG (Shi et al., IEEE Access 2019) in JAX.",
        "",
        "commands:",
        *(f"  {name:<{width}}  {help_}" for name, (_, help_) in COMMANDS.items()),
        "",
        "Run `hiddpg COMMAND --help` for the options of a command.",
    ]
    return "\n".join(lines)


def _load(target: str):
    module, func = target.split(":")
    return getattr(importlib.import_module(module), func)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hiddpg`` script; returns the exit code (0 on success, 2 on usage
    errors). Called with ``argv=None`` it reads ``sys.argv[1:]`` and exits the process."""
    if argv is None:
        from hiddpg import stopping
        from hiddpg.devices import request_cpu_devices, seeds_on_device

        stopping.install()  # SIGTERM / Ctrl-C: stop at once, runs marked (hiddpg.stopping)

        try:  # one CPU device per core, before JAX starts (hiddpg.devices)
            request_cpu_devices()
            seeds_on_device()
        except ValueError as err:
            print(f"hiddpg: error: {err}", file=sys.stderr)
            sys.exit(2)
        code = main(sys.argv[1:])
        sys.stdout.flush()
        sys.exit(code)
    args = list(argv)
    if not args or args[0] in ("-h", "--help", "help"):
        print(_usage())
        return 0 if args else 2
    if args[0] in ("-V", "--version"):
        from hiddpg import __version__

        print(f"hiddpg {__version__}")
        return 0
    name, rest = args[0], args[1:]
    if name not in COMMANDS:
        print(f"hiddpg: unknown command {name!r}; choose one of {sorted(COMMANDS)}",
              file=sys.stderr)
        return 2
    code = _load(COMMANDS[name][0])(rest)
    return 0 if code is None else int(code)


if __name__ == "__main__":  # pragma: no cover
    main()
