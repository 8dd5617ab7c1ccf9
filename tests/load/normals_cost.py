#!/usr/bin/env python3
"""What octvertexnormals costs a client streaming a block of tiles: a fresh server per run
(cold caches), the same 6×6 block of zoom-10 tiles fetched in order, without and with
normals, alternating which goes first, 4 runs each; ms per tile, medians.

With normals the server also decodes each tile's corner neighbours (the normals read a
sample of each), so this is the price of corner normals that agree, plus the normals.

usage: tests/load/normals_cost.py ZEROTILE_BIN DATA_DIR
DATA_DIR must hold srtm.ztd: zerotile ingest --scheme geodetic --name srtm --data DIR N44W072.hgt
"""
import statistics
import sys
import time
import urllib.request

from fresh_server import fresh_server

ADDR = "127.0.0.1:18411"
ACCEPT = "application/vnd.quantized-mesh"


def run(binary: str, data: str, normals: bool) -> tuple[float, int]:
    with fresh_server(binary, data, ADDR, "srtm") as layer:
        base = f"http://{ADDR}/v1/datasets/srtm"
        r = layer["available"][10][0]
        accept = ACCEPT + (";extensions=octvertexnormals" if normals else "")
        t0, n = time.perf_counter(), 0
        for y in range(r["startY"], min(r["endY"], r["startY"] + 5) + 1):
            for x in range(r["startX"], min(r["endX"], r["startX"] + 5) + 1):
                url = f"{base}/tiles/10/{x}/{y}.terrain?threshold=4"
                req = urllib.request.Request(url, headers={"Accept": accept})
                with urllib.request.urlopen(req) as resp:
                    resp.read()
                n += 1
        return (time.perf_counter() - t0) * 1000 / n, n


def main() -> None:
    binary, data = sys.argv[1], sys.argv[2]
    times: dict[bool, list[float]] = {False: [], True: []}
    n = 0
    for k in range(4):
        for normals in ([False, True] if k % 2 == 0 else [True, False]):
            ms, n = run(binary, data, normals)
            times[normals].append(ms)
    plain, lit = statistics.median(times[False]), statistics.median(times[True])
    print(f"{n} tiles in order, a cold server each run; ms per tile, median of 4: "
          f"plain {plain:.2f}, octvertexnormals {lit:.2f}, ratio {lit / plain:.2f}")


if __name__ == "__main__":
    main()
