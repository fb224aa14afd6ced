"""Build the seacover-vs-NumPy benchmark table from one scripts/bench-baseline run.

Reads, for each scenario NAME (standard library only):
  WORK/NAME.reference.json  seacover evaluate --tolerance ... (high-accuracy reference)
  WORK/NAME.seacover.json   seacover evaluate (default mode)
  WORK/NAME.numpy.json      bench/baseline/coverage_grid.py --out
  CRITERION/evaluate/NAME/new/estimates.json   criterion's estimates (median, ns)

and prints a Markdown table (also written to --out). Errors are maxima over
cells against the reference: centroid error is the Euclidean distance in
metres, mass error is |M - M_ref| / M_ref. Cells are matched by id.

--since EPOCH rejects criterion estimates older than that time, so that a
benchmark that did not run (filtered out, failed) cannot leave a stale number
in the table.
"""

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time


def load(path):
    with open(path) as fh:
        return json.load(fh)


def max_errors(result, reference):
    """(max centroid error in m, max relative mass error) of result vs reference."""
    ref = {c["id"]: c for c in reference["cells"]}
    ids = [c["id"] for c in result["cells"]]
    if sorted(ids) != sorted(ref):
        raise SystemExit("compare.py: cell ids differ from the reference's")
    centroid, mass = 0.0, 0.0
    for cell in result["cells"]:
        r = ref[cell["id"]]
        if None in cell["centroid"]:
            centroid = math.inf  # a cell the method found no sample in
        else:
            centroid = max(centroid, math.dist(cell["centroid"], r["centroid"]))
        mass = max(mass, abs(cell["mass"] - r["mass"]) / r["mass"])
    return centroid, mass


def criterion_median_ns(criterion_dir, name, since):
    path = os.path.join(criterion_dir, "evaluate", name, "new", "estimates.json")
    if not os.path.exists(path):
        raise SystemExit(f"compare.py: no criterion estimates for {name} at {path}")
    if since is not None and os.path.getmtime(path) < since:
        raise SystemExit(f"compare.py: {path} predates this run (benchmark did not run?)")
    return load(path)["median"]["point_estimate"]


def fmt_time(seconds):
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("µs", 1e-6), ("ns", 1e-9)):
        if seconds >= scale or unit == "ns":
            return f"{seconds / scale:.3g} {unit}"


def fmt_err(x):
    return "–" if x is None else f"{x:.1e}"


def cpu_model():
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def rustc_version():
    try:
        return subprocess.run(["rustc", "--version"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "rustc (unknown version)"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="+")
    ap.add_argument("--work", required=True, help="directory with the NAME.*.json results")
    ap.add_argument("--criterion", default="target/criterion")
    ap.add_argument("--tolerance", required=True, help="reference tolerance, for the caption")
    ap.add_argument("--since", type=float, help="reject criterion estimates older than this epoch")
    ap.add_argument("--out", help="also write the Markdown here")
    args = ap.parse_args()

    rows, h_rows, versions = [], [], None
    for name in args.scenarios:
        seacover = load(os.path.join(args.work, f"{name}.seacover.json"))
        numpy_res = load(os.path.join(args.work, f"{name}.numpy.json"))
        ref_path = os.path.join(args.work, f"{name}.reference.json")
        reference = load(ref_path) if os.path.exists(ref_path) else None
        versions = numpy_res["versions"]

        ours_s = criterion_median_ns(args.criterion, name, args.since) * 1e-9
        grid_s = numpy_res["seconds_median"]
        if reference is not None:
            sc_c, sc_m = max_errors(seacover, reference)
            np_c, np_m = max_errors(numpy_res, reference)
            h_ref = reference["H"]
            h_rows.append(
                f"| {name} | {h_ref:.10g} | {fmt_err(abs(seacover['H'] - h_ref) / h_ref)} "
                f"| {fmt_err(abs(numpy_res['H'] - h_ref) / h_ref)} "
                f"| {numpy_res['grid']['nx']} × {numpy_res['grid']['ny']} |"
            )
        else:
            sc_c = sc_m = np_c = np_m = None
        rows.append(
            f"| {name} | {len(seacover['cells'])} | {fmt_time(ours_s)} | {fmt_time(grid_s)} "
            f"| {grid_s / ours_s:,.0f}× | {fmt_err(sc_c)} | {fmt_err(np_c)} "
            f"| {fmt_err(sc_m)} | {fmt_err(np_m)} |"
        )

    lines = [
        f"Measured {time.strftime('%Y-%m-%d')} on {cpu_model()}, one thread each; "
        f"{rustc_version()}; Python {versions['python']}, NumPy {versions['numpy']}, "
        f"SciPy {versions['scipy']}. Times are medians of one full evaluation "
        f"(criterion for seacover, repeated runs in the same script for NumPy); "
        f"errors are maxima over cells against seacover's adaptive reference "
        f"(`--tolerance {args.tolerance}`).",
        "",
        "| scenario | vessels | seacover median time | NumPy 1 m grid median time (same run) "
        "| speed-up | seacover max centroid error (m) | NumPy max centroid error (m) "
        "| seacover max relative mass error | NumPy max relative mass error |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        *rows,
    ]
    if h_rows:
        lines += [
            "",
            "| scenario | H (reference) | seacover relative error of H | NumPy relative error of H | NumPy grid |",
            "|---|---:|---:|---:|---:|",
            *h_rows,
        ]
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()
