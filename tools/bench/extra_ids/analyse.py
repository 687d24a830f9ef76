"""Where the extra final ids of a run come from (docs/benchmarks/16-extra-ids.md).

Usage: python3 analyse.py SCENE RUN DEBUG > extra.json, where SCENE is a `splatseg synth` folder,
RUN the `splatseg run SCENE --masks SCENE/sam --features SCENE/features --gt SCENE/gt --out RUN`
folder (as `bench quality` runs it) and DEBUG the file a run of a binary with a temporary
instrumentation of `LiftStage::run` wrote (not in the code base; lines `reserved N`, `split CHILD
PARENT`, `gauss ID N` after the split, `snapped|given|filled VIEW ID PX` after snapping, the
give-back and the fill, `owned VIEW ID`, `new OLD NEW` the final numbering).

Every final id belongs to the ground-truth instance holding most of its pixels over all views;
per instance the largest such id is its own, the others are extra. Each extra id is printed with
its origin (a matched global id, or a cluster the 3D split cut off object P), pixels, views,
Gaussians and the views where it wins a SAM region.
"""
import sys, json, numpy as np
from PIL import Image
from collections import defaultdict
S, R, D = sys.argv[1:4]
objs = json.load(open(f"{S}/gt/objects.json"))
views = objs["views"]
names = {}
for o in objs.get("objects", []):
    if isinstance(o, dict) and "id" in o:
        names[o["id"]] = o.get("name", "?")
names.setdefault(1, "floor"); names.setdefault(2, "left_wall"); names.setdefault(3, "back_wall")
# pred x gt pixel counts
inter = defaultdict(int); pred_px = defaultdict(int); gt_px = defaultdict(int); pred_views = defaultdict(set)
for vi, v in enumerate(views):
    p = np.array(Image.open(f"{R}/masks/{v}.png")).astype(np.int64)
    g = np.array(Image.open(f"{S}/gt/instance/{v}.png")).astype(np.int64)
    key = p * 100000 + g
    u, c = np.unique(key, return_counts=True)
    for k, n in zip(u, c):
        pi, gi = divmod(int(k), 100000)
        inter[(pi, gi)] += int(n)
        if pi: pred_px[pi] += int(n); pred_views[pi].add(vi)
        if gi: gt_px[gi] += int(n)
P = sorted(pred_px); G = sorted(gt_px)
# each pred id belongs to its majority GT (or background 0); per GT the largest such pred is its
# main id, the others extra
major = {p: max(list(G) + [0], key=lambda g: inter.get((p, g), 0)) for p in P}
main = {}
for p in P:
    g = major[p]
    if g and (g not in main or inter[(p, g)] > inter[(main[g], g)]): main[g] = p
matched = {p: g for g, p in main.items()}
# debug: origin of final ids
dbg = [l.split() for l in open(D)]
reserved = int([l for l in dbg if l[0] == "reserved"][0][1])
parent = {int(l[1]): int(l[2]) for l in dbg if l[0] == "split"}
gauss = {int(l[1]): int(l[2]) for l in dbg if l[0] == "gauss"}
old_of_new = {int(l[2]): int(l[1]) for l in dbg if l[0] == "new" and l[2] != "0"}
def stage_px(st):
    d = defaultdict(int)
    for l in dbg:
        if l[0] == st: d[int(l[2])] += int(l[3])
    return d
snapped, given, filled = stage_px("snapped"), stage_px("given"), stage_px("filled")
owned = defaultdict(set)
for l in dbg:
    if l[0] == "owned": owned[int(l[2])].add(int(l[1]))
gt_gid = None
out = []
for p in P:
    if p in matched: continue
    old = old_of_new.get(p, -1)
    best = max(G, key=lambda g: inter.get((p, g), 0))
    share = inter.get((p, best), 0) / pred_px[p]
    origin = ("split of %d" % parent[old]) if old in parent else ("matched" if old < reserved else "?")
    if gauss.get(old, 0) == 0 and snapped.get(old, 0) == 0: origin += "+fill-only"
    out.append(dict(final=p, old=old, origin=origin, px=pred_px[p], views=len(pred_views[p]),
                    gt=best, gt_name=names.get(best, str(best)), share=round(share, 2), gaussians=gauss.get(old, 0),
                    snapped_px=snapped.get(old, 0), given_px=given.get(old, 0), filled_px=filled.get(old, 0),
                    owned_views=len(owned.get(old, ()))))
print(json.dumps(dict(scene=S, n_pred=len(P), n_gt=len(G), extra=out)))
