#!/usr/bin/env python3
"""Seed 003's bar as error growth: 12 seeds of `dive-27min`, each reconstructed by the default
command (no configuration: the plan switches the propeller velocity filter on, the DVL having
gaps) and by the same with the filter switched off (`[rpm_velocity] use = false`: switching
alone). For each DVL outage (the stretches where the filter's aid was applied), the forward
horizontal error at its end minus at its start, against the log's /truth (errors.parquet).
Prints per seed the growth of each outage with both, and how many seeds grow less with the
filter (summed over their outages).

    cargo build --release && python3 tests/python/dive27_outage_growth.py WORKDIR

Needs pyarrow. About 3 minutes on 2 cores.
"""
import bisect, os, subprocess, sys
from concurrent.futures import ThreadPoolExecutor
import pyarrow.parquet as pq

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
H = os.path.join(REPO, "target", "release", "hindsight")
SEEDS = range(1, 13)


def table(path):
    """A Parquet table as columns, its timestamps as integer nanoseconds."""
    t = pq.read_table(path)
    d = t.to_pydict()
    d["stamp_ns"] = t.column("stamp_ns").cast("int64").to_pylist()
    return d


def simulate(work, s):
    log = os.path.join(work, f"dive27-{s}.mcap")
    if not os.path.exists(log):
        subprocess.run([H, "simulate", "--scenario", "dive-27min", "--seed", str(s), "--out", log,
                        "-q"], check=True)


def reconstruct(work, s, k):
    out = os.path.join(work, f"default-{s}-{k}")
    if not os.path.exists(os.path.join(out, "summary.json")):
        extra = []
        if k == "switch":
            conf = os.path.join(work, "switch.toml")
            open(conf, "w").write("[rpm_velocity]\nuse = false\n")
            extra = ["--config", conf]
        subprocess.run([H, "reconstruct", os.path.join(work, f"dive27-{s}.mcap"), "--out", out,
                        "-q", *extra], check=True)
    e = table(os.path.join(out, "errors.parquet"))
    return [(t, h) for t, so, h in zip(e["stamp_ns"], e["solution"], e["horizontal_error_m"])
            if so == "forward"]


def outages(work, s):
    """(start, end) of each stretch the filter's aid was applied (readings at most 5 s apart)."""
    r = table(os.path.join(work, f"default-{s}-vkf", "residuals.parquet"))
    st = sorted(t for t, so in zip(r["stamp_ns"], r["sensor"]) if so == "rpm_velocity")
    spans, first = [], None
    for a, b in zip(st, st[1:] + [None]):
        first = a if first is None else first
        if b is None or b - a > 5e9:
            spans.append((first, a))
            first = None
    return spans


def at(f, t):
    ts = [x[0] for x in f]
    return f[min(bisect.bisect_left(ts, t), len(ts) - 1)][1]


def main():
    work = sys.argv[1]
    os.makedirs(work, exist_ok=True)
    with ThreadPoolExecutor(2) as ex:
        list(ex.map(lambda s: simulate(work, s), SEEDS))
        jobs = [(s, k) for s in SEEDS for k in ("vkf", "switch")]
        res = dict(zip(jobs, ex.map(lambda j: reconstruct(work, *j), jobs)))
    better_seeds = better_outages = total = 0
    print("| seed | outages | growth with the filter (m) | growth switching alone (m) | sum: filter / switching |")
    print("|---|---|---|---|---|")
    for s in SEEDS:
        spans = outages(work, s)
        g = {k: [at(res[(s, k)], b) - at(res[(s, k)], a) for a, b in spans] for k in ("vkf", "switch")}
        better_outages += sum(v < w for v, w in zip(g["vkf"], g["switch"]))
        total += len(spans)
        better_seeds += sum(g["vkf"]) < sum(g["switch"])
        print(f"| {s} | {len(spans)} | " + " / ".join(f"{x:+.2f}" for x in g["vkf"]) + " | "
              + " / ".join(f"{x:+.2f}" for x in g["switch"])
              + f" | {sum(g['vkf']):+.2f} / {sum(g['switch']):+.2f} |")
    print(f"the filter's error grows less over {better_outages} of {total} outages; summed over "
          f"each seed's outages, on {better_seeds} of {len(SEEDS)} seeds")


if __name__ == "__main__":
    main()
