"""A sweep's shards run on a Dask LocalCluster (worker processes), come back
pickled, and merge into exactly what one run gives, byte for byte."""

import filecmp
import os

import pytest

import frameid
from conftest import CASE1

distributed = pytest.importorskip("distributed")


def test_shards_on_a_local_cluster_merge_into_one_run(tmp_path):
    plan = dict(noise=[0, 0.01], trials=6, seed=11)
    shards = 4
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        # Two worker processes, neither of them this one.
        pids = set(client.run(os.getpid).values())
        assert len(pids) == 2 and os.getpid() not in pids
        futures = [
            client.submit(frameid.sweep, str(CASE1), shard=(k, shards), threads=1, pure=False, **plan)
            for k in range(1, shards + 1)
        ]
        parts = client.gather(futures)
    assert [p.shard for p in parts] == [(k, shards) for k in range(1, shards + 1)]
    assert sum(len(p) for p in parts) == 2 * 6
    merged = frameid.merge(parts[::-1])
    single = frameid.sweep(str(CASE1), threads=2, **plan)
    assert merged.complete and merged == single
    assert merged.trials_csv() == single.trials_csv()
    assert merged.summary_json() == single.summary_json()
    # The directories they write are the same, file for file.
    merged.write(tmp_path / "merged")
    single.write(tmp_path / "single")
    names = sorted(p.name for p in (tmp_path / "single").iterdir())
    assert names == ["representative.json", "summary.json", "sweep.json", "trials.csv"]
    match, mismatch, errors = filecmp.cmpfiles(tmp_path / "merged", tmp_path / "single", names, shallow=False)
    assert mismatch == [] and errors == []
