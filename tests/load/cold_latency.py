#!/usr/bin/env python3
"""Cold-render latency, two zerotile binaries side by side (A/B in one script, so the
machine's drift falls on both): a fresh server per sample (empty caches), then

  tile    the first request of a zoom-10 tile (.terrain, default T): the tile and its four
          neighbours decoded, the stitched mesh, the encoding;
  view    the first request of a camera view (paper eq. 4): up to 16 tiles and their
          neighbours decoded and meshed, cut to the footprint;
  block   a 6x6 block of zoom-10 tiles fetched in order, one at a time (ms per tile);
  block4  the same block with 4 requests in flight (ms per tile): the server busy on
          every core, where parallel work inside one render has nothing left to gain;
  png     the same block as 512² terrain-RGB PNGs, in order (ms per tile): one decode and
          the PNG's compression each.

Rounds alternate which binary goes first; the report gives each binary's medians and the
median over rounds of B / A (below 1: B is faster).

usage: tests/load/cold_latency.py BIN_A BIN_B DATA_DIR [ROUNDS]
DATA_DIR must hold srtm.ztd: zerotile ingest --scheme geodetic --name srtm --data DIR N44W072.hgt
"""
import concurrent.futures
import statistics
import sys
import time
import urllib.request

from fresh_server import fresh_server

ADDR = "127.0.0.1:18412"
BASE = f"http://{ADDR}/v1/datasets/srtm"
ACCEPT = {"Accept": "application/vnd.quantized-mesh"}
VIEW = "/view?eye=-71.3,44.3,2500&target=-71.5,44.5,500&fov=60"
KINDS = ("tile", "view", "block", "block4", "png")


def get(url: str, headers: dict | None = None) -> None:
    with urllib.request.urlopen(urllib.request.Request(url, headers=headers or {})) as r:
        r.read()


def timed_ms(f) -> float:
    t0 = time.perf_counter()
    f()
    return (time.perf_counter() - t0) * 1000


def block(layer: dict) -> list[str]:
    r = layer["available"][10][0]
    return [f"{BASE}/tiles/10/{x}/{y}.terrain?threshold=4"
            for y in range(r["startY"], min(r["endY"], r["startY"] + 5) + 1)
            for x in range(r["startX"], min(r["endX"], r["startX"] + 5) + 1)]


def sample(binary: str, data: str, kind: str) -> float:
    """One cold measurement of `kind` on a fresh server, in ms (per tile for blocks)."""
    with fresh_server(binary, data, ADDR, "srtm") as layer:
        urls = block(layer)
        if kind == "tile":
            return timed_ms(lambda: get(urls[14].replace("?threshold=4", ""), ACCEPT))
        if kind == "view":
            return timed_ms(lambda: get(BASE + VIEW))
        if kind == "block":
            return timed_ms(lambda: [get(u, ACCEPT) for u in urls]) / len(urls)
        if kind == "png":
            pngs = [u.replace(".terrain?threshold=4", ".png") for u in urls]
            return timed_ms(lambda: [get(u) for u in pngs]) / len(pngs)
        with concurrent.futures.ThreadPoolExecutor(4) as pool:
            return timed_ms(lambda: list(pool.map(lambda u: get(u, ACCEPT), urls))) / len(urls)


def main() -> None:
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    a, b, data = sys.argv[1:4]
    rounds = int(sys.argv[4]) if len(sys.argv) > 4 else 7
    ms = {k: {a: [], b: []} for k in KINDS}
    ratios = {k: [] for k in KINDS}
    for i in range(rounds):
        for kind in KINDS:
            order = (a, b) if i % 2 == 0 else (b, a)
            got = {binary: sample(binary, data, kind) for binary in order}
            for binary, v in got.items():
                ms[kind][binary].append(v)
            ratios[kind].append(got[b] / got[a])
        print(f"round {i + 1}/{rounds}: " + ", ".join(
            f"{k} {ratios[k][-1]:.2f}" for k in KINDS), file=sys.stderr)
    print("| cold | A median ms | B median ms | B / A (median over rounds) | rounds B faster |")
    print("|---|---|---|---|---|")
    for k in KINDS:
        faster = sum(r < 1 for r in ratios[k])
        print(f"| {k} | {statistics.median(ms[k][a]):.1f} | {statistics.median(ms[k][b]):.1f} "
              f"| {statistics.median(ratios[k]):.2f} | {faster} of {rounds} |")


if __name__ == "__main__":
    main()
