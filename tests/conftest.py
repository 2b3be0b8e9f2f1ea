"""XLA's optimisation level per test.

``scripts/test.sh`` (CI) sets ``JAX_DISABLE_MOST_OPTIMIZATIONS=1``: most tests compile far more
than they run, and XLA compiles a program without its expensive passes in about two thirds of
the time. A test that trains long enough for the slower program to cost more than the
compilation saves, or that compares numbers recorded from the default build (the golden runs),
is marked ``xla_optimized``: it runs with XLA's default optimisation, in this process and in
the processes it starts. The numbers a program computes differ between the two levels only in
floating-point rounding. A plain ``pytest`` run (the variable unset) uses the default level
everywhere.
"""

from __future__ import annotations

import os

import jax
import pytest

FLAG = "jax_disable_most_optimizations"
ENV = "JAX_DISABLE_MOST_OPTIMIZATIONS"
pytest_plugins = ["pytester"]


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Setup, call and teardown of a marked test (a module fixture it sets up included) at
    the default level."""
    if item.get_closest_marker("xla_optimized") is None or not jax.config.read(FLAG):
        yield
        return
    # an executable compiled without the optimisations must not be reused by this test
    jax.clear_caches()
    jax.config.update(FLAG, False)
    before = os.environ.get(ENV)
    os.environ[ENV] = "0"
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(ENV, None)
        else:
            os.environ[ENV] = before
        jax.config.update(FLAG, True)
        jax.clear_caches()


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(items):
    """Under ``--dist loadgroup`` (scripts/test.sh) a test without an ``xdist_group`` mark is
    in its file's group: each file runs on one worker and sets its module fixtures up once, as
    under ``--dist loadfile``. Files that share a session fixture name one group
    (tests/experiments/tiny_output.py)."""
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
