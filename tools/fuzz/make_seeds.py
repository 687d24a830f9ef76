#!/usr/bin/env python3
"""Writes the committed fuzz seeds (fuzz/corpus/<target>/seed_*) from a synthetic scene.

    cargo run --release -- synth --out /tmp/seed_scene --views 2 --size 64x48
    python3 tools/fuzz/make_seeds.py /tmp/seed_scene fuzz/corpus

Every seed is trimmed to a few rows / masks so the committed corpus stays small. Only files
derived from our own synthetic scene are committed; see fuzz/README.md for adding real files
(../shared/data) to a local, uncommitted corpus.
"""
import io
import json
import struct
import sys
import zipfile
from pathlib import Path

import numpy as np

TYPES = {"float": "f", "float32": "f", "double": "d", "int": "i", "int32": "i", "uint": "I",
         "uchar": "B", "uint8": "B", "char": "b", "short": "h", "ushort": "H"}


def read_ply(path):
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    props = [line.split()[1:] for line in header.splitlines() if line.startswith("property")]
    count = int(next(l for l in header.splitlines() if l.startswith("element vertex")).split()[2])
    fmt = "<" + "".join(TYPES[t] for t, _ in props)
    size = struct.calcsize(fmt)
    rows = [struct.unpack_from(fmt, data, end + i * size) for i in range(count)]
    return props, rows


def write_ply(props, rows, body_format):
    head = [f"ply", f"format {body_format} 1.0", f"element vertex {len(rows)}"]
    head += [f"property {t} {n}" for t, n in props]
    head.append("end_header")
    out = ("\n".join(head) + "\n").encode()
    if body_format == "ascii":
        return out + "".join(" ".join(repr(v) for v in r) + "\n" for r in rows).encode()
    order = "<" if body_format == "binary_little_endian" else ">"
    fmt = order + "".join(TYPES[t] for t, _ in props)
    return out + b"".join(struct.pack(fmt, *r) for r in rows)


MODEL_IDS = {"SIMPLE_PINHOLE": 0, "PINHOLE": 1, "SIMPLE_RADIAL": 2, "RADIAL": 3, "OPENCV": 4}


def data_lines(text):
    return [l for l in text.splitlines() if l.strip() and not l.startswith("#")]


def cameras_bin(text):
    lines = data_lines(text)
    out = struct.pack("<Q", len(lines))
    for l in lines:
        f = l.split()
        out += struct.pack("<iiQQ", int(f[0]), MODEL_IDS[f[1]], int(f[2]), int(f[3]))
        out += b"".join(struct.pack("<d", float(p)) for p in f[4:])
    return out


def images_bin(text):
    lines = [l for l in text.splitlines() if not l.startswith("#")]
    images = [(lines[i], lines[i + 1] if i + 1 < len(lines) else "") for i in range(0, len(lines), 2)]
    images = [(a, b) for a, b in images if a.strip()]
    out = struct.pack("<Q", len(images))
    for a, b in images:
        f = a.split()
        out += struct.pack("<i", int(f[0])) + struct.pack("<7d", *map(float, f[1:8]))
        out += struct.pack("<i", int(f[8])) + f[9].encode() + b"\0"
        pts = b.split()
        out += struct.pack("<Q", len(pts) // 3)
        for k in range(0, len(pts) - 2, 3):
            out += struct.pack("<ddq", float(pts[k]), float(pts[k + 1]), int(pts[k + 2]))
    return out


def points_bin(text):
    lines = data_lines(text)
    out = struct.pack("<Q", len(lines))
    for l in lines:
        f = l.split()
        track = list(map(int, f[8:]))
        out += struct.pack("<Q3d3Bd", int(f[0]), *map(float, f[1:4]), *map(int, f[4:7]), float(f[7]))
        out += struct.pack("<Q", len(track) // 2) + b"".join(struct.pack("<i", t) for t in track)
    return out


def quat_to_matrix(w, x, y, z):
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def transforms(images_text, cameras_text):
    cam = data_lines(cameras_text)[0].split()
    w, h, fx, fy, cx, cy = int(cam[2]), int(cam[3]), *map(float, cam[4:8])
    frames = []
    for l in [l for l in images_text.splitlines() if not l.startswith("#")][::2]:
        f = l.split()
        if not f:
            continue
        r = quat_to_matrix(*map(float, f[1:5]))
        t = np.array(list(map(float, f[5:8])))
        c2w = np.eye(4)
        c2w[:3, :3] = r.T
        c2w[:3, 3] = -r.T @ t
        c2w = c2w @ np.diag([1, -1, -1, 1])  # OpenCV → OpenGL camera axes
        frames.append({"file_path": "images/" + f[9], "transform_matrix": c2w.tolist()})
    return json.dumps({"fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy, "w": w, "h": h, "frames": frames}, indent=1)


def npy_bytes(array):
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def png_seeds(path):
    raw = path.read_bytes()
    return [raw]


# The fuzz site's address and token (crates/view/src/fuzzing.rs).
VIEW_ADDR, VIEW_TOKEN = "127.0.0.1:8080", "00112233445566778899aabbccddeeff"


def view_request_seeds(put):
    """Raw requests for the viewer's server (`view_request`): every route, an export with and
    without the token, and the hostile heads of issue 28."""
    host = f"Host: {VIEW_ADDR}\r\n"
    export = '{"ids":[1],"mode":"extract","keep_extras":true}'
    remove = '{"ids":[-1,2],"mode":"remove"}'
    allowed = f"Origin: http://{VIEW_ADDR}\r\nX-Splatseg-Token: {VIEW_TOKEN}\r\n"
    seeds = {
        "page": f"GET / HTTP/1.1\r\n{host}\r\n",
        "scene": f"GET /api/scene.json?x=1 HTTP/1.1\r\n{host}Connection: close\r\n\r\n",
        "chunk": f"HEAD /api/gaussians/0.bin HTTP/1.0\r\n{host}\r\n",
        "label": f"GET /api/label/0/1/2 HTTP/1.1\r\n{host}\r\n",
        "asset": f"GET /assets/viewer.js HTTP/1.1\r\nHost: localhost:8080\r\n\r\n",
        "export": f"POST /api/export HTTP/1.1\r\n{host}{allowed}Content-Length: {len(export)}\r\n\r\n{export}",
        "export_remove": f"POST /api/export HTTP/1.1\r\n{host}{allowed}Content-Length: {len(remove)}\r\n\r\n{remove}",
        "export_no_token": f"POST /api/export HTTP/1.1\r\n{host}Origin: http://evil.example\r\n"
                           f"Content-Type: text/plain\r\nContent-Length: {len(export)}\r\n\r\n{export}",
        "huge_length": f"POST /api/export HTTP/1.1\r\n{host}{allowed}Content-Length: 1000000000000\r\n\r\n{{}}",
        "chunked": f"POST /api/export HTTP/1.1\r\n{host}Transfer-Encoding: chunked\r\n\r\n2\r\n{{}}\r\n0\r\n\r\n",
        "rebind": "GET /api/scene.json HTTP/1.1\r\nHost: rebind.evil.example:8080\r\n\r\n",
    }
    for name, text in seeds.items():
        put("view_request", f"seed_{name}.http", text)


def main(scene, corpus):
    scene, corpus = Path(scene), Path(corpus)

    def put(target, name, data):
        d = corpus / target
        d.mkdir(parents=True, exist_ok=True)
        (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())

    props, rows = read_ply(scene / "gaussians.ply")
    rows = rows[:6]
    for fmt, name in [("binary_little_endian", "le"), ("binary_big_endian", "be"), ("ascii", "ascii")]:
        put("ply", f"seed_{name}.ply", write_ply(props, rows, fmt))
    nan_rows = [tuple(float("nan") if (i == 1 and k == 0) else v for k, v in enumerate(r)) for i, r in enumerate(rows)]
    put("ply", "seed_nan_row.ply", write_ply(props, nan_rows, "binary_little_endian"))

    model = scene / "sparse" / "0"
    cameras, images = (model / "cameras.txt").read_text(), (model / "images.txt").read_text()
    points = "\n".join(data_lines((model / "points3D.txt").read_text())[:12]) + "\n"
    for i, text in enumerate([cameras, images, points]):
        put("colmap_txt", f"seed_{i}.txt", bytes([i]) + text.encode())
    for i, data in enumerate([cameras_bin(cameras), images_bin(images), points_bin(points)]):
        put("colmap_bin", f"seed_{i}.bin", bytes([i]) + data)
    put("transforms_json", "seed_ngp.json", transforms(images, cameras))

    masks = json.loads((scene / "sam" / "view_000.json").read_text())[:3]
    put("sam_json", "seed_coco_rle.json", json.dumps(masks))
    h, w = masks[0]["segmentation"]["size"]
    put("rle_string", "seed_0.bin", struct.pack("<HH", h, w) + masks[0]["segmentation"]["counts"].encode())
    csv = ["id,area,bbox_x0,bbox_y0,bbox_w,bbox_h,point_input_x,point_input_y,predicted_iou,"
           "stability_score,crop_box_x0,crop_box_y0,crop_box_w,crop_box_h"]
    for i, m in enumerate(masks):
        csv.append(",".join(str(v) for v in [i, m["area"], *m["bbox"], *m["point_coords"][0],
                                             m["predicted_iou"], m["stability_score"], *m["crop_box"]]))
    put("sam_metadata_csv", "seed_metadata.csv", "\n".join(csv) + "\n")

    depth = np.load(scene / "depth" / "view_000.npy")[:12, :16]
    put("npy", "seed_f32.npy", npy_bytes(depth.astype("<f4")))
    put("npy", "seed_f16_be.npy", npy_bytes(depth.astype(">f2")))
    features = np.load(scene / "features" / "view_000.npy")[:3, :4, :8]
    put("npy", "seed_features.npy", npy_bytes(np.ascontiguousarray(features)))
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("depth.npy", npy_bytes(depth.astype("<f4")))
        z.writestr("width.npy", npy_bytes(np.array(16, dtype="<i8")))
    put("npz", "seed_deflated.npz", buffer.getvalue())

    put("label_png", "seed_16bit.png", (scene / "gt" / "instance" / "view_000.png").read_bytes())
    view_request_seeds(put)


if __name__ == "__main__":
    main(*sys.argv[1:3])
