"""Writes the two learned-belief scenarios the benchmarks evaluate
(docs/learning.md, "Cost"): the fleet and region of a scenario with its
risk replaced by a lattice of Gaussians such as the learner fits, each of
spread equal to the spacing and weight 0.3 times the scenario's own risk at
its centre (positive, as a fitted belief's weights are), over a base of 0.1.

    python bench/baseline/belief_scenarios.py

writes examples/paper-belief.json (20 x 20 = 400 Gaussians over the
paper's square) and examples/fleet-1000-belief.json (71 x 71 = 5041 over
fleet-1000's square). Deterministic: running it again writes the same bytes.
"""

import json
import math
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]


def risk_at(risk, x, y):
    return risk["base"] + sum(
        o["alpha"] * math.exp(-((x - o["x"]) ** 2 + (y - o["y"]) ** 2) / (2 * o["sigma"] ** 2))
        for o in risk["objects"]
    )


def belief(source, name, per_side):
    doc = json.loads((ROOT / "examples" / f"{source}.json").read_text())
    xs = [p[0] for p in doc["region"]["polygon"]]
    ys = [p[1] for p in doc["region"]["polygon"]]
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    h = (x1 - x0) / (per_side - 1)
    objects = []
    for j in range(per_side):
        for i in range(per_side):
            x, y = x0 + i * h, y0 + j * (y1 - y0) / (per_side - 1)
            objects.append(
                {
                    "x": round(x, 6),
                    "y": round(y, 6),
                    "alpha": round(0.3 * risk_at(doc["risk"], x, y), 9),
                    "sigma": round(h, 6),
                }
            )
    out = {
        "name": name,
        "region": doc["region"],
        "risk": {"base": 0.1, "objects": objects},
        "vessels": doc["vessels"],
    }
    path = ROOT / "examples" / f"{name}.json"
    path.write_text(json.dumps(out, separators=(",", ":")) + "\n")
    print(f"{path}: {len(objects)} Gaussians, spacing {h:.3f} m, {len(doc['vessels'])} vessels")


if __name__ == "__main__":
    belief("paper", "paper-belief", 20)
    belief("fleet-1000", "fleet-1000-belief", 71)
