"""Shared fixtures of the batch tests."""

import pytest


@pytest.fixture(scope="module")
def dask_client():
    """A local Dask cluster of 2 threaded workers (processes=False: starts in a fraction of a second)."""
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0")
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()
