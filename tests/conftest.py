"""XLA's optimisation level per test.

``scripts/test.sh`` (CI) sets ``JAX_DISABLE_MOST_OPTIMIZATIONS=1``: most tests compile far more
than they run, so CI compiles at a lowered level: XLA without its expensive passes, and with
its older CPU fusion emitters (``xla_cpu_use_fusion_emitters=false``). A program compiles in
about a third of the default time there and runs somewhat slower. A test that trains long
enough for the slower program to cost more than the compilation saves, or that compares
numbers recorded from the default build (the golden runs), is marked ``xla_optimized``: it runs
at XLA's default level, in this process and in the processes it starts. So is a test that needs
two programs to agree bit for bit (the lowered level rounds them apart), and the box QP check,
whose one program leaves some problems unconverged at the lowered level only
(tests/control/test_ilqr.py). A plain ``pytest`` run (the variable unset or ``0``) uses the
default level everywhere.
"""

from __future__ import annotations

import os

import jax
import pytest

FLAG = "jax_disable_most_optimizations"
ENV = "JAX_DISABLE_MOST_OPTIMIZATIONS"
EMITTERS = "xla_cpu_use_fusion_emitters"
OLD_EMITTERS = f"--{EMITTERS}=false"
#: this run lowers the level (scripts/test.sh); a marked test raises it back
LOWERED_RUN = os.environ.get(ENV) == "1"
pytest_plugins = ["pytester"]


def _with_emitters(xla_flags: str | None, old: bool) -> str:
    kept = [f for f in (xla_flags or "").split() if not f.startswith(f"--{EMITTERS}=")]
    return " ".join(kept + ([OLD_EMITTERS] if old else []))


def _choose_emitters_per_compile() -> None:
    """Every compilation of this process uses the old fusion emitters while the level is
    lowered and the default ones while a marked test runs (XLA reads its flags once per
    process, so the choice goes with each compilation's options). Without JAX's internal
    hook the flag below applies to every compilation of the process."""
    from jax._src import compiler

    original = compiler.get_compile_options

    def get_compile_options(*args, **kwargs):
        options = original(*args, **kwargs)
        options.env_option_overrides = [
            *(o for o in options.env_option_overrides if o[0] != EMITTERS),
            (EMITTERS, not jax.config.read(FLAG))]
        return options

    compiler.get_compile_options = get_compile_options


if LOWERED_RUN:
    os.environ["XLA_FLAGS"] = _with_emitters(os.environ.get("XLA_FLAGS"), old=True)
    try:
        _choose_emitters_per_compile()
    except (ImportError, AttributeError):
        pass


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Setup, call and teardown of a marked test (a module fixture it sets up included) at
    the default level."""
    if item.get_closest_marker("xla_optimized") is None or not jax.config.read(FLAG):
        yield
        return
    # an executable compiled at the lowered level must not be reused by this test
    jax.clear_caches()
    jax.config.update(FLAG, False)
    before = {name: os.environ.get(name) for name in (ENV, "XLA_FLAGS")}
    os.environ[ENV] = "0"
    os.environ["XLA_FLAGS"] = _with_emitters(before["XLA_FLAGS"], old=False)
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
        jax.config.update(FLAG, True)
        jax.clear_caches()

