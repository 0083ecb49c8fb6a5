"""A fleet on Dask (issue 59): six simulated missions on a 2-worker LocalCluster give the
rows of ``hindsight batch``'s batch_summary.parquet and the same partitioned trajectories.

Run: `pip install .[test] dask distributed` then `pytest tests/python` (CI: `.ci/run`).
"""

import pathlib
import subprocess

import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest
from dask.distributed import Client, LocalCluster

import hindsight
import hindsight.fleet

REPO = pathlib.Path(__file__).resolve().parents[2]
CLI = REPO / "target" / "release" / "hindsight"


def test_a_dask_fleet_writes_what_hindsight_batch_writes(tmp_path):
    if not CLI.exists():
        pytest.skip("the CLI is built by `cargo test --release` first")
    logs = tmp_path / "logs"
    logs.mkdir()
    for seed in range(1, 7):
        log = logs / f"dive-{seed}.mcap"
        args = ["simulate", "--scenario", "survey-short", "--seed", str(seed), "--out", log]
        subprocess.run([CLI, *args, "--quiet"], check=True)
    cli_out, dask_out = tmp_path / "cli", tmp_path / "dask"
    subprocess.run([CLI, "batch", logs, "--out", cli_out, "--quiet"], check=True)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True) as cluster:
        with Client(cluster):
            path = hindsight.fleet.on_dask(sorted(logs.glob("*.mcap")), dask_out)
    assert pathlib.Path(path) == dask_out / "batch_summary.parquet"
    by_cli = pq.read_table(cli_out / "batch_summary.parquet")
    by_dask = pq.read_table(path)
    assert by_dask.num_rows == 6
    assert by_dask.column("status").to_pylist() == ["done"] * 6
    # The same rows but for the run times.
    assert by_dask.drop(["run_time_s"]).equals(by_cli.drop(["run_time_s"]))
    for seed in range(1, 7):
        partition = f"mission=dive-{seed}"
        a = (cli_out / partition / "trajectory.parquet").read_bytes()
        b = (dask_out / partition / "trajectory.parquet").read_bytes()
        assert a == b, partition
    # The hive-style partitions read as one dataset, the mission a column.
    files = sorted(str(p) for p in dask_out.glob("mission=*/trajectory.parquet"))
    dataset = ds.dataset(
        files, format="parquet", partitioning="hive", partition_base_dir=str(dask_out)
    ).to_table()
    assert sorted(set(dataset.column("mission").to_pylist())) == [
        f"dive-{s}" for s in range(1, 7)
    ]


def test_two_logs_of_one_name_are_refused(tmp_path):
    with pytest.raises(ValueError, match="both be mission `dive`"):
        hindsight.fleet.missions([tmp_path / "a" / "dive.mcap", tmp_path / "b" / "dive.mcap"])
