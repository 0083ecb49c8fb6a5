#!/usr/bin/env python3
"""Open every Parquet file of an export in pyarrow, polars and DuckDB with warnings as errors.

    python3 tests/python/check_parquet.py OUT_DIR

Checks: each file opens in all three; `stamp_ns` is timestamp[ns, tz=UTC] and strictly
increasing; per-topic files have `log_time_ns` too; row counts agree between the readers;
aligned.parquet has an `<topic>_age_s` column per topic that is null or >= 0.
Needs: pip install pyarrow polars duckdb
"""
import glob
import os
import sys
import warnings

warnings.simplefilter("error")

import duckdb  # noqa: E402
import polars as pl  # noqa: E402
import pyarrow as pa  # noqa: E402
import pyarrow.compute as pc  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402


def main(out_dir):
    files = sorted(glob.glob(os.path.join(out_dir, "*.parquet")))
    assert files, f"no Parquet files in {out_dir}"
    assert os.path.join(out_dir, "aligned.parquet") in files
    con = duckdb.connect()
    topics = []
    for path in files:
        table = pq.read_table(path)
        ts = table.schema.field("stamp_ns").type
        assert ts == pa.timestamp("ns", tz="UTC"), f"{path}: stamp_ns is {ts}"
        stamps = table.column("stamp_ns").cast(pa.int64()).to_pylist()
        assert all(a < b for a, b in zip(stamps, stamps[1:])), f"{path}: stamps not increasing"
        frame = pl.read_parquet(path)
        assert frame.height == table.num_rows, path
        assert str(frame.schema["stamp_ns"]) == "Datetime(time_unit='ns', time_zone='UTC')", frame.schema["stamp_ns"]
        (count,) = con.execute(f"SELECT count(*) FROM read_parquet('{path}')").fetchone()
        assert count == table.num_rows, path
        name = os.path.basename(path)[: -len(".parquet")]
        if name != "aligned":
            assert table.schema.field("log_time_ns").type == pa.timestamp("ns", tz="UTC")
            topics.append(name)
        print(f"ok  {os.path.basename(path):24} {table.num_rows:>8} rows  {table.num_columns:>3} columns")
    aligned = pq.read_table(os.path.join(out_dir, "aligned.parquet"))
    for topic in topics:
        age = aligned.column(f"{topic}_age_s")
        assert pc.min(age).as_py() is None or pc.min(age).as_py() >= 0.0, topic
    print(f"all {len(files)} files open in pyarrow {pa.__version__}, polars {pl.__version__}, "
          f"duckdb {duckdb.__version__} without warnings")


if __name__ == "__main__":
    main(sys.argv[1])
