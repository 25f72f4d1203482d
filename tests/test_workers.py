"""The suite's share-out among pytest-xdist's workers (tests/_workers.py): every file that uses a
shared costly fixture is in that fixture's group, so the fixture is built once per run."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests._workers import LONGEST_GROUPS_FIRST, SHARED_FIXTURE_GROUPS, worker_group

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent

#: Each shared fixture, with the group whose worker builds it.
SHARED_FIXTURES = {"dem_grid_campaign": "dem-campaigns", "dem_poured_campaign": "dem-campaigns",
                   "slurm_cluster": "slurm-cluster"}


def _test_files() -> list[str]:
    """Every test file but this one (which names the fixtures), relative to the repository."""
    return sorted(str(p.relative_to(REPO)) for p in TESTS.rglob("test_*.py")
                  if p != Path(__file__).resolve())


@pytest.mark.parametrize(("fixture", "group"), SHARED_FIXTURES.items())
def test_every_file_that_uses_a_shared_fixture_is_in_its_group(fixture, group):
    users = [path for path in _test_files()
             if re.search(rf"\b{fixture}\b", (REPO / path).read_text(encoding="utf-8"))]
    assert users, f"no test file uses {fixture}: the group {group} is stale"
    assert {path: worker_group(f"{path}::test") for path in users} == dict.fromkeys(users, group)


def test_the_longest_groups_name_groups_that_exist():
    groups = {worker_group(f"{path}::test") for path in _test_files()}
    assert set(LONGEST_GROUPS_FIRST) <= groups
    assert set(SHARED_FIXTURE_GROUPS) <= groups


def test_a_file_outside_the_shared_groups_is_its_own_group():
    assert worker_group("tests/cell/test_layout.py::test_x[a::b]") == "tests/cell/test_layout.py"
    assert worker_group("tests/cluster/test_profile.py::test_x") == "slurm-cluster"
