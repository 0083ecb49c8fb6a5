#!/usr/bin/env python3
"""Open the outputs of `hindsight reconstruct` in pyarrow, polars and DuckDB, warnings as errors.

    python3 tests/python/check_reconstruct.py OUT_DIR

Checks: trajectory.parquet, residuals.parquet and (with /truth) errors.parquet open in all
three with the same row counts; stamp_ns is timestamp[ns, tz=UTC]; within each solution
(`forward`, `smoothed`) the trajectory's stamps strictly increase and every sigma is
positive; residuals have a known sensor and a NIS >= 0; summary.json parses and its counts
match the files.
trajectory.mcap, read with the official `mcap` reader, holds each solution's rows as
foxglove.LocationFix and foxglove.PoseInFrame messages.
Needs: pip install pyarrow polars duckdb mcap
"""
import json
import os
import sys
import warnings

warnings.simplefilter("error")

import duckdb  # noqa: E402
import polars as pl  # noqa: E402
import pyarrow as pa  # noqa: E402
import pyarrow.compute as pc  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402


def open_everywhere(con, path):
    table = pq.read_table(path)
    assert table.schema.field("stamp_ns").type == pa.timestamp("ns", tz="UTC"), path
    frame = pl.read_parquet(path)
    assert frame.height == table.num_rows, path
    (count,) = con.execute(f"SELECT count(*) FROM read_parquet('{path}')").fetchone()
    assert count == table.num_rows, path
    print(f"ok  {os.path.basename(path):20} {table.num_rows:>8} rows  {table.num_columns:>3} columns")
    return table


def check_trajectory_mcap(path, per_solution):
    from collections import Counter

    from mcap.reader import make_reader

    counts = Counter()
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
            body = json.loads(message.data)
            assert body["timestamp"]["nsec"] < 10**9
            counts[(channel.topic, schema.name)] += 1
    expected = {
        (f"/hindsight/{s}/{kind}", schema): per_solution
        for s in ("forward", "smoothed")
        for kind, schema in (("fix", "foxglove.LocationFix"), ("pose", "foxglove.PoseInFrame"))
    }
    assert dict(counts) == expected, counts
    print(f"ok  trajectory.mcap      {sum(counts.values()):>8} messages on {len(counts)} topics (mcap reader)")


def main(out_dir):
    con = duckdb.connect()
    with open(os.path.join(out_dir, "summary.json")) as f:
        summary = json.load(f)
    trajectory = open_everywhere(con, os.path.join(out_dir, "trajectory.parquet"))
    per_solution = summary["trajectory_rows_per_solution"]
    assert trajectory.num_rows == 2 * per_solution
    for solution in ("forward", "smoothed"):
        rows = trajectory.filter(pc.equal(trajectory.column("solution"), solution))
        assert rows.num_rows == per_solution, solution
        stamps = rows.column("stamp_ns").cast(pa.int64()).to_pylist()
        assert all(a < b for a, b in zip(stamps, stamps[1:])), f"{solution}: stamps not increasing"
        for name in rows.column_names:
            if "_sigma_" in name:
                assert pc.min(rows.column(name)).as_py() > 0.0, f"{solution}: {name}"
    residuals = open_everywhere(con, os.path.join(out_dir, "residuals.parquet"))
    assert residuals.num_rows == summary["residuals"]
    assert set(residuals.column("sensor").to_pylist()) <= {"dvl", "depth", "gnss", "eml", "position_fix", "mag"}
    assert pc.min(residuals.column("nis")).as_py() >= 0.0
    rejected = residuals.num_rows - pc.sum(residuals.column("accepted").cast(pa.int64())).as_py()
    assert rejected == summary["rejected"]
    errors = os.path.join(out_dir, "errors.parquet")
    if summary["truth"] is not None:
        table = open_everywhere(con, errors)
        assert table.num_rows == 2 * per_solution
    else:
        assert not os.path.exists(errors)
    check_trajectory_mcap(os.path.join(out_dir, "trajectory.mcap"), per_solution)
    print(f"reconstruct outputs open in pyarrow {pa.__version__}, polars {pl.__version__}, "
          f"duckdb {duckdb.__version__} without warnings")


if __name__ == "__main__":
    main(sys.argv[1])
