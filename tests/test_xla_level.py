"""tests/conftest.py: where CI lowers XLA's optimisation, a test marked ``xla_optimized`` (its
module fixtures and the processes it starts included) compiles at the default level, and the
level comes back for the next test. The fusion emitters are told apart by what they compute:
``tanh`` on a grid differs in its last bits between the old and the default emitters."""

from __future__ import annotations

from pathlib import Path

CONFTEST = Path(__file__).with_name("conftest.py")

INNER = '''
import hashlib
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

FLAG = "jax_disable_most_optimizations"
CHILD = "import jax; print(jax.config.read('jax_disable_most_optimizations'))"
TANH = ("import hashlib, jax, jax.numpy as jnp, numpy as np\\n"
        "x = jnp.linspace(-5, 5, 10001, dtype=jnp.float32)\\n"
        "print(hashlib.sha256(np.asarray(jax.jit(jnp.tanh)(x)).tobytes()).hexdigest())")


def child(code, env=None):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, env=env).stdout.strip()


def child_level():
    return child(CHILD)


def tanh_here():
    x = jnp.linspace(-5, 5, 10001, dtype=jnp.float32)
    return hashlib.sha256(np.asarray(jax.jit(jnp.tanh)(x)).tobytes()).hexdigest()


def tanh_at_xla_defaults():
    plain = {k: v for k, v in os.environ.items()
             if k not in ("JAX_DISABLE_MOST_OPTIMIZATIONS", "XLA_FLAGS")}
    return child(TANH, plain)


@pytest.fixture(scope="module")
def level_at_module_setup():
    return jax.config.read(FLAG)


def test_a_plain_test_runs_lowered():
    assert jax.config.read(FLAG) is True and child_level() == "True"
    default = tanh_at_xla_defaults()
    assert tanh_here() != default and child(TANH) != default


@pytest.mark.xla_optimized
def test_a_marked_test_and_its_module_fixture_run_at_the_default(level_at_module_setup):
    assert level_at_module_setup is False
    assert jax.config.read(FLAG) is False and os.environ["JAX_DISABLE_MOST_OPTIMIZATIONS"] == "0"
    assert child_level() == "False"
    default = tanh_at_xla_defaults()
    assert tanh_here() == default and child(TANH) == default


def test_the_next_plain_test_runs_lowered_again():
    assert jax.config.read(FLAG) is True and os.environ["JAX_DISABLE_MOST_OPTIMIZATIONS"] == "1"
    assert child_level() == "True"
    default = tanh_at_xla_defaults()
    assert tanh_here() != default and child(TANH) != default
'''


def test_marked_tests_run_at_the_default_level_and_others_lowered(pytester, monkeypatch):
    pytester.makeconftest(CONFTEST.read_text())
    pytester.makeini("[pytest]\nmarkers =\n    xla_optimized: default level\n")
    pytester.makepyfile(test_inner=INNER)
    monkeypatch.setenv("JAX_DISABLE_MOST_OPTIMIZATIONS", "1")
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-q")
    result.assert_outcomes(passed=3)


def test_without_the_variable_every_test_runs_at_the_default_level(pytester, monkeypatch):
    pytester.makeconftest(CONFTEST.read_text())
    pytester.makepyfile(test_inner=(
        "import jax\n\n"
        "def test_default():\n"
        "    assert jax.config.read('jax_disable_most_optimizations') is False\n"))
    monkeypatch.delenv("JAX_DISABLE_MOST_OPTIMIZATIONS", raising=False)
    pytester.runpytest_subprocess("-p", "no:cacheprovider", "-q").assert_outcomes(passed=1)
