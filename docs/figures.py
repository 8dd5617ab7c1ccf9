"""The pictures in the docs, made from the benchmarks' JSON and the zerotile binary.

    python3 docs/figures.py --zerotile target/release/zerotile \
        --codec-json codec.json --mesh-json mesh.json

`codec.json` / `mesh.json` come from `../shared/bench/terrain_codec.py --json` and
`../shared/bench/terrain_mesh.py --json`. Writes into docs/img/:
- rd-curves.svg: PSNR against bits per sample, zerotile and OpenJPEG 9/7, per tile;
- triangles-vs-error.svg: triangles against true max error, zerotile, Martini, Delatin;
- speed-vs-error.svg: decode + mesh time against true max error, zerotile and both Martinis;
- table1-meshes.png: the paper's Table 1 setting (8-bit 256², zerotree mesher) at three T;
- fandisk-curvature.png: the three nested curvature levels of the fandisk.
The charts need only the standard library; the two pictures need Pillow (the bench peers'
venv has it).
"""

import argparse
import json
import math
import pathlib
import subprocess
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
IMG = ROOT / "docs" / "img"
SHARED = ROOT.parent / "shared" / "data"
# Below 0.1 m of true error every mesher keeps nearly the full grid: the charts start there.
MIN_ERR = 0.1
COLOURS = {"zerotile": "#d62728", "OpenJPEG 9/7": "#1f77b4", "Martini": "#1f77b4",
           "Delatin": "#2ca02c", "pymartini": "#1f77b4", "@mapbox/martini": "#9467bd"}


# ----------------------------------------------------------------------------- charts
def chart(panels, x_label, y_label, log_x=False, log_y=False, legend_top=True, width=300,
          height=240):
    """One SVG with a panel per (title, {series: [(x, y)]}) side by side; the legend goes in
    the first panel's top-left or bottom-left corner, wherever the curves are not."""
    pad_l, pad_r, pad_t, pad_b = 56, 10, 24, 40
    total_w = width * len(panels)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{total_w}" height="{height + 28}" '
           'font-family="sans-serif" font-size="11">',
           f'<rect width="{total_w}" height="{height + 28}" fill="white"/>']
    tx = (lambda v: math.log10(v)) if log_x else (lambda v: v)
    ty = (lambda v: math.log10(v)) if log_y else (lambda v: v)
    for i, (title, series) in enumerate(panels):
        pts = [(x, y) for s in series.values() for x, y in s
               if (x > 0 or not log_x) and (y > 0 or not log_y)]
        if not pts:
            continue
        xs, ys = [tx(x) for x, _ in pts], [ty(y) for _, y in pts]
        x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
        x1, y1 = (x1 if x1 > x0 else x0 + 1), (y1 if y1 > y0 else y0 + 1)
        left, top = i * width + pad_l, pad_t
        w, h = width - pad_l - pad_r, height - pad_t - pad_b

        def px(x, y):
            return (left + (tx(x) - x0) / (x1 - x0) * w, top + h - (ty(y) - y0) / (y1 - y0) * h)
        out.append(f'<rect x="{left}" y="{top}" width="{w}" height="{h}" fill="none" '
                   'stroke="#999"/>')
        out.append(f'<text x="{left + w / 2}" y="{top - 8}" text-anchor="middle" '
                   f'font-weight="bold">{title}</text>')
        for v in ticks(x0, x1, log_x):
            a = left + (v - x0) / (x1 - x0) * w
            out.append(f'<line x1="{a:.1f}" y1="{top}" x2="{a:.1f}" y2="{top + h}" '
                       'stroke="#eee"/>')
            out.append(f'<text x="{a:.1f}" y="{top + h + 14}" text-anchor="middle">'
                       f'{label(10 ** v if log_x else v)}</text>')
        for v in ticks(y0, y1, log_y):
            b = top + h - (v - y0) / (y1 - y0) * h
            out.append(f'<line x1="{left}" y1="{b:.1f}" x2="{left + w}" y2="{b:.1f}" '
                       'stroke="#eee"/>')
            out.append(f'<text x="{left - 4}" y="{b + 4:.1f}" text-anchor="end">'
                       f'{label(10 ** v if log_y else v)}</text>')
        out.append(f'<text x="{left + w / 2}" y="{top + h + 30}" '
                   f'text-anchor="middle">{x_label}</text>')
        if i == 0:
            out.append(f'<text x="11" y="{top + h / 2}" text-anchor="middle" '
                       f'transform="rotate(-90 11 {top + h / 2})">{y_label}</text>')
        for j, (name, s) in enumerate(series.items()):
            s = sorted((x, y) for x, y in s if (x > 0 or not log_x) and (y > 0 or not log_y))
            colour = COLOURS.get(name, "#555")
            path = " ".join(f"{'M' if k == 0 else 'L'}{a:.1f},{b:.1f}"
                            for k, (a, b) in enumerate(px(x, y) for x, y in s))
            out.append(f'<path d="{path}" fill="none" stroke="{colour}" stroke-width="1.6"/>')
            for x, y in s:
                a, b = px(x, y)
                out.append(f'<circle cx="{a:.1f}" cy="{b:.1f}" r="2.2" fill="{colour}"/>')
            if i == 0:
                ly = (top + 12 + 14 * j) if legend_top else (top + h - 8 - 14 * (len(series) - 1 - j))
                out.append(f'<line x1="{left + 8}" y1="{ly - 4}" x2="{left + 22}" '
                           f'y2="{ly - 4}" stroke="{colour}" stroke-width="2"/>')
                out.append(f'<text x="{left + 26}" y="{ly}">{name}</text>')
    out.append("</svg>")
    return "\n".join(out)


def ticks(lo, hi, log):
    """Tick positions (in axis units) inside [lo, hi]: decades on a log axis, else a 1-2-5
    step giving 3 to 6 ticks."""
    if log:
        # Decades, and 2 / 5 (then 2.5) between them while that leaves too few ticks.
        for mantissas in ((1,), (1, 2, 5), (1, 2, 2.5, 5)):
            out = [e + math.log10(m) for e in range(math.floor(lo) - 1, math.ceil(hi) + 1)
                   for m in mantissas if lo - 1e-9 <= e + math.log10(m) <= hi + 1e-9]
            if len(out) >= 3:
                break
        return out
    span = hi - lo
    step = next(m * 10 ** e for e in range(math.floor(math.log10(span)) - 1, 99)
                for m in (1, 2, 5) if span / (m * 10 ** e) <= 5)
    return [k * step for k in range(math.ceil(lo / step), math.floor(hi / step) + 1)]


def label(v):
    if v >= 1000:
        return f"{v / 1000:g}k"
    return f"{v:g}"


def rd_curves(codec):
    panels = []
    for t in codec["tiles"]:
        opj = [(p["bps"], p["psnr_db"]) for p in t["peers"]
               if p["codec"] == "OpenJPEG 9/7" and p["psnr_db"]]
        ours = [(p["bps"], p["psnr_db"]) for p in t["zerotile"]
                if p["mode"] == "bpp" and p["psnr_db"]]
        panels.append((t["name"], {"zerotile": ours, "OpenJPEG 9/7": opj}))
    return chart(panels, "bits per sample", "PSNR (dB)", log_x=True)


def triangles_vs_error(mesh):
    panels = []
    for t in mesh["tiles"]:
        def curve(points):
            return [(p["max_abs_err"], p["triangles"]) for p in points
                    if p["max_abs_err"] >= MIN_ERR]
        ours = [(p["mesh_max_abs_err"], p["mesh_triangles"]) for p in t["zerotile"]
                if p["mesh_max_abs_err"] >= MIN_ERR]
        panels.append((t["name"], {"zerotile": ours,
                                   "Martini": curve(t["martini"]["points"]),
                                   "Delatin": curve(t["delatin"]["points"])}))
    return chart(panels, "true max error (m)", "triangles", log_x=True, log_y=True,
                 legend_top=False)


def speed_vs_error(mesh):
    """Decode + mesh time against true max error; Martini's is createTile + getMesh, at the
    true error the script measured for the same parameter."""
    panels = []
    for t in mesh["tiles"]:
        m = t["martini"]
        pts = [p for p in m["points"] if p["max_abs_err"] >= MIN_ERR and p.get("ms")]
        py = [(p["max_abs_err"], m["create_tile_ms"] + p["ms"]) for p in pts]
        js = []
        node = (t.get("node") or {}).get("martini") or {}
        by_param = {g["max_error"]: g["get_mesh_ms"] for g in node.get("meshes", [])}
        for p in pts:
            if p["param"] in by_param:
                js.append((p["max_abs_err"], node["create_tile_ms"] + by_param[p["param"]]))
        ours = [(p["mesh_max_abs_err"], p["decode_ms"] + p["mesh_ms"]) for p in t["zerotile"]
                if p["mesh_max_abs_err"] >= MIN_ERR]
        panels.append((t["name"], {"zerotile": ours, "pymartini": py, "@mapbox/martini": js}))
    return chart(panels, "true max error (m)", "decode + mesh ms", log_x=True, log_y=True,
                 legend_top=False)


# ----------------------------------------------------------------------------- pictures
def read_obj(path):
    vs, fs = [], []
    for line in pathlib.Path(path).read_text().splitlines():
        if line.startswith("v "):
            vs.append(tuple(float(c) for c in line.split()[1:4]))
        elif line.startswith("f "):
            fs.append(tuple(int(c.split("/")[0]) - 1 for c in line.split()[1:4]))
    return vs, fs


def terrain_panel(vs, fs, size, scale):
    """Top-down over the `size`² top-left window: heights as grey, the triangles' edges
    over them (the whole 256² tile at a readable scale would be too dense to see)."""
    from PIL import Image, ImageDraw
    fs = [f for f in fs if min(vs[k][0] for k in f) < size and min(vs[k][1] for k in f) < size]
    img = Image.new("RGB", (size * scale, size * scale), "white")
    draw = ImageDraw.Draw(img)
    zs = [v[2] for v in vs]
    lo, hi = min(zs), max(zs)
    for f in fs:
        z = sum(vs[k][2] for k in f) / 3
        g = int(150 + 100 * (z - lo) / max(hi - lo, 1e-9))
        draw.polygon([(vs[k][0] * scale, vs[k][1] * scale) for k in f], fill=(g, g, g))
    for f in fs:
        pts = [(vs[k][0] * scale, vs[k][1] * scale) for k in f]
        draw.line(pts + [pts[0]], fill=(40, 60, 120), width=1)
    return img


def shaded_panel(vs, fs, size):
    """Flat-shaded, painter's algorithm, a fixed oblique view filling the panel."""
    from PIL import Image, ImageDraw
    c = [sum(v[i] for v in vs) / len(vs) for i in range(3)]
    r = max(math.dist(v, c) for v in vs)
    ya, xa = math.radians(35), math.radians(25)

    def view(v):
        x, y, z = (v[i] - c[i] for i in range(3))
        x, z = x * math.cos(ya) + z * math.sin(ya), -x * math.sin(ya) + z * math.cos(ya)
        y, z = y * math.cos(xa) - z * math.sin(xa), y * math.sin(xa) + z * math.cos(xa)
        return x, y, z
    p = [view(v) for v in vs]
    xs, ys = [q[0] for q in p], [q[1] for q in p]
    s = 0.94 * size / max(max(xs) - min(xs), max(ys) - min(ys), r * 1e-9)
    mx, my = (max(xs) + min(xs)) / 2, (max(ys) + min(ys)) / 2
    p = [(q[0] - mx, q[1] - my, q[2]) for q in p]
    img = Image.new("RGB", (size, size), "white")
    draw = ImageDraw.Draw(img)
    light = (0.3, 0.5, 0.81)
    for f in sorted(fs, key=lambda f: sum(p[k][2] for k in f)):
        a, b, cc = (p[k] for k in f)
        u = [b[i] - a[i] for i in range(3)]
        w = [cc[i] - a[i] for i in range(3)]
        n = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
        ln = math.hypot(*n) or 1
        shade = abs(sum(n[i] * light[i] for i in range(3)) / ln)
        g = int(110 + 140 * shade)
        pts = [(size / 2 + q[0] * s, size / 2 - q[1] * s) for q in (a, b, cc)]
        draw.polygon(pts, fill=(g, g, int(g * 0.93)), outline=(70, 70, 80))
    return img


def run(cmd):
    return subprocess.run([str(c) for c in cmd], check=True, capture_output=True, text=True)


def side_by_side(panels, captions):
    from PIL import Image, ImageDraw
    w = sum(p.width for p in panels) + 10 * (len(panels) - 1)
    h = max(p.height for p in panels) + 22
    out = Image.new("RGB", (w, h), "white")
    x = 0
    for p, cap in zip(panels, captions):
        out.paste(p, (x, 0))
        ImageDraw.Draw(out).text((x + 4, p.height + 5), cap, fill=(0, 0, 0))
        x += p.width + 10
    return out


def table1(zt, tmp):
    thresholds = ["1.6", "3.2", "7"]
    out = run([zt, "eval", "terrain", SHARED / "dem" / "N44W072.hgt", "--crop", "300,500,256",
               "--8bit", "--mesher", "zerotree", "--wavelet", "97", "--threshold",
               ",".join(thresholds), "--repeat", "1", "--json", "--out", tmp])
    points = [json.loads(line) for line in out.stdout.splitlines()]
    panels, captions = [], []
    for t, p in zip(thresholds, points):
        vs, fs = read_obj(pathlib.Path(tmp) / f"threshold-{t}.obj")
        panels.append(terrain_panel(vs, fs, 128, 3))
        share = 100 * p["mesh_triangles"] / 130050
        captions.append(f"T = {t}: {p['mesh_triangles']:,} triangles ({share:.1f} %), "
                        f"mesh PSNR {p['mesh_psnr_db']:.1f} dB")
    return side_by_side(panels, captions)


def fandisk(zt, tmp):
    panels, captions = [], []
    model = SHARED / "meshes" / "fandisk.obj"
    for level in (1, 2, 3):
        path = pathlib.Path(tmp) / f"fandisk-{level}.obj"
        out = run([zt, "eval", "mesh", model, "--method", "curvature", "--level", str(level),
                   "--repeat", "1", "--samples", "0", "--json", "--out", path])
        p = json.loads(out.stdout.splitlines()[-1])
        vs, fs = read_obj(path)
        panels.append(shaded_panel(vs, fs, 420))
        captions.append(f"level {level}: {p['vertices']:,} of {p['vertices_in']:,} vertices")
    return side_by_side(panels, captions)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--zerotile", default=str(ROOT / "target" / "release" / "zerotile"))
    ap.add_argument("--codec-json")
    ap.add_argument("--mesh-json")
    a = ap.parse_args()
    IMG.mkdir(parents=True, exist_ok=True)
    if a.codec_json:
        (IMG / "rd-curves.svg").write_text(rd_curves(json.loads(pathlib.Path(a.codec_json)
                                                                .read_text())))
    if a.mesh_json:
        mesh = json.loads(pathlib.Path(a.mesh_json).read_text())
        (IMG / "triangles-vs-error.svg").write_text(triangles_vs_error(mesh))
        (IMG / "speed-vs-error.svg").write_text(speed_vs_error(mesh))
    with tempfile.TemporaryDirectory() as tmp:
        table1(a.zerotile, tmp).save(IMG / "table1-meshes.png", optimize=True)
        fandisk(a.zerotile, tmp).save(IMG / "fandisk-curvature.png", optimize=True)
    print(f"wrote {IMG}")


if __name__ == "__main__":
    main()
