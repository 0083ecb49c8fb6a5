#!/usr/bin/env python3
"""The default run (no config, no flags) on simulated logs, scored against their /truth.

Usage: python3 tests/python/default_runs.py WORKDIR CASE [SEEDS...]

CASE is one of:
  seed000-case1, seed000-case2   long-dive-dynamic, coefficients exact / 10 % off
  trench-eml, trench-turn, dive-27min, survey-dvl-calibration, survey, survey-short
Each seed is simulated (`hindsight simulate`), reconstructed with the default command
(`hindsight reconstruct LOG --out DIR`), and its summary.json's truth scores printed, one
line per seed, then the worst forward and smoothed max.
"""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.path.join(ROOT, "target", "release", "hindsight")

CASES = {
    "seed000-case1": ("long-dive-dynamic", ["--coef-uncertainty", "0"]),
    "seed000-case2": ("long-dive-dynamic", ["--coef-uncertainty", "0.1"]),
}


def main():
    work, case = sys.argv[1], sys.argv[2]
    seeds = [int(s) for s in sys.argv[3:]] or [1, 2, 3, 4, 5]
    scenario, extra = CASES.get(case, (case, []))
    os.makedirs(work, exist_ok=True)
    worst = [0.0, 0.0]
    for seed in seeds:
        log = os.path.join(work, f"{case}-{seed}.mcap")
        if not os.path.exists(log):
            subprocess.run([BIN, "simulate", "--scenario", scenario, "--seed", str(seed),
                            "--out", log, "-q", *extra], check=True)
        out = os.path.join(work, f"{case}-{seed}")
        subprocess.run([BIN, "reconstruct", log, "--out", out, "-q"], check=True)
        s = json.load(open(os.path.join(out, "summary.json")))
        f, m = s["truth"]["forward"], s["truth"]["smoothed"]
        worst = [max(worst[0], f["horizontal_max_m"]), max(worst[1], m["horizontal_max_m"])]
        imu = s["tuning"]["imu"]["model"] if s.get("tuning") else "-"
        dvl = s.get("dvl_calibration") or {}
        sf = dvl.get("scale_factor", {})
        hd = (dvl.get("misalignment_deg") or {}).get("heading", {})
        print(f"{case} seed {seed}: forward RMS {f['horizontal_rms_m']:.2f} max "
              f"{f['horizontal_max_m']:.2f} m, smoothed RMS {m['horizontal_rms_m']:.2f} max "
              f"{m['horizontal_max_m']:.2f} m; NEES inside fwd {100*f['nees_horizontal_inside_95']:.1f} % "
              f"smo {100*m['nees_horizontal_inside_95']:.1f} %; imu {imu}; "
              f"dvl scale {sf.get('value', 1):.5f} +- {sf.get('sigma', 0):.5f}, heading "
              f"{hd.get('value', 0):.3f} +- {hd.get('sigma', 0):.3f} deg; "
              f"run {s['run_time_s']['total']:.1f} s (ingest {s['run_time_s']['ingest']:.1f})",
              flush=True)
    print(f"{case}: worst forward max {worst[0]:.2f} m, worst smoothed max {worst[1]:.2f} m")


if __name__ == "__main__":
    main()
