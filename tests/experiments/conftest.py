"""Fixtures shared by the end-to-end reproduction tests."""

from __future__ import annotations

from pathlib import Path

import pytest
from tiny_output import TINY

from hiddpg.commands import reproduce


@pytest.fixture(scope="session")
def tiny_fig4(tmp_path_factory) -> Path:
    """The output of ``hiddpg reproduce fig4`` on the tiny budget (tiny_output.TINY); copy it
    before changing it."""
    out = tmp_path_factory.mktemp("tiny-fig4")
    assert reproduce.main(["fig4", "--out", str(out), *TINY]) == 0
    return out
