"""Independent readers for the tests (pure Python + NumPy): PNG, COCO RLE strings, PLY columns.

They let the tests compare the package's arrays with the files the command line wrote without
going through the package's own readers.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np


def read_png(path: Path) -> np.ndarray:
    """A non-interlaced 8/16-bit grey or RGB(A) PNG as ``[H, W]`` or ``[H, W, C]`` (uint8/uint16)."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"not a PNG: {path}"
    pos, idat = 8, b""
    width = height = depth = colour = None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert interlace == 0, "interlaced PNGs are not read here"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    channels = {0: 1, 2: 3, 4: 2, 6: 4}[colour]
    bpp = channels * depth // 8
    stride = width * bpp
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8).reshape(height, stride + 1)
    out = np.zeros((height, stride), dtype=np.int32)
    previous = np.zeros(stride, dtype=np.int32)
    for y in range(height):
        kind, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        row = np.zeros(stride, dtype=np.int32)
        if kind == 0:
            row = line
        elif kind == 2:
            row = (line + previous) & 0xFF
        else:
            for x in range(stride):
                left = row[x - bpp] if x >= bpp else 0
                up = previous[x]
                if kind == 1:
                    row[x] = (line[x] + left) & 0xFF
                elif kind == 3:
                    row[x] = (line[x] + (left + up) // 2) & 0xFF
                else:
                    upper_left = previous[x - bpp] if x >= bpp else 0
                    p = left + up - upper_left
                    pa, pb, pc = abs(p - left), abs(p - up), abs(p - upper_left)
                    pred = left if pa <= pb and pa <= pc else (up if pb <= pc else upper_left)
                    row[x] = (line[x] + pred) & 0xFF
        out[y] = row
        previous = row
    if depth == 16:
        pixels = (out[:, 0::2] << 8 | out[:, 1::2]).astype(np.uint16)
    else:
        pixels = out.astype(np.uint8)
    pixels = pixels.reshape(height, width, channels)
    return pixels[:, :, 0] if channels == 1 else pixels


def coco_counts(text: str) -> List[int]:
    """The run lengths of a compressed COCO RLE string (pycocotools' format)."""
    counts: List[int] = []
    p = 0
    while p < len(text):
        x, k, more = 0, 0, True
        while more:
            c = ord(text[p]) - 48
            x |= (c & 0x1F) << (5 * k)
            more = bool(c & 0x20)
            p += 1
            k += 1
            if not more and (c & 0x10):
                x |= -1 << (5 * k)
        if len(counts) > 2:
            x += counts[-2]
        counts.append(x)
    return counts


def decode_rle(rle: Dict) -> np.ndarray:
    """A COCO RLE ``{"size": [H, W], "counts": str | list}`` as ``bool[H, W]``."""
    h, w = rle["size"]
    counts = rle["counts"]
    if isinstance(counts, str):
        counts = coco_counts(counts)
    flat = np.zeros(h * w, dtype=bool)
    pos, value = 0, False
    for n in counts:
        flat[pos : pos + n] = value
        pos += n
        value = not value
    return flat.reshape(w, h).T.copy()  # column-major runs


PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def read_ply_columns(path: Path) -> Tuple[List[str], np.ndarray]:
    """A binary little-endian PLY's vertex property names and rows (a structured array)."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert "format binary_little_endian 1.0" in header, header[:3]
    count = next(int(line.split()[2]) for line in header if line.startswith("element vertex"))
    fields = [(line.split()[2], "<" + PLY_TYPES[line.split()[1]]) for line in header if line.startswith("property")]
    rows = np.frombuffer(data, dtype=np.dtype(fields), count=count, offset=end)
    return [name for name, _ in fields], rows
