"""Python's `reconstruct(...).write(dir)` against `hindsight reconstruct LOG --out DIR` on the
same log: the median wall time of each over interleaved runs, and their ratio (issue 59's
bar: at most 1.05). The machines are shared and noisy: read the medians and the ratio.

    pip install .            # the package, in a virtual environment
    cargo build --release    # the CLI
    python benches/python_reconstruct.py [LOG] [--runs 5]

Without LOG it simulates `dive-27min` (seed 1) once into a temporary folder.
"""

import argparse
import pathlib
import statistics
import subprocess
import tempfile
import time

import hindsight

REPO = pathlib.Path(__file__).resolve().parents[1]
CLI = REPO / "target" / "release" / "hindsight"


def cli_run(log, out):
    started = time.perf_counter()
    subprocess.run([CLI, "reconstruct", log, "--out", out, "--quiet"], check=True)
    return time.perf_counter() - started


def python_run(log, out):
    started = time.perf_counter()
    hindsight.reconstruct(log).write(out)
    return time.perf_counter() - started


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("log", nargs="?")
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        log = args.log
        if log is None:
            log = tmp / "dive-27min.mcap"
            simulate = [CLI, "simulate", "--scenario", "dive-27min", "--seed", "1"]
            subprocess.run([*simulate, "--out", log, "--quiet"], check=True)
        times = {"cli": [], "python": []}
        for k in range(args.runs):
            # Interleaved, the order alternating: the machine's drift falls on both.
            order = [("cli", cli_run), ("python", python_run)]
            for name, run in order if k % 2 == 0 else order[::-1]:
                times[name].append(run(log, tmp / f"{name}-{k}"))
        cli, py = statistics.median(times["cli"]), statistics.median(times["python"])
        print(f"log {log}: {args.runs} runs each")
        print(f"  hindsight reconstruct --out     median {cli:.2f} s  {sorted(round(t, 2) for t in times['cli'])}")
        print(f"  hindsight.reconstruct().write() median {py:.2f} s  {sorted(round(t, 2) for t in times['python'])}")
        print(f"  ratio python / cli: {py / cli:.3f}")


if __name__ == "__main__":
    main()
