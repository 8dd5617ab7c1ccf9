#!/usr/bin/env python3
"""Two zerotile binaries alternated on terrain_mesh.py's three 257² tiles: decode + mesh ms
(`eval terrain --repeat 11`, its medians) at T = 0.5 / 2 / 4 (about 4 / 15 / 30 m true error),
the second's time over the first's taken inside each round.

usage: pgo_compare.py BASE_BIN OTHER_BIN [ROUNDS]   (pgo.sh runs it; the tiles come from
terrain_mesh.py through peer.py, so it runs in the peers' venv like rounds.py)
"""
import json
import statistics
import subprocess
import sys
from pathlib import Path

sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parent))
import peer  # noqa: E402  (terrain_mesh.py's tiles)

THRESHOLDS = [0.5, 2.0, 4.0]


def times(binary: str) -> dict:
    out = {}
    for name, path, crop, encoding in peer.tm.DEFAULT_TILES:
        cmd = [binary, "eval", "terrain", str(path), "--crop", crop, "--json", "--repeat", "11",
               "--threshold", ",".join(f"{t:g}" for t in THRESHOLDS)]
        if encoding:
            cmd += ["--encoding", encoding]
        run = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
        for row in (json.loads(line) for line in run.splitlines() if line.startswith("{")):
            out[(name, row["param"])] = row["decode_ms"] + row["mesh_ms"]
    return out


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    base, other = sys.argv[1], sys.argv[2]
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 7
    pairs: dict = {}
    for r in range(rounds):
        if r % 2:
            o, b = times(other), times(base)
        else:
            b, o = times(base), times(other)
        for key in b:
            pairs.setdefault(key, []).append((b[key], o[key]))
    print(f"# {rounds} rounds alternating; ratio = {other} / {base}\n")
    for (name, t), ps in pairs.items():
        rs = [o / b for b, o in ps]
        print(f"{name} T={t:g}: base {statistics.median(b for b, _ in ps):.2f} ms, other "
              f"{statistics.median(o for _, o in ps):.2f} ms, ratio median {statistics.median(rs):.3f} "
              f"(range {min(rs):.3f}–{max(rs):.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
