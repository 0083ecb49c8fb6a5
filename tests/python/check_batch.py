#!/usr/bin/env python3
"""Read the partitioned output of `hindsight batch` in DuckDB, warnings as errors.

    python3 tests/python/check_batch.py OUT_DIR FAILED_MISSION

Checks: DuckDB reads OUT_DIR/mission=*/trajectory.parquet as one table with the mission as
a hive partition column; every mission has both solutions with the row count its
summary.json gives; batch_summary.parquet has one row per mission, the failed one with its
error, the others `done` or `complete` with the distance their summary.json gives.
Needs: pip install duckdb
"""
import glob
import json
import os
import sys
import warnings

warnings.simplefilter("error")

import duckdb  # noqa: E402


def main(out_dir, failed_mission):
    con = duckdb.connect()
    partitions = sorted(
        os.path.basename(p)[len("mission="):] for p in glob.glob(os.path.join(out_dir, "mission=*"))
    )
    rows = con.execute(
        f"""SELECT mission, solution, count(*) AS n
            FROM read_parquet('{out_dir}/mission=*/trajectory.parquet', hive_partitioning = true)
            GROUP BY mission, solution ORDER BY mission, solution"""
    ).fetchall()
    done = [p for p in partitions if os.path.exists(os.path.join(out_dir, f"mission={p}", "summary.json"))]
    assert done, "no complete mission"
    assert [r[0] for r in rows] == [m for m in done for _ in (0, 1)], rows
    for mission, solution, n in rows:
        with open(os.path.join(out_dir, f"mission={mission}", "summary.json")) as f:
            summary = json.load(f)
        assert n == summary["trajectory_rows_per_solution"], (mission, solution, n)
    print(f"ok  mission=*/trajectory.parquet  {len(done)} missions, {sum(r[2] for r in rows)} rows (hive partitions)")

    table = con.execute(
        f"SELECT mission, status, error, distance_travelled_m FROM read_parquet('{out_dir}/batch_summary.parquet') ORDER BY mission"
    ).fetchall()
    assert [r[0] for r in table] == sorted(done + [failed_mission]), table
    for mission, status, error, distance in table:
        if mission == failed_mission:
            assert status == "failed" and error and distance is None, (mission, status, error)
            continue
        assert status in ("done", "complete") and error is None, (mission, status, error)
        with open(os.path.join(out_dir, f"mission={mission}", "summary.json")) as f:
            assert distance == json.load(f)["distance_travelled_m"], mission
    print(f"ok  batch_summary.parquet  {len(table)} missions, 1 failed as expected")
    print(f"batch output reads in duckdb {duckdb.__version__} without warnings")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
