"""Whole-process wall time of `seacover evaluate` beside the NumPy grid, one run.

docs/performance.md sets seacover's target at >= 100x faster than the usual
research code on fleet-1000. The criterion benchmark times one evaluation
in-process; this times what a user waits for: each side as a fresh process, from exec to exit,
reading the scenario and writing its result.

- NumPy: `PYTHON bench/baseline/coverage_grid.py SCENARIO --out FILE` (one
  evaluation: interpreter start, NumPy/SciPy import, parse, grid, output);
  single-threaded as the script sets it (research code usually is).
- seacover: `SEACOVER evaluate SCENARIO > FILE` (start-up, parse, partition,
  integrals, JSON out), with its default threads (both cores on the
  2-vCPU reference machine).

Both write their output to a file under --work (not a pipe to this process).
The runs are interleaved, the order alternating from round to round, so that
the machine's drift and noise fall on both sides alike; one untimed warm-up of
each comes first (page cache, venv bytecode). Reported: the median, the
quartiles and the minimum of each side over --repeat rounds, and the ratio of
the medians. Each round runs seacover --seacover-runs times (default 3), all
of them counted, since its runs are short and noisier. Beside it, the
stricter ratio of seacover's whole process to NumPy's evaluation alone, as
coverage_grid.py times it (`seconds_median`: no interpreter start-up, no
imports, no parsing, no output).

Usage:
    python3 bench/baseline/side_by_side.py SCENARIO.json --seacover BIN \
        --python VENV_PYTHON [--repeat N] [--seacover-runs K] [--work DIR] [--json FILE]

Standard library only (the NumPy side runs in --python's environment).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def timed(cmd, stdout_path):
    """Wall seconds of one process, its stdout to stdout_path; fails loudly."""
    with open(stdout_path, "wb") as out:
        t0 = time.perf_counter()
        done = subprocess.run(cmd, stdout=out, stderr=subprocess.PIPE)
        seconds = time.perf_counter() - t0
    if done.returncode != 0:
        sys.exit(
            f"side_by_side.py: {' '.join(cmd)} exited {done.returncode}:\n"
            + done.stderr.decode(errors="replace")
        )
    return seconds


def summary(xs):
    q = statistics.quantiles(xs, n=4) if len(xs) >= 2 else [xs[0]] * 3
    return {
        "median": statistics.median(xs),
        "q1": q[0],
        "q3": q[2],
        "min": min(xs),
        "runs": len(xs),
    }


def fmt_ms(seconds):
    return f"{seconds * 1e3:.1f} ms" if seconds < 10 else f"{seconds:.2f} s"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--seacover", required=True, help="the seacover binary")
    parser.add_argument("--python", required=True, help="interpreter with NumPy and SciPy")
    parser.add_argument("--repeat", type=int, default=15, help="rounds (default 15)")
    parser.add_argument(
        "--seacover-runs", type=int, default=3, help="seacover runs per round (default 3)"
    )
    parser.add_argument("--work", default="target/bench-baseline", help="output files here")
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()
    if args.repeat < 1 or args.seacover_runs < 1:
        parser.error("--repeat and --seacover-runs must be at least 1")

    os.makedirs(args.work, exist_ok=True)
    name = os.path.splitext(os.path.basename(args.scenario))[0]
    numpy_out = os.path.join(args.work, f"{name}.side-numpy.json")
    seacover_out = os.path.join(args.work, f"{name}.side-seacover.json")
    numpy_cmd = [
        args.python,
        os.path.join(HERE, "coverage_grid.py"),
        args.scenario,
        "--out",
        numpy_out,
    ]
    seacover_cmd = [args.seacover, "evaluate", args.scenario]

    numpy_inside = []  # the script's own timing of its evaluation

    def numpy_run():
        seconds = timed(numpy_cmd, numpy_out + ".log")
        with open(numpy_out) as fh:
            numpy_inside.append(json.load(fh)["seconds_median"])
        return seconds

    def seacover_run():
        return timed(seacover_cmd, seacover_out)

    # Warm-up, untimed; also checks that both agree on H.
    numpy_run()
    seacover_run()
    numpy_inside.clear()
    h_numpy = json.load(open(numpy_out))["H"]
    h_seacover = json.load(open(seacover_out))["H"]
    if abs(h_numpy - h_seacover) > 1e-3 * abs(h_seacover):
        sys.exit(f"side_by_side.py: H differs: NumPy {h_numpy}, seacover {h_seacover}")

    numpy_times, seacover_times = [], []
    for r in range(args.repeat):
        if r % 2 == 0:
            numpy_times.append(numpy_run())
            seacover_times.extend(seacover_run() for _ in range(args.seacover_runs))
        else:
            seacover_times.extend(seacover_run() for _ in range(args.seacover_runs))
            numpy_times.append(numpy_run())

    n, s = summary(numpy_times), summary(seacover_times)
    inside = summary(numpy_inside)
    ratio = n["median"] / s["median"]
    ratio_inside = inside["median"] / s["median"]
    result = {
        "scenario": args.scenario,
        "numpy_seconds": n,
        "seacover_seconds": s,
        "ratio_of_medians": ratio,
        "numpy_evaluation_seconds": inside,
        "ratio_to_numpy_evaluation": ratio_inside,
        "cpus": os.cpu_count(),
        "H": {"numpy": h_numpy, "seacover": h_seacover},
        "numpy_all": numpy_times,
        "seacover_all": seacover_times,
    }
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=1)
            fh.write("\n")

    print(f"{args.scenario}, whole process, {os.cpu_count()} CPUs:")
    for label, x in (("NumPy 1 m grid", n), ("seacover evaluate", s)):
        print(
            f"  {label:<18} median {fmt_ms(x['median'])}"
            f" (quartiles {fmt_ms(x['q1'])} - {fmt_ms(x['q3'])}, min {fmt_ms(x['min'])},"
            f" {x['runs']} runs)"
        )
    print(f"  ratio of medians: {ratio:.0f}x")
    print(
        f"  (NumPy's evaluation alone, as the script times it without start-up, imports,"
        f" parsing and output: median {fmt_ms(inside['median'])};"
        f" seacover's whole process is {ratio_inside:.0f}x faster than that)"
    )


if __name__ == "__main__":
    main()
