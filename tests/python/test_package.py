"""The Python package (issue 59), against the CLI on the shipped sample log.

Run: `pip install .[test]` then `pytest tests/python` (CI: `.ci/run`).
"""

import json
import os
import pathlib
import re
import subprocess

import pyarrow
import polars
import pytest

import hindsight

REPO = pathlib.Path(__file__).resolve().parents[2]
SAMPLE = REPO / "sample-logs" / "survey-short-seed1.mcap"
CLI = REPO / "target" / "release" / "hindsight"


@pytest.fixture(scope="module")
def r():
    return hindsight.reconstruct(SAMPLE)


def test_reconstruct_gives_the_tables_plan_and_summary(r):
    assert r.trajectory.num_rows > 1000
    assert "north_m" in r.trajectory.column_names
    assert r.residuals.num_rows > 100
    # The sample log carries a truth: errors against it.
    assert r.errors.num_rows > 0
    assert any(d["used"] for d in r.plan["decisions"])
    assert r.summary["plan"] == r.plan
    assert isinstance(r.warnings, list)


def test_pyarrow_and_polars_take_the_buffers_without_a_copy(r):
    address = r.trajectory._values_address("north_m")
    assert address != 0
    table = pyarrow.table(r.trajectory)
    assert table.num_rows == r.trajectory.num_rows
    assert table.column("north_m").chunk(0).buffers()[1].address == address
    frame = polars.DataFrame(r.trajectory)
    assert frame.height == r.trajectory.num_rows
    assert frame["north_m"].get_chunks()[0]._s.as_single_ptr() == address
    # polars.from_arrow takes a stream as a struct Series (rechunk=False keeps the chunks).
    unnested = polars.from_arrow(r.trajectory, rechunk=False).struct.unnest()
    assert unnested["north_m"].get_chunks()[0]._s.as_single_ptr() == address


def test_write_gives_the_clis_files(r, tmp_path):
    if not CLI.exists():
        pytest.skip("the CLI is built by `cargo test --release` first")
    cli, py = tmp_path / "cli", tmp_path / "py"
    subprocess.run([CLI, "reconstruct", SAMPLE, "--out", cli, "--quiet"], check=True)
    written = r.write(py)
    assert sorted(pathlib.Path(p).name for p in written) == sorted(os.listdir(cli))
    for name in os.listdir(cli):
        a, b = (cli / name).read_bytes(), (py / name).read_bytes()
        # Apart from the run times: summary.json's run_time_s, the report's line of them.
        if name == "summary.json":
            a, b = json.loads(a), json.loads(b)
            for s in (a, b):
                s.pop("run_time_s")
        if name == "report.html":
            a, b = (re.sub(rb"<tr><th>run time</th><td>[^<]*</td></tr>", b"", x) for x in (a, b))
        assert a == b, name


def clis_error(*args):
    """The message the CLI prints for a run that fails (its `error: ` line)."""
    done = subprocess.run([CLI, *args], capture_output=True, text=True)
    assert done.returncode != 0
    return done.stderr.splitlines()[0].removeprefix("error: ")


def test_bad_input_carries_the_clis_message(tmp_path):
    if not CLI.exists():
        pytest.skip("the CLI is built by `cargo test --release` first")
    out = tmp_path / "out"
    not_a_log = tmp_path / "not-a-log.mcap"
    not_a_log.write_text("not a log")
    bad = tmp_path / "bad.toml"
    bad.write_text('[output]\nrate_hz = "ten"\n')
    for exception, args, kwargs in [
        (hindsight.LogError, [tmp_path / "no-such.mcap"], {}),
        (hindsight.LogError, [not_a_log], {}),
        (hindsight.SettingsError, [SAMPLE], {"settings": bad}),
    ]:
        with pytest.raises(exception) as raised:
            hindsight.reconstruct(*args, **kwargs)
        cli_args = ["reconstruct", *args, "--out", out]
        if "settings" in kwargs:
            cli_args += ["--config", kwargs["settings"]]
        assert str(raised.value) == clis_error(*cli_args)
    assert not out.exists()


def test_bad_input_raises_the_named_exception_and_writes_nothing(tmp_path):
    with pytest.raises(hindsight.LogError, match="no-such.mcap"):
        hindsight.reconstruct(tmp_path / "no-such.mcap")
    not_a_log = tmp_path / "not-a-log.mcap"
    not_a_log.write_text("not a log")
    with pytest.raises(hindsight.LogError, match="not-a-log.mcap"):
        hindsight.reconstruct(not_a_log)
    with pytest.raises(hindsight.SettingsError, match="rate_hz"):
        hindsight.reconstruct(SAMPLE, output={"rate_hz": "ten"})
    with pytest.raises(hindsight.SettingsError, match="no_such_key"):
        hindsight.reconstruct(SAMPLE, dvl={"no_such_key": 1})
    assert sorted(os.listdir(tmp_path)) == ["not-a-log.mcap"]
    assert issubclass(hindsight.SettingsError, hindsight.HindsightError)


def test_settings_come_from_a_file_a_dict_and_overrides(tmp_path):
    config = tmp_path / "settings.toml"
    config.write_text("[output]\nrate_hz = 2.0\n")
    default = hindsight.reconstruct(SAMPLE)
    from_file = hindsight.reconstruct(SAMPLE, config)
    from_dict = hindsight.reconstruct(SAMPLE, {"output": {"rate_hz": 2.0}})
    overridden = hindsight.reconstruct(SAMPLE, config, output={"rate_hz": 1.0})
    rows = [r.trajectory.num_rows for r in (default, from_file, from_dict, overridden)]
    # Rows per solution at the rate asked (the sample log's 181 s): 10, 2, 2 and 1 Hz.
    assert rows[1] == rows[2] < rows[0]
    assert rows[3] < rows[1]
    assert abs(rows[1] / rows[0] - 0.2) < 0.01, rows


def test_progress_is_told_and_a_failing_callback_ends_the_run():
    told = []
    hindsight.reconstruct(SAMPLE, progress=lambda stage, f: told.append((stage, f)))
    stages = {stage for stage, _ in told}
    # The smoother tells every 16384 epochs: the sample log is shorter.
    assert {"read", "forward"} <= stages, stages
    assert all(0.0 <= f <= 1.0 for _, f in told)

    def fail(stage, fraction):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        hindsight.reconstruct(SAMPLE, progress=fail)


def test_read_log_gives_every_topic_as_arrow():
    topics = hindsight.read_log(SAMPLE)
    assert "/imu" in topics and "/truth" in topics
    imu = pyarrow.table(topics["/imu"])
    assert imu.column_names[:2] == ["stamp_ns", "log_time_ns"]
    assert imu.num_rows > 10000
    with pytest.raises(hindsight.LogError, match="no-such.mcap"):
        hindsight.read_log("no-such.mcap")


def test_simulate_writes_the_clis_file(tmp_path):
    if not CLI.exists():
        pytest.skip("the CLI is built by `cargo test --release` first")
    written = hindsight.simulate("survey-short", 3, tmp_path / "py.mcap")
    assert written["messages"] > 10000 and written["duration_s"] > 100
    cli = tmp_path / "cli.mcap"
    args = ["simulate", "--scenario", "survey-short", "--seed", "3", "--out", cli, "--quiet"]
    subprocess.run([CLI, *args], check=True)
    assert (tmp_path / "py.mcap").read_bytes() == cli.read_bytes()
    with pytest.raises(hindsight.SettingsError, match="no-such-scenario"):
        hindsight.simulate("no-such-scenario", 1, tmp_path / "x.mcap")
    assert sorted(os.listdir(tmp_path)) == ["cli.mcap", "py.mcap"]
