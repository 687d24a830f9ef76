#!/usr/bin/env python3
"""Measure the object graph's evidence against ground truth (issue 58).

Every `run` writes its object graph to `OUT/cache/graph.json`; `splatseg bench quality --out DIR`
keeps each scene's as `DIR/graphs/<family>_<seed>_<descriptors>.json`, each edge with the object
ground truth says each side mostly is. This script reads such folders and

1. labels every edge *same* (both sides mostly the same ground-truth object) or *different*
   (edges with a side that is mostly no object, or less than `--purity` pure, are left out: no
   decision can be right about an impure node);
2. scores the run's own decision (the rules of `crates/lift/src/touching.rs`: an edge counts as
   joined when its outcome is "joined" or "already one set");
3. fits one logistic model, a sum of log-odds over the edge's named terms (surface, views,
   appearance, SAM's wholes), on the first folder, and scores it on every folder, so that a term's
   weight is measured, not chosen; `--drop TERM` fits without a term (the ablation).

Errors are weighted by what they cost: the Gaussians of the smaller side (a wrong join of two
large objects loses one of them, a missed join of a small piece loses the piece).

Pure Python (no NumPy: it runs where the Rust toolchain does). Usage:

    python3 tools/edge_study.py FIT_DIR [TEST_DIR ...] [--descriptors features] [--drop cos]
"""

import argparse
import glob
import json
import math
import os
import sys

TERMS = [
    # (name, function of the edge record) — each a number the decision weighs.
    ("contact", lambda e: math.log1p(e["voxel_pairs"])),
    ("smooth", lambda e: e["smooth"] / e["measured"] if e["measured"] else 0.0),
    ("concave", lambda e: e["concave"] / e["oriented"] if e["oriented"] else 0.0),
    ("convex", lambda e: e["convex"] / e["oriented"] if e["oriented"] else 0.0),
    ("coplanar", lambda e: float(e["coplanar"])),
    ("thin_line", lambda e: float(e["thin_line"])),
    ("views", lambda e: math.log((e["together"] + 0.5) / (e["seeing_both"] - e["together"] + 0.5))),
    ("views_seen", lambda e: math.log1p(e["seeing_both"])),
    ("sam", lambda e: math.log((e["sam"]["together"] + 0.5) / (e["sam"]["apart"] + 0.5)) if e.get("sam") else 0.0),
    ("cos", lambda e: e["cos"]),
    ("small_side", lambda e: math.log1p(min(e["sizes"]))),
    # The rules' conjunctions, as terms of their own: one surface continuing on a plane; no
    # concave edge where the views hold both together; a convex edge with no concave one.
    ("seam", lambda e: float(e["coplanar"]) * (e["smooth"] / e["measured"] if e["measured"] else 0.0)),
    ("no_edge_together", lambda e: (1.0 - (e["concave"] / e["oriented"] if e["oriented"] else 1.0))
        * (e["together"] / e["seeing_both"] if e["seeing_both"] else 0.0)),
    ("convex_edge", lambda e: (e["convex"] - e["concave"]) / e["oriented"] if e["oriented"] else 0.0),
]


def _sam(e, k):
    return (e.get("sam") or {}).get(k, 0)


# The terms of `crates/lift/src/decision.rs` (`--model sqrt-counts`): counts that add up over the
# edges between two sets, each entering as its square root, two flags and the cosine. Same order
# as its `WEIGHTS`.
COUNT_TERMS = [
    ("views_together", lambda e: math.sqrt(e["together"])),
    ("views_apart", lambda e: math.sqrt(max(0, e["seeing_both"] - e["together"]))),
    ("sam_together", lambda e: math.sqrt(_sam(e, "together"))),
    ("sam_apart", lambda e: math.sqrt(_sam(e, "apart"))),
    ("concave", lambda e: math.sqrt(e["concave"])),
    ("not_concave", lambda e: math.sqrt(max(0, e["oriented"] - e["concave"]))),
    ("convex", lambda e: math.sqrt(e["convex"])),
    ("smooth", lambda e: math.sqrt(e["smooth"])),
    ("not_smooth", lambda e: math.sqrt(max(0, e["measured"] - e["smooth"]))),
    ("coplanar", lambda e: float(e["coplanar"])),
    ("thin_line", lambda e: float(e["thin_line"])),
    ("cos", lambda e: e["cos"]),
]


def _share(part, whole):
    return part / whole if whole else 0.0


# The terms of `crates/lift/src/decision.rs` (`--model kinds`, the lift's decision since
# docs/benchmarks/39): the views as counts (square roots), again where the contact is two planes or
# one thin line (SAM cuts a floor or a post into many masks, so there the views say less); SAM's
# wholes apart; the contact's shape as shares of its pairs (one observation, whatever the contact's
# size); the two flags and the cosine. Same order as its `WEIGHTS`.
def _views(e):
    return math.sqrt(e["together"]), math.sqrt(max(0, e["seeing_both"] - e["together"]))


KIND_TERMS = [
    ("views_together", lambda e: _views(e)[0]),
    ("views_apart", lambda e: _views(e)[1]),
    ("planes_x_together", lambda e: float(e["coplanar"]) * _views(e)[0]),
    ("planes_x_apart", lambda e: float(e["coplanar"]) * _views(e)[1]),
    ("sam_apart", lambda e: math.sqrt(_sam(e, "apart"))),
    ("concave_share", lambda e: _share(e["concave"], e["oriented"])),
    ("convex_share", lambda e: _share(e["convex"], e["oriented"])),
    ("smooth_share", lambda e: _share(e["smooth"], e["measured"])),
    ("coplanar", lambda e: float(e["coplanar"])),
    ("thin_line", lambda e: float(e["thin_line"])),
    ("line_x_apart", lambda e: float(e["thin_line"]) * _views(e)[1]),
    ("cos", lambda e: e["cos"]),
]


TERMS_IN_USE = TERMS


def load(folder, descriptors, purity):
    """Per graph under `folder`: its edges as (terms, same, cost, today's decision, (a, b),
    labelled), `same` None for an edge left out."""
    graphs = []
    paths = sorted(glob.glob(os.path.join(folder, "graphs", f"*_{descriptors}.json")))
    if not paths:
        sys.exit(f"no graphs in {folder}/graphs (run `splatseg bench quality --out {folder}` first)")
    for path in paths:
        with open(path) as f:
            graph = json.load(f)
        rows = []
        for e in graph["edges"]:
            truth = e.get("truth")
            labelled = bool(truth) and all(t["object"] >= 0 and t["purity"] >= purity for t in truth)
            same = truth[0]["object"] == truth[1]["object"] if labelled else None
            today = e["outcome"] == "joined"
            x = [f(e) for _, f in TERMS_IN_USE]
            rows.append((x, same, min(e["sizes"]), today, (e["a"], e["b"]), e))
        graphs.append((os.path.basename(path), rows))
    return graphs


def labelled(graphs):
    return [r for _, rows in graphs for r in rows if r[1] is not None]


def fit_stumps(rows, keep, rounds=150, rate=0.3, cuts=12):
    """Boosted one-split stumps on the log-loss: a sum of log-odds again, each term a step
    function of one input measured from the data (no term's shape is chosen). Returns a function
    of an edge's term vector."""
    xs = [r[0] for r in rows]
    ys = [1.0 if r[1] else 0.0 for r in rows]
    ws = [math.log1p(r[2]) for r in rows]
    thresholds = {}
    for k in keep:
        values = sorted(x[k] for x in xs)
        thresholds[k] = sorted({values[int(len(values) * q / cuts)] for q in range(1, cuts)})
    pos = sum(w for w, y in zip(ws, ys) if y)
    neg = sum(w for w, y in zip(ws, ys) if not y)
    bias = math.log(pos / neg)
    f = [bias] * len(xs)
    stumps = []
    for _ in range(rounds):
        p = [1.0 / (1.0 + math.exp(-max(-30.0, min(30.0, z)))) for z in f]
        g = [w * (y - pi) for w, y, pi in zip(ws, ys, p)]
        h = [w * pi * (1 - pi) + 1e-9 for w, pi in zip(ws, p)]
        best = None
        for k in keep:
            for t in thresholds[k]:
                gl = hl = 0.0
                for x, gi, hi in zip(xs, g, h):
                    if x[k] <= t:
                        gl += gi
                        hl += hi
                gr, hr = sum(g) - gl, sum(h) - hl
                gain = gl * gl / (hl + 1.0) + gr * gr / (hr + 1.0)
                if best is None or gain > best[0]:
                    best = (gain, k, t, gl / (hl + 1.0), gr / (hr + 1.0))
        _, k, t, left, right = best
        stumps.append((k, t, rate * left, rate * right))
        f = [fi + (rate * left if x[k] <= t else rate * right) for fi, x in zip(f, xs)]

    def log_odds(x):
        return bias + sum(l if x[k] <= t else r for k, t, l, r in stumps)

    return log_odds, stumps


def standardise(rows, keep):
    """Means and deviations of the kept terms over `rows`."""
    n = len(rows)
    mean = [sum(r[0][k] for r in rows) / n for k in keep]
    dev = []
    for j, k in enumerate(keep):
        v = sum((r[0][k] - mean[j]) ** 2 for r in rows) / n
        dev.append(math.sqrt(v) or 1.0)
    return mean, dev


def features(row, keep, mean, dev):
    return [(row[0][k] - mean[j]) / dev[j] for j, k in enumerate(keep)]


def fit(rows, keep, l2=1e-3, steps=3000, rate=0.5):
    """Logistic regression by gradient descent, each edge weighted by log(1 + its cost) so that
    a few large objects do not decide everything."""
    mean, dev = standardise(rows, keep)
    xs = [features(r, keep, mean, dev) for r in rows]
    ys = [1.0 if r[1] else 0.0 for r in rows]
    ws = [math.log1p(r[2]) for r in rows]
    total = sum(ws)
    w = [0.0] * len(keep)
    b = 0.0
    for _ in range(steps):
        gw = [0.0] * len(keep)
        gb = 0.0
        for x, y, c in zip(xs, ys, ws):
            z = b + sum(wi * xi for wi, xi in zip(w, x))
            p = 1.0 / (1.0 + math.exp(-max(-30.0, min(30.0, z))))
            d = (p - y) * c
            gb += d
            for j, xi in enumerate(x):
                gw[j] += d * xi
        b -= rate * gb / total
        w = [wi - rate * (g / total + l2 * wi) for wi, g in zip(w, gw)]
    return w, b, mean, dev


def find(parent, x):
    while parent.setdefault(x, x) != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


ADDITIVE = ["voxel_pairs", "measured", "smooth", "oriented", "concave", "convex", "seeing_both", "together"]


def pooled(edges):
    """One edge record standing for every edge between two sets: counts summed, flags any, the
    cosine weighted by contact, sizes of the two sets' sides as given."""
    e = {k: sum(x[k] for x in edges) for k in ADDITIVE}
    e["coplanar"] = any(x["coplanar"] for x in edges)
    e["thin_line"] = any(x["thin_line"] for x in edges)
    sams = [x["sam"] for x in edges if x.get("sam")]
    e["sam"] = {k: sum(s[k] for s in sams) for k in ("together", "apart", "seen")} if sams else None
    total = sum(x["voxel_pairs"] for x in edges) or 1
    e["cos"] = sum(x["cos"] * x["voxel_pairs"] for x in edges) / total
    return e


def agglomerate(rows, log_odds_of_edge, threshold):
    """Joins sets best first while the pooled evidence between two sets says more than
    `threshold`; returns the parent map."""
    parent = {}
    size = {}
    for r in rows:
        for side, n in zip(r[4], r[5]["sizes"]):
            size[side] = n
    while True:
        between = {}
        for r in rows:
            ra, rb = find(parent, r[4][0]), find(parent, r[4][1])
            if ra != rb:
                between.setdefault((min(ra, rb), max(ra, rb)), []).append(r[5])
        best = None
        for (ra, rb), edges in between.items():
            e = pooled(edges)
            e["sizes"] = [size[ra], size[rb]]
            z = log_odds_of_edge(e)
            if z > threshold and (best is None or z > best[0]):
                best = (z, ra, rb)
        if best is None:
            return parent
        _, ra, rb = best
        parent[rb] = ra
        size[ra] += size[rb]


def score_sets(graphs, make_parent):
    """Counts and cost-weighted errors over the labelled edges of the sets `make_parent(rows)` makes
    of each graph: an edge is joined when its two sides end in one set."""
    s = {"edges": 0, "wrong_joins": 0, "missed_joins": 0, "cost_wrong": 0, "cost_missed": 0, "cost": 0}
    for _, rows in graphs:
        parent = make_parent(rows)
        for r in rows:
            if r[1] is None:
                continue
            s["edges"] += 1
            joined = find(parent, r[4][0]) == find(parent, r[4][1])
            same, cost = r[1], r[2]
            s["cost"] += cost
            if joined and not same:
                s["wrong_joins"] += 1
                s["cost_wrong"] += cost
            elif same and not joined:
                s["missed_joins"] += 1
                s["cost_missed"] += cost
    return s


def score(graphs, decide):
    """[`score_sets`] of a pairwise decision: every edge `decide` accepts joined by union-find, as
    the lift's union-find does, each edge then judged by whether its two sides end in one set."""

    def union_of_accepted(rows):
        parent = {}
        for r in rows:
            if decide(r):
                ra, rb = find(parent, r[4][0]), find(parent, r[4][1])
                parent[max(ra, rb)] = min(ra, rb)
        return parent

    return score_sets(graphs, union_of_accepted)


def show(name, s):
    err = (s["cost_wrong"] + s["cost_missed"]) / max(1, s["cost"])
    print(
        f"  {name:<22} edges {s['edges']:>6}  wrong joins {s['wrong_joins']:>5} ({s['cost_wrong']:>9} G)  "
        f"missed {s['missed_joins']:>5} ({s['cost_missed']:>9} G)  cost-weighted error {err:.4f}"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="+", help="bench quality --out folders; the first is fitted on")
    ap.add_argument("--descriptors", default="features", choices=["features", "model_free"])
    ap.add_argument("--purity", type=float, default=0.8, help="a side less pure than this is left out")
    ap.add_argument("--drop", action="append", default=[], help="a term to leave out (repeatable)")
    ap.add_argument("--model", default="linear", choices=["linear", "stumps", "sqrt-counts", "kinds"],
                    help="one weight per term (linear), boosted stumps (a step function per term), the "
                         "square roots of counts that add up between sets (docs/benchmarks/38), or the views "
                         "as counts per kind of contact and its shape as shares (kinds: the lift's `decision`)")
    ap.add_argument("--halves", action="store_true",
                    help="also fit on the even seeds of the first folder and score the odd ones, and back")
    ap.add_argument("--breakdown", action="store_true", help="today's rules and outcomes against the truth")
    ap.add_argument("--thresholds", type=float, nargs="+", default=[0.0], help="join above these log-odds")
    args = ap.parse_args()
    global TERMS_IN_USE
    if args.model == "sqrt-counts":
        TERMS_IN_USE = COUNT_TERMS
    if args.model == "kinds":
        TERMS_IN_USE = KIND_TERMS
    names = [n for n, _ in TERMS_IN_USE]
    for d in args.drop:
        if d not in names:
            sys.exit(f"unknown term {d!r}; terms: {', '.join(names)}")
    keep = [k for k, n in enumerate(names) if n not in args.drop]
    sets = [(f, load(f, args.descriptors, args.purity)) for f in args.folders]
    # The lift's weights (`--model kinds`; `sqrt-counts` before) are the fit after 2,000 steps.
    steps = 2000 if args.model in ("sqrt-counts", "kinds") else 3000
    w, b, mean, dev = fit(labelled(sets[0][1]), keep, steps=steps)

    def log_odds(r):
        return b + sum(wi * xi for wi, xi in zip(w, features(r, keep, mean, dev)))

    if args.model == "stumps":
        stump_odds, stumps = fit_stumps(labelled(sets[0][1]), keep)
        log_odds = lambda r: stump_odds(r[0])  # noqa: E731
        used = {}
        for k, _, l, r in stumps:
            used[names[k]] = used.get(names[k], 0.0) + abs(l - r)
        print("  boosted stumps; summed log-odds step per term:",
              ", ".join(f"{n} {v:.2f}" for n, v in sorted(used.items(), key=lambda x: -x[1])))

    print(f"fitted on {sets[0][0]} ({len(labelled(sets[0][1]))} labelled edges, {args.descriptors}); "
          f"left out: {', '.join(args.drop) or 'nothing'}")
    print("  log-odds per deviation of each term (the term's mean and deviation):")
    for j, k in enumerate(keep):
        print(f"    {names[k]:<12} {w[j]:+.3f}   (mean {mean[j]:.3f}, deviation {dev[j]:.3f})")
    print(f"    {'bias':<12} {b:+.3f}")
    if args.model in ("sqrt-counts", "kinds"):
        print("  per unit of each term (crates/lift/src/decision.rs WEIGHTS):")
        for j, k in enumerate(keep):
            print(f"    {names[k]:<16} {w[j] / dev[j]:.4f}")
        print(f"    {'bias':<16} {b - sum(w[j] * mean[j] / dev[j] for j in range(len(keep))):.4f}")
    if args.halves:
        graphs = sets[0][1]
        parity = lambda name: int(name.split("_")[-2]) % 2  # noqa: E731
        for fit_on in (0, 1):
            train = [g for g in graphs if parity(g[0]) == fit_on]
            test = [g for g in graphs if parity(g[0]) != fit_on]
            hw, hb, hmean, hdev = fit(labelled(train), keep, steps=steps)
            half_odds = lambda e: hb + sum(  # noqa: E731
                wi * xi for wi, xi in zip(hw, features(([f(e) for _, f in TERMS_IN_USE],), keep, hmean, hdev)))
            label = "odd" if fit_on == 0 else "even"
            print(f"  fitted on the {'even' if fit_on == 0 else 'odd'} seeds, scored on the {label} ones:")
            show("today's rules", score(test, lambda r: r[3]))
            show("agglomerative > 0", score_sets(test, lambda g: agglomerate(g, half_odds, 0.0)))
    def breakdown(graphs):
        """Labelled edges by today's (rule, outcome): how many join one object, how many two."""
        table = {}
        for _, rows in graphs:
            for r in rows:
                if r[1] is None:
                    continue
                key = (r[5]["rule"], r[5]["outcome"])
                same, diff = table.get(key, (0, 0))
                table[key] = (same + r[1], diff + (not r[1]))
        for (rule, outcome), (same, diff) in sorted(table.items()):
            print(f"    {rule:<15} {outcome:<40} one object {same:>5}   two objects {diff:>5}")

    for folder, rows in sets:
        same = sum(1 for r in labelled(rows) if r[1])
        print(f"{folder}: {len(labelled(rows))} labelled edges, {same} same object, "
              f"{len(labelled(rows)) - same} different, in {len(rows)} graphs")
        show("today's rules", score(rows, lambda r: r[3]))
        if args.breakdown:
            breakdown(rows)
        for t in args.thresholds:
            show(f"log-odds > {t:g}", score(rows, lambda r: log_odds(r) > t))
            edge_odds = lambda e: log_odds(([f(e) for _, f in TERMS_IN_USE],))
            show(f"agglomerative > {t:g}", score_sets(rows, lambda g: agglomerate(g, edge_odds, t)))
        show("join nothing", score(rows, lambda r: False))


if __name__ == "__main__":
    main()
