"""Seed inputs for the `raster_read` fuzz target: one small valid file per reader, each
prefixed with the byte that selects its extension (and PNG encoding) in the target.

Usage (numpy and Pillow, e.g. the peers' venv from ../shared/bench/setup.sh):
    python3 codec/fuzz/raster_seeds.py OUT_DIR
then `cargo fuzz run raster_read corpus/raster_read OUT_DIR -- ...` from codec/.
"""

import io
import pathlib
import sys

import numpy as np
from PIL import Image

SHARED = pathlib.Path(__file__).resolve().parents[3] / "shared" / "data" / "dem"
# The target's extension order: hgt, tif, png, asc, npy, npz; PNG encoding = pick / 8 % 4.
HGT, TIF, PNG, ASC, NPY, NPZ = range(6)
GRAY, TERRAIN_RGB = 8, 16


def png(img):
    out = io.BytesIO()
    img.save(out, format="PNG")
    return out.getvalue()


def main(out):
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(7)
    heights = (rng.integers(0, 2000, size=(17, 17))).astype(np.int16)
    seeds = {
        "hgt-short": bytes([HGT]) + heights.astype(">i2").tobytes(),
        "tif-terra": bytes([TIF]) + (SHARED / "terra_elev.tif").read_bytes(),
        "png-gray16": bytes([PNG + GRAY])
        + png(Image.fromarray(heights.astype(np.uint16))),
        "png-rgb": bytes([PNG + TERRAIN_RGB])
        + png(Image.open(SHARED / "fuji.png").convert("RGB").crop((0, 0, 17, 17))),
        "asc": bytes([ASC])
        + (
            "ncols 4\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 30\nNODATA_value -9999\n"
            "1 2 3 4\n5 -9999 7 8\n9 10 11 12\n"
        ).encode(),
    }
    npy = io.BytesIO()
    np.save(npy, heights.astype(np.float32))
    seeds["npy-f32"] = bytes([NPY]) + npy.getvalue()
    npz = io.BytesIO()
    np.savez_compressed(npz, elevation=heights)
    seeds["npz"] = bytes([NPZ]) + npz.getvalue()
    for name, data in seeds.items():
        (out / name).write_bytes(data)
    print(f"{len(seeds)} seeds in {out}")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]))
