#!/usr/bin/env python3
"""Times gsplat's pure-PyTorch reference on the CPU on the scene `render_timing --dump DIR` wrote,
for the speed ratio recorded in `BENCHMARKS.md` (section render).

Projection and colour are gsplat's own `_torch_impl` functions (`_quat_scale_to_covar_preci`,
`_fully_fused_projection`, `_spherical_harmonics`). gsplat's reference binning (`_isect_tiles`)
is a Python loop over Gaussians and its reference blending (`_rasterize_to_pixels`) calls a CUDA
kernel, so both are replaced by vectorised PyTorch with the same rules (per-tile lists sorted by
depth; per tile a [pixels, Gaussians] alpha matrix, cumulative transmittance, the 1/255, 0.999 and
1e-4 cut-offs). Backward is autograd through all of it, with the same loss as the Rust timing
(0.001·Σ rgb + 0.0001·Σ depth).

Usage:
  cargo run --release -p splatseg-render --example render_timing -- 100000 800 800 2 --dump /tmp/scene
  python tools/bench_gsplat_torch.py /tmp/scene [--threads 2]
"""

import argparse
import math
import pathlib
import time

import numpy as np
import torch

from gsplat.cuda._torch_impl import (
    _fully_fused_projection,
    _quat_scale_to_covar_preci,
    _spherical_harmonics,
)

TILE = 16


def load(dir_):
    d = pathlib.Path(dir_)
    arr = {p.stem: np.load(p) for p in d.glob("*.npy")}
    w, h = (int(v) for v in arr.pop("size"))
    return {k: torch.tensor(v, dtype=torch.float32) for k, v in arr.items()}, w, h


def bin_tiles(means2d, radii, depths, w, h):
    tw, th = math.ceil(w / TILE), math.ceil(h / TILE)
    r = radii.float()
    tmin = torch.floor((means2d - r) / TILE).long()
    tmax = torch.ceil((means2d + r) / TILE).long()
    tmin[:, 0].clamp_(0, tw), tmax[:, 0].clamp_(0, tw)
    tmin[:, 1].clamp_(0, th), tmax[:, 1].clamp_(0, th)
    span = (tmax - tmin).clamp(min=0)
    counts = span[:, 0] * span[:, 1] * (radii > 0).all(-1)
    gid = torch.repeat_interleave(torch.arange(len(counts)), counts)
    start = torch.cumsum(counts, 0) - counts
    j = torch.arange(len(gid)) - start[gid]
    tx = tmin[gid, 0] + j % span[gid, 0].clamp(min=1)
    ty = tmin[gid, 1] + j // span[gid, 0].clamp(min=1)
    tile = ty * tw + tx
    rank = torch.empty_like(depths, dtype=torch.long)
    rank[torch.argsort(depths)] = torch.arange(len(depths))
    order = torch.argsort(tile * len(depths) + rank[gid])
    tile, gid = tile[order], gid[order]
    offsets = torch.zeros(tw * th + 1, dtype=torch.long)
    offsets[1:] = torch.cumsum(torch.bincount(tile, minlength=tw * th), 0)
    return gid, offsets, tw, th


def rasterise(means2d, conics, opac, channels, gid, offsets, tw, th, w, h):
    out = torch.zeros(h * w, channels.shape[1])
    acc = torch.zeros(h * w)
    ys, xs = torch.meshgrid(torch.arange(TILE), torch.arange(TILE), indexing="ij")
    pieces, alphas, where = [], [], []
    for t in range(tw * th):
        a, b = int(offsets[t]), int(offsets[t + 1])
        if a == b:
            continue
        tx, ty = t % tw, t // tw
        px, py = xs.reshape(-1) + tx * TILE, ys.reshape(-1) + ty * TILE
        keep = (px < w) & (py < h)
        px, py = px[keep], py[keep]
        ids = gid[a:b]
        dx = px[:, None] + 0.5 - means2d[ids, 0][None]
        dy = py[:, None] + 0.5 - means2d[ids, 1][None]
        c = conics[ids]
        sigma = 0.5 * (c[None, :, 0] * dx**2 + c[None, :, 2] * dy**2) + c[None, :, 1] * dx * dy
        alpha = torch.clamp_max(opac[ids][None] * torch.exp(-sigma), 0.999)
        valid = (sigma >= 0) & (alpha >= 1 / 255)
        alpha = torch.where(valid, alpha, torch.zeros_like(alpha))
        t_incl = torch.cumprod(1 - alpha, 1)
        alpha = torch.where(t_incl > 1e-4, alpha, torch.zeros_like(alpha))
        t_after = torch.cumprod(1 - alpha, 1)
        t_before = torch.cat([torch.ones_like(t_after[:, :1]), t_after[:, :-1]], 1)
        weights = alpha * t_before
        pieces.append(weights @ channels[ids])
        alphas.append(weights.sum(1))
        where.append(py * w + px)
    idx = torch.cat(where)
    out = out.index_put((idx,), torch.cat(pieces))
    acc = acc.index_put((idx,), torch.cat(alphas))
    return out, acc


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    g, w, h = load(args.scene)
    n = len(g["means"])
    params = {k: g[k].clone().requires_grad_(True) for k in ["means", "log_scales", "quats", "raw_opacities", "sh_dc", "sh_rest"]}
    viewmat = torch.eye(4)[None]
    ks = g["K"][None]

    t0 = time.perf_counter()
    covars, _ = _quat_scale_to_covar_preci(params["quats"], torch.exp(params["log_scales"]), compute_preci=False)
    radii, means2d, depths, conics, _ = _fully_fused_projection(params["means"], covars, viewmat, ks, w, h)
    radii, means2d, depths, conics = radii[0], means2d[0], depths[0], conics[0]
    coeffs = torch.cat([params["sh_dc"][:, None, :], params["sh_rest"].transpose(1, 2)], 1)
    colours = torch.clamp_min(_spherical_harmonics(3, params["means"], coeffs) + 0.5, 0.0)
    channels = torch.cat([colours, depths[:, None]], 1)
    opac = torch.sigmoid(params["raw_opacities"])
    t1 = time.perf_counter()
    gid, offsets, tw, th = bin_tiles(means2d.detach(), radii, depths.detach(), w, h)
    t2 = time.perf_counter()
    out, acc = rasterise(means2d, conics, opac, channels, gid, offsets, tw, th, w, h)
    depth = out[:, 3] / acc.clamp(min=1e-10)
    t3 = time.perf_counter()
    loss = 1e-3 * out[:, :3].sum() + 1e-4 * depth.sum()
    loss.backward()
    t4 = time.perf_counter()
    print(
        f"gsplat torch reference, n={n} {w}x{h} threads={args.threads}: "
        f"projection+SH {1e3 * (t1 - t0):.0f} ms, bin {1e3 * (t2 - t1):.0f} ms ({len(gid)} intersections), "
        f"rasterise {1e3 * (t3 - t2):.0f} ms | forward {1e3 * (t3 - t0):.0f} ms, "
        f"forward+backward {1e3 * (t4 - t0):.0f} ms"
    )


if __name__ == "__main__":
    main()
