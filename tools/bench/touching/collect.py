"""Every merge a scene's per-view merge executed, with its ground truth and the candidate cues of
docs/benchmarks/15-touching-objects.md: the minima rule (disc fractions of the union at the ends
of the boundary), SAM's masks in this view, and SAM's masks in the other views (whole regions and
2–4 px from the contact; together / apart in a whole), through ground-truth depth.

usage: python3 collect.py SCENE MERGE_OUT OUT.json
  SCENE      a `splatseg synth` folder (images, sam, sparse, gt with instance and depth)
  MERGE_OUT  a `splatseg merge SCENE --masks SCENE/sam --features SCENE/features --out MERGE_OUT`
             folder (its cache/merge/<view>.{raw.png,log.json} are replayed)
env: DEPTH=rendered  correspond through SCENE/rdepth/<view>_depth.npy (`splatseg render --what depth`)
     FAST=1          skip the minima rule and the whole-region cue
"""
import json
import os
import sys
import numpy as np
from common import load_png, load_sam, load_cameras, shift, dilate4, dilate8

S, M, OUT = sys.argv[1], sys.argv[2], sys.argv[3]
meta = json.load(open(f'{S}/gt/objects.json'))
views = meta['views']
objects = {o['id']: o for o in meta['objects']}
poses = load_cameras(S)
rng = np.random.default_rng(0)

gts = {v: load_png(f'{S}/gt/instance/{v}.png') for v in views}
depths = {v: np.load(f'{S}/gt/depth/{v}.npy') for v in views}
gt_depths = depths
FAST = os.environ.get('FAST') == '1'
if os.environ.get('DEPTH') == 'rendered':
    depths = {v: np.nan_to_num(np.load(f'{S}/rdepth/{v}_depth.npy'), nan=0.0) for v in views}
sams = {v: load_sam(S, v) for v in views}
imgs = {v: load_png(f'{S}/images/{v}.png')[:, :, :3].astype(float) for v in views}
H, W = gts[views[0]].shape
uu, vv = np.meshgrid(np.arange(W), np.arange(H))
RADII = (5, 9)
DISCS = {}
for r in RADII:
    dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
    DISCS[r] = (dy[(dy * dy + dx * dx) <= r * r], dx[(dy * dy + dx * dx) <= r * r])


def backproject(v, ys, xs):
    K, R, t = poses[v]
    z = depths[v][ys, xs]
    cam = np.linalg.inv(K) @ np.stack([xs + 0.5, ys + 0.5, np.ones_like(xs, dtype=float)]) * z
    return R.T @ (cam - t[:, None])


def project(w, X):
    K, R, t = poses[w]
    c = R @ X + t[:, None]
    z = c[2]
    p = K @ c
    with np.errstate(divide='ignore', invalid='ignore'):
        px, py = p[0] / z, p[1] / z
    ok = (z > 1e-3) & (px >= 0) & (px < W) & (py >= 0) & (py < H)
    xi = np.clip(np.floor(np.nan_to_num(px)).astype(int), 0, W - 1)
    yi = np.clip(np.floor(np.nan_to_num(py)).astype(int), 0, H - 1)
    ok &= np.abs(depths[w][yi, xi] - z) < 0.03 * z
    return ok, yi, xi


KMAX = max(len(m) for m in sams.values() if m is not None)
NB = (KMAX + 7) // 8
BITS = np.zeros((len(views), H, W, NB), dtype=np.uint8)
for i, v in enumerate(views):
    if sams[v] is not None:
        m = np.zeros((KMAX, H, W), dtype=bool)
        m[:len(sams[v])] = sams[v]
        BITS[i] = np.packbits(m.transpose(1, 2, 0), axis=2)
VIDX = np.arange(len(views))
GT_ALL = np.stack([gts[v] for v in views])
D_ALL = np.stack([depths[v] for v in views])
K_ALL = np.stack([poses[v][0] for v in views])
R_ALL = np.stack([poses[v][1] for v in views])
T_ALL = np.stack([poses[v][2] for v in views])


def project_all(X):
    """(3, n) world points -> per view (V, n): visible, row, column."""
    c = np.einsum('vij,jn->vin', R_ALL, X) + T_ALL[:, :, None]
    p = np.einsum('vij,vjn->vin', K_ALL, c)
    z = c[:, 2]
    with np.errstate(divide='ignore', invalid='ignore'):
        px, py = p[:, 0] / z, p[:, 1] / z
    ok = (z > 1e-3) & (px >= 0) & (px < W) & (py >= 0) & (py < H)
    xi = np.where(ok, px, 0).astype(int).clip(0, W - 1)
    yi = np.where(ok, py, 0).astype(int).clip(0, H - 1)
    ok &= np.abs(D_ALL[VIDX[:, None], yi, xi] - z) < 0.03 * z
    return ok, yi, xi


def concavity(U, contact):
    """Minima rule: disc fractions of the union at the ends of the A|B boundary on U's outline."""
    # the image frame is not an outline: pixels outside count as inside
    inner = U.copy()
    inner[0, :] = inner[-1, :] = inner[:, 0] = inner[:, -1] = True
    outline = U & ~(shift(inner, 1, 0, True) & shift(inner, -1, 0, True) & shift(inner, 0, 1, True)
                    & shift(inner, 0, -1, True))
    J = contact & dilate8(outline)
    ys, xs = np.nonzero(J)
    if len(ys) == 0:
        return {r: None for r in RADII}, 0
    # 8-connected components of the junction pixels
    pts = set(zip(ys.tolist(), xs.tolist()))
    comps = []
    while pts:
        s = pts.pop()
        st = [s]
        comp = [s]
        while st:
            y, x = st.pop()
            for dy in (-1, 0, 1):
                for dx in (-1, 0, 1):
                    q = (y + dy, x + dx)
                    if q in pts:
                        pts.remove(q)
                        st.append(q)
                        comp.append(q)
        comps.append(comp)
    res = {}
    for r in RADII:
        fr = []
        for comp in comps:
            c = np.array(comp)
            cy, cx = c.mean(0)
            k = np.argmin(((c - [cy, cx]) ** 2).sum(1))
            y0, x0 = c[k]
            dy, dx = DISCS[r]
            yy, xx = y0 + dy, x0 + dx
            inb = (yy >= 0) & (yy < U.shape[0]) & (xx >= 0) & (xx < U.shape[1])
            fr.append(float(U[yy[inb], xx[inb]].mean()))
        res[r] = fr
    return res, len(comps)


def sample(mask, n=160):
    ys, xs = np.nonzero(mask)
    if len(ys) > n:
        k = rng.choice(len(ys), n, replace=False)
        ys, xs = ys[k], xs[k]
    return ys, xs


records = []
for v in views:
    gt = gts[v]
    raw = load_png(f'{M}/cache/merge/{v}.raw.png')
    log = json.load(open(f'{M}/cache/merge/{v}.log.json'))['log']['log']
    grp = raw.copy()
    iv = views.index(v)
    bbs = {}
    for lab in range(1, raw.max() + 1):
        ys_, xs_ = np.nonzero(raw == lab)
        if len(ys_):
            bbs[lab] = [ys_.min(), ys_.max(), xs_.min(), xs_.max()]
    sam = sams[v]
    nmax = gt.max() + 1
    for d in log['decisions']:
        if not d['merged']:
            continue
        a, b = d['a'], d['b']
        if a not in bbs or b not in bbs:
            continue
        ba, bb_ = bbs[a], bbs[b]
        Y0 = max(min(ba[0], bb_[0]) - 12, 0)
        Y1 = min(max(ba[1], bb_[1]) + 13, H)
        X0 = max(min(ba[2], bb_[2]) - 12, 0)
        X1 = min(max(ba[3], bb_[3]) + 13, W)
        bbs[a] = [min(ba[0], bb_[0]), max(ba[1], bb_[1]), min(ba[2], bb_[2]), max(ba[3], bb_[3])]
        del bbs[b]
        gsub = grp[Y0:Y1, X0:X1]
        A = gsub == a
        B = gsub == b
        if not A.any() or not B.any():
            continue
        gt_full = gt
        gt = gt_full[Y0:Y1, X0:X1]
        ca = np.bincount(gt[A], minlength=nmax)
        cb = np.bincount(gt[B], minlength=nmax)
        ga, gb = int(ca.argmax()), int(cb.argmax())
        rec = dict(view=v, a=a, b=b, area_a=int(A.sum()), area_b=int(B.sum()), ga=ga, gb=gb,
                   pur_a=float(ca[ga] / A.sum()), pur_b=float(cb[gb] / B.sum()), terms=d['terms'])
        # contact band (4-adjacent pixels of the two sides)
        ca_ = A & dilate4(B)
        cb_ = B & dilate4(A)
        contact = ca_ | cb_
        rec['contact_px'] = int(contact.sum())
        # 3D: touching at the boundary (GT depth) or an occlusion
        z = gt_depths[v][Y0:Y1, X0:X1]
        gaps = []
        for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            nb = shift(B, dy, dx)  # pixel whose neighbour at (-dy,-dx) is in B
            sel = A & nb
            ys, xs = np.nonzero(sel)
            if len(ys):
                zb = z[ys - dy, xs - dx]
                gaps.append(np.abs(z[ys, xs] - zb) / np.minimum(z[ys, xs], zb))
        rec['gt_rel_gap'] = float(np.median(np.concatenate(gaps))) if gaps else None
        # (a) minima rule
        U = A | B
        fr, nj = concavity(U, contact) if not FAST else ({r: [] for r in RADII}, 0)
        rec['concav'] = {str(r): fr[r] for r in RADII}
        rec['junctions'] = nj
        # (b1) in-view SAM co-coverage
        if sam is not None:
            bsub = BITS[iv, Y0:Y1, X0:X1]
            cova = np.unpackbits(bsub[A], axis=1).sum(0) / A.sum()
            covb = np.unpackbits(bsub[B], axis=1).sum(0) / B.sum()
            rec['inview_cov'] = float(np.max(np.minimum(cova, covb)))
        else:
            rec['inview_cov'] = 0.0
        # (b2) cross-view SAM co-coverage through GT geometry
        ya, xa = sample(A, 160 if not FAST else 4)
        yb, xb = sample(B, 160 if not FAST else 4)
        ya, xa, yb, xb = ya + Y0, xa + X0, yb + Y0, xb + X0
        gt = gt_full
        XA, XB = backproject(v, ya, xa), backproject(v, yb, xb)
        oka, pya, pxa = project_all(XA)
        okb, pyb, pxb = project_all(XB)
        ma_bits = np.unpackbits(BITS[VIDX[:, None], pya, pxa], axis=2)  # (V, n, K)
        mb_bits = np.unpackbits(BITS[VIDX[:, None], pyb, pxb], axis=2)
        na = oka.sum(1)
        nb_ = okb.sum(1)
        sa = (ma_bits * oka[:, :, None]).sum(1) / np.maximum(na, 1)[:, None]
        sb = (mb_bits * okb[:, :, None]).sum(1) / np.maximum(nb_, 1)[:, None]
        cov = np.minimum(sa, sb).max(1)
        gok_a = ((GT_ALL[VIDX[:, None], pya, pxa] == gt[ya, xa][None, :]) & oka).sum(1) / np.maximum(na, 1)
        per = []
        for i, w in enumerate(views):
            if w == v:
                continue
            if na[i] < 8 or nb_[i] < 8:
                per.append((w, int(na[i]), int(nb_[i]), None, None, None, None))
            else:
                per.append((w, int(na[i]), int(nb_[i]), float(cov[i]), float(sa[i].max()), float(sb[i].max()),
                            float(gok_a[i])))
        rec['xview'] = per
        # (b3) the same, local: pixels 2-4 px from the boundary on each side
        nearB = A & dilate4(dilate4(dilate4(dilate4(B)))) & ~dilate4(B)
        nearA = B & dilate4(dilate4(dilate4(dilate4(A)))) & ~dilate4(A)
        if not nearB.any():
            nearB = ca_
        if not nearA.any():
            nearA = cb_
        # colour of each side near the boundary
        img = imgs[v][Y0:Y1, X0:X1]
        rec['colour_a'] = np.median(img[nearB], 0).tolist()
        rec['colour_b'] = np.median(img[nearA], 0).tolist()
        ya, xa = sample(nearB, 100)
        yb, xb = sample(nearA, 100)
        ya, xa, yb, xb = ya + Y0, xa + X0, yb + Y0, xb + X0
        oka, pya, pxa = project_all(backproject(v, ya, xa))
        okb, pyb, pxb = project_all(backproject(v, yb, xb))
        ma_bits = np.unpackbits(BITS[VIDX[:, None], pya, pxa], axis=2)
        mb_bits = np.unpackbits(BITS[VIDX[:, None], pyb, pxb], axis=2)
        na = oka.sum(1)
        nb_ = okb.sum(1)
        sa = (ma_bits * oka[:, :, None]).sum(1) / np.maximum(na, 1)[:, None]
        sb = (mb_bits * okb[:, :, None]).sum(1) / np.maximum(nb_, 1)[:, None]
        cov = np.minimum(sa, sb).max(1)
        per = []
        for i, w in enumerate(views):
            if na[i] < 5 or nb_[i] < 5:
                continue
            per.append((i, int(na[i]), int(nb_[i]), float(cov[i]), float(sa[i].max()), float(sb[i].max()),
                        int((sa[i] >= 0.5).sum()), int((sb[i] >= 0.5).sum()), int(i == iv)))
        rec['xband'] = per
        records.append(rec)
        # replay
        gsub[B] = a

json.dump(dict(scene=S, objects={k: dict(name=o['name'], kind=o['kind'], classes=o['classes'],
                                         tags=o['tags'], texture=o['texture'].get('kind'))
                                 for k, o in objects.items()}, records=records), open(OUT, 'w'))
print(S, len(records), 'merges')
