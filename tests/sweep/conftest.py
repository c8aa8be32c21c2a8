"""One LocalCluster of 2 single-threaded worker processes for the sweep tests (its
start-up, about 2 s, is paid once), with a private FMU cache the tests can inspect."""
import os

import pytest


@pytest.fixture(scope="session")
def fmu_cache(tmp_path_factory):
    d = tmp_path_factory.mktemp("fmu-cache")
    # set before the workers are spawned: they inherit the environment
    os.environ["PKM_SWEEP_FMU_CACHE"] = str(d)
    return d


@pytest.fixture(scope="session")
def cluster(fmu_cache):
    from cosim.sweep.cluster import _start_client

    client, cluster, desc = _start_client(None, 2)
    assert len(client.nthreads()) == 2 and set(client.nthreads().values()) == {1}
    yield client, cluster
    client.close()
    cluster.close()


@pytest.fixture(scope="session")
def client(cluster):
    return cluster[0]
