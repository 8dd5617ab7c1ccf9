#!/usr/bin/env python3
"""Martini beside the criterion medians of `decode_and_mesh_257` (see run.sh), on the three
257² tiles of ../shared/bench/terrain_mesh.py (N44W072, fuji, jacksboro).

usage: peer.py CRITERION_DIR [REPEAT]

Martini's side is what it does per tile: createTile (its error pass) + getMesh(E), with E = the
zerotile budget T. Martini's E understates its true max error (up to ~1.7x on these tiles, see
docs/terrain-mesh.md), so at equal E its mesh is coarser and cheaper than zerotile's: the
comparison leans towards Martini. Its init (per grid size, like zerotile's Hierarchy) is left
out on both sides. Times are medians of REPEAT runs, in the same run as the criterion bench.

A second table compares at equal true max error, the measure the triangle-count figure uses:
Martini is timed at the largest E whose mesh's true max error (every sample against the mesh,
benchlib.mesh_error) is within T, the bound zerotile's mesh keeps (decode to T/8, mesh within
7T/8, the server's split). Only getMesh's time changes with E; createTile is the same.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

sys.dont_write_bytecode = True
BENCH = Path(os.environ.get("ZT_BENCH", Path(__file__).resolve().parents[4] / "shared" / "bench"))
sys.path.insert(0, str(BENCH))
import benchlib as bl  # noqa: E402

# Re-execs the script that was run (this one, or rounds.py importing it) under the peers' venv.
bl.use_peers_python()

import numpy as np  # noqa: E402

import terrain_mesh as tm  # noqa: E402  (its Curve: the peer's E at a true max error)

BUDGETS = [4.0, 16.0, 64.0]
WAVELETS = ["cdf97", "legall53"]


class PyMartini:
    """terrain_mesh.Curve's mesher interface over one pymartini tile."""

    def __init__(self, tile, heights: np.ndarray):
        self.tile, self.heights = tile, heights

    def mesh(self, p):
        v, t = self.tile.get_mesh(float(p))
        return v, self.heights[v[:, 1], v[:, 0]], t


def criterion_median_ms(root: Path, tile: str, wavelet: str, t: float) -> float | None:
    # N44W072 keeps the wavelet's bare name (see the bench); the others are TILE-wavelet.
    name = wavelet if tile == "N44W072" else f"{tile}-{wavelet}"
    f = root / "decode_and_mesh_257" / name / f"T={t:g}" / "new" / "estimates.json"
    if not f.exists():
        return None
    return json.loads(f.read_text())["median"]["point_estimate"] / 1e6


def martini_times(z: np.ndarray, repeat: int) -> tuple[dict, dict, dict, dict]:
    """Martini on one tile: (ms at E = T, ms at equal true error, that E and its error, the
    true error at E = T), each per peer name and budget."""
    from pymartini import Martini

    tile = np.ascontiguousarray(z, dtype=np.float32)
    martini = Martini(257)
    fair, nominal = fair_params(tile, martini.create_tile(tile))
    params = sorted(set(BUDGETS) | {p for p, _ in fair.values()})
    times = {"pymartini": pymartini_times(martini, tile, params, repeat)}
    m = node_martini(tile, params, repeat)
    if m is not None:
        times["@mapbox/martini"] = m
    # Look-ups by the exact float passed (node echoes it back as parsed from repr).
    at_e = {name: {e: ts[e] for e in BUDGETS} for name, ts in times.items()}
    at_true = {name: {e: ts[fair[e][0]] for e in fair} for name, ts in times.items()}
    return at_e, at_true, fair, nominal


def fair_params(tile: np.ndarray, t) -> tuple[dict, dict]:
    """Per budget T: Martini's E at equal true max error (the largest E whose mesh is within
    T, with that mesh's true error) where one exists, and the true error at E = T. `t` is
    pymartini's tile of `tile`."""
    # Martini's E with true max error within each budget (terrain_mesh.py's search).
    curve = tm.Curve("Martini", tile.astype(np.float64), PyMartini(t, tile))
    for e in [x * b for b in BUDGETS for x in (0.25, 0.5, 0.75, 1.0)]:
        curve.point(e)
    fair = {}
    for e in BUDGETS:
        best = curve.best_at(e, steps=10)
        if best is None:  # no Martini mesh within T at all: no fair row
            continue
        # best_at breaks ties towards the smaller E; name the largest E giving that mesh.
        same = [q["param"] for q in curve.points.values()
                if q["triangles"] == best["triangles"] and q["max_abs_err"] <= e + curve.tol]
        fair[e] = max(same), best["max_abs_err"]
    nominal = {e: curve.point(e)["max_abs_err"] for e in BUDGETS}
    return fair, nominal


def pymartini_times(martini, tile: np.ndarray, params: list[float], repeat: int) -> dict:
    """pymartini's createTile + getMesh(E) ms (the sum of their medians of `repeat`) per E in
    `params`; `martini` is a `Martini(257)`, whose init neither side times."""
    _, create = bl.median_ms(lambda: martini.create_tile(tile), repeat)
    t = martini.create_tile(tile)
    return {p: create + bl.median_ms(lambda: t.get_mesh(p), repeat)[1] for p in params}


def node_martini(tile: np.ndarray, params: list[float], repeat: int) -> dict | None:
    """@mapbox/martini's createTile + getMesh(E) ms (medians of `repeat`) per E in `params`,
    keyed by the float passed; None without node or the package (setup.sh installs both)."""
    node_js = BENCH / "terrain_mesh_node.mjs"
    if not shutil.which("node") or not (bl.NODE_DIR / "node_modules" / "@mapbox" / "martini").exists():
        return None
    with tempfile.TemporaryDirectory() as tmp:
        f32 = Path(tmp) / "tile.f32"
        tile.astype("<f4").tofile(f32)
        errors = ",".join(repr(p) for p in params)
        # Delatin's minimum error above every E: this times Martini alone.
        out = subprocess.run(["node", str(node_js), str(bl.NODE_DIR), str(f32), "257", errors, str(repeat), "1e30"],
                             capture_output=True, text=True, check=True).stdout
    m = json.loads(out.strip().splitlines()[-1]).get("martini")
    if not m:
        return None
    return {g["max_error"]: m["create_tile_ms"] + g["get_mesh_ms"] for g in m["meshes"]}


def main() -> int:
    root = Path(sys.argv[1])
    repeat = int(sys.argv[2]) if len(sys.argv) > 2 else 51
    nominal_rows, fair_rows, names = [], [], []
    for tile, path, spec, encoding in tm.DEFAULT_TILES:
        z = bl.crop(bl.load_heightmap(path, encoding)[0], spec)
        at_e, at_true, fair, nominal = martini_times(z, repeat)
        names = list(at_e)
        for w in WAVELETS:
            for e in BUDGETS:
                zt = criterion_median_ms(root, tile, w, e)
                cells = [tile, w, f"{e:g}", "-" if zt is None else f"{zt:.3f}"]
                cells += [f"{at_e[p][e]:.3f}" for p in names]
                cells += ["-" if zt is None else f"{zt / at_e[p][e]:.2f}" for p in names]
                nominal_rows.append(cells)
            for e in fair:
                zt = criterion_median_ms(root, tile, w, e)
                p, err = fair[e]
                cells = [tile, w, f"{e:g}", f"{p:.3g} ({err:.3g} m)", f"{nominal[e]:.3g} m",
                         "-" if zt is None else f"{zt:.3f}"]
                cells += [f"{at_true[n][e]:.3f}" for n in names]
                cells += ["-" if zt is None else f"{zt / at_true[n][e]:.2f}" for n in names]
                fair_rows.append(cells)

    head = ["tile", "wavelet", "T (m)", "zerotile ms"] + [f"{p} ms" for p in names]
    head += [f"zerotile / {p}" for p in names]
    print(f"# decode to T/8 + mesh (criterion median) vs Martini createTile + getMesh(T) (median of {repeat})\n")
    print(bl.md_table(head, nominal_rows))

    head = ["tile", "wavelet", "T (m)", "Martini E", "Martini true max err (at E = T)", "zerotile ms"]
    head += [f"{p} ms" for p in names] + [f"zerotile / {p}" for p in names]
    print("\n# the same, Martini at equal true max error: the largest E whose mesh is within T\n")
    print(bl.md_table(head, fair_rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
