"""A poor reconstruction of a scene: drop the Gaussians of random 0.6 m voxels from a 3DGS PLY.

Used for issue 27's "where the Gaussians say nothing" measurement (BENCHMARKS.md, Blind families):

    splatseg synth --family rooms --seed 0 --out S
    python3 tools/bench/poor_reconstruction.py S/gaussians.ply poor.ply 0.6
    cp -r S/gt gt && rm gt/gaussian_ids.npy      # the per-Gaussian truth no longer fits
    splatseg run S --gaussians poor.ply --features S/features --masks S/sam --gt gt --out OUT

Arguments: input PLY (binary little-endian, float properties only, as `splatseg synth` writes it),
output PLY, share of voxels kept. Deterministic (NumPy's default_rng(0)).
"""

import sys

import numpy as np


def main() -> None:
    src, dst, keep = sys.argv[1], sys.argv[2], float(sys.argv[3])
    data = open(src, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    lines = header.splitlines()
    props = [line.split()[2] for line in lines if line.startswith("property float")]
    if len(props) != sum(line.startswith("property") for line in lines):
        sys.exit(f"{src}: only float properties are supported")
    n = int(next(line for line in lines if line.startswith("element vertex")).split()[2])
    rows = np.frombuffer(data[end:], dtype="<f4", count=n * len(props)).reshape(n, len(props))
    voxel = np.floor(rows[:, :3] / 0.6).astype(np.int64)
    _, which = np.unique(voxel, axis=0, return_inverse=True)
    kept_voxels = np.random.default_rng(0).random(which.max() + 1) < keep
    out = rows[kept_voxels[which.ravel()]]
    header = header.replace(f"element vertex {n}", f"element vertex {len(out)}")
    with open(dst, "wb") as f:
        f.write(header.encode() + out.astype("<f4").tobytes())
    print(f"{n} -> {len(out)} Gaussians")


if __name__ == "__main__":
    main()
