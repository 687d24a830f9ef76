"""Shared loaders for the touching-objects analysis (numpy + PIL only)."""
import json
import os
import numpy as np
from PIL import Image


def rle_counts(s):
    """COCO compressed RLE string -> run counts (pycocotools' LEB128-like scheme)."""
    cnts = []
    p = 0
    while p < len(s):
        x = 0
        k = 0
        more = True
        while more:
            c = ord(s[p]) - 48
            x |= (c & 0x1F) << (5 * k)
            more = bool(c & 0x20)
            p += 1
            k += 1
            if not more and (c & 0x10):
                x |= -1 << (5 * k)
        if len(cnts) > 2:
            x += cnts[-2]
        cnts.append(x)
    return cnts


def decode_mask(seg):
    h, w = seg['size']
    counts = seg['counts']
    if isinstance(counts, str):
        counts = rle_counts(counts)
    flat = np.zeros(h * w, dtype=bool)
    pos = 0
    val = False
    for c in counts:
        if val:
            flat[pos:pos + c] = True
        pos += c
        val = not val
    return flat.reshape(w, h).T


def load_sam(scene, view):
    masks = json.load(open(f'{scene}/sam/{view}.json'))
    return np.stack([decode_mask(m['segmentation']) for m in masks]) if masks else None


def qvec_to_r(q):
    w, x, y, z = q
    return np.array([
        [1 - 2 * y * y - 2 * z * z, 2 * x * y - 2 * w * z, 2 * x * z + 2 * w * y],
        [2 * x * y + 2 * w * z, 1 - 2 * x * x - 2 * z * z, 2 * y * z - 2 * w * x],
        [2 * x * z - 2 * w * y, 2 * y * z + 2 * w * x, 1 - 2 * x * x - 2 * y * y]])


def load_cameras(scene):
    d = f'{scene}/sparse/0' if os.path.isdir(f'{scene}/sparse/0') else f'{scene}/sparse'
    cams = {}
    for line in open(f'{d}/cameras.txt'):
        if line.startswith('#') or not line.strip():
            continue
        t = line.split()
        assert t[1] == 'PINHOLE', t[1]
        fx, fy, cx, cy = map(float, t[4:8])
        cams[int(t[0])] = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    poses = {}
    lines = [l for l in open(f'{d}/images.txt') if not l.startswith('#')]
    for i in range(0, len(lines), 2):
        t = lines[i].split()
        if not t:
            continue
        q = list(map(float, t[1:5]))
        tv = np.array(list(map(float, t[5:8])))
        name = t[9].rsplit('.', 1)[0]
        poses[name] = (cams[int(t[8])], qvec_to_r(q), tv)
    return poses


def load_png(path):
    return np.array(Image.open(path)).astype(np.int64)


def shift(m, dy, dx, fill=False):
    out = np.full_like(m, fill)
    h, w = m.shape
    ys = slice(max(dy, 0), h + min(dy, 0))
    yd = slice(max(-dy, 0), h + min(-dy, 0))
    xs = slice(max(dx, 0), w + min(dx, 0))
    xd = slice(max(-dx, 0), w + min(-dx, 0))
    out[ys, xs] = m[yd, xd]
    return out


def dilate4(m):
    return m | shift(m, 1, 0) | shift(m, -1, 0) | shift(m, 0, 1) | shift(m, 0, -1)


def dilate8(m):
    d = dilate4(m)
    return d | shift(m, 1, 1) | shift(m, 1, -1) | shift(m, -1, 1) | shift(m, -1, -1)
