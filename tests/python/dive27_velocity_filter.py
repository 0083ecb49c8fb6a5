#!/usr/bin/env python3
"""The dive-27min table: 12 seeds of `dive-27min`, each reconstructed with
configs/dive-27min.toml as pure INS, INS-DVL trusting every reading, INS-DVL with switching
and with seed 003's velocity filter, with a gyrocompass start and with the heading given.
Prints per seed the forward horizontal RMS and the forward error at the end of each DVL
outage, and the medians. Scored against each log's /truth (errors.parquet).

    cargo build --release && python3 tests/python/dive27_velocity_filter.py WORKDIR

Needs pyarrow. About 6 minutes on 2 cores.
"""
import bisect, math, os, subprocess, sys
from concurrent.futures import ThreadPoolExecutor
import pyarrow.parquet as pq

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
H = os.path.join(REPO, "target", "release", "hindsight")
BASE = open(os.path.join(REPO, "configs", "dive-27min.toml")).read()
GIVEN = '\n[initial]\nheading = "given"\nyaw_deg = 0.0\ngiven_yaw_sigma_deg = 0.05\n'
OFF, ON = "\n[rpm_velocity]\nuse = false\n", "\n[rpm_velocity]\nuse = true\n"
CONFIGS = {
    "pure": BASE.replace("[dvl]\n", "[dvl]\nuse = false\n").replace("[eml]\n", "[eml]\nuse = false\n") + OFF,
    "trust": BASE.replace("[dvl]\n", "[dvl]\ncheck_range = false\n") + OFF,
    "switch": BASE + OFF,
    "vkf": BASE + ON,
    "given-switch": BASE + GIVEN + OFF,
    "given-vkf": BASE + GIVEN + ON,
}
SEEDS = range(1, 13)


def stamp(t):
    return t.value if hasattr(t, "value") else int(t)


def simulate(work, s):
    log = os.path.join(work, f"dive27-{s}.mcap")
    if not os.path.exists(log):
        subprocess.run([H, "simulate", "--scenario", "dive-27min", "--seed", str(s), "--out", log],
                       capture_output=True, check=True)
    return log


def reconstruct(work, s, k):
    out = os.path.join(work, f"run-{s}-{k}")
    if not os.path.exists(os.path.join(out, "errors.parquet")):
        conf = os.path.join(work, f"{k}.toml")
        subprocess.run([H, "reconstruct", os.path.join(work, f"dive27-{s}.mcap"), "--config", conf,
                        "--out", out], capture_output=True, check=True)
    e = pq.read_table(os.path.join(out, "errors.parquet")).to_pydict()
    return [(stamp(t), h) for t, so, h in zip(e["stamp_ns"], e["solution"], e["horizontal_error_m"])
            if so == "forward"]


def outage_ends(work, s, k):
    r = pq.read_table(os.path.join(work, f"run-{s}-{k}", "residuals.parquet")).to_pydict()
    st = sorted(stamp(t) for t, so in zip(r["stamp_ns"], r["sensor"]) if so == "rpm_velocity")
    return [a for a, b in zip(st, st[1:] + [None]) if b is None or b - a > 5e9]


def at(f, t):
    ts = [x[0] for x in f]
    return f[min(bisect.bisect_left(ts, t), len(ts) - 1)][1]


def main():
    work = sys.argv[1]
    os.makedirs(work, exist_ok=True)
    for k, text in CONFIGS.items():
        open(os.path.join(work, f"{k}.toml"), "w").write(text)
    with ThreadPoolExecutor(2) as ex:
        list(ex.map(lambda s: simulate(work, s), SEEDS))
        jobs = [(s, k) for s in SEEDS for k in CONFIGS]
        res = dict(zip(jobs, ex.map(lambda j: reconstruct(work, *j), jobs)))
    rms = lambda f: math.sqrt(sum(h * h for _, h in f) / len(f))
    for s in SEEDS:
        cells = []
        for k in CONFIGS:
            ends = outage_ends(work, s, "given-vkf" if k.startswith("given") else "vkf")
            f = res[(s, k)]
            cells.append(f"{k} {rms(f):.2f} ends " + "/".join(f"{at(f, t):.2f}" for t in ends))
        print(f"seed {s:2d} | " + " | ".join(cells))
    for k in CONFIGS:
        v = sorted(rms(res[(s, k)]) for s in SEEDS)
        print(f"{k}: median forward RMS {v[len(v) // 2]:.2f} m")
    for tag in ("", "given-"):
        wins = total = both = 0
        for s in SEEDS:
            ends = outage_ends(work, s, tag + "vkf")
            better = [at(res[(s, tag + "vkf")], t) < at(res[(s, tag + "switch")], t) for t in ends]
            wins += sum(better)
            total += len(better)
            both += all(better) and bool(better)
        print(f"{tag or 'gyrocompass-'}start: the velocity filter better at {wins} of {total} "
              f"outage ends; at every outage end on {both} of 12 seeds")


if __name__ == "__main__":
    main()
