//! `zerotile serve` run as a user would: a real dataset ingested by the real binary from
//! SRTM data, the real server on an ephemeral port, every route over HTTP.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "end-to-end test: any failure should stop the test loudly"
)]

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use glam::DVec3;
use serde_json::Value;
use zerotile_codec::container::{
    Availability, Container, Limits, Metadata, TileId, ViewParams, Writer,
};
use zerotile_codec::ezw::{self, DecodeLimit, EncodeParams};
use zerotile_codec::formats::{mesh_bin, quantized_mesh, terrain_rgb};
use zerotile_codec::raster::Encoding;
use zerotile_codec::wavelet::Wavelet;
use zerotile_codec::zerotree::{mesh_error, TerrainMesh};
use zerotile_codec::Grid;
use zerotile_tests::server::Server;
use zerotile_tests::{fresh_dir, ingest_command, qm, run_ok, shared_data, zerotile_bin};

/// Top-left sample of the crop in N44W072 and its side: 2 × 2 tiles of 257 samples.
const CROP: (usize, usize, usize) = (300, 400, 513);

fn n44w072() -> Grid<f64> {
    let bytes = std::fs::read(shared_data().join("dem/N44W072.hgt")).unwrap();
    let data = bytes
        .chunks_exact(2)
        .map(|b| f64::from(i16::from_be_bytes([b[0], b[1]])))
        .collect();
    Grid::new(1201, 1201, data).unwrap()
}

fn crop() -> Grid<f64> {
    let (r, c, n) = CROP;
    n44w072().crop(r, c, n, n).unwrap()
}

/// The data folder, built once per test run: `crop` (local scheme) and `srtm` (geodetic)
/// ingested by the real binary, and `world`, `half` and `merc`, containers of real root
/// tiles written with the codec (for root-tile cases a real ingest never produces).
fn data_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = fresh_dir("serve-data");
        // An ESRI ASCII grid of the crop: what a user would hand to ingest.
        let g = crop();
        let asc = dir.join("crop.asc");
        let mut text = format!(
            "ncols {n}\nnrows {n}\nxllcorner 0\nyllcorner 0\ncellsize 1\nNODATA_value -32768\n",
            n = g.cols()
        );
        for r in 0..g.rows() {
            let row: Vec<String> = g.row(r).iter().map(|h| format!("{h}")).collect();
            text.push_str(&row.join(" "));
            text.push('\n');
        }
        std::fs::write(&asc, text).unwrap();
        run_ok(&mut ingest_command(&asc, "crop", &dir, &[]));
        std::fs::remove_file(&asc).unwrap();
        // The whole SRTM tile on Cesium's geodetic grid.
        zerotile_tests::ingest_n44_geodetic_as(&dir, "srtm");
        write_world(&dir.join("world.ztd"), "geodetic", &[0, 1]);
        write_world(&dir.join("half.ztd"), "geodetic", &[0]);
        write_world(&dir.join("merc.ztd"), "mercator", &[0]);
        dir
    })
}

/// Root tiles of a world `scheme` (0/0/0 west, 0/1/0 east for geodetic) holding adjacent
/// real crops, so a shared edge holds the same samples.
fn write_world(path: &Path, scheme: &str, xs: &[u32]) {
    let dem = n44w072();
    let mut w = Writer::new();
    let mut samples = 0;
    let mut bytes = 0;
    for &x in xs {
        let g = dem.crop(300, 400 + 256 * x as usize, 257, 257).unwrap();
        let corners = [
            *g.get(0, 0),
            *g.get(0, 256),
            *g.get(256, 0),
            *g.get(256, 256),
        ];
        let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
        samples += 257 * 257;
        bytes += enc.bytes.len() as u64;
        w.add(TileId { z: 0, x, y: 0 }, corners, &enc.bytes);
    }
    let m = Metadata {
        name: "world".into(),
        scheme: scheme.into(),
        tile_side: 257,
        min_zoom: 0,
        max_zoom: 0,
        bounds: if scheme == "mercator" {
            [-180.0, -85.0, 180.0, 85.0]
        } else {
            [-180.0, -90.0, 180.0, 90.0]
        },
        source_size: [257, 513],
        wavelet: Wavelet::Cdf97,
        step: 1.0,
        precision: None,
        height_range: [0.0, 1500.0],
        source_height_range: None,
        vertical_datum: None,
        fill: 0.0,
        view: ViewParams { a: 40.0, b: 0.0 },
        available: vec![vec![Availability {
            start_x: 0,
            start_y: 0,
            end_x: xs.len() as u32 - 1,
            end_y: 0,
        }]],
        source: "N44W072.hgt".into(),
        source_crs: "EPSG:4326".into(),
        samples,
        stream_bytes: bytes,
        created: "2026-01-01T00:00:00Z".into(),
    };
    std::fs::write(path, w.finish(&m).unwrap()).unwrap();
}

#[test]
fn health_list_and_describe() {
    let s = Server::start(data_dir());
    let h = s.get("/healthz", &[]);
    assert_eq!(h.status, 200);
    assert_eq!(h.json()["status"], "ok");

    let list = s.get("/v1/datasets", &[]).json();
    let names: Vec<&str> = list["datasets"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|d| d["name"].as_str())
        .collect();
    assert_eq!(names, ["crop", "half", "merc", "srtm", "world"]);

    let d = s.get("/v1/datasets/crop", &[]).json();
    assert_eq!(d["scheme"], "local");
    assert_eq!(d["maxzoom"], 1);
    assert_eq!(d["tiles"], 5);
    assert_eq!(d["default_thresholds"].as_array().unwrap().len(), 2);
    assert!(d["view"]["a"].as_f64().unwrap() > 0.0);
    assert!(d["codec"]["stream_bytes"].as_u64().unwrap() > 0);

    let m = String::from_utf8(s.get("/metrics", &[]).body).unwrap();
    assert!(
        m.contains("zerotile_requests_total{route=\"/healthz\",status=\"200\"} 1"),
        "{m}"
    );
    assert!(m.contains("zerotile_request_duration_seconds_bucket"));
    assert!(m.contains("zerotile_cache_hits_total"));
}

/// Bilinear sample of `g` at fractional (row, col).
fn bilinear(g: &Grid<f64>, r: f64, c: f64) -> f64 {
    let (r0, c0) = (r.floor() as usize, c.floor() as usize);
    let (r1, c1) = ((r0 + 1).min(g.rows() - 1), (c0 + 1).min(g.cols() - 1));
    let (fr, fc) = (r - r0 as f64, c - c0 as f64);
    let top = g.get(r0, c0) * (1.0 - fc) + g.get(r0, c1) * fc;
    let bottom = g.get(r1, c0) * (1.0 - fc) + g.get(r1, c1) * fc;
    top * (1.0 - fr) + bottom * fr
}

#[test]
fn png_heights_agree_with_the_source_within_the_threshold() {
    let s = Server::start(data_dir());
    let source = crop();
    for (encoding, query) in [
        (Encoding::TerrainRgb, ""),
        (Encoding::Terrarium, "&encoding=terrarium"),
    ] {
        let t = 2.0;
        let r = s.get(
            &format!("/v1/datasets/crop/tiles/1/1/0.png?threshold={t}&size=256{query}"),
            &[],
        );
        assert_eq!(r.status, 200);
        assert_eq!(r.header("content-type"), Some("image/png"));
        assert_eq!(r.header("x-threshold"), Some("2"));
        let heights = terrain_rgb::decode(&r.body, encoding, 1 << 20).unwrap();
        assert_eq!((heights.rows(), heights.cols()), (256, 256));
        // Tile 1/1/0 is the crop's top-right quarter; pixel centres fall between samples.
        let mut worst = 0f64;
        for i in 0..256 {
            for j in 0..256 {
                let want = bilinear(&source, i as f64 + 0.5, 256.0 + j as f64 + 0.5);
                worst = worst.max((heights.get(i, j) - want).abs());
            }
        }
        assert!(
            worst <= t + 0.1,
            "{encoding:?}: max error {worst} above T = {t}"
        );
    }
}

/// Vertices of a JSON tile mesh on the vertical line x = `col`: (y, z), sorted.
fn column(mesh: &Value, col: f64) -> Vec<(f64, f64)> {
    let p: Vec<f64> = mesh["positions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let mut v: Vec<(f64, f64)> = p
        .chunks_exact(3)
        .filter(|q| q[0] == col)
        .map(|q| (q[1], q[2]))
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v
}

/// A local tile's JSON mesh (tile 1/0/0: x = column, y = −row) as the codec's grid mesh.
fn terrain_mesh(v: &Value) -> TerrainMesh {
    let f = |k: &str| -> Vec<f64> {
        v[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (p, i) = (f("positions"), f("indices"));
    TerrainMesh {
        rows: 257,
        cols: 257,
        positions: p.chunks_exact(3).map(|q| [q[0], -q[1], q[2]]).collect(),
        triangles: i
            .chunks_exact(3)
            .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32])
            .collect(),
    }
}

#[test]
fn mesh_formats_agree_and_neighbours_share_their_edge() {
    let s = Server::start(data_dir());
    let q = "?threshold=4";
    let west = s.get(&format!("/v1/datasets/crop/tiles/1/0/0.json{q}"), &[]);
    let east = s.get(&format!("/v1/datasets/crop/tiles/1/1/0.json{q}"), &[]);
    assert_eq!(west.status, 200);
    let triangles: usize = west.header("x-triangles").unwrap().parse().unwrap();
    let (wj, ej) = (west.json(), east.json());
    assert_eq!(wj["indices"].as_array().unwrap().len(), 3 * triangles);
    // The shared edge: full-resolution column 256 in both tiles, same vertices, same heights.
    let (a, b) = (column(&wj, 256.0), column(&ej, 256.0));
    assert!(a.len() >= 2);
    assert_eq!(a, b, "tiles 1/0/0 and 1/1/0 disagree on their shared edge");
    // Two tiles side by side, not one served twice: columns 0..=256 and 256..=512, and the
    // edge holds the source's column 256 (y = −row), within the budget.
    let x_range = |v: &Value| {
        let xs = v["positions"].as_array().unwrap().iter().step_by(3);
        xs.map(|x| x.as_f64().unwrap())
            .fold((f64::MAX, f64::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)))
    };
    assert_eq!((x_range(&wj), x_range(&ej)), ((0.0, 256.0), (256.0, 512.0)));
    let whole = crop();
    for &(y, z) in &a {
        let h = *whole.get(-y as usize, 256);
        assert!((z - h).abs() <= 4.0, "edge row {}: {z} against {h}", -y);
    }

    // ZTM1 holds the same triangles; OBJ and GLB are what their headers say.
    let bin = s.get(&format!("/v1/datasets/crop/tiles/1/0/0.bin{q}"), &[]);
    let m = mesh_bin::decode(&bin.body).unwrap();
    assert_eq!(m.triangles.len(), triangles);
    assert_eq!(m.crs, mesh_bin::MeshCrs::LocalGrid);
    let obj = s.get(&format!("/v1/datasets/crop/tiles/1/0/0.obj{q}"), &[]);
    let text = String::from_utf8(obj.body).unwrap();
    assert_eq!(
        text.lines().filter(|l| l.starts_with("f ")).count(),
        triangles
    );
    let glb = s.get(&format!("/v1/datasets/crop/tiles/1/0/0.glb{q}"), &[]);
    assert_eq!(&glb.body[..4], b"glTF");

    // The mesh covers its tile without holes and stays within the budget of the source.
    let source = crop().crop(0, 0, 257, 257).unwrap();
    for t in [1.0, 4.0, 16.0] {
        let r = s.get(
            &format!("/v1/datasets/crop/tiles/1/0/0.json?threshold={t}"),
            &[],
        );
        let e = mesh_error(&terrain_mesh(&r.json()), &source);
        assert_eq!(e.uncovered, 0, "T = {t}");
        assert!(e.max_abs <= t, "T = {t}: mesh max error {} m", e.max_abs);
    }

    // Triangle counts fall as T rises.
    let counts: Vec<usize> = [0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0]
        .iter()
        .map(|t| {
            let r = s.get(
                &format!("/v1/datasets/crop/tiles/1/0/0.bin?threshold={t}"),
                &[],
            );
            r.header("x-triangles").unwrap().parse().unwrap()
        })
        .collect();
    assert!(counts.windows(2).all(|w| w[1] <= w[0]), "{counts:?}");
    assert!(counts[0] > 20 * counts[8], "{counts:?}");
}

#[test]
fn view_threshold_rises_with_camera_height() {
    let s = Server::start(data_dir());
    let t_at = |h: f64| -> f64 {
        let r = s.get(
            &format!(
                "/v1/datasets/crop/tiles/1/0/0.json?eye=256,256,{h}&target=300,300,300&fov=60"
            ),
            &[],
        );
        assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
        r.header("x-threshold").unwrap().parse().unwrap()
    };
    let (low, high) = (t_at(400.0), t_at(3000.0));
    assert!(high > low, "T at 3000 m = {high}, at 400 m = {low}");
    let ratio = s.get("/v1/datasets/crop/tiles/1/0/0.png?ratio=0.5", &[]);
    assert_eq!(ratio.status, 200);
}

#[test]
fn ezw_prefixes_grow_as_the_threshold_falls_and_honour_ranges() {
    let s = Server::start(data_dir());
    let coarse = s.get("/v1/datasets/crop/tiles/1/0/1.ezw?threshold=64", &[]);
    let fine = s.get("/v1/datasets/crop/tiles/1/0/1.ezw?threshold=1", &[]);
    assert_eq!(coarse.status, 200);
    assert_eq!(coarse.header("accept-ranges"), Some("bytes"));
    assert_eq!(&coarse.body[..4], b"ZTW2");
    assert!(coarse.body.len() < fine.body.len());
    // The coarse prefix is a prefix of the fine one, and decodes on its own.
    assert_eq!(&fine.body[..coarse.body.len()], &coarse.body[..]);
    let d = ezw::decode(&coarse.body, DecodeLimit::All, ezw::DEFAULT_MAX_SAMPLES).unwrap();
    assert_eq!((d.heights.rows(), d.heights.cols()), (257, 257));

    let part = s.get(
        "/v1/datasets/crop/tiles/1/0/1.ezw?threshold=1",
        &[("Range", "bytes=10-109")],
    );
    assert_eq!(part.status, 206);
    assert_eq!(part.body, &fine.body[10..110]);
    let len = fine.body.len();
    assert_eq!(
        part.header("content-range"),
        Some(format!("bytes 10-109/{len}").as_str())
    );
    let past = s.get(
        "/v1/datasets/crop/tiles/1/0/1.ezw?threshold=1",
        &[("Range", "bytes=99999999-")],
    );
    past.assert_error(416, "range_not_satisfiable", "range past the end");
    assert_eq!(
        past.header("content-range"),
        Some(format!("bytes */{len}").as_str())
    );
}

#[test]
fn etags_give_304_and_change_with_the_threshold() {
    let s = Server::start(data_dir());
    let url = "/v1/datasets/crop/tiles/0/0/0.png?threshold=8";
    let first = s.get(url, &[]);
    let etag = first.header("etag").unwrap().to_string();
    assert!(first.header("cache-control").unwrap().contains("max-age"));
    let again = s.get(url, &[("If-None-Match", &etag)]);
    assert_eq!(again.status, 304);
    assert!(again.body.is_empty());
    let other = s.get("/v1/datasets/crop/tiles/0/0/0.png?threshold=9", &[]);
    assert_ne!(other.header("etag").unwrap(), etag);
    // −0 is 0: the same tile under the same tag.
    let zero = |t: &str| {
        let r = s.get(
            &format!("/v1/datasets/crop/tiles/0/0/0.png?threshold={t}"),
            &[],
        );
        (
            r.header("etag").map(str::to_string),
            r.header("x-threshold").map(str::to_string),
        )
    };
    assert_eq!(zero("-0"), zero("0"));
}

#[test]
fn json_is_compressed_when_the_client_accepts_it() {
    let s = Server::start(data_dir());
    let url = "/v1/datasets/crop/tiles/1/0/0.json?threshold=16";
    let plain = s.get(url, &[]);
    assert_eq!(plain.header("content-encoding"), None);
    let gz = s.get(url, &[("Accept-Encoding", "gzip")]);
    assert_eq!(gz.header("content-encoding"), Some("gzip"));
    let mut back = Vec::new();
    flate2::read::GzDecoder::new(&gz.body[..])
        .read_to_end(&mut back)
        .unwrap();
    assert_eq!(back, plain.body);
}

#[test]
fn quantized_mesh_root_tiles_decode_and_share_their_edge() {
    let s = Server::start(data_dir());
    let layer = s.get("/v1/datasets/world/layer.json", &[]).json();
    assert_eq!(layer["format"], "quantized-mesh-1.0");
    assert_eq!(layer["scheme"], "tms");
    assert_eq!(layer["available"][0][0]["endX"], 1);
    // Listing `metadata` would make CesiumJS require `metadataAvailability`.
    assert_eq!(
        layer["extensions"],
        serde_json::json!(["octvertexnormals", "watermask"])
    );
    let template = layer["tiles"][0].as_str().unwrap();
    assert!(
        template.starts_with("tiles/{z}/{x}/{y}.terrain"),
        "{template}"
    );

    let accept = "application/vnd.quantized-mesh;extensions=octvertexnormals-metadata";
    let tile = |x: u32| {
        let r = s.get(
            &format!("/v1/datasets/world/tiles/0/{x}/0.terrain?threshold=4"),
            &[("Accept", accept)],
        );
        assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
        assert_eq!(r.header("content-encoding"), None);
        assert!(r.header("vary").unwrap().contains("Accept-Encoding"));
        assert!(r
            .header("content-type")
            .unwrap()
            .starts_with("application/vnd.quantized-mesh"));
        let triangles: usize = r.header("x-triangles").unwrap().parse().unwrap();
        // Our own reader first: every invariant of the wire format.
        let wire = qm::read(&r.body).unwrap();
        let n = wire.u.len();
        assert_eq!(wire.triangles.len(), triangles);
        let ids: Vec<u8> = wire.extensions.iter().map(|e| e.0).collect();
        assert_eq!(ids, [1, 4], "octvertexnormals then metadata");
        assert_eq!(wire.extensions[0].1.len(), 2 * n);
        let meta = &wire.extensions[1].1;
        let json_len = u32::from_le_bytes([meta[0], meta[1], meta[2], meta[3]]) as usize;
        let meta: Value = serde_json::from_slice(&meta[4..4 + json_len]).unwrap();
        assert!(meta["available"].is_array(), "{meta}");
        // Every vertex on a border is in that border's list.
        let on = |f: &dyn Fn(usize) -> bool| (0..n).filter(|&i| f(i)).count();
        assert_eq!(on(&|i| wire.u[i] == 0), wire.edges[0].len());
        assert_eq!(on(&|i| wire.v[i] == 0), wire.edges[1].len());
        assert_eq!(on(&|i| wire.u[i] == 32767), wire.edges[2].len());
        assert_eq!(on(&|i| wire.v[i] == 32767), wire.edges[3].len());
        assert!(wire.min_height < wire.max_height);
        assert!(wire.h.contains(&0) && wire.h.contains(&32767));

        // The codec's decoder agrees with it.
        let qm = quantized_mesh::decode(&r.body).unwrap();
        assert_eq!(qm.triangles, wire.triangles);
        assert_eq!((&qm.u, &qm.v), (&wire.u, &wire.v));
        assert_eq!(qm.normals.as_ref().map(Vec::len), Some(qm.vertex_count()));
        assert!(qm.metadata.as_ref().unwrap()["available"].is_array());
        assert!(qm.header.min_height < qm.header.max_height);
        for &i in &qm.west {
            assert_eq!(qm.u[i as usize], 0);
        }
        for &i in &qm.east {
            assert_eq!(qm.u[i as usize], 32767);
        }
        qm
    };
    let (w, e) = (tile(0), tile(1));
    // West tile's east edge against east tile's west edge: same v, same heights.
    let edge = |qm: &quantized_mesh::QuantizedMesh, idx: &[u32]| -> Vec<(u16, f64)> {
        let mut v: Vec<(u16, f64)> = idx
            .iter()
            .map(|&i| (qm.v[i as usize], qm.height_m(i as usize).unwrap()))
            .collect();
        v.sort_by_key(|p| p.0);
        v
    };
    let (a, b) = (edge(&w, &w.east), edge(&e, &e.west));
    assert_eq!(a.len(), b.len());
    for (p, q) in a.iter().zip(&b) {
        assert_eq!(p.0, q.0);
        // Quantised heights: within one step of each tile's height range.
        assert!((p.1 - q.1).abs() < 0.1, "{p:?} vs {q:?}");
    }

    // gzip only when asked for, labelled, and identical once unpacked.
    let url = "/v1/datasets/world/tiles/0/0/0.terrain?threshold=4";
    let plain = s.get(url, &[]);
    let gz = s.get(url, &[("Accept-Encoding", "gzip, deflate")]);
    assert_eq!(gz.header("content-encoding"), Some("gzip"));
    let mut back = Vec::new();
    flate2::read::GzDecoder::new(&gz.body[..])
        .read_to_end(&mut back)
        .unwrap();
    assert_eq!(back, plain.body);
    s.get(url, &[("Accept", "image/png")]).assert_error(
        406,
        "not_acceptable",
        "terrain for an image client",
    );
}

#[test]
fn bad_requests_are_4xx_json() {
    let s = Server::start(data_dir());
    let t = "/v1/datasets/crop/tiles";
    for (path, status, code) in [
        ("/v1/datasets/nope", 404, "unknown_dataset"),
        ("/v1/datasets/nope/tiles/0/0/0.png", 404, "unknown_dataset"),
        // Names are never percent-encoded (all their characters are unreserved).
        (
            "/v1/datasets/..%2F..%2Fetc%2Fpasswd/tiles/0/0/0.png",
            400,
            "bad_name",
        ),
        ("/nope", 404, "not_found"),
        (&format!("{t}/9/0/0.png"), 404, "tile_not_found"),
        (&format!("{t}/1/7/7.png"), 404, "tile_not_found"),
        (&format!("{t}/1/x/0.png"), 400, "bad_tile_address"),
        (&format!("{t}/1/0/-1.png"), 400, "bad_tile_address"),
        // One tile, one URL: aliases would split every cache.
        (&format!("{t}/+1/0/0.png"), 400, "bad_tile_address"),
        (&format!("{t}/1/00/0.png"), 400, "bad_tile_address"),
        (&format!("{t}/1/0/0.tif"), 404, "unknown_format"),
        (&format!("{t}/1/0/0"), 404, "unknown_format"),
        (&format!("{t}/1/0/0.terrain"), 404, "not_georeferenced"),
        ("/v1/datasets/crop/layer.json", 404, "not_georeferenced"),
        ("/v1/datasets/crop/tiles.json", 404, "not_mercator"),
        ("/v1/datasets/srtm/tiles.json", 404, "not_mercator"),
        (
            "/v1/datasets/merc/tiles.json?encoding=gray",
            400,
            "bad_encoding",
        ),
        ("/v1/datasets/merc/tiles.json?size=8", 400, "out_of_range"),
        (&format!("{t}/1/0/0.png?threshold=NaN"), 400, "out_of_range"),
        (&format!("{t}/1/0/0.png?threshold=inf"), 400, "out_of_range"),
        (&format!("{t}/1/0/0.png?threshold=-1"), 400, "out_of_range"),
        (
            &format!("{t}/1/0/0.png?threshold=1e300"),
            400,
            "out_of_range",
        ),
        (&format!("{t}/1/0/0.png?threshold=abc"), 400, "bad_number"),
        (&format!("{t}/1/0/0.png?ratio=-2"), 400, "out_of_range"),
        (
            &format!("{t}/1/0/0.png?threshold=1&ratio=1"),
            400,
            "conflicting_threshold",
        ),
        // Part of a camera beside a threshold is a second source, not a stray to drop.
        (
            &format!("{t}/1/0/0.png?threshold=4&fov=60"),
            400,
            "conflicting_threshold",
        ),
        (
            &format!("{t}/1/0/0.png?ratio=0.1&target=0,0,0"),
            400,
            "conflicting_threshold",
        ),
        // Alone, it is an incomplete camera.
        (&format!("{t}/1/0/0.png?aspect=2"), 400, "missing_parameter"),
        (
            &format!("{t}/1/0/0.json?eye=1,2&target=0,0,0&fov=60"),
            400,
            "bad_vector",
        ),
        (
            &format!("{t}/1/0/0.json?eye=1,2,3&target=0,0,0"),
            400,
            "missing_parameter",
        ),
        (
            &format!("{t}/1/0/0.json?eye=0,0,-5&target=9,9,0&fov=60"),
            400,
            "bad_view",
        ),
        (
            &format!("{t}/1/0/0.json?eye=0,0,NaN&target=9,9,0&fov=60"),
            400,
            "out_of_range",
        ),
        (
            &format!("{t}/1/0/0.json?eye=0,0,50&target=9,9,0&fov=500"),
            400,
            "out_of_range",
        ),
        (&format!("{t}/1/0/0.png?encoding=gray"), 400, "bad_encoding"),
        (&format!("{t}/1/0/0.png?size=100000"), 400, "out_of_range"),
        // A size is a pixel count: 100.7 is refused, not cut to 100.
        (&format!("{t}/1/0/0.png?size=100.7"), 400, "out_of_range"),
    ] {
        s.get(path, &[]).assert_error(status, code, path);
    }
    let post = s
        .agent
        .post(format!("{}/v1/datasets", s.base))
        .send("x")
        .unwrap();
    assert_eq!(post.status().as_u16(), 405);
}

#[test]
fn a_corrupt_dataset_is_skipped_and_the_others_serve() {
    let dir = fresh_dir("serve-corrupt");
    std::fs::copy(data_dir().join("crop.ztd"), dir.join("good.ztd")).unwrap();
    let mut bad = std::fs::read(data_dir().join("crop.ztd")).unwrap();
    bad[30] ^= 0xff; // inside the header: its CRC fails
    std::fs::write(dir.join("bad.ztd"), &bad).unwrap();
    std::fs::File::create(dir.join("empty.ztd"))
        .unwrap()
        .write_all(b"")
        .unwrap();
    let mut s = Server::start(&dir);
    s.warnings_expected = true;
    let list = s.get("/v1/datasets", &[]).json();
    assert_eq!(list["datasets"].as_array().unwrap().len(), 1);
    assert_eq!(list["skipped"].as_array().unwrap().len(), 2);
    assert_eq!(s.get("/v1/datasets/good/tiles/0/0/0.png", &[]).status, 200);
    s.get("/v1/datasets/bad", &[])
        .assert_error(404, "unknown_dataset", "skipped dataset");
    drop(s);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Polls `path` until `done` holds for its reply, failing after 20 s.
fn wait_for(
    s: &Server,
    path: &str,
    what: &str,
    done: impl Fn(&zerotile_tests::server::Reply) -> bool,
) {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    loop {
        if done(&s.get(path, &[])) {
            return;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "{what}: not within 20 s"
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// The data folder as a user changes it while the server runs: a dataset ingested by the
/// real binary is served at the next rescan, one re-ingested is served anew (a new
/// version, so new ETags), one with half a copy moved over it stays served as it was and
/// the copy is listed as skipped, one removed is gone.
#[test]
fn datasets_follow_the_folder_while_serving() {
    let dir = fresh_dir("serve-rescan");
    std::fs::copy(data_dir().join("crop.ztd"), dir.join("crop.ztd")).unwrap();
    let mut s = Server::start_flags(&dir, &["--rescan", "1"]);
    s.get("/v1/datasets/late", &[])
        .assert_error(404, "unknown_dataset", "not ingested yet");

    let hgt = shared_data().join("dem/N44W072.hgt");
    run_ok(&mut ingest_command(
        &hgt,
        "late",
        &dir,
        &["--scheme", "geodetic", "--max-zoom", "3"],
    ));
    wait_for(&s, "/v1/datasets/late", "an ingested dataset served", |r| {
        r.status == 200
    });
    assert_eq!(s.get("/v1/datasets/late/layer.json", &[]).status, 200);
    let tile = "/v1/datasets/late/tiles/0/0/0.terrain";
    let first = s.get(tile, &[]);
    assert_eq!(first.status, 200);

    // Re-ingested (ingest renames its file over the old one): a new build, new ETags.
    let v0 = s.get("/v1/datasets/late", &[]).json()["version"].clone();
    run_ok(&mut ingest_command(
        &hgt,
        "late",
        &dir,
        &["--scheme", "geodetic", "--max-zoom", "2"],
    ));
    wait_for(
        &s,
        "/v1/datasets/late",
        "a re-ingested dataset served anew",
        |r| r.json()["version"] != v0,
    );
    assert_eq!(s.get("/v1/datasets/late", &[]).json()["maxzoom"], 2);
    assert_ne!(s.get(tile, &[]).header("etag"), first.header("etag"));

    // Half a copy moved over a dataset: the build before, which reads its own file, stays
    // served.
    s.warnings_expected = true;
    let whole = std::fs::read(dir.join("late.ztd")).unwrap();
    let half = dir.join("half-copy");
    std::fs::write(&half, &whole[..whole.len() / 2]).unwrap();
    std::fs::rename(&half, dir.join("crop.ztd")).unwrap();
    wait_for(&s, "/v1/datasets", "a half copy listed as skipped", |r| {
        !r.json()["skipped"].as_array().unwrap().is_empty()
    });
    let list = s.get("/v1/datasets", &[]).json();
    let why = list["skipped"][0]["error"].as_str().unwrap();
    assert!(
        why.contains("truncated") && why.contains("still served"),
        "{why}"
    );
    assert_eq!(s.get("/v1/datasets/crop/tiles/0/0/0.png", &[]).status, 200);

    std::fs::remove_file(dir.join("late.ztd")).unwrap();
    wait_for(&s, "/v1/datasets/late", "a removed dataset gone", |r| {
        r.status == 404
    });
    assert!(
        s.log_text()
            .contains("datasets rescanned: removed late.ztd"),
        "{}",
        s.log_text()
    );
    drop(s);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Object meshes follow `meshes/` as datasets follow the folder: a mesh copied in is served
/// at the rescan after the copy settles, one replaced is served anew (its faces, new ETags),
/// one that no longer reads stays served and is listed as skipped, one removed is gone.
#[test]
fn meshes_follow_the_mesh_folder_while_serving() {
    let dir = fresh_dir("serve-mesh-rescan");
    std::fs::copy(data_dir().join("crop.ztd"), dir.join("crop.ztd")).unwrap();
    let meshes = dir.join("meshes");
    std::fs::create_dir_all(&meshes).unwrap();
    let mut s = Server::start_flags(&dir, &["--rescan", "1"]);
    s.get("/v1/meshes/m", &[])
        .assert_error(404, "mesh_not_found", "not there yet");

    // Copied in place, as `cp` does: read once it has been left alone for a second.
    std::fs::copy(shared_data().join("meshes/cow.obj"), meshes.join("m.obj")).unwrap();
    wait_for(&s, "/v1/meshes/m", "a mesh copied in served", |r| {
        r.status == 200
    });
    let cow = s.get("/v1/meshes/m", &[]).json()["faces"].clone();
    let lod = "/v1/meshes/m/qem?ratio=0.5";
    let first = s.get(lod, &[]);
    assert_eq!(first.status, 200);

    let tmp = meshes.join(".m.obj.tmp");
    std::fs::copy(shared_data().join("meshes/teapot.obj"), &tmp).unwrap();
    std::fs::rename(&tmp, meshes.join("m.obj")).unwrap();
    wait_for(&s, "/v1/meshes/m", "a replaced mesh served anew", |r| {
        r.json()["faces"] != cow
    });
    assert_ne!(s.get(lod, &[]).header("etag"), first.header("etag"));

    s.warnings_expected = true;
    std::fs::write(&tmp, b"v 0 0 0\nv 1 0 0\nf 1 1 2\n").unwrap();
    std::fs::rename(&tmp, meshes.join("m.obj")).unwrap();
    wait_for(&s, "/v1/meshes", "a broken mesh listed as skipped", |r| {
        !r.json()["skipped"].as_array().unwrap().is_empty()
    });
    let why = s.get("/v1/meshes", &[]).json()["skipped"][0]["error"].clone();
    assert!(why.as_str().unwrap().contains("still served"), "{why}");
    assert_eq!(s.get(lod, &[]).status, 200);

    std::fs::remove_file(meshes.join("m.obj")).unwrap();
    wait_for(&s, "/v1/meshes/m", "a removed mesh gone", |r| {
        r.status == 404
    });
    assert!(
        s.log_text().contains("meshes rescanned: removed m.obj"),
        "{}",
        s.log_text()
    );
    drop(s);
    let _ = std::fs::remove_dir_all(&dir);
}

/// With `--rescan 0` the folder is read at start and on SIGHUP only.
#[test]
fn sighup_rescans_when_the_timer_is_off() {
    let dir = fresh_dir("serve-sighup");
    std::fs::copy(data_dir().join("crop.ztd"), dir.join("first.ztd")).unwrap();
    let s = Server::start_flags(&dir, &["--rescan", "0"]);
    let tmp = dir.join(".crop.ztd.tmp");
    std::fs::copy(data_dir().join("crop.ztd"), &tmp).unwrap();
    std::fs::rename(&tmp, dir.join("crop.ztd")).unwrap();
    // A timer of a second would have found it by now.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert_eq!(s.get("/v1/datasets/crop", &[]).status, 404, "no timer");
    let pid = s.child.id().to_string();
    assert!(Command::new("kill")
        .args(["-HUP", &pid])
        .status()
        .unwrap()
        .success());
    wait_for(&s, "/v1/datasets/crop", "SIGHUP's rescan", |r| {
        r.status == 200
    });
    assert!(
        s.log_text().contains("SIGHUP: rescanning"),
        "{}",
        s.log_text()
    );
    drop(s);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_data_folder_is_a_clear_error() {
    let out = Command::new(zerotile_bin())
        .args([
            "serve",
            "--addr",
            "127.0.0.1:0",
            "--data",
            "/nonexistent/zerotile-data",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("/nonexistent/zerotile-data"), "{err}");
}

#[test]
fn the_view_endpoint_meshes_the_view_plane_at_eq4_threshold() {
    let s = Server::start(data_dir());
    let view = |h: f64, extra: &str| {
        s.get(
            &format!("/v1/datasets/crop/view?eye=256,400,{h}&target=256,256,300&fov=60{extra}"),
            &[],
        )
    };
    let (low, high) = (view(400.0, ""), view(3000.0, ""));
    assert_eq!(low.status, 200, "{}", String::from_utf8_lossy(&low.body));
    let (l, h) = (low.json(), high.json());
    for v in [&l, &h] {
        let a = v["a_v"].as_f64().unwrap() / v["a_t"].as_f64().unwrap();
        assert!((a - v["ratio"].as_f64().unwrap()).abs() < 1e-9);
        let n = v["triangles"].as_u64().unwrap() as usize;
        assert_eq!(v["mesh"]["indices"].as_array().unwrap().len(), 3 * n);
    }
    let t = |v: &Value| v["threshold"].as_f64().unwrap();
    assert!(
        t(&h) > t(&l),
        "T at 3000 m {} ≤ T at 400 m {}",
        t(&h),
        t(&l)
    );
    assert!(h["triangles"].as_u64() < l["triangles"].as_u64());

    let glb = view(400.0, "&format=glb");
    assert_eq!(&glb.body[..4], b"glTF");
    assert_eq!(glb.header("x-threshold"), Some(t(&l).to_string().as_str()));
    view(400.0, "&format=stl").assert_error(400, "bad_format", "view as stl");
    s.get(
        "/v1/datasets/crop/view?eye=-9000,-9000,50&target=-9000,-9100,0&fov=30",
        &[],
    )
    .assert_error(404, "empty_view", "a view beside the data");
}

/// A footprint smaller than one triangle, over the data, is the triangle under it, not
/// `empty_view` (no triangle's centroid falls inside so small a footprint).
#[test]
fn a_footprint_smaller_than_a_triangle_still_sees_the_terrain() {
    let s = Server::start(data_dir());
    let r = s.get(
        "/v1/datasets/crop/view?eye=256,256.01,302&target=256,256,300&fov=1",
        &[],
    );
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    let v = r.json();
    assert!(v["a_v"].as_f64().unwrap() < 1.0, "{v}");
    let n = v["triangles"].as_u64().unwrap();
    assert!((1..=8).contains(&n), "{n} triangles");

    // A grazing view: a sliver from near the eye to far past the data, too thin for any
    // centroid, its vertex mean off the data; the target is on the ground inside it.
    let r = s.get(
        "/v1/datasets/crop/view?eye=100,256,300.001&target=300,256,300&fov=0.01",
        &[],
    );
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    let v = r.json();
    let n = v["triangles"].as_u64().unwrap();
    assert!((1..=8).contains(&n), "{n} triangles");
    let xs = v["mesh"]["positions"].as_array().unwrap().iter().step_by(3);
    let xs: Vec<f64> = xs.map(|x| x.as_f64().unwrap()).collect();
    let (lo, hi) = xs
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
    assert!(
        lo <= 300.0 && 300.0 <= hi,
        "not under the target: x in {lo}..{hi}"
    );
}

#[test]
fn views_refuse_a_second_threshold_and_take_aspect_as_w_over_h() {
    let s = Server::start(data_dir());
    let view = "/v1/datasets/crop/view?eye=256,400,900&target=256,256,300&fov=60";
    for extra in ["&threshold=5", "&ratio=0.1"] {
        s.get(&format!("{view}{extra}"), &[])
            .assert_error(400, "conflicting_threshold", extra);
    }
    let a_v = |aspect: &str| {
        let r = s.get(&format!("{view}&aspect={aspect}"), &[]);
        assert_eq!(
            r.status,
            200,
            "{aspect}: {}",
            String::from_utf8_lossy(&r.body)
        );
        r.json()["a_v"].as_f64().unwrap()
    };
    assert_eq!(a_v("16/9"), a_v(&(16.0f64 / 9.0).to_string()));
    assert!(a_v("16/9") > a_v("1"));
    s.get(&format!("{view}&aspect=16/0"), &[])
        .assert_error(400, "out_of_range", "aspect 16/0");
}

#[test]
fn a_missing_root_tile_is_flat_and_mercator_tiles_work() {
    let s = Server::start(data_dir());
    // `half` holds only the western root: the eastern one comes flat, as Cesium needs both.
    let r = s.get("/v1/datasets/half/tiles/0/1/0.terrain", &[]);
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    let qm = quantized_mesh::decode(&r.body).unwrap();
    assert_eq!(qm.triangles.len(), 2);
    assert_eq!(qm.header.min_height, qm.header.max_height);
    let layer = s.get("/v1/datasets/half/layer.json", &[]).json();
    assert_eq!(layer["available"][0][0]["endX"], 1);
    // Below the roots, a missing tile is a 404, not a flat tile.
    s.get("/v1/datasets/half/tiles/0/1/0.png", &[])
        .assert_error(404, "tile_not_found", "missing tile as PNG");

    let layer = s.get("/v1/datasets/merc/layer.json", &[]).json();
    assert_eq!(layer["scheme"], "slippyMap");
    assert_eq!(layer["projection"], "EPSG:3857");
    let r = s.get("/v1/datasets/merc/tiles/0/0/0.terrain?threshold=8", &[]);
    assert_eq!(r.status, 200);
    let qm = quantized_mesh::decode(&r.body).unwrap();
    assert!(qm.triangles.len() > 2);
    let bin = s.get("/v1/datasets/merc/tiles/0/0/0.bin?threshold=8", &[]);
    assert_eq!(
        mesh_bin::decode(&bin.body).unwrap().crs,
        mesh_bin::MeshCrs::WebMercator
    );
}

/// TileJSON is what a MapLibre `raster-dem` source reads from `url`: every tile it lists must
/// answer with the PNG the options asked for, and its URLs must be absolute (MapLibre fails
/// on relative ones), as the client or its proxy reached the server.
#[test]
fn tilejson_lists_tiles_that_answer_as_asked() {
    let s = Server::start(data_dir());
    let r = s.get("/v1/datasets/merc/tiles.json", &[]);
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    let vary: Vec<&str> = r
        .headers
        .iter()
        .filter(|(k, _)| k.eq_ignore_ascii_case("vary"))
        .map(|(_, v)| v.as_str())
        .collect();
    let vary = vary.join(", ");
    assert!(vary.contains("Host"), "{vary}");
    let t = r.json();
    assert_eq!(t["tilejson"], "3.0.0");
    assert_eq!(
        (t["minzoom"].as_u64(), t["maxzoom"].as_u64()),
        (Some(0), Some(0))
    );
    assert_eq!(t["bounds"], serde_json::json!([-180.0, -85.0, 180.0, 85.0]));
    assert_eq!(
        (t["tileSize"].as_u64(), t["encoding"].as_str()),
        (Some(512), Some("mapbox"))
    );
    let template = t["tiles"][0].as_str().unwrap();
    let own = format!(
        "{}/v1/datasets/merc/tiles/{{z}}/{{x}}/{{y}}.png?v=",
        s.base()
    );
    assert!(
        template.starts_with(&own),
        "{template} does not start with {own}"
    );
    // A tile as MapLibre decodes it: the size and encoding the document gives.
    let dem = |template: &str, encoding| {
        let url = template.replace("{z}/{x}/{y}", "0/0/0");
        let tile = s.get(&url[s.base().len()..], &[]);
        assert_eq!(tile.status, 200, "{url}");
        terrain_rgb::decode(&tile.body, encoding, 1 << 22).unwrap()
    };
    // The dataset holds 0–1,500 m: read with the wrong encoding, the heights are far off.
    let in_range = |g: &Grid<f64>| g.data().iter().all(|h| (-1.0..1600.0).contains(h));
    let g = dem(template, Encoding::TerrainRgb);
    assert_eq!((g.rows(), g.cols()), (512, 512));
    assert!(in_range(&g));
    assert!(!in_range(&dem(template, Encoding::Terrarium)));

    // Terrarium at 256 px: the listed tile is one.
    let t = s
        .get(
            "/v1/datasets/merc/tiles.json?encoding=terrarium&size=256",
            &[],
        )
        .json();
    assert_eq!(
        (t["tileSize"].as_u64(), t["encoding"].as_str()),
        (Some(256), Some("terrarium"))
    );
    let template = t["tiles"][0].as_str().unwrap();
    let g = dem(template, Encoding::Terrarium);
    assert_eq!((g.rows(), g.cols()), (256, 256));
    assert!(in_range(&g));

    // Proxy headers any client can send are not trusted by default (`--trust-forwarded`;
    // the router's tests cover it and `--public-url`): one request could otherwise point every
    // cached copy at another host.
    let spoofed = s.get(
        "/v1/datasets/merc/tiles.json",
        &[
            ("x-forwarded-host", "evil.example"),
            ("x-forwarded-proto", "https"),
        ],
    );
    let template = spoofed.json()["tiles"][0].as_str().unwrap().to_string();
    assert!(template.starts_with(&own), "{template}");
    s.get(
        "/v1/datasets/merc/tiles.json",
        &[("host", "evil.example/<script>")],
    )
    .assert_error(400, "bad_header", "a host that is no host");

    // The description points at it, for mercator datasets only.
    let d = s.get("/v1/datasets/merc", &[]).json();
    assert_eq!(d["tilejson"], "/v1/datasets/merc/tiles.json");
    assert!(s.get("/v1/datasets/srtm", &[]).json()["tilejson"].is_null());
}

#[test]
fn sigterm_drains_and_exits_cleanly() {
    let mut s = Server::start(data_dir());
    assert_eq!(s.get("/healthz", &[]).status, 200);
    let pid = s.child.id().to_string();
    let killed = Command::new("kill").args(["-TERM", &pid]).status().unwrap();
    assert!(killed.success());
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    let status = loop {
        if let Some(st) = s.child.try_wait().unwrap() {
            break st;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "still running 10 s after SIGTERM"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert!(status.success(), "{status:?}");
}

#[test]
fn a_corrupt_tile_fails_alone() {
    let dir = fresh_dir("serve-corrupt-tile");
    let mut bytes = std::fs::read(data_dir().join("crop.ztd")).unwrap();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    let e = c.entry(TileId { z: 1, x: 1, y: 1 }).unwrap();
    bytes[e.offset as usize + 40] ^= 0x55; // inside the stream: the record's CRC fails
    std::fs::write(dir.join("crop.ztd"), &bytes).unwrap();
    let mut s = Server::start(&dir);
    s.warnings_expected = true;
    s.get("/v1/datasets/crop/tiles/1/1/1.png", &[])
        .assert_error(500, "internal", "corrupt tile");
    // Its neighbour still meshes (without the corrupt edge), other tiles are untouched.
    assert_eq!(s.get("/v1/datasets/crop/tiles/1/0/1.json", &[]).status, 200);
    assert_eq!(s.get("/v1/datasets/crop/tiles/1/0/0.png", &[]).status, 200);
    drop(s);
    let _ = std::fs::remove_dir_all(&dir);
}

/// (u or v along the edge, height) of the vertices listed in `edge`, sorted.
fn qm_edge(t: &qm::Tile, edge: usize, along_u: bool) -> Vec<(u16, f64)> {
    let (lo, hi) = (f64::from(t.min_height), f64::from(t.max_height));
    let mut v: Vec<(u16, f64)> = t.edges[edge]
        .iter()
        .map(|&i| {
            let i = i as usize;
            let h = lo + f64::from(t.h[i]) / 32767.0 * (hi - lo);
            (if along_u { t.u[i] } else { t.v[i] }, h)
        })
        .collect();
    v.sort_by_key(|p| p.0);
    v
}

#[test]
fn real_geodetic_tiles_match_their_neighbours_on_every_side() {
    let s = Server::start(data_dir());
    let layer = s.get("/v1/datasets/srtm/layer.json", &[]).json();
    let z10 = &layer["available"][10][0];
    let (x0, y0) = (
        z10["startX"].as_u64().unwrap() as u32,
        z10["startY"].as_u64().unwrap() as u32,
    );
    let tile = |x: u32, y: u32| {
        let r = s.get(
            &format!("/v1/datasets/srtm/tiles/10/{x}/{y}.terrain?threshold=4"),
            &[],
        );
        assert_eq!(
            r.status,
            200,
            "10/{x}/{y}: {}",
            String::from_utf8_lossy(&r.body)
        );
        qm::read(&r.body).unwrap()
    };
    let close = |a: &[(u16, f64)], b: &[(u16, f64)], what: &str| {
        assert!(a.len() >= 2, "{what}");
        assert_eq!(a.len(), b.len(), "{what}: edge vertex counts differ");
        for (p, q) in a.iter().zip(b) {
            assert_eq!(p.0, q.0, "{what}");
            assert!((p.1 - q.1).abs() < 0.1, "{what}: {p:?} vs {q:?}");
        }
    };
    // Edge lists: 0 west, 1 south, 2 east, 3 north; geodetic y grows northwards.
    let (a, east, north) = (
        tile(x0 + 1, y0 + 1),
        tile(x0 + 2, y0 + 1),
        tile(x0 + 1, y0 + 2),
    );
    close(
        &qm_edge(&a, 2, false),
        &qm_edge(&east, 0, false),
        "east edge",
    );
    close(
        &qm_edge(&a, 3, true),
        &qm_edge(&north, 1, true),
        "north edge",
    );

    // Lighting: the normals of every shared edge vertex agree across the
    // border (they came from each tile's own triangles once, and differed by up to tens of
    // degrees: a lit seam along every tile edge in CesiumJS).
    let lit_at = |x: u32, y: u32, t: f64| {
        let accept = "application/vnd.quantized-mesh;extensions=octvertexnormals";
        let r = s.get(
            &format!("/v1/datasets/srtm/tiles/10/{x}/{y}.terrain?threshold={t}"),
            &[("Accept", accept)],
        );
        assert_eq!(r.status, 200);
        qm::read(&r.body).unwrap()
    };
    let lit = |x, y| lit_at(x, y, 4.0);
    let (a, east, north) = (
        lit(x0 + 1, y0 + 1),
        lit(x0 + 2, y0 + 1),
        lit(x0 + 1, y0 + 2),
    );
    let normals = |t: &qm::Tile, edge: usize, along_u: bool| -> Vec<(u16, DVec3)> {
        let oct = &t.extensions.iter().find(|(id, _)| *id == 1).unwrap().1;
        let mut v: Vec<(u16, DVec3)> = t.edges[edge]
            .iter()
            .map(|&i| {
                let i = i as usize;
                let n = quantized_mesh::oct_decode([oct[2 * i], oct[2 * i + 1]]);
                (if along_u { t.u[i] } else { t.v[i] }, n)
            })
            .filter(|(k, _)| *k != 0 && *k != 32767)
            .collect();
        v.sort_by_key(|p| p.0);
        v
    };
    for (mine, theirs, what) in [
        (normals(&a, 2, false), normals(&east, 0, false), "east"),
        (normals(&a, 3, true), normals(&north, 1, true), "north"),
    ] {
        assert!(!mine.is_empty() && mine.len() == theirs.len(), "{what}");
        let worst = mine
            .iter()
            .zip(&theirs)
            .map(|((_, p), (_, q))| p.angle_between(*q).to_degrees())
            .fold(0.0, f64::max);
        // Oct encoding keeps a byte per component: ~1° apart at worst.
        assert!(
            worst < 2.0,
            "{what} edge normals differ by up to {worst:.1}°"
        );
    }

    // The corner the four tiles share gets one normal: each tile reads the samples next to
    // it from the same decodes (its diagonal neighbour's included), so the oct bytes match.
    // Coarse decodes (T = 200 m), where reading the two far arms from one tile's decode
    // alone, as before, moved the bytes by two steps.
    let coarse = |x, y| lit_at(x, y, 200.0);
    let (a, east, north, north_east) = (
        coarse(x0 + 1, y0 + 1),
        coarse(x0 + 2, y0 + 1),
        coarse(x0 + 1, y0 + 2),
        coarse(x0 + 2, y0 + 2),
    );
    let corner = |t: &qm::Tile, u: u16, v: u16| -> [u8; 2] {
        let oct = &t.extensions.iter().find(|(id, _)| *id == 1).unwrap().1;
        let i = (0..t.u.len())
            .find(|&i| t.u[i] == u && t.v[i] == v)
            .expect("a tile corner is a vertex");
        [oct[2 * i], oct[2 * i + 1]]
    };
    let seen = [
        corner(&a, 32767, 32767),
        corner(&east, 0, 32767),
        corner(&north, 32767, 0),
        corner(&north_east, 0, 0),
    ];
    assert!(
        seen.iter().all(|&o| o == seen[0]),
        "the corner's oct normals differ: {seen:?}"
    );
}

#[test]
fn view_and_ratio_thresholds_are_eq4() {
    let s = Server::start(data_dir());
    let d = s.get("/v1/datasets/crop", &[]).json();
    let (a, b) = (
        d["view"]["a"].as_f64().unwrap(),
        d["view"]["b"].as_f64().unwrap(),
    );
    let eq4 = |ratio: f64| (a * ratio + b).clamp(0.0, 100_000.0);
    for h in [400.0, 3000.0] {
        let v = s
            .get(
                &format!("/v1/datasets/crop/view?eye=256,400,{h}&target=256,256,300&fov=60"),
                &[],
            )
            .json();
        let (t, ratio) = (
            v["threshold"].as_f64().unwrap(),
            v["ratio"].as_f64().unwrap(),
        );
        assert!(
            (t - eq4(ratio)).abs() <= 1e-9 * t.max(1.0),
            "h {h}: T {t}, eq. 4 gives {}",
            eq4(ratio)
        );
    }
    for ratio in [0.01, 0.5] {
        let r = s.get(
            &format!("/v1/datasets/crop/tiles/1/0/0.png?ratio={ratio}"),
            &[],
        );
        assert_eq!(r.status, 200);
        let t = r.number("x-threshold");
        assert!(
            (t - eq4(ratio)).abs() <= 1e-9 * t.max(1.0),
            "ratio {ratio}: T {t}, eq. 4 gives {}",
            eq4(ratio)
        );
    }
}
