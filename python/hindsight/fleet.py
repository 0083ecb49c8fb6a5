"""Many missions on a distributed engine: the same outputs as ``hindsight batch``.

Each mission is one task (:func:`hindsight.batch_mission`): it reconstructs its log and
writes its own partition, ``OUT/mission=<log's stem>/``; only its summary row (a small dict)
comes back. The rows are then written as ``batch_summary.parquet`` and ``report.html``.

With Dask (``pip install dask distributed``)::

    from dask.distributed import Client
    import hindsight.fleet
    client = Client()                     # or Client("scheduler:8786"), a LocalCluster...
    hindsight.fleet.on_dask(logs, "out/") # the active client runs the tasks

With Ray Data (``pip install ray[data]``), the same task::

    import ray, hindsight
    rows = ray.data.from_items([{"log": l} for l in logs]).map(
        lambda item: hindsight.batch_mission(item["log"], "out/")
    ).take_all()
    hindsight.write_batch_summary(sorted(rows, key=lambda r: r["mission"]), "out/")
"""

from __future__ import annotations

import os
from typing import Any, Iterable, Mapping, Union

from . import batch_mission, write_batch_summary


def missions(logs: Iterable[Any]) -> list:
    """The logs sorted by mission name, as ``hindsight batch`` orders them; two logs of one
    name are refused (their partitions would be one)."""
    named = sorted((os.path.splitext(os.path.basename(os.fspath(l).rstrip("/")))[0], os.fspath(l)) for l in logs)
    for (a, la), (b, lb) in zip(named, named[1:]):
        if a == b:
            raise ValueError(f"two logs would both be mission `{a}`: {la} and {lb}")
    return [log for _, log in named]


def on_dask(
    logs: Iterable[Any],
    out: Any,
    settings: Union[None, Any, Mapping[str, Any]] = None,
    force: bool = False,
    **overrides: Mapping[str, Any],
) -> str:
    """Runs every log as one Dask task (``dask.bag``, one partition per mission) on the
    active scheduler, then writes ``batch_summary.parquet``; returns its path. Failed
    missions are rows with their error, as in ``hindsight batch``."""
    import dask.bag as db

    ordered = missions(logs)
    out = os.fspath(out)
    bag = db.from_sequence(ordered, npartitions=max(len(ordered), 1))
    rows = bag.map(lambda log: batch_mission(log, out, settings, force, **overrides)).compute()
    return write_batch_summary(rows, out)
