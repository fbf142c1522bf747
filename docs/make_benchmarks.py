#!/usr/bin/env python3
"""Builds the tables of docs/benchmarks.md from `normalnet bench` results.

    python3 docs/make_benchmarks.py GD_TABLE2_DIR GD_DEFAULTS_DIR CNR_DIR > tables.md

Each DIR is the --out folder of one bench (its results.json). Only the
standard library is used. E_a in degrees; best ranked method per row in bold
(the oracle reads the ground truth and is never ranked); per-noise-level
means for the cnr set (n1, n2, n3) and an overall mean; the time row is the
sum of the denoising calls over the table's meshes.
"""

import json
import sys
from collections import defaultdict

UNRANKED = {"oracle", "noisy"}


def load(path):
    with open(f"{path}/results.json") as fh:
        r = json.load(fh)
    methods = ["noisy"] + [m for m in r["methods"]]
    e_a = defaultdict(dict)
    secs = defaultdict(float)
    for x in r["records"]:
        if x.get("e_a_deg") is not None:
            e_a[x["model"]][x["method"]] = x["e_a_deg"]
        if x.get("denoise_seconds") is not None:
            secs[x["method"]] += x["denoise_seconds"]
    return r, methods, e_a, secs


def row(label, values, methods):
    ranked = [values[m] for m in methods if m not in UNRANKED and values.get(m) is not None]
    best = min(ranked) if ranked else None
    cells = []
    for m in methods:
        v = values.get(m)
        if v is None:
            cells.append("–")
        elif m not in UNRANKED and v == best:
            cells.append(f"**{v:.2f}**")
        else:
            cells.append(f"{v:.2f}")
    return f"| {label} | " + " | ".join(cells) + " |"


def table(path, groups=None):
    r, methods, e_a, secs = load(path)
    out = ["| model | " + " | ".join(methods) + " |", "|---|" + "---:|" * len(methods)]
    models = r["models"]
    for m in models:
        out.append(row(m, e_a[m], methods))

    def mean_of(ms):
        vals = {}
        for meth in methods:
            xs = [e_a[m][meth] for m in ms if meth in e_a[m]]
            if len(xs) == len(ms) and xs:
                vals[meth] = sum(xs) / len(xs)
        return vals

    if groups:
        for g in groups:
            ms = [m for m in models if m.endswith(g)]
            if ms:
                out.append(row(f"*mean {g}*", mean_of(ms), methods))
    out.append(row("**mean**", mean_of(models), methods))
    out.append("| time (s) | " + " | ".join("–" if m == "noisy" else f"{secs[m]:.1f}" for m in methods) + " |")
    return "\n".join(out)


def main():
    gd2, gdd, cnr = sys.argv[1:4]
    print("### gd test models, the paper's Table 2 settings (`configs/bench.toml`)\n")
    print(table(gd2))
    print("\n### gd test models, every method at its own defaults\n")
    print(table(gdd))
    print("\n### cnr synthetic test set (30 pairs), every method at its own defaults\n")
    print(table(cnr, groups=["_n1", "_n2", "_n3"]))


if __name__ == "__main__":
    main()
