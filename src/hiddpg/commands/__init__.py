"""Sub-commands of the ``hiddpg`` CLI (see :mod:`hiddpg.cli`): one module per command, each
with ``main(argv: list[str]) -> int``. Modules are imported only when their command runs."""
