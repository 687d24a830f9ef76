#!/usr/bin/env python3
"""Side-by-side timing of SAM's automatic mask generator: Meta's `segment-anything` against
`splatseg cues --sam`, on the same random-weight checkpoint and the same image, 2 threads, back to back.

What it does, in WORKDIR (default /tmp/bench_sam_amg):
1. writes a random-weight checkpoint under the reference's own tensor names:
   - `--model vit_b|vit_l|vit_h`: `segment_anything.sam_model_registry[...]()` (PyTorch's default init),
     saved as a plain state dict `sam_<model>_random.pth`;
   - `--model mobile_sam`: the released MobileSAM (TinyViT-5M image encoder from `ultralytics`, the
     segment-anything prompt encoder and mask decoder), as `mobile_sam.pt` names;
2. makes a deterministic 1280×960 RGB image (smooth colour blobs plus noise) and a one-view scene
   folder around it (`transforms.json` + `images/view_000.png`);
3. runs, each in its own process with 2 threads: the reference's `SamAutomaticMaskGenerator(model)
   .generate(image)` with default settings (32×32 points, no crops), then
   `splatseg cues SCENE --out OUT --sam CKPT` (whole process, fresh OUT; the scene has one view);
4. prints both wall times, the ratio, each process's peak resident memory (from `wait4`), the mask
   counts, and splatseg's per-stage split (from its log).

Needs: `pip install torch segment-anything numpy` (PyPI), plus `ultralytics` for `--model mobile_sam`,
and a release build of splatseg (`cargo build --release`; pass `--splatseg PATH` otherwise).

Usage: python tools/bench_sam_amg.py [--model vit_b] [--workdir DIR] [--threads 2] [--splatseg PATH]
       [--skip-reference]
"""
import argparse
import json
import os
import struct
import subprocess
import sys
import time
import zlib

WIDTH, HEIGHT = 1280, 960


def write_png(path, rgb_rows):
    """Minimal RGB8 PNG writer (no Pillow needed): `rgb_rows` is a list of `bytes` of length 3·W."""
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + row for row in rgb_rows)
    header = struct.pack(">IIBBBBB", len(rgb_rows[0]) // 3, len(rgb_rows), 8, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def make_image():
    import numpy as np

    rng = np.random.default_rng(12)
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float32)
    img = np.zeros((HEIGHT, WIDTH, 3), np.float32) + 60.0
    for _ in range(24):
        cx, cy = rng.uniform(0, WIDTH), rng.uniform(0, HEIGHT)
        r = rng.uniform(40, 260)
        colour = rng.uniform(0, 255, 3)
        inside = ((x - cx) ** 2 + (y - cy) ** 2) < r * r
        img[inside] = colour
    img += rng.normal(0, 6, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)


def write_scene(workdir, img):
    scene = os.path.join(workdir, "scene")
    os.makedirs(os.path.join(scene, "images"), exist_ok=True)
    write_png(os.path.join(scene, "images", "view_000.png"), [img[r].tobytes() for r in range(img.shape[0])])
    pose = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 4], [0, 0, 0, 1]]
    transforms = {"camera_angle_x": 0.9, "frames": [{"file_path": "images/view_000.png", "transform_matrix": pose}]}
    with open(os.path.join(scene, "transforms.json"), "w") as f:
        json.dump(transforms, f)
    return scene


def build_model(model):
    import torch
    from segment_anything import sam_model_registry

    torch.manual_seed(0)
    if model != "mobile_sam":
        return sam_model_registry[model]()
    from segment_anything.modeling import MaskDecoder, PromptEncoder, Sam, TwoWayTransformer
    from ultralytics.models.sam.modules.tiny_encoder import TinyViT

    encoder = TinyViT(
        img_size=1024, in_chans=3, num_classes=1000, embed_dims=[64, 128, 160, 320], depths=[2, 2, 6, 2],
        num_heads=[2, 4, 5, 10], window_sizes=[7, 7, 14, 7], mlp_ratio=4.0, drop_rate=0.0, drop_path_rate=0.0,
        use_checkpoint=False, mbconv_expand_ratio=4.0, local_conv_size=3, layer_lr_decay=0.8,
    )
    return Sam(
        image_encoder=encoder,
        prompt_encoder=PromptEncoder(
            embed_dim=256, image_embedding_size=(64, 64), input_image_size=(1024, 1024), mask_in_chans=16
        ),
        mask_decoder=MaskDecoder(
            num_multimask_outputs=3,
            transformer=TwoWayTransformer(depth=2, embedding_dim=256, mlp_dim=2048, num_heads=8),
            transformer_dim=256, iou_head_depth=3, iou_head_hidden_dim=256,
        ),
        pixel_mean=[123.675, 116.28, 103.53],
        pixel_std=[58.395, 57.12, 57.375],
    )


def child_reference(args):
    """Runs in its own process: load the checkpoint, time `generate` (model load not timed)."""
    import numpy as np
    import torch
    from segment_anything import SamAutomaticMaskGenerator

    torch.set_num_threads(args.threads)
    model = build_model(args.model)
    model.load_state_dict(torch.load(args.checkpoint, map_location="cpu"))
    model.eval()
    img = np.load(args.image)
    generator = SamAutomaticMaskGenerator(model)
    start = time.perf_counter()
    with torch.inference_mode():
        masks = generator.generate(img)
    print(json.dumps({"generate_s": time.perf_counter() - start, "masks": len(masks)}))


def run_measured(cmd, env=None):
    """Wall time, peak RSS (MB) and output of a child process."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
    out, err = proc.communicate()
    wall = time.perf_counter() - start
    # communicate() reaped it; ru_maxrss of the children so far is a running maximum, so each run is
    # measured through a fresh intermediate process below instead
    return wall, out, err, proc.returncode


def measured_child(cmd, env):
    """Runs `cmd` under a small Python parent that reports the child's own wait4 rusage."""
    wrapper = (
        "import os,sys,json,time,subprocess;"
        "t=time.perf_counter();p=subprocess.Popen(sys.argv[1:]);"
        "_,s,r=os.wait4(p.pid,0);"
        "print(json.dumps({'wall':time.perf_counter()-t,'rss_mb':r.ru_maxrss/1024,'status':s}),file=sys.stderr)"
    )
    wall, out, err, code = run_measured([sys.executable, "-c", wrapper] + cmd, env)
    stats = json.loads(err.strip().splitlines()[-1])
    log = "\n".join(err.strip().splitlines()[:-1])
    if stats["status"] != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{out}\n{log}")
    return stats, out, log


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="vit_b", choices=["vit_b", "vit_l", "vit_h", "mobile_sam"])
    parser.add_argument("--workdir", default="/tmp/bench_sam_amg")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--splatseg", default=os.path.join(os.path.dirname(__file__), "..", "target", "release", "splatseg"))
    parser.add_argument("--skip-reference", action="store_true", help="time splatseg only")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--checkpoint", help=argparse.SUPPRESS)
    parser.add_argument("--image", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return child_reference(args)

    import numpy as np
    import torch

    os.makedirs(args.workdir, exist_ok=True)
    name = "mobile_sam.pt" if args.model == "mobile_sam" else f"sam_{args.model}_random.pth"
    checkpoint = os.path.join(args.workdir, name)
    if not os.path.exists(checkpoint):
        torch.save(build_model(args.model).state_dict(), checkpoint)
    img = make_image()
    image_npy = os.path.join(args.workdir, "image.npy")
    np.save(image_npy, img)
    scene = write_scene(args.workdir, img)

    env = dict(os.environ, OMP_NUM_THREADS=str(args.threads), MKL_NUM_THREADS=str(args.threads),
               RAYON_NUM_THREADS=str(args.threads), RUST_LOG="info,splatseg_models=debug")
    results = {}
    out_dir = os.path.join(args.workdir, f"cues_{args.model}")
    subprocess.run(["rm", "-rf", out_dir], check=True)
    cmd = [args.splatseg, "cues", scene, "--out", out_dir, "--sam", checkpoint]
    stats, out, log = measured_child(cmd, env)
    with open(os.path.join(out_dir, "sam", "view_000.json")) as f:
        written = json.load(f)
    ours_masks = len(written) if isinstance(written, list) else len(next(iter(written.values())))
    stages = [line for line in log.splitlines() if "SAM crop" in line]
    results["splatseg"] = (stats["wall"], stats["rss_mb"], ours_masks)
    if not args.skip_reference:
        cmd = [sys.executable, __file__, "--child", "--model", args.model, "--checkpoint", checkpoint,
               "--image", image_npy, "--threads", str(args.threads)]
        stats, out, _ = measured_child(cmd, env)
        ref = json.loads(out.strip().splitlines()[-1])
        results["reference"] = (stats["wall"], stats["rss_mb"], ref["masks"], ref["generate_s"])

    print(f"SAM automatic masks, {args.model}, random weights, {WIDTH}x{HEIGHT}, {args.threads} threads")
    wall, rss, n = results["splatseg"]
    print(f"  splatseg cues (whole process)       {wall:8.2f} s  peak {rss:7.0f} MB  masks {n}")
    for line in stages:
        print("    " + line.split("SAM crop", 1)[1].strip())
    if "reference" in results:
        rwall, rrss, rn, gen = results["reference"]
        print(f"  segment-anything generate()          {gen:8.2f} s  (process {rwall:.2f} s, peak {rrss:7.0f} MB)  masks {rn}")
        print(f"  ratio reference generate / splatseg  {gen / wall:8.2f}x")


if __name__ == "__main__":
    main()
