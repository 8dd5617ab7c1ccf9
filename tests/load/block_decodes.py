#!/usr/bin/env python3
"""Decodes a tile once the decoded-tile cache is full: a fresh server with --cache-mb 64
fetches N44W072's 42 zoom-10 tiles (a 7x6 block, in order, as .bin) at seven thresholds in
turn, and reports for each pass the decodes a tile (from /metrics) and the time a tile. A
stitched tile needs its four neighbours decoded to the same depth; fetched in order, each
tile's neighbours were decoded for the tile before, so a cache that keeps new tiles long
enough decodes about one tile a tile.

usage: tests/load/block_decodes.py BIN DATA_DIR PORT
DATA_DIR must hold n44g.ztd: zerotile ingest --scheme geodetic --name n44g --data DIR ../shared/data/dem/N44W072.hgt
"""
import re
import subprocess
import sys
import time
import urllib.request

binp, data, port = sys.argv[1], sys.argv[2], int(sys.argv[3])
base = f"http://127.0.0.1:{port}"
server = subprocess.Popen(
    [binp, "serve", "--data", data, "--addr", f"127.0.0.1:{port}", "--cache-mb", "64"],
    stdout=subprocess.PIPE,
    stderr=subprocess.DEVNULL,
)
server.stdout.readline()


def counter(name):
    text = urllib.request.urlopen(f"{base}/metrics").read().decode()
    return float(re.search(f"zerotile_{name} ([0-9.e+]+)", text).group(1))


try:
    for t in ["13.7", "7.3", "3.1", "1.5", "0.7", "13.7", "7.3"]:
        before, started, n = counter("tiles_decoded_total"), time.time(), 0
        for x in range(614, 621):
            for y in range(762, 768):
                url = f"{base}/v1/datasets/n44g/tiles/10/{x}/{y}.bin?threshold={t}"
                urllib.request.urlopen(url).read()
                n += 1
        decodes = counter("tiles_decoded_total") - before
        took = (time.time() - started) / n * 1000
        print(f"T {t:>5}: {n} tiles, {decodes / n:.2f} decodes a tile, {took:.1f} ms a tile")
finally:
    server.terminate()
    server.wait(timeout=20)
