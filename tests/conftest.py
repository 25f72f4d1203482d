"""Shared fixtures. Tests marked ``engine`` run the real LIGGGHTS.

LIGGGHTS is installable everywhere pidpipe runs (`apt-get install --no-install-recommends
liggghts`; the README's test command does it). If it is missing, engine tests fail in CI
(CI=true) and are skipped elsewhere with the reason printed.
"""

from __future__ import annotations

import os
import shutil

import pytest

from pidpipe.config import load_config
from tests._workers import GroupScheduling, longest_groups_first

MISSING_ENGINE = ("LIGGGHTS is not installed: apt-get install -y --no-install-recommends liggghts "
                  "(the README's test command installs it)")


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """Under pytest-xdist's ``--dist loadscope`` (pyproject.toml's addopts), the suite's own
    scopes: files that share a costly fixture run in one worker (:mod:`tests._workers`)."""
    if config.getvalue("dist") == "loadscope":
        return GroupScheduling(config, log)
    return None


def pytest_collection_modifyitems(config, items):
    longest_groups_first(items)
    if shutil.which("liggghts") or os.environ.get("PIDPIPE_LIGGGHTS"):
        return
    for item in items:
        if "engine" in item.keywords:
            if os.environ.get("CI"):
                item.add_marker(pytest.mark.usefixtures("_fail_without_engine"))
            else:
                item.add_marker(pytest.mark.skip(reason=MISSING_ENGINE))


@pytest.fixture
def _fail_without_engine():
    pytest.fail(MISSING_ENGINE)


@pytest.fixture
def config():
    """The default config, validated (a fresh copy per test)."""
    return load_config()


def short_config(transient: int = 3, measured: int = 12) -> dict:
    """The default config with few cycles: for tests, not for numbers anyone reports."""
    cfg = load_config()
    cfg["fidelity"]["transient_cycles"] = transient
    cfg["fidelity"]["transient_min_time_s"] = 0.0
    cfg["fidelity"]["measured_cycles"] = measured
    return cfg
