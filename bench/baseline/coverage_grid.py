"""NumPy 1 m grid baseline for one coverage evaluation (masses, centroids, H).

This is the comparison point for seacover's benchmark table: the way coverage-
control code is usually written in research prototypes. The region is sampled
with the composite midpoint rule on a 1 m grid, every sample is given to its
nearest vessel with a k-d tree (an ordinary Voronoi partition, so all vessels
must share k and beta), and the per-cell integrals

    M_i = integral over V_i of f_i * Phi,     C_i = (1 / M_i) integral of q f_i Phi,
    f_i(q) = k exp(-beta |q - p_i|^2),
    Phi(q) = phi0 + sum_j alpha_j exp(-|q - s_j|^2 / (2 sigma_j^2)),

are sums of the sample weights per cell (np.bincount). H = sum_i M_i.

Grid: 1 m cells tile the region's bounding box from its lower-left corner, so
cell centres are at x0 + 0.5, x0 + 1.5, ... When the box's width or height is
not a whole number of metres (fleet-100 is 316.2 m wide) the last row and
column of cells are cut at the box's edge: their sample sits at the centre of
the cut cell and carries its smaller area. Without that the grid would miss or
overshoot a strip of the region and H would be off by ~1e-3 from the edges
alone. When the region is not its own bounding box (any other polygon, or one
with holes) samples whose centre falls outside are dropped, by an even-odd
test over all rings; cut cells are then not area-weighted along the slanted
edges, which is the usual first-order staircase error of a masked grid.

Everything runs on one thread (the environment variables below are set before
NumPy is imported; cKDTree.query uses one worker by default) so that the time
compares with seacover's single-threaded criterion benchmark. The timed part is
one full evaluation from the parsed scenario: grid, tree build and query,
density and actuator, per-cell sums. JSON parsing is not timed, as in the Rust
benchmark. The grid is processed in blocks of rows so that memory stays bounded
(fleet-10000 is a 3163 x 3163 grid); risk objects are added one at a time for
the same reason.

Usage:
    python3 bench/baseline/coverage_grid.py SCENARIO.json [--repeat N] [--out FILE]

Output (stdout, or FILE with a one-line summary on stderr):
    {"H", "seconds_median", "seconds_all", "grid": {...}, "versions": {...},
     "cells": [{"id", "mass", "centroid": [x, y]}, ...]}    (cells in vessel order)
"""

import os

# Single-threaded, like the Rust benchmark. Must precede the NumPy import.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

GRID_STEP = 1.0  # metres
BLOCK_POINTS = 1 << 20  # samples per row block (~8 MB per float64 array)


def load_scenario(path):
    """Parse a scenario document into plain NumPy arrays (not timed)."""
    with open(path) as fh:
        doc = json.load(fh)
    region = doc["region"]
    rings = [np.asarray(region["polygon"], dtype=float)]
    rings += [np.asarray(h, dtype=float) for h in region.get("holes", [])]
    risk = doc["risk"]
    objects = np.array(
        [[o["x"], o["y"], o["alpha"], o["sigma"]] for o in risk["objects"]], dtype=float
    ).reshape(-1, 4)
    vessels = doc["vessels"]
    ks = {float(v["k"]) for v in vessels}
    betas = {float(v["beta"]) for v in vessels}
    if len(ks) != 1 or len(betas) != 1:
        # With unequal k or beta the cells are not the nearest-vessel (Voronoi)
        # cells any more, and a k-d tree does not find them.
        sys.exit("coverage_grid.py: all vessels must share k and beta")
    return {
        "rings": rings,
        "phi0": float(risk["base"]),
        "objects": objects,
        "ids": [v["id"] for v in vessels],
        "positions": np.array([[v["x"], v["y"]] for v in vessels], dtype=float),
        "k": ks.pop(),
        "beta": betas.pop(),
    }


def axis_samples(lo, hi, step):
    """Midpoints and widths of the grid cells tiling [lo, hi], last one cut at hi."""
    # The tolerance keeps a width like 3.0000000001 from adding a sliver cell.
    n = max(1, math.ceil((hi - lo) / step - 1e-9))
    edges = np.minimum(lo + step * np.arange(n + 1), hi)
    edges[-1] = hi
    return 0.5 * (edges[:-1] + edges[1:]), np.diff(edges)


def is_bounding_box(rings):
    """True when the region is a single axis-aligned rectangle (no holes)."""
    if len(rings) != 1:
        return False
    outer = rings[0]
    if len(outer) > 1 and np.array_equal(outer[0], outer[-1]):
        outer = outer[:-1]  # tolerate an explicitly closed ring
    if len(outer) != 4:
        return False
    edges = np.roll(outer, -1, axis=0) - outer
    axis_aligned = ((edges[:, 0] == 0) != (edges[:, 1] == 0)).all()
    corners = {(x, y) for x, y in outer.tolist()}
    return bool(axis_aligned and len(corners) == 4)


def inside_even_odd(x, y, rings):
    """Even-odd point-in-polygon over all rings (outer and holes) at once."""
    inside = np.zeros(x.shape, dtype=bool)
    for ring in rings:
        xa, ya = ring[:, 0], ring[:, 1]
        xb, yb = np.roll(xa, -1), np.roll(ya, -1)
        for ax, ay, bx, by in zip(xa, ya, xb, yb):
            if ay == by:
                continue  # horizontal edges never cross a horizontal ray
            crosses = (ay > y) != (by > y)
            x_cross = ax + (y - ay) * (bx - ax) / (by - ay)
            inside ^= crosses & (x < x_cross)
    return inside


def evaluate(sc):
    """One full evaluation. Returns (H, masses, centroids, grid info)."""
    rings, positions = sc["rings"], sc["positions"]
    n = len(positions)
    outer = rings[0]
    xs, wx = axis_samples(outer[:, 0].min(), outer[:, 0].max(), GRID_STEP)
    ys, wy = axis_samples(outer[:, 1].min(), outer[:, 1].max(), GRID_STEP)
    masked = not is_bounding_box(rings)

    tree = cKDTree(positions)
    mass = np.zeros(n)
    moment_x = np.zeros(n)
    moment_y = np.zeros(n)
    samples = 0
    rows_per_block = max(1, BLOCK_POINTS // len(xs))
    for start in range(0, len(ys), rows_per_block):
        by = ys[start:start + rows_per_block]
        X = np.broadcast_to(xs, (len(by), len(xs))).ravel()
        Y = np.repeat(by, len(xs))
        area = np.outer(wy[start:start + rows_per_block], wx).ravel()
        if masked:
            keep = inside_even_odd(X, Y, rings)
            X, Y, area = X[keep], Y[keep], area[keep]
        if X.size == 0:
            continue
        samples += X.size

        # Nearest vessel; the tree also returns the distance that f needs.
        dist, owner = tree.query(np.column_stack((X, Y)))
        f = sc["k"] * np.exp(-sc["beta"] * dist * dist)

        phi = np.full(X.shape, sc["phi0"])
        for sx, sy, alpha, sigma in sc["objects"]:
            phi += alpha * np.exp(-((X - sx) ** 2 + (Y - sy) ** 2) / (2.0 * sigma * sigma))

        w = area * f * phi
        mass += np.bincount(owner, weights=w, minlength=n)
        moment_x += np.bincount(owner, weights=w * X, minlength=n)
        moment_y += np.bincount(owner, weights=w * Y, minlength=n)

    with np.errstate(invalid="ignore", divide="ignore"):
        centroids = np.column_stack((moment_x / mass, moment_y / mass))
    grid = {"nx": len(xs), "ny": len(ys), "samples": samples, "step": GRID_STEP, "masked": masked}
    return float(mass.sum()), mass, centroids, grid


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", help="scenario JSON document")
    parser.add_argument("--repeat", type=int, default=1, help="timed evaluations (median reported)")
    parser.add_argument("--out", help="write the result here instead of stdout")
    args = parser.parse_args()
    if args.repeat < 1:
        parser.error("--repeat must be at least 1")

    sc = load_scenario(args.scenario)
    seconds = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        H, mass, centroids, grid = evaluate(sc)
        seconds.append(time.perf_counter() - t0)

    # A cell that got no sample (a vessel with a tiny cell) has no centroid:
    # reported as null, never as NaN, so the output stays valid JSON.
    def num(v):
        return float(v) if math.isfinite(v) else None

    result = {
        "H": H,
        "seconds_median": statistics.median(seconds),
        "seconds_all": seconds,
        "grid": grid,
        "versions": {"python": sys.version.split()[0], "numpy": np.__version__, "scipy": scipy.__version__},
        "cells": [
            {"id": i, "mass": float(m), "centroid": [num(c[0]), num(c[1])]}
            for i, m, c in zip(sc["ids"], mass, centroids)
        ],
    }
    text = json.dumps(result)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text + "\n")
        print(
            f"{args.scenario}: H={H:.10g} median {result['seconds_median']:.4g} s "
            f"over {args.repeat} run(s), grid {grid['nx']}x{grid['ny']}",
            file=sys.stderr,
        )
    else:
        print(text)


if __name__ == "__main__":
    main()
