#!/usr/bin/env python3
"""Builds the Results tables of docs/benchmarks.md from `normalnet bench` results.

    python3 docs/make_benchmarks.py GD_TABLE2_DIR GD_DEFAULTS_DIR CNR_DIR [--print] [--page PAGE]

Each DIR is the --out folder of one bench (its results.json). The three
tables replace what lies between the two marker comments of PAGE (default:
docs/benchmarks.md beside this script), in place; the rest of the page is
kept byte for byte. --print writes the tables to stdout instead. Only the
standard library is used. E_a in degrees; best ranked method per row in bold
(the oracle reads the ground truth and is never ranked); per-noise-level
means for the cnr set (n1, n2, n3) and an overall mean; the time row is the
sum of the denoising calls over the table's meshes.
"""

import argparse
import json
import os
import sys
from collections import defaultdict

BEGIN = "<!-- tables from docs/make_benchmarks.py: begin -->"
END = "<!-- tables from docs/make_benchmarks.py: end -->"

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


def tables(gd2, gdd, cnr):
    """The three Results tables as one markdown block (no trailing newline)."""
    return "\n".join([
        "### gd test models, the paper's Table 2 settings (`configs/bench.toml`)\n",
        table(gd2),
        "\n### gd test models, every method at its own defaults\n",
        table(gdd),
        "\n### cnr synthetic test set (30 pairs), every method at its own defaults\n",
        table(cnr, groups=["_n1", "_n2", "_n3"]),
    ])


def replace_between_markers(page, block):
    """Writes `block` between BEGIN and END of the file `page` (temporary
    file, then rename); everything outside the markers is kept."""
    with open(page, encoding="utf-8") as fh:
        text = fh.read()
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        sys.exit(f"{page}: no `{BEGIN}` ... `{END}` pair; nothing written")
    start += len(BEGIN)
    text = text[:start] + "\n\n" + block + "\n\n" + text[end:]
    tmp = f"{page}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(tmp, page)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("gd_table2", help="bench --out folder: gd models, Table 2 settings")
    ap.add_argument("gd_defaults", help="bench --out folder: gd models, every default")
    ap.add_argument("cnr", help="bench --out folder: the cnr set, every default")
    ap.add_argument("--print", action="store_true", help="write the tables to stdout, not PAGE")
    ap.add_argument("--page", default=os.path.join(here, "benchmarks.md"),
                    help="the page whose marked block is replaced (default: %(default)s)")
    args = ap.parse_args()
    block = tables(args.gd_table2, args.gd_defaults, args.cnr)
    if args.print:
        print(block)
    else:
        replace_between_markers(args.page, block)


if __name__ == "__main__":
    main()
