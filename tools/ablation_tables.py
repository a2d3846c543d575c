#!/usr/bin/env python3
"""Markdown tables of the small-scale ablations (docs/ABLATIONS.md) from the eval summaries
that scripts/run_ablations.sh leaves in runs/ablations/<run>/eval/summary.json.

    tools/ablation_tables.py [RUNS_DIR]

The base configuration has three seeds: its cells are the mean ± the sample standard
deviation over them; every variant is one run (seed 0, same data and budget).
"""
import json
import statistics
import sys
from pathlib import Path

SPLITS = ["S.FoV", "L.FoV", "360°"]
BASE = ["s2_base_seed0", "s2_base_seed1", "s2_base_seed2"]


def load(runs, name):
    path = runs / name / "eval" / "summary.json"
    return json.loads(path.read_text()) if path.exists() else None


def score(summary, split, mode, entry, key):
    try:
        value = summary["scores"][split][mode]["entries"][entry][key]
    except (KeyError, TypeError):
        return None
    return None if value is None else 100.0 * value


def cell(runs, names, split, mode, entry, key):
    values = [v for v in (score(load(runs, n), split, mode, entry, key) for n in names) if v is not None]
    if not values:
        return "–"
    if len(values) == 1:
        return f"{values[0]:.1f}"
    return f"{statistics.mean(values):.1f} ± {statistics.stdev(values):.1f}"


def table(runs, rows, columns):
    """rows: [(label, [run names])]; columns: [(header, split, mode, entry, key)]."""
    lines = ["| Variant | " + " | ".join(c[0] for c in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for label, names in rows:
        lines.append(f"| {label} | " + " | ".join(cell(runs, names, *c[1:]) for c in columns) + " |")
    return "\n".join(lines)


def geometry_columns(mode="none"):
    columns = []
    for split in SPLITS:
        columns.append((f"{split} points Rel↓", split, mode, "points_scale_invariant", "rel"))
        columns.append((f"{split} points δ1↑", split, mode, "points_scale_invariant", "delta1"))
        columns.append((f"{split} depth Rel↓", split, mode, "depth_scale_invariant", "rel"))
    return columns


def main():
    runs = Path(sys.argv[1] if len(sys.argv) > 1 else "runs/ablations")
    base = ("Ray+D, P + GT-ray loss (base)", BASE)
    print("### Output representation (mode none)\n")
    print(table(runs, [base, ("XYZ head", ["s2_xyz"])], geometry_columns()))
    print("\n### Point loss (mode none)\n")
    print(table(runs, [("P + GT-ray (decoupled, base)", BASE), ("P (naive, entangled)", ["s2_naive"]),
                       ("D + Ray (disjoint)", ["s2_disjoint"])], geometry_columns()))
    print("\n### Bidirectional augmentation (360° split; none and +K)\n")
    columns = [("points Rel↓", "360°", "none", "points_scale_invariant", "rel"),
               ("points δ1↑", "360°", "none", "points_scale_invariant", "delta1"),
               ("depth Rel↓", "360°", "none", "depth_scale_invariant", "rel"),
               ("depth δ1↑", "360°", "none", "depth_scale_invariant", "delta1"),
               ("+K depth Rel↓", "360°", "+K", "depth_scale_invariant", "rel"),
               ("+K depth δ1↑", "360°", "+K", "depth_scale_invariant", "delta1")]
    print(table(runs, [("neither", ["s2_no_p2a_no_a2p"]), ("P2A only", ["s2_p2a_only"]),
                       ("A2P only", ["s2_a2p_only"]), ("P2A + A2P (base)", BASE)], columns))
    print("\n### Sparse-depth conditioning (+D mode)\n")
    columns = []
    for split in SPLITS:
        columns.append((f"{split} metric δ1↑", split, "+D", "points_metric", "delta1"))
        columns.append((f"{split} metric Rel↓", split, "+D", "points_metric", "rel"))
        columns.append((f"{split} points Rel↓", split, "+D", "points_scale_invariant", "rel"))
    print(table(runs, [("smoothing + state embeddings (base)", BASE),
                       ("no Gaussian smoothing", ["s2_no_smoothing"]),
                       ("no state embeddings", ["s2_no_state_embeddings"])], columns))


if __name__ == "__main__":
    main()
