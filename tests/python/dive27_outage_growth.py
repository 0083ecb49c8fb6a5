#!/usr/bin/env python3
"""Seed 003's bar as error growth: 12 seeds of `dive-27min`, each reconstructed by the default
command (no configuration: the plan switches the propeller velocity filter on, the DVL having
gaps) and by the same with the filter switched off (`[rpm_velocity] use = false`: switching
alone). For each DVL outage (the stretches where the filter's aid was applied), the forward
horizontal error at its end minus at its start, against the log's /truth (errors.parquet).
Prints per seed the growth of each outage with both, and how many seeds grow less with the
filter (summed over their outages).

    cargo build --release && python3 tests/python/dive27_outage_growth.py WORKDIR

Needs pyarrow. About 5 minutes on 2 cores. Also prints the along-track part of the growth
"""
import bisect, math, os, subprocess, sys
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
    return [(t, (h, n, ea)) for t, so, h, n, ea in zip(e["stamp_ns"], e["solution"],
                                                        e["horizontal_error_m"], e["north_error_m"],
                                                        e["east_error_m"])
            if so == "forward"]


def track_direction(work, s, a, b):
    """The unit (north, east) direction of the forward solution's velocity over [a, b]."""
    t = table(os.path.join(work, f"default-{s}-vkf", "trajectory.parquet"))
    vn = ve = 0.0
    for ts, so, n, e in zip(t["stamp_ns"], t["solution"], t["vel_north_m_s"], t["vel_east_m_s"]):
        if so == "forward" and a <= ts <= b:
            vn, ve = vn + n, ve + e
    norm = math.hypot(vn, ve) or 1.0
    return vn / norm, ve / norm


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
    """The horizontal error at `t` (and its north and east parts)."""
    ts = [x[0] for x in f]
    return f[min(bisect.bisect_left(ts, t), len(ts) - 1)][1]


def along_growth(f, a, b, u):
    """Growth over [a, b] of the along-track error's size (the part a velocity aid acts on)."""
    along = lambda t: abs(at(f, t)[1] * u[0] + at(f, t)[2] * u[1])
    return along(b) - along(a)


def main():
    work = sys.argv[1]
    os.makedirs(work, exist_ok=True)
    with ThreadPoolExecutor(2) as ex:
        list(ex.map(lambda s: simulate(work, s), SEEDS))
        jobs = [(s, k) for s in SEEDS for k in ("vkf", "switch")]
        res = dict(zip(jobs, ex.map(lambda j: reconstruct(work, *j), jobs)))
    better_seeds = better_outages = total = better_along = 0
    print("| seed | outages | growth with the filter (m) | growth switching alone (m) | sum: filter / switching "
          "| along-track growth, sum: filter / switching |")
    print("|---|---|---|---|---|---|")
    for s in SEEDS:
        spans = outages(work, s)
        g = {k: [at(res[(s, k)], b)[0] - at(res[(s, k)], a)[0] for a, b in spans]
             for k in ("vkf", "switch")}
        dirs = [track_direction(work, s, a, b) for a, b in spans]
        al = {k: sum(along_growth(res[(s, k)], a, b, u) for (a, b), u in zip(spans, dirs))
              for k in ("vkf", "switch")}
        better_outages += sum(v < w for v, w in zip(g["vkf"], g["switch"]))
        total += len(spans)
        better_seeds += sum(g["vkf"]) < sum(g["switch"])
        better_along += al["vkf"] < al["switch"]
        print(f"| {s} | {len(spans)} | " + " / ".join(f"{x:+.2f}" for x in g["vkf"]) + " | "
              + " / ".join(f"{x:+.2f}" for x in g["switch"])
              + f" | {sum(g['vkf']):+.2f} / {sum(g['switch']):+.2f} | {al['vkf']:+.2f} / {al['switch']:+.2f} |")
    print(f"the filter's error grows less over {better_outages} of {total} outages; summed over "
          f"each seed's outages, on {better_seeds} of {len(SEEDS)} seeds; its along-track error "
          f"grows less on {better_along} of {len(SEEDS)} seeds")


if __name__ == "__main__":
    main()
