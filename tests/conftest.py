"""Shared test set-up: one Taichi runtime per test session, in float64 by default."""

import pytest

from sandbox import runtime


@pytest.fixture(scope="session", autouse=True)
def taichi_f64():
    """Tests compare against finite differences and references: run Taichi in float64."""
    runtime.init("cpu", float64=True)
    yield


@pytest.fixture(scope="module", autouse=True)
def fresh_field_trees():
    """Each test module starts with room for its fields: Taichi allows 512 field trees per
    runtime and frees none, so a long session reset it when past ``runtime.RECYCLE_AT``."""
    runtime.recycle()
    # a test that ran a command in float32 (the CLI's default) leaves that runtime behind;
    # every module starts in float64 again
    runtime.init("cpu", float64=True)
    yield
