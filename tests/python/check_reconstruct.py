#!/usr/bin/env python3
"""Open the outputs of `hindsight reconstruct` in pyarrow, polars and DuckDB, warnings as errors.

    python3 tests/python/check_reconstruct.py OUT_DIR

Checks: trajectory.parquet, residuals.parquet and (with /truth) errors.parquet open in all
three with the same row counts; stamp_ns is timestamp[ns, tz=UTC]; within each solution
(`forward`, `smoothed`) the trajectory's stamps strictly increase and every sigma is
positive; residuals have a known sensor and a NIS >= 0; summary.json parses and its counts
match the files.
trajectory.mcap, read with the official `mcap` reader and decoded by `mcap-ros2-support`
from the definitions it carries, holds each solution's rows as foxglove_msgs/msg/LocationFix
and foxglove_msgs/msg/PoseInFrame (ROS 2 CDR), whose stamps and positions are the table's.
Needs: pip install pyarrow polars duckdb mcap mcap-ros2-support
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


def check_trajectory_mcap(path, trajectory, per_solution):
    from collections import Counter, defaultdict

    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    counts = Counter()
    fixes = defaultdict(list)
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, body in reader.iter_decoded_messages():
            assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
            assert body.timestamp.nanosec < 10**9
            assert message.log_time == body.timestamp.sec * 10**9 + body.timestamp.nanosec
            counts[(channel.topic, schema.name)] += 1
            if schema.name.endswith("LocationFix"):
                assert len(body.position_covariance) == 9
                fixes[body.frame_id].append((message.log_time, body.latitude, body.longitude))
    expected = {
        (f"/hindsight/{s}/{kind}", f"foxglove_msgs/msg/{schema}"): per_solution
        for s in ("forward", "smoothed")
        for kind, schema in (("fix", "LocationFix"), ("pose", "PoseInFrame"))
    }
    assert dict(counts) == expected, counts
    # The fixes are the trajectory table's rows, solution by solution.
    for solution, got in fixes.items():
        rows = trajectory.filter(pc.equal(trajectory.column("solution"), solution))
        table = zip(
            rows.column("stamp_ns").cast(pa.int64()).to_pylist(),
            rows.column("latitude_deg").to_pylist(),
            rows.column("longitude_deg").to_pylist(),
        )
        for (t, lat, lon), (t_table, lat_table, lon_table) in zip(got, table):
            assert t == t_table and abs(lat - lat_table) < 1e-9 and abs(lon - lon_table) < 1e-9
    print(f"ok  trajectory.mcap      {sum(counts.values()):>8} messages on {len(counts)} topics "
          "(mcap reader, ROS 2 decoder)")


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
    check_trajectory_mcap(os.path.join(out_dir, "trajectory.mcap"), trajectory, per_solution)
    print(f"reconstruct outputs open in pyarrow {pa.__version__}, polars {pl.__version__}, "
          f"duckdb {duckdb.__version__} without warnings")


if __name__ == "__main__":
    main(sys.argv[1])
