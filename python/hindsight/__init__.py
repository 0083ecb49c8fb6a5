"""hindsight from Python: the reconstruction of an underwater vehicle's recorded dive.

    >>> import hindsight
    >>> r = hindsight.reconstruct("sample-logs/survey-short-seed1.mcap")
    >>> r.trajectory.num_rows
    >>> import pyarrow; pyarrow.table(r.trajectory)     # no copy
    >>> r.write("out/")                                 # the CLI's output folder

The work runs in Rust with the GIL released; the tables cross as Arrow through the
PyCapsule interface (``__arrow_c_stream__``), so pyarrow, polars and DuckDB take their
buffers as they are. Errors are :class:`LogError`, :class:`SettingsError` or
:class:`OutputError` (all :class:`HindsightError`), with the message the CLI prints.
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Mapping, Optional, Union

from ._hindsight import (
    ArrowTable,
    HindsightError,
    LogError,
    OutputError,
    SettingsError,
)
from ._hindsight import batch_mission as _batch_mission
from ._hindsight import read_log as _read_log
from ._hindsight import reconstruct as _reconstruct
from ._hindsight import simulate as _simulate
from ._hindsight import write_batch_summary as _write_batch_summary

__all__ = [
    "reconstruct",
    "read_log",
    "simulate",
    "batch_mission",
    "write_batch_summary",
    "Reconstruction",
    "ArrowTable",
    "HindsightError",
    "LogError",
    "SettingsError",
    "OutputError",
]

PathLike = Union[str, "os.PathLike[str]"]


def _toml_value(value: Any, key: str) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v, key) for v in value) + "]"
    raise SettingsError(f"`{key}`: {type(value).__name__} is not a setting's type")


def _toml(settings: Mapping[str, Any], prefix: str = "") -> str:
    """TOML text of nested settings: top-level keys, then one table per section."""
    lines, tables = [], []
    for key, value in settings.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            tables.append((name, value))
        else:
            lines.append(f"{key} = {_toml_value(value, name)}")
    text = "\n".join(lines) + ("\n" if lines else "")
    for name, table in tables:
        text += f"\n[{name}]\n" + _toml(table, prefix=f"{name}.")
    return text


def _merged(base: dict, over: Mapping[str, Any]) -> dict:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merged(dict(out[key]), value)
        else:
            out[key] = value
    return out


def _settings_toml(settings: Union[None, PathLike, Mapping[str, Any]], overrides) -> tuple:
    """The settings' TOML text, and what to call them in a message: a file given alone is
    passed as it is (its lines as the CLI names them), else the merged settings as TOML."""
    if settings is None:
        base: dict = {}
    elif isinstance(settings, Mapping):
        base = dict(settings)
    else:
        path = os.fspath(settings)
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise SettingsError(f"configuration {path}: {e.strerror}") from None
        if not overrides:
            return text, f"configuration {path}"
        import tomllib  # Python 3.11+; a dict works on any version

        try:
            base = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise SettingsError(f"configuration {path}: {e}") from None
    return _toml(_merged(base, overrides)).lstrip("\n"), "settings"


def _settings_said(call, origin: str, *args):
    """``call(*args)``, a settings error named as the CLI names it (``configuration FILE:``)."""
    try:
        return call(*args)
    except SettingsError as e:
        raise SettingsError(f"{origin}: {e}") from None


class Reconstruction:
    """One reconstructed mission: its tables, its plan and summary, its output folder."""

    def __init__(self, inner) -> None:
        self._inner = inner
        self._summary: Optional[dict] = None

    @property
    def trajectory(self) -> ArrowTable:
        """trajectory.parquet's rows (forward and smoothed solutions), as Arrow."""
        return self._inner.trajectory

    @property
    def residuals(self) -> ArrowTable:
        """residuals.parquet's rows: every aiding reading's innovation, as Arrow."""
        return self._inner.residuals

    @property
    def errors(self) -> ArrowTable:
        """errors.parquet's rows against the log's truth (none without one), as Arrow."""
        return self._inner.errors

    @property
    def summary(self) -> dict:
        """summary.json's content."""
        if self._summary is None:
            self._summary = json.loads(self._inner.summary_json)
        return self._summary

    @property
    def plan(self) -> dict:
        """What the run decided from the log, and why (summary.json's ``plan``)."""
        return self.summary["plan"]

    @property
    def warnings(self) -> list:
        """The run's warnings (summary.json's ``warnings``)."""
        return self.summary.get("warnings", [])

    def write(self, dir: PathLike) -> list:
        """Writes the output folder, as ``hindsight reconstruct --out DIR`` does."""
        return [os.fspath(p) for p in self._inner.write(os.fspath(dir))]


def reconstruct(
    log: PathLike,
    settings: Union[None, PathLike, Mapping[str, Any]] = None,
    progress: Optional[Callable[[str, float], Any]] = None,
    **overrides: Mapping[str, Any],
) -> Reconstruction:
    """Reconstructs the mission in ``log`` (MCAP, ROS 1 bag, rosbag2 folder).

    ``settings``: a TOML file as ``hindsight reconstruct --config`` takes, or the same as a
    dict. ``overrides``: sections laid over it, e.g. ``usbl={"ship_heading_correlation_s": 5}``.
    ``progress(stage, fraction)``: told now and then how far ``"read"``, ``"forward"`` and
    ``"smoother"`` are (from the worker threads; an exception it raises ends the run after
    it). Raises :class:`LogError` or :class:`SettingsError` with the CLI's message.
    """
    text, origin = _settings_toml(settings, overrides)
    return Reconstruction(_settings_said(_reconstruct, origin, os.fspath(log), text, progress))


def simulate(scenario: str, seed: int, out: PathLike) -> dict:
    """Simulates the built-in ``scenario`` (``hindsight simulate --list`` names them) with
    ``seed`` into the log file ``out``, with ``/truth``, as ``hindsight simulate`` writes it
    (the same scenario and seed give the same file). Returns the messages written and the
    mission's duration. An unknown scenario is a :class:`SettingsError`."""
    messages, duration_s = _simulate(scenario, seed, os.fspath(out))
    return {"messages": messages, "duration_s": duration_s}


def read_log(log: PathLike) -> dict:
    """Every topic of ``log`` as an Arrow table (``stamp_ns``, ``log_time_ns``, then every
    field, as ``hindsight export`` writes them), by topic name."""
    return dict(_read_log(os.fspath(log)))


def batch_mission(
    log: PathLike,
    out: PathLike,
    settings: Union[None, PathLike, Mapping[str, Any]] = None,
    force: bool = False,
    **overrides: Mapping[str, Any],
) -> dict:
    """One mission of a batch, as ``hindsight batch`` runs each log: reconstructed into
    ``out/mission=<log's stem>/`` (a hive-style partition) unless its outputs are complete
    there already (and not ``force``). Returns its row of ``batch_summary.parquet``; a failed
    mission is a row too (``status`` "failed", ``error``). The tables go to disk from here:
    only the row comes back. A task for Dask or Ray: see :mod:`hindsight.fleet`.
    """
    text, origin = _settings_toml(settings, overrides)
    row = _settings_said(_batch_mission, origin, os.fspath(log), os.fspath(out), text, force)
    return json.loads(row)


def write_batch_summary(rows: list, out: PathLike, shard: Optional[tuple] = None) -> str:
    """``batch_summary.parquet`` and the batch's ``report.html`` in ``out`` from the missions'
    rows (in the order given), as ``hindsight batch`` writes them. Returns the summary's path.
    """
    return os.fspath(_write_batch_summary(json.dumps(list(rows)), os.fspath(out), shard))
