"""The Gaussian-based variant of the cross-view SAM part-whole evidence, as the Rust gate would
compute it: per executed merge of view v, the Gaussians whose centre pixel lies in each side's
part of the contact band (pixels within Chebyshev distance R of the other side), and for every
other view w that sees them, the SAM masks (all, overlapping) holding their centre pixels.

usage: python3 collect_g.py SCENE MERGE_OUT OUT.json [R [R0 [interior]]]
  the zone: pixels of a side within R px (Chebyshev) of the other, not within R0 − 1 px of it
  (R0 = 0: no exclusion), with `interior` also not next to any other region. The gate as built:
  4 2. Needs SCENE/rdepth/<view>_depth.npy (`splatseg render SCENE --gaussians SCENE/gaussians.ply
  --what depth --out SCENE/rdepth`) for the visibility of the Gaussians' centres.
"""
import json
import sys
import numpy as np
from common import load_png, load_sam, load_cameras, dilate8

S, M, OUT = sys.argv[1], sys.argv[2], sys.argv[3]
R = int(sys.argv[4]) if len(sys.argv) > 4 else 2
R0 = int(sys.argv[5]) if len(sys.argv) > 5 else 0
INTERIOR = len(sys.argv) > 6 and sys.argv[6] == 'interior'
meta = json.load(open(f'{S}/gt/objects.json'))
views = meta['views']
poses = load_cameras(S)


def read_ply(path):
    with open(path, 'rb') as f:
        props = []
        n = 0
        while True:
            line = f.readline().decode().strip()
            if line.startswith('element vertex'):
                n = int(line.split()[-1])
            elif line.startswith('property'):
                props.append(line.split()[-1])
            elif line == 'end_header':
                break
        data = np.frombuffer(f.read(n * 4 * len(props)), dtype='<f4').reshape(n, len(props))
    return {p: data[:, i] for i, p in enumerate(props)}


ply = read_ply(f'{S}/gaussians.ply')
means = np.stack([ply['x'], ply['y'], ply['z']], 1).astype(np.float64)
sigma = np.exp(np.stack([ply['scale_0'], ply['scale_1'], ply['scale_2']], 1)).mean(1)
N = len(means)
gts = {v: load_png(f'{S}/gt/instance/{v}.png') for v in views}
H, W = gts[views[0]].shape
V = len(views)
# per view: visible Gaussians' pixel (or -1) and the packed mask bits per pixel
PIX = np.full((V, N), -1, dtype=np.int64)
sams = [load_sam(S, v) for v in views]
KMAX = max(len(m) for m in sams if m is not None)
NB = (KMAX + 7) // 8
BITS = np.zeros((V, H * W, NB), dtype=np.uint8)
for i, v in enumerate(views):
    K, Rm, t = poses[v]
    c = means @ Rm.T + t
    z = c[:, 2]
    p = c @ K.T
    with np.errstate(divide='ignore', invalid='ignore'):
        u, w_ = p[:, 0] / z, p[:, 1] / z
    ok = (z > 0.01) & (u >= 0) & (u < W) & (w_ >= 0) & (w_ < H)
    x = np.where(ok, u, 0).astype(int)
    y = np.where(ok, w_, 0).astype(int)
    d = np.nan_to_num(np.load(f'{S}/rdepth/{v}_depth.npy'), nan=0.0)
    surf = d[y, x]
    surf = np.where(surf > 0, surf, np.inf)
    ok &= z <= surf * 1.03 + sigma
    PIX[i] = np.where(ok, y * W + x, -1)
    if sams[i] is not None:
        m = np.zeros((KMAX, H, W), dtype=bool)
        m[:len(sams[i])] = sams[i]
        BITS[i] = np.packbits(m.reshape(KMAX, -1).T, axis=1)


def evidence(iv, zone_a, zone_b):
    """per other view: (n_a, n_b, together, whole_a, whole_b)."""
    own = PIX[iv]
    flat_a = np.flatnonzero(zone_a.ravel())
    flat_b = np.flatnonzero(zone_b.ravel())
    ga = np.flatnonzero(np.isin(own, flat_a))
    gb = np.flatnonzero(np.isin(own, flat_b))
    out = []
    for w in range(V):
        if w == iv:
            continue
        pa = PIX[w, ga]
        pb = PIX[w, gb]
        pa = pa[pa >= 0]
        pb = pb[pb >= 0]
        if len(pa) == 0 or len(pb) == 0:
            out.append((len(pa), len(pb), 0, 0, 0))
            continue
        ca = np.unpackbits(BITS[w, pa], axis=1).sum(0)
        cb = np.unpackbits(BITS[w, pb], axis=1).sum(0)
        ha = 2 * ca >= len(pa)
        hb = 2 * cb >= len(pb)
        out.append((len(pa), len(pb), int((ha & hb).any()), int(ha.sum()), int(hb.sum())))
    return len(ga), len(gb), out


records = []
for iv, v in enumerate(views):
    gt = gts[v]
    raw = load_png(f'{M}/cache/merge/{v}.raw.png')
    log = json.load(open(f'{M}/cache/merge/{v}.log.json'))['log']['log']
    grp = raw.copy()
    nmax = gt.max() + 1
    for d in log['decisions']:
        if not d['merged']:
            continue
        a, b = d['a'], d['b']
        A = grp == a
        B = grp == b
        if not A.any() or not B.any():
            continue
        ca = np.bincount(gt[A], minlength=nmax)
        cb = np.bincount(gt[B], minlength=nmax)
        ga, gb = int(ca.argmax()), int(cb.argmax())
        db = B.copy()
        da = A.copy()
        for k in range(R):
            if k == R0 - 1:
                nb0, na0 = db.copy(), da.copy()
            db = dilate8(db)
            da = dilate8(da)
        za = A & db
        zb = B & da
        if R0 > 0:
            za &= ~nb0
            zb &= ~na0
        if INTERIOR:
            za &= ~dilate8(~A)
            zb &= ~dilate8(~B)
        na, nb, ev = evidence(iv, za, zb)
        records.append(dict(view=v, a=a, b=b, ga=ga, gb=gb, area_a=int(A.sum()), area_b=int(B.sum()),
                            ng_a=na, ng_b=nb, ev=ev, terms=d['terms']))
        grp[B] = a
json.dump(dict(scene=S, records=records), open(OUT, 'w'))
print(S, len(records), 'merges')
