"""The real single-node SLURM of the cluster tests (tests/cluster/local_slurm.py).

One cluster for the tests of this folder, started on first use and shut down after them. It is never
skipped: if SLURM cannot be installed or started, every test that uses it fails with the
daemons' logs.
"""

from __future__ import annotations

import pytest

from tests.cluster import local_slurm


@pytest.fixture(scope="package")
def slurm_cluster(tmp_path_factory):
    """A started :class:`~tests.cluster.local_slurm.LocalSlurm`: this machine as its one idle node."""
    try:
        cluster = local_slurm.start(tmp_path_factory.mktemp("slurm"))
    except local_slurm.SlurmStartError as exc:
        pytest.fail(str(exc), pytrace=False)
    yield cluster
    cluster.stop()
