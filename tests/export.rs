//! `zerotile export`: a static tree that serves the same bytes as `zerotile serve`.
#![allow(
    clippy::unwrap_used,
    reason = "test helpers: a failure to spawn the binary should fail the test loudly"
)]

use std::path::{Path, PathBuf};
use std::process::Command;

use zerotile_codec::container::{Container, Limits};
use zerotile_codec::formats::quantized_mesh;
use zerotile_tests::server::Server;
use zerotile_tests::{assert_success, fresh_dir, shared_data, zerotile_bin};

fn zerotile(args: &[&str], dir: &Path) -> std::process::Output {
    Command::new(zerotile_bin())
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().filter_map(Result::ok) {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == ext) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn a_static_tree_holds_what_the_server_serves() {
    let dir = fresh_dir("export-tree");
    let hgt = shared_data().join("dem/N44W072.hgt");
    let hgt = hgt.to_str().unwrap();
    let out = zerotile(
        &[
            "ingest", hgt, "--name", "n44", "--scheme", "geodetic", "--quiet",
        ],
        &dir,
    );
    assert_success(&out);
    let out = zerotile(
        &[
            "export", "n44", "--out", "static", "--zoom", "8-10", "--quiet",
        ],
        &dir,
    );
    assert_success(&out);
    // Zooms 0–7 are missing, and CesiumJS starts at 0: the export says so.
    let note = String::from_utf8_lossy(&out.stderr);
    assert!(
        note.contains("no zooms below 8") && note.contains("level 0"),
        "{note}"
    );

    // Every tile of zooms 8–10 is there and decodes; layer.json points at them.
    let tiles = files(&dir.join("static"), "terrain");
    let per_zoom = |z: &str| {
        tiles
            .iter()
            .filter(|p| p.strip_prefix(dir.join("static")).unwrap().starts_with(z))
            .count()
    };
    // Exactly the container's tiles of each zoom, which cover lon −72..−71, lat 44..45:
    // at least 2×2, 4×3 and 7×6 tiles at zooms 8, 9, 10.
    let bytes = std::fs::read(dir.join("data/n44.ztd")).unwrap();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    for (z, footprint) in [(8u8, 4), (9, 12), (10, 42)] {
        let stored = c.tiles().filter(|(id, _)| id.z == z).count();
        assert_eq!(per_zoom(&z.to_string()), stored, "zoom {z}");
        assert!(stored >= footprint, "zoom {z}: {stored}");
    }
    let layer: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("static/layer.json")).unwrap()).unwrap();
    assert_eq!(layer["scheme"], "tms");
    assert!(layer["tiles"][0]
        .as_str()
        .unwrap()
        .starts_with("{z}/{x}/{y}.terrain"));
    // Each tile carries the extensions layer.json lists and no other: a static host cannot
    // negotiate, and CesiumJS reads a metadata extension whether it asked for it or not,
    // failing the tile when layer.json has no `metadataAvailability` (it has none).
    assert_eq!(
        layer["extensions"],
        serde_json::json!(["octvertexnormals", "watermask"])
    );
    assert!(layer.get("metadataAvailability").is_none());
    assert_eq!(layer["maxzoom"], 10);
    assert_eq!(layer["available"].as_array().unwrap().len(), 11);
    for t in &tiles {
        let qm = quantized_mesh::decode(&std::fs::read(t).unwrap()).unwrap();
        assert!(!qm.triangles.is_empty(), "{}", t.display());
        assert!(qm.normals.is_some(), "{}", t.display());
        assert!(qm.water_mask.is_some(), "{}", t.display());
        assert!(qm.metadata.is_none(), "{}", t.display());
        assert!(qm.unknown_extensions.is_empty(), "{}", t.display());
    }

    // Byte for byte what `zerotile serve` sends for the same ask.
    let s = Server::start(&dir.join("data"));
    for rel in [
        "10/617/765.terrain",
        "9/308/382.terrain",
        "8/154/191.terrain",
    ] {
        let file = std::fs::read(dir.join("static").join(rel)).unwrap();
        let r = s.get(
            &format!("/v1/datasets/n44/tiles/{rel}"),
            &[(
                "accept",
                "application/vnd.quantized-mesh;extensions=octvertexnormals-watermask",
            )],
        );
        assert_eq!(r.status, 200, "{rel}");
        assert_eq!(r.body, file, "{rel}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_failed_export_leaves_the_previous_tree_and_says_why() {
    let dir = fresh_dir("export-atomic");
    let tif = shared_data().join("dem/terra_elev.tif");
    let tif = tif.to_str().unwrap();
    assert!(zerotile(
        &["ingest", tif, "--name", "lux", "--scheme", "geodetic", "--quiet"],
        &dir
    )
    .status
    .success());
    let ok = zerotile(
        &[
            "export", "lux", "--format", "png", "--out", "tree", "--quiet",
        ],
        &dir,
    );
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let before = files(&dir.join("tree"), "png");
    assert!(!before.is_empty());

    // Exit 2 for a usage error (a flag no dataset could make right), 1 for the data's.
    for (args, code, needle) in [
        // Past zoom 28 no dataset has tiles; past lux's own, this one has none.
        (
            &["export", "lux", "--out", "tree", "--zoom", "3-40"][..],
            2,
            "--zoom",
        ),
        (
            &["export", "lux", "--out", "tree", "--zoom", "20-25"][..],
            1,
            "--zoom",
        ),
        (&["export", "nope", "--out", "tree"][..], 1, "nope"),
        (
            &["export", "lux", "--out", "tree", "--format", "tiff"][..],
            2,
            "--format",
        ),
        (
            &["export", "../lux", "--out", "tree"][..],
            1,
            "dataset name",
        ),
        // A TileJSON lists PNG tiles: the flags alone rule out any other format; a png
        // export of this geodetic dataset is refused by the dataset's scheme.
        (
            &[
                "export",
                "lux",
                "--out",
                "tree",
                "--format",
                "json",
                "--base-url",
                "https://a.example/",
            ][..],
            2,
            "use it with --format png",
        ),
        (
            &[
                "export",
                "lux",
                "--out",
                "tree",
                "--format",
                "png",
                "--base-url",
                "https://a.example/",
            ][..],
            1,
            "lux: --base-url writes a TileJSON for MapLibre",
        ),
    ] {
        let out = zerotile(args, &dir);
        assert_eq!(out.status.code(), Some(code), "{args:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(needle),
            "{args:?}"
        );
        assert_eq!(files(&dir.join("tree"), "png"), before, "{args:?}");
    }

    // A failure after rendering began (one tile's record corrupted) keeps the tree too, to
    // the byte: the argument errors above all stop before any tile is rendered.
    let bytes_before: Vec<Vec<u8>> = before.iter().map(|p| std::fs::read(p).unwrap()).collect();
    let path = dir.join("data/lux.ztd");
    let mut bytes = std::fs::read(&path).unwrap();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    let (_, e) = c.tiles().max_by_key(|(id, _)| id.z).unwrap();
    bytes[e.offset as usize + 40] ^= 0x55;
    std::fs::write(&path, &bytes).unwrap();
    let out = zerotile(
        &[
            "export", "lux", "--format", "png", "--out", "tree", "--quiet",
        ],
        &dir,
    );
    // The record's failure names the dataset file it is in, not only the tile.
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("data/lux.ztd: tile "), "{err}");
    assert_eq!(files(&dir.join("tree"), "png"), before);
    let bytes_after: Vec<Vec<u8>> = before.iter().map(|p| std::fs::read(p).unwrap()).collect();
    assert!(bytes_after == bytes_before);
    assert_no_temporary_folders(&dir);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--out` is replaced whole, so only an empty folder or an earlier export may be: a folder
/// of the user's files and a plain file are refused untouched, with exit 1.
#[test]
fn export_refuses_to_replace_what_is_not_an_export() {
    let dir = fresh_dir("export-refuse");
    let tif = shared_data().join("dem/terra_elev.tif");
    let tif = tif.to_str().unwrap();
    assert_success(&zerotile(
        &[
            "ingest", tif, "--name", "lux", "--scheme", "geodetic", "--quiet",
        ],
        &dir,
    ));
    let export = |out: &str| {
        zerotile(
            &[
                "export", "lux", "--format", "png", "--zoom", "3", "--out", out, "--quiet",
            ],
            &dir,
        )
    };

    std::fs::create_dir_all(dir.join("precious")).unwrap();
    std::fs::write(dir.join("precious/notes.txt"), "mine").unwrap();
    std::fs::write(dir.join("plain"), "also mine").unwrap();
    // A place no folder can be made (procfs) is named, not left as a bare OS error.
    for (out, says) in [
        ("precious", "not an earlier zerotile export"),
        ("plain", "is a file"),
        ("/proc/zerotile-export", "cannot create"),
    ] {
        let r = export(out);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{out}: {err}");
        assert!(err.contains(out) && err.contains(says), "{out}: {err}");
    }
    assert_eq!(
        std::fs::read_to_string(dir.join("precious/notes.txt")).unwrap(),
        "mine"
    );
    assert_eq!(std::fs::read_dir(dir.join("precious")).unwrap().count(), 1);
    assert_eq!(
        std::fs::read_to_string(dir.join("plain")).unwrap(),
        "also mine"
    );
    // A dataset that is not there, or a file that is not one, is named with what to give.
    let hgt = shared_data().join("dem/N44W072.hgt");
    for (dataset, says) in [
        ("nope", "nope.ztd: no such dataset file"),
        (hgt.to_str().unwrap(), "N44W072.hgt: not a zerotile dataset"),
    ] {
        let r = zerotile(&["export", dataset, "--out", "fresh", "--quiet"], &dir);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{dataset}: {err}");
        assert!(err.contains(says), "{dataset}: {err}");
    }

    // An empty folder is replaced, and so is an earlier export, which says it is one: its
    // stale tiles (another zoom's) go with it.
    std::fs::create_dir_all(dir.join("empty")).unwrap();
    assert_success(&export("empty"));
    assert!(!files(&dir.join("empty"), "png").is_empty());
    assert!(dir.join("empty/.zerotile-export").is_file());
    std::fs::create_dir_all(dir.join("empty/9/99")).unwrap();
    std::fs::write(dir.join("empty/9/99/99.png"), "old").unwrap();
    assert_success(&export("empty"));
    assert!(!dir.join("empty/9").exists());
    assert!(!files(&dir.join("empty"), "png").is_empty());

    // But not once the user has put a file of their own into it: the swap deleted it with
    // exit 0. Refused with exit 1, the file named and every tile left as it was.
    std::fs::write(dir.join("empty/index.html"), "<html>mine</html>").unwrap();
    let before = files(&dir.join("empty"), "png");
    let r = export("empty");
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(
        err.contains(
            "empty: an earlier zerotile export, but index.html in it is not the export's own"
        ) && err.contains("move index.html out first or give another --out"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("empty/index.html")).unwrap(),
        "<html>mine</html>"
    );
    assert_eq!(files(&dir.join("empty"), "png"), before);
    std::fs::remove_file(dir.join("empty/index.html")).unwrap();
    assert_success(&export("empty"));

    assert_no_temporary_folders(&dir);
    let _ = std::fs::remove_dir_all(&dir);
}

/// An export swaps its tree in through hidden siblings of `--out`: none may be left in `dir`.
fn assert_no_temporary_folders(dir: &Path) {
    let stray: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|name| name.starts_with('.'))
        .collect();
    assert!(stray.is_empty(), "{stray:?}");
}

/// layer.json makes available only the zooms the tree holds: CesiumJS asks for every level
/// it lists, and a static host answers 404 for the ones left out.
#[test]
fn a_partial_export_lists_only_its_zooms() {
    let dir = fresh_dir("export-partial");
    let hgt = shared_data().join("dem/N44W072.hgt");
    assert_success(&zerotile(
        &[
            "ingest",
            hgt.to_str().unwrap(),
            "--name",
            "n44",
            "--scheme",
            "geodetic",
            "--quiet",
        ],
        &dir,
    ));
    // What an export killed mid-render left (its process gone) is swept by the next one.
    let leftover = dir.join(".low.export-4294967295");
    std::fs::create_dir_all(leftover.join("3/1")).unwrap();
    std::fs::write(leftover.join("3/1/0.terrain"), b"partial").unwrap();
    let out = zerotile(
        &["export", "n44", "--out", "low", "--zoom", "0-8", "--quiet"],
        &dir,
    );
    assert_success(&out);
    assert!(!leftover.exists());
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let layer: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("low/layer.json")).unwrap()).unwrap();
    assert_eq!(layer["maxzoom"], 8);
    let available = layer["available"].as_array().unwrap();
    assert_eq!(available.len(), 9);
    // Every tile layer.json makes available is a file in the tree (TMS y, as the paths).
    for (z, ranges) in available.iter().enumerate() {
        for r in ranges.as_array().unwrap() {
            let n = |k: &str| r[k].as_u64().unwrap();
            for x in n("startX")..=n("endX") {
                for y in n("startY")..=n("endY") {
                    let rel = format!("low/{z}/{x}/{y}.terrain");
                    assert!(dir.join(&rel).is_file(), "{rel}");
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A png export told where it will be served writes the TileJSON a MapLibre `raster-dem`
/// source reads from `url`: absolute tile URLs under that base, each naming a file the tree
/// holds, and the exported zooms only. Without a mercator dataset or an absolute URL the
/// export is refused before any work.
#[test]
fn a_png_export_with_a_base_url_writes_tilejson() {
    let dir = fresh_dir("export-tilejson");
    let hgt = shared_data().join("dem/N44W072.hgt");
    let hgt = hgt.to_str().unwrap();
    for (name, scheme) in [("m", "mercator"), ("g", "geodetic")] {
        let out = zerotile(
            &[
                "ingest",
                hgt,
                "--name",
                name,
                "--scheme",
                scheme,
                "--max-zoom",
                "8",
                "--quiet",
            ],
            &dir,
        );
        assert_success(&out);
    }
    let base = "https://cdn.example/dem/";
    // `export DATASET --format png --base-url base EXTRA… --out OUT`, then OUT/tiles.json.
    let tilejson = |dataset: &str, out: &str, extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["export", dataset, "--format", "png", "--base-url", base];
        args.extend(extra);
        args.extend(["--out", out, "--quiet"]);
        assert_success(&zerotile(&args, &dir));
        let doc = std::fs::read(dir.join(out).join("tiles.json")).unwrap();
        serde_json::from_slice(&doc).unwrap()
    };
    let t = tilejson("m", "rgb", &["--zoom", "0-7"]);
    assert_eq!(t["tilejson"], "3.0.0");
    assert_eq!(
        (t["minzoom"].as_u64(), t["maxzoom"].as_u64()),
        (Some(0), Some(7))
    );
    assert_eq!(t["bounds"], serde_json::json!([-72.0, 44.0, -71.0, 45.0]));
    assert_eq!(
        (t["tileSize"].as_u64(), t["encoding"].as_str()),
        (Some(512), Some("mapbox"))
    );
    let template = t["tiles"][0].as_str().unwrap();
    let (path, query) = template
        .strip_prefix("https://cdn.example/dem/")
        .and_then(|p| p.split_once('?'))
        .unwrap_or_else(|| panic!("{template}"));
    assert!(query.starts_with("v="), "{template}");
    // Every tile MapLibre asks for with these bounds and zooms (its TileBounds.contains:
    // floor of the west/north edge to ceil of the east/south one) is a file in the tree.
    let [w, s_, e, n] = [0, 1, 2, 3].map(|i| t["bounds"][i].as_f64().unwrap());
    let mx = |lng: f64| (180.0 + lng) / 360.0;
    let my = |lat: f64| {
        let r = (std::f64::consts::FRAC_PI_4 + lat.to_radians() / 2.0)
            .tan()
            .ln();
        (180.0 - r.to_degrees()) / 360.0
    };
    let mut asked = 0;
    for z in 0..=7u32 {
        let size = f64::from(1u32 << z);
        let (x0, x1) = ((mx(w) * size).floor() as u32, (mx(e) * size).ceil() as u32);
        let (y0, y1) = ((my(n) * size).floor() as u32, (my(s_) * size).ceil() as u32);
        for x in x0..x1 {
            for y in y0..y1 {
                let rel = path
                    .replace("{z}", &z.to_string())
                    .replace("{x}", &x.to_string())
                    .replace("{y}", &y.to_string());
                assert!(
                    dir.join("rgb").join(&rel).is_file(),
                    "MapLibre would ask for {rel}"
                );
                asked += 1;
            }
        }
    }
    // And nothing else was written (zooms past maxzoom, tiles outside the bounds).
    assert_eq!(files(&dir.join("rgb"), "png").len(), asked);

    // A source reaching past Web Mercator's 85.05° (an SRTM cell named N85: its name places
    // it) is stored as it came; its TileJSON stops at the grid's edge instead of failing.
    std::fs::copy(hgt, dir.join("N85W072.hgt")).unwrap();
    let polar = [
        "ingest",
        "N85W072.hgt",
        "--name",
        "polar",
        "--scheme",
        "mercator",
        "--max-zoom",
        "3",
        "--quiet",
    ];
    assert_success(&zerotile(&polar, &dir));
    let t = tilejson("polar", "polar", &[]);
    let north = t["bounds"][3].as_f64().unwrap();
    assert!(
        (north - 85.051_128_779_806_59).abs() < 1e-9,
        "{}",
        t["bounds"]
    );

    // Refused: a geodetic dataset (MapLibre tiles Web Mercator), another format, a relative
    // URL. Nothing is written.
    for (args, says) in [
        (
            vec!["g", "--format", "png", "--base-url", base],
            "--scheme mercator",
        ),
        (
            vec!["m", "--format", "terrain", "--base-url", base],
            "--format png",
        ),
        (
            vec!["m", "--format", "png", "--base-url", "dem/"],
            "absolute",
        ),
        (
            vec!["m", "--format", "png", "--base-url", "https://"],
            "absolute",
        ),
        (
            vec![
                "m",
                "--format",
                "png",
                "--base-url",
                "https://a.example/?k=1",
            ],
            "no query",
        ),
    ] {
        let mut all = vec!["export"];
        all.extend(&args);
        all.extend(["--out", "refused", "--quiet"]);
        let out = zerotile(&all, &dir);
        assert!(!out.status.success(), "{args:?} was exported");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!dir.join("refused").exists(), "{args:?} wrote --out");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A local grid has no place on the globe: quantized-mesh and 3D Tiles are refused before any
/// work, while meshes export as one file per stored tile and no layer.json (a CesiumJS
/// manifest).
#[test]
fn a_local_dataset_exports_meshes_and_refuses_quantized_mesh_and_3d_tiles() {
    let dir = fresh_dir("export-local");
    let tif = shared_data().join("dem/terra_elev.tif");
    let tif = tif.to_str().unwrap();
    assert_success(&zerotile(
        &["ingest", tif, "--name", "lux", "--quiet"],
        &dir,
    ));
    let out = zerotile(&["export", "lux", "--out", "qm", "--quiet"], &dir);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("local grid"), "{err}");
    assert!(!dir.join("qm").exists());

    let out = zerotile(
        &[
            "export", "lux", "--format", "json", "--out", "mesh", "--quiet",
        ],
        &dir,
    );
    assert_success(&out);
    let bytes = std::fs::read(dir.join("data/lux.ztd")).unwrap();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    let mut want: Vec<PathBuf> = c
        .tiles()
        .map(|(id, _)| dir.join(format!("mesh/{}/{}/{}.json", id.z, id.x, id.y)))
        .collect();
    want.sort();
    assert_eq!(files(&dir.join("mesh"), "json"), want);
    assert!(!dir.join("mesh/layer.json").exists());
    assert!(dir.join("mesh/.zerotile-export").is_file());

    // 3D Tiles places tiles on the Earth: refused, nothing written. The other mesh formats
    // go as json does, each tile once; a later export of another format replaces the tree.
    let out = zerotile(
        &[
            "export", "lux", "--format", "3dtiles", "--out", "3d", "--quiet",
        ],
        &dir,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("local grid") && err.contains("3D Tiles"),
        "{err}"
    );
    assert!(!dir.join("3d").exists());
    for ext in ["glb", "obj", "bin"] {
        let out = zerotile(
            &["export", "lux", "--format", ext, "--out", "mesh", "--quiet"],
            &dir,
        );
        assert_success(&out);
        let names = |e: &str| want.iter().map(|p| p.with_extension(e)).collect::<Vec<_>>();
        assert_eq!(files(&dir.join("mesh"), ext), names(ext), "{ext}");
        assert!(files(&dir.join("mesh"), "json").is_empty(), "{ext}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A mercator png tree without --base-url has no tiles.json, and the export says how to get one.
#[test]
fn a_mercator_png_export_without_a_base_url_says_it_wrote_no_tilejson() {
    let dir = fresh_dir("export-no-tilejson");
    let tif = shared_data().join("dem/terra_elev.tif");
    let tif = tif.to_str().unwrap();
    let ingest = [
        "ingest",
        tif,
        "--name",
        "lux",
        "--scheme",
        "mercator",
        "--max-zoom",
        "3",
        "--quiet",
    ];
    assert_success(&zerotile(&ingest, &dir));
    let out = zerotile(
        &[
            "export", "lux", "--format", "png", "--out", "rgb", "--quiet",
        ],
        &dir,
    );
    assert_success(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no tiles.json") && err.contains("--base-url"),
        "{err}"
    );
    assert!(!dir.join("rgb/tiles.json").exists());
    assert!(!files(&dir.join("rgb"), "png").is_empty());
    // layer.json is CesiumJS's quantized-mesh manifest: a png or json tree of a world
    // dataset has none (it used to get one saying "quantized-mesh-1.0" over .png files).
    assert!(!dir.join("rgb/layer.json").exists());
    let out = zerotile(
        &[
            "export", "lux", "--format", "json", "--out", "mesh", "--quiet",
        ],
        &dir,
    );
    assert_success(&out);
    assert!(!files(&dir.join("mesh"), "json").is_empty());
    assert!(!dir.join("mesh/layer.json").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
