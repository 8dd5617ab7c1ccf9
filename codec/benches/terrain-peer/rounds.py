#!/usr/bin/env python3
"""Paired speed rounds: zerotile's decode to T/8 + mesh against Martini's createTile + getMesh
at equal true max error, alternating, on terrain_mesh.py's three 257² tiles. Both Martinis run:
@mapbox/martini (JS, the original) and pymartini (Cython, the one terrain_mesh.py times).

usage: rounds.py [ROUNDS] [ITERATIONS]   (defaults 9 and 31; run from anywhere)

run.sh's criterion group takes minutes before Martini runs, and load on a shared machine drifts
in that time, on one side of the ratio only. Here each round times every case on both sides
(the `terrain_rounds` bench binary, the same function the criterion bench times, then node and
pymartini, or the peers first on odd rounds), each a median of ITERATIONS after warm-up, and
takes the ratio inside the round. terrain_mesh.py's pymartini figure is medians of 5 a side
minutes apart, so it carries the machine's drift; this one does not. The table gives the median ratio over the rounds, its range, and how many rounds came
out below 1. Martini's E per budget is fixed once, before the rounds (peer.fair_params: the
largest E whose mesh's true max error is within T).
"""
from __future__ import annotations

import json
import statistics
import subprocess
import sys
from pathlib import Path

sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parent))
import peer  # noqa: E402  (benchlib, the peers' venv, Martini's fair E)

bl, tm, np = peer.bl, peer.tm, peer.np


def zerotile_round(repo: Path, iterations: int) -> dict:
    out = subprocess.run(
        ["cargo", "bench", "-q", "-p", "zerotile-codec", "--bench", "terrain_rounds", "--", str(iterations)],
        cwd=repo, capture_output=True, text=True, check=True).stdout
    rows = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    return {(r["tile"], r["wavelet"], float(r["budget"])): r["ms"] for r in rows}


def main() -> int:
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 9
    iterations = int(sys.argv[2]) if len(sys.argv) > 2 else 31
    repo = Path(__file__).resolve().parents[3]
    from pymartini import Martini

    pym = Martini(257)
    # Per tile: its heights, Martini's (E, true error) per budget, and those E for node.
    tiles = []
    for name, path, spec, encoding in tm.DEFAULT_TILES:
        z = np.ascontiguousarray(bl.crop(bl.load_heightmap(path, encoding)[0], spec), dtype=np.float32)
        fair, _ = peer.fair_params(z, pym.create_tile(z))
        tiles.append((name, z, fair, sorted({e for e, _ in fair.values()})))
    # Build before the first round, so no round times a compile.
    zerotile_round(repo, 1)

    def martini() -> dict:
        return {name: peer.node_martini(z, params, iterations) for name, z, _, params in tiles}

    def pymartini() -> dict:
        return {name: peer.pymartini_times(pym, z, params, iterations) for name, z, _, params in tiles}

    # (tile, wavelet, T) -> one (zerotile ms, @mapbox/martini ms, pymartini ms) per round.
    pairs: dict = {}
    for r in range(rounds):
        if r % 2:
            m, py = martini(), pymartini()
            zt = zerotile_round(repo, iterations)
        else:
            zt = zerotile_round(repo, iterations)
            m, py = martini(), pymartini()
        for name, _, fair, _ in tiles:
            if m[name] is None:
                print("@mapbox/martini not installed: run ../shared/bench/setup.sh", file=sys.stderr)
                return 1
            for w in peer.WAVELETS:
                for t, (e, _) in fair.items():
                    pairs.setdefault((name, w, t), []).append((zt[(name, w, t)], m[name][e], py[name][e]))
        print(f"round {r + 1}/{rounds} done", file=sys.stderr)

    fair_of = {name: fair for name, _, fair, _ in tiles}
    rows = []
    for (name, w, t), ps in pairs.items():
        e, err = fair_of[name][t]
        row = [name, w, f"{t:g}", f"{e:.3g} ({err:.3g} m)", f"{statistics.median(p[0] for p in ps):.3f}"]
        for side in (1, 2):
            rs = [p[0] / p[side] for p in ps]
            row += [f"{statistics.median(p[side] for p in ps):.3f}", f"{statistics.median(rs):.2f}",
                    f"{min(rs):.2f}–{max(rs):.2f}", f"{sum(x < 1 for x in rs)}/{len(rs)}"]
        rows.append(row)
    head = ["tile", "wavelet", "T (m)", "Martini E (true err)", "zerotile ms",
            "@mapbox/martini ms", "ratio (median)", "ratio range", "rounds < 1",
            "pymartini ms", "ratio (median)", "ratio range", "rounds < 1"]
    print(f"# {rounds} paired rounds, medians of {iterations} a side a round; ratio = zerotile / Martini "
          "at equal true max error\n")
    print(bl.md_table(head, rows))
    # The docs' one-line form: per budget, the range of the median ratios over tiles and wavelets.
    print()
    for side, peer_name in ((1, "@mapbox/martini"), (2, "pymartini")):
        spans = []
        for t in sorted({t for _, _, t in pairs}):
            meds = [statistics.median(p[0] / p[side] for p in ps) for (_, _, tt), ps in pairs.items() if tt == t]
            spans.append(f"T = {t:g}: {min(meds):.2f}–{max(meds):.2f}")
        print(f"zerotile / {peer_name}, median over rounds, range over tiles and wavelets: " + "; ".join(spans))
    return 0


if __name__ == "__main__":
    sys.exit(main())
