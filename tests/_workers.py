"""How the suite shares its tests out among pytest-xdist's workers (pyproject.toml: ``-n 2``).

A worker runs a whole group, one after another: a test file, or the files that share a session-
or package-scoped fixture too costly to build twice (:data:`SHARED_FIXTURE_GROUPS`). The groups
are handed out longest first (:data:`LONGEST_GROUPS_FIRST`), so that no long group starts while
the other worker is nearly done.
"""

from __future__ import annotations

import pytest
from xdist.scheduler import LoadScopeScheduling

#: Groups of files that share a costly fixture: the DEM campaigns of tests/workflow/conftest.py
#: and the SLURM cluster of tests/cluster/conftest.py (two clusters cannot run on one machine).
SHARED_FIXTURE_GROUPS = {
    "dem-campaigns": ("tests/workflow/test_refine_workflow.py",
                      "tests/workflow/test_verify_workflow.py",
                      "tests/workflow/test_workflow_dem.py"),
    "slurm-cluster": ("tests/cluster/",),
}

#: Groups handed out first, longest first; the others follow in the order pytest collects them.
#: The order comes from a serial run's ``pytest -n 0 --durations=0``: each of these took 1.2 to
#: 4.6 minutes, the next file (tests/design/test_bootstrap.py) about one.
LONGEST_GROUPS_FIRST = (
    "dem-campaigns",
    "tests/workflow/test_workflow.py",
    "tests/workflow/test_interruption.py",
    "slurm-cluster",
    "tests/liggghts/test_corners.py",
    "tests/steps/test_refine.py",
    "tests/design/test_surrogate_gp.py",
    "tests/dem/test_pour.py",
)


def worker_group(nodeid: str) -> str:
    """The group of a test, from its node id: its shared-fixture group, or else its file."""
    path = nodeid.split("::", 1)[0]
    for group, prefixes in SHARED_FIXTURE_GROUPS.items():
        if path.startswith(prefixes):
            return group
    return path


def longest_groups_first(items: list[pytest.Item]) -> None:
    """Reorder collected tests (in place) group by group, :data:`LONGEST_GROUPS_FIRST` first.

    Within a group the collected order is kept. xdist's scheduler hands the groups out in this
    order (``--no-loadscope-reorder``); a run in one process (``-n 0``) runs them in it too.
    """
    groups: dict[str, list[pytest.Item]] = {}
    for item in items:
        groups.setdefault(worker_group(item.nodeid), []).append(item)
    first = [name for name in LONGEST_GROUPS_FIRST if name in groups]
    rest = [name for name in groups if name not in LONGEST_GROUPS_FIRST]
    items[:] = [item for name in first + rest for item in groups[name]]


class GroupScheduling(LoadScopeScheduling):
    """xdist's scheduling by scope, with :func:`worker_group` as the scope of a test."""

    def _split_scope(self, nodeid: str) -> str:
        return worker_group(nodeid)
