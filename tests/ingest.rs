//! `zerotile ingest` run as a user would, on real SRTM data.
#![allow(
    clippy::unwrap_used,
    reason = "test helpers: a failure to spawn the binary should fail the test loudly"
)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use zerotile_codec::container::{Container, Limits, TileId, TileRecord};
use zerotile_codec::ezw::{self, DecodeLimit};
use zerotile_tests::{assert_success, ingest_command, shared_data, zerotile_bin};

/// A data folder not made yet: ingest makes it.
fn scratch(name: &str) -> PathBuf {
    zerotile_tests::fresh_dir(&format!("e2e-{name}")).join("data")
}

fn ingest(input: &Path, name: &str, data: &Path, extra: &[&str]) -> std::process::Output {
    ingest_command(input, name, data, extra).output().unwrap()
}

/// [`ingest`], which must succeed, and the dataset file it wrote: its bytes and container.
fn ingested(input: &Path, name: &str, data: &Path, extra: &[&str]) -> (Vec<u8>, Container) {
    assert_success(&ingest(input, name, data, extra));
    let bytes = std::fs::read(data.join(format!("{name}.ztd"))).unwrap();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    (bytes, c)
}

#[test]
fn ingest_builds_a_pyramid_whose_tiles_decode_to_the_source() {
    let data = scratch("pyramid");
    let hgt = shared_data().join("dem/N44W072.hgt");
    let (bytes, c) = ingested(&hgt, "n44", &data, &["--precision", "0.5"]);
    // 1201 samples = 4.7 tiles of 256 steps: 5×5, 3×3, 2×2, 1×1.
    assert_eq!(c.metadata.max_zoom, 3);
    assert_eq!(c.len(), 25 + 9 + 4 + 1);

    // A full-resolution tile decodes to the source within the stated precision.
    let source: Vec<f64> = std::fs::read(&hgt)
        .unwrap()
        .chunks_exact(2)
        .map(|b| f64::from(i16::from_be_bytes([b[0], b[1]])))
        .collect();
    let id = TileId { z: 3, x: 2, y: 1 };
    let e = c.entry(id).unwrap();
    let rec = TileRecord::parse(id, &bytes[e.offset as usize..][..e.len as usize], &e).unwrap();
    let d = ezw::decode(rec.stream, DecodeLimit::All, ezw::DEFAULT_MAX_SAMPLES).unwrap();
    let mut worst = 0f64;
    for r in 0..257 {
        for col in 0..257 {
            let s = source[(256 + r) * 1201 + 512 + col];
            worst = worst.max((d.heights.get(r, col) - s).abs());
        }
    }
    assert!(
        worst <= 0.5,
        "max error {worst} above the requested precision"
    );
    assert_eq!(rec.corners[0], source[256 * 1201 + 512]);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn a_failed_ingest_leaves_the_previous_dataset_intact() {
    let data = scratch("atomic");
    let good = shared_data().join("dem/terra_elev.tif");
    assert_success(&ingest(&good, "lux", &data, &[]));
    let before = std::fs::read(data.join("lux.ztd")).unwrap();

    let bad = data.join("broken.hgt");
    std::fs::write(&bad, [0u8; 1000]).unwrap();
    let out = ingest(&bad, "lux", &data, &[]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("broken.hgt"));
    assert_eq!(std::fs::read(data.join("lux.ztd")).unwrap(), before);
    let leftovers: Vec<_> = std::fs::read_dir(&data)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left behind");
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn bad_names_and_schemes_are_refused_with_a_message() {
    let data = scratch("names");
    let hgt = shared_data().join("dem/terra_elev.tif");
    // Usage errors, exit 2 as the parser's own below.
    for (name, extra, needle) in [
        ("../escape", &[][..], "dataset name"),
        ("ok", &["--precision", "0"][..], "--precision"),
    ] {
        let out = ingest(&hgt, name, &data, extra);
        assert_eq!(out.status.code(), Some(2), "{name} {extra:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{name} {extra:?}: {err}");
    }
    // An unknown scheme is a usage error, as clap reports any bad value: exit 2.
    let out = ingest(&hgt, "ok", &data, &["--scheme", "utm"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("'utm'") && err.contains("--scheme"), "{err}");
    assert!(!data.join("ok.ztd").exists());
}

/// Reads a tile's stream from a container and decodes every pass.
fn decode_tile(bytes: &[u8], c: &Container, id: TileId) -> zerotile_codec::Grid<f64> {
    let e = c.entry(id).unwrap_or_else(|| panic!("tile {id:?} missing"));
    let rec = TileRecord::parse(id, &bytes[e.offset as usize..][..e.len as usize], &e).unwrap();
    ezw::decode(rec.stream, DecodeLimit::All, ezw::DEFAULT_MAX_SAMPLES)
        .unwrap()
        .heights
}

/// The SRTM tile's height at (`lon`, `lat`) by bilinear interpolation, computed here from
/// the file and its name alone (1201² samples, row 0 on lat 45, column 0 on lon −72).
fn srtm_height(source: &[f64], lon: f64, lat: f64) -> f64 {
    let (r, c) = ((45.0 - lat) * 1200.0, (lon + 72.0) * 1200.0);
    let (r0, c0) = (r.floor().clamp(0.0, 1199.0), c.floor().clamp(0.0, 1199.0));
    let (fr, fc) = (r - r0, c - c0);
    let at = |dr: usize, dc: usize| source[(r0 as usize + dr) * 1201 + c0 as usize + dc];
    (1.0 - fr) * ((1.0 - fc) * at(0, 0) + fc * at(0, 1))
        + fr * ((1.0 - fc) * at(1, 0) + fc * at(1, 1))
}

fn srtm() -> Vec<f64> {
    std::fs::read(shared_data().join("dem/N44W072.hgt"))
        .unwrap()
        .chunks_exact(2)
        .map(|b| f64::from(i16::from_be_bytes([b[0], b[1]])))
        .collect()
}

#[test]
fn geodetic_ingest_places_srtm_on_cesiums_grid() {
    let data = scratch("geodetic");
    let hgt = shared_data().join("dem/N44W072.hgt");
    let (bytes, c) = ingested(
        &hgt,
        "n44",
        &data,
        &["--scheme", "geodetic", "--wavelet", "53"],
    );
    let m = &c.metadata;
    // 3" SRTM: 180° / (256 · 2^z) ≤ 1/1200° first at z = 10.
    assert_eq!(
        (m.scheme.as_str(), m.min_zoom, m.max_zoom),
        ("geodetic", 0, 10)
    );
    for (got, want) in m.bounds.iter().zip([-72.0, 44.0, -71.0, 45.0]) {
        assert!((got - want).abs() < 1e-9, "{:?}", m.bounds);
    }
    // Both root tiles exist; at zoom 10 lon −72..−71 is x 614..620 (2048 across, 614.4..620.1) and
    // lat 44..45 is TMS y 762..767 (1024 down, from the south; lat 45 is exactly 768).
    assert!(c.entry(TileId { z: 0, x: 0, y: 0 }).is_some());
    assert!(c.entry(TileId { z: 0, x: 1, y: 0 }).is_some());
    let a = m.available[10][0];
    assert_eq!(
        (a.start_x, a.end_x, a.start_y, a.end_y),
        (614, 620, 762, 767)
    );
    assert_eq!(c.len() as u64, c.tiles().count() as u64);

    // Every sample of a deepest tile is the source, bilinearly, at the tile's own lon/lat.
    let source = srtm();
    let (x, y) = (617u32, 765u32);
    let h = decode_tile(&bytes, &c, TileId { z: 10, x, y });
    let mut worst = 0f64;
    for r in (0..257).step_by(8) {
        for col in (0..257).step_by(8) {
            let lon = -180.0 + 360.0 * f64::from(x * 256 + col) / (2048.0 * 256.0);
            let lat = 90.0 - 180.0 * f64::from((1023 - y) * 256 + r) / (1024.0 * 256.0);
            let want = srtm_height(&source, lon, lat);
            worst = worst.max((h.get(r as usize, col as usize) - want).abs());
        }
    }
    // Lossless 5/3 on a 1 m step: only the rounding of the interpolated height remains.
    assert!(worst <= 0.5 + 1e-9, "max error {worst} m");
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn mercator_ingest_uses_xyz_rows_from_the_north() {
    let data = scratch("mercator");
    let hgt = shared_data().join("dem/N44W072.hgt");
    let (bytes, c) = ingested(
        &hgt,
        "n44m",
        &data,
        &["--scheme", "mercator", "--max-zoom", "9", "--wavelet", "53"],
    );
    assert_eq!(
        (c.metadata.scheme.as_str(), c.metadata.max_zoom),
        ("mercator", 9)
    );

    // The XYZ tile holding (−71.5°, 44.5°) at zoom 9, from the slippy-map formula.
    let n = 512.0f64;
    let (lon, lat) = (-71.5f64, 44.5f64);
    let x = ((lon + 180.0) / 360.0 * n).floor();
    let lat_r = lat.to_radians();
    let y =
        ((1.0 - (lat_r.tan() + 1.0 / lat_r.cos()).ln() / std::f64::consts::PI) / 2.0 * n).floor();
    let h = decode_tile(
        &bytes,
        &c,
        TileId {
            z: 9,
            x: x as u32,
            y: y as u32,
        },
    );
    // Its centre sample's lon/lat, then the source there.
    let (gx, gy) = (
        (x * 256.0 + 128.0) / (n * 256.0),
        (y * 256.0 + 128.0) / (n * 256.0),
    );
    let clon = gx * 360.0 - 180.0;
    let clat = (std::f64::consts::PI * (1.0 - 2.0 * gy))
        .sinh()
        .atan()
        .to_degrees();
    let want = srtm_height(&srtm(), clon, clat);
    let got = *h.get(128, 128);
    assert!(
        (got - want).abs() <= 0.5 + 1e-6,
        "{got} vs {want} at {clon}, {clat}"
    );
    let _ = std::fs::remove_dir_all(&data);
}

/// N44W072's north-west 601 × 301 samples (lon −72..−71.5, lat 45..44.75) written as an ESRI
/// ASCII grid with a WGS 84 `.prj`, its corner moved to lon 179.75: across the antimeridian.
fn srtm_across_the_antimeridian(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let source = srtm();
    let (rows, cols) = (301, 601);
    let mut text = format!(
        "ncols {cols}\nnrows {rows}\nxllcenter 179.75\nyllcenter 44.75\ncellsize {}\n",
        1.0 / 1200.0
    );
    for r in 0..rows {
        let row: Vec<String> = (0..cols)
            .map(|c| source[r * 1201 + c].to_string())
            .collect();
        text += &(row.join(" ") + "\n");
    }
    let asc = dir.join("seam.asc");
    std::fs::write(&asc, text).unwrap();
    std::fs::write(
        dir.join("seam.prj"),
        r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#,
    )
    .unwrap();
    asc
}

#[test]
fn a_source_across_the_antimeridian_is_ingested_on_both_sides() {
    let data = scratch("antimeridian");
    let asc = srtm_across_the_antimeridian(&data.parent().unwrap().join("src"));
    let (bytes, c) = ingested(
        &asc,
        "seam",
        &data,
        &["--scheme", "geodetic", "--wavelet", "53"],
    );
    let m = &c.metadata;
    assert_eq!(m.max_zoom, 10);
    // Cesium's convention: west past east when the rectangle crosses the antimeridian.
    for (got, want) in m.bounds.iter().zip([179.75, 44.75, -179.75, 45.0]) {
        assert!((got - want).abs() < 1e-9, "{:?}", m.bounds);
    }
    // At zoom 10 (2048 across) lon 179.75..180 is x 2046..2047 (2046.6..2048) and
    // −180..−179.75 is x 0..1 (0..1.4); lat 44.75..45 is TMS y 766..767 (766.6..768).
    let xs: Vec<(u32, u32, u32, u32)> = m.available[10]
        .iter()
        .map(|a| (a.start_x, a.end_x, a.start_y, a.end_y))
        .collect();
    assert_eq!(xs, [(2046, 2047, 766, 767), (0, 1, 766, 767)]);
    assert_eq!(c.len() as u64, c.tiles().count() as u64);

    // The tiles on either side hold the source (lossless 5/3: the rounding alone), read
    // from N44W072 at the place the moved corner puts each sample.
    let source = srtm();
    let y = 767u32;
    let (mut worst, mut checked) = (0f64, 0);
    for x in [2046u32, 2047, 0, 1] {
        let h = decode_tile(&bytes, &c, TileId { z: 10, x, y });
        for r in (0..257).step_by(4) {
            for col in (0..257).step_by(4) {
                let lon = -180.0 + 360.0 * f64::from(x * 256 + col) / (2048.0 * 256.0);
                let lat = 90.0 - 180.0 * f64::from((1023 - y) * 256 + r) / (1024.0 * 256.0);
                let east = if lon < 0.0 { lon + 360.0 } else { lon };
                if !(179.75..=180.25).contains(&east) || !(44.75..=45.0).contains(&lat) {
                    continue;
                }
                let want = srtm_height(&source, -72.0 + (east - 179.75), lat);
                worst = worst.max((h.get(r as usize, col as usize) - want).abs());
                checked += 1;
            }
        }
    }
    assert!(checked > 2000, "{checked} samples");
    assert!(worst <= 0.5 + 1e-9, "max error {worst} m");

    // The seam is one column: the last tile's east edge is the first tile's west edge, at
    // every zoom down to the roots.
    for z in 0..=10u8 {
        let (nx, y) = (2u32 << z, 767 >> (10 - z));
        let west = decode_tile(&bytes, &c, TileId { z, x: nx - 1, y });
        let east = decode_tile(&bytes, &c, TileId { z, x: 0, y });
        for r in 0..257 {
            assert_eq!(west.get(r, 256), east.get(r, 0), "zoom {z} row {r}");
        }
    }

    // Mercator goes round the same way: the last column and the first at zoom 9.
    let (bytes, c) = ingested(
        &asc,
        "seam-m",
        &data,
        &["--scheme", "mercator", "--max-zoom", "9", "--wavelet", "53"],
    );
    let ranges = &c.metadata.available[9];
    assert_eq!(ranges.len(), 2, "{ranges:?}");
    assert_eq!((ranges[0].end_x, ranges[1].start_x), (511, 0));
    let y = ranges[0].start_y;
    let west = decode_tile(&bytes, &c, TileId { z: 9, x: 511, y });
    let east = decode_tile(&bytes, &c, TileId { z: 9, x: 0, y });
    for r in 0..257 {
        assert_eq!(west.get(r, 256), east.get(r, 0), "mercator row {r}");
    }
    let out = Command::new(zerotile_bin())
        .args(["info", "seam", "--verify", "--data"])
        .arg(&data)
        .output()
        .unwrap();
    assert_success(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(
            "bounds (W, S, E, N) 179.75, 44.75, -179.75, 45 degrees (across the antimeridian)"
        ),
        "{text}"
    );

    // Served: the bounds as stored, the manifests' (which may not wrap) every longitude with
    // both sides listed, tiles either side, and a view east of the seam over 0.5° × 0.25°.
    let s = zerotile_tests::server::Server::start(&data);
    let d = s.get("/v1/datasets/seam", &[]).json();
    assert_eq!(
        d["bounds"],
        serde_json::json!([179.75, 44.75, -179.75, 45.0])
    );
    let layer = s.get("/v1/datasets/seam/layer.json", &[]).json();
    assert_eq!(
        layer["bounds"],
        serde_json::json!([-180.0, 44.75, 180.0, 45.0])
    );
    let starts: Vec<u64> = layer["available"][10]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["startX"].as_u64().unwrap())
        .collect();
    assert_eq!(starts, [2046, 0]);
    let tj = s.get("/v1/datasets/seam-m/tiles.json", &[]).json();
    assert_eq!(
        (tj["bounds"][0].as_f64(), tj["bounds"][2].as_f64()),
        (Some(-180.0), Some(180.0))
    );
    for x in [2047, 0] {
        let r = s.get(&format!("/v1/datasets/seam/tiles/10/{x}/767.terrain"), &[]);
        assert_eq!(r.status, 200, "tile {x}");
    }
    // A view's answer, and every `stride`-th number of one of its arrays (flattened).
    let view = |query: &str| {
        let r = s.get(&format!("/v1/datasets/{query}"), &[]);
        assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
        r.json()
    };
    let numbers = |a: &serde_json::Value, stride: usize| -> Vec<f64> {
        let flat: Vec<f64> = match a.as_array().unwrap().first() {
            Some(serde_json::Value::Array(_)) => a
                .as_array()
                .unwrap()
                .iter()
                .flat_map(|p| p.as_array().unwrap().clone())
                .map(|x| x.as_f64().unwrap())
                .collect(),
            _ => a
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect(),
        };
        flat.into_iter().step_by(stride).collect()
    };
    // Looking almost straight down east of the seam: the footprint, some 200 m across, lies
    // wholly within −180..−179.75.
    let v = view("seam/view?eye=-179.9,44.9,3000&target=-179.9,44.8999,500&fov=10");
    let lons = numbers(&v["footprint"], 2);
    assert!(lons.iter().all(|&x| x < -179.75), "{lons:?}");
    assert!(v["triangles"].as_u64().unwrap() > 0, "{v}");
    let a_t = v["a_t"].as_f64().unwrap();
    let want = 0.5 * 0.25 * 44.875f64.to_radians().cos() * 111_319.490_793_273_57f64.powi(2);
    assert!((a_t / want - 1.0).abs() < 1e-6, "A_t {a_t} m², want {want}");
    // From 200 km up the footprint (as far as the data's diagonal round the eye's foot) is
    // wider than the data: it is cut to the data's part east of the seam and keeps the
    // deepest zoom.
    let v = s.get(
        "/v1/datasets/seam/view?eye=-179.8,44.9,200000&target=-179.8,44.8999,0&fov=60",
        &[],
    );
    assert_eq!(v.status, 200, "{}", String::from_utf8_lossy(&v.body));
    assert_eq!(v.json()["zoom"], 10);
    // Looking down on the seam from an eye some 80 m across it: the footprint (some 6 km
    // across) runs on past ±180° round the target, and the mesh holds the data either side
    // of the seam as one piece, the far side moved a turn round, welded where the sides
    // meet: a vertex on the seam serves faces on both sides. Taking the eye as 359.998°
    // away cut the view to one side, or refused it. Both ways across, on both schemes
    // (mercator's turn is the world's width in metres).
    let half_mercator = 6_378_137.0 * std::f64::consts::PI;
    for (name, half) in [("seam", 180.0), ("seam-m", half_mercator)] {
        for (eye, target, seam) in [(-179.999, 179.999, 1.0), (179.999, -179.999, -1.0)] {
            let camera = format!("eye={eye},44.87,5000&target={target},44.87,0&fov=60");
            let v = view(&format!("{name}/view?{camera}"));
            let at = format!("{name} {camera}");
            if name == "seam" {
                let lons = numbers(&v["footprint"], 2);
                assert!(lons.iter().any(|&x| x * seam > 180.01), "{at}: {lons:?}");
                assert!(lons.iter().any(|&x| x * seam < 179.99), "{at}: {lons:?}");
            }
            // x in half turns, the seam side's sign taken off: the seam is at 1.
            let xs: Vec<f64> = numbers(&v["mesh"]["positions"], 3)
                .into_iter()
                .map(|x| x * seam / half)
                .collect();
            assert!(
                xs.iter().all(|&x| (0.999..1.001).contains(&x)),
                "{at}: a vertex off the view"
            );
            let indices: Vec<usize> = numbers(&v["mesh"]["indices"], 1)
                .into_iter()
                .map(|i| i as usize)
                .collect();
            let (mut near, mut far) = (
                std::collections::HashSet::new(),
                std::collections::HashSet::new(),
            );
            for f in indices.chunks(3) {
                let side = if f.iter().any(|&i| xs[i] < 1.0) {
                    &mut near
                } else {
                    &mut far
                };
                side.extend(f.iter().copied().filter(|&i| xs[i] == 1.0));
            }
            let shared = near.intersection(&far).count();
            assert!(
                shared > 2 && xs.iter().filter(|&&x| x > 1.0).count() > 10,
                "{at}: {shared} seam vertices welded across it"
            );
        }
    }
    // A footprint away from the data, in the gap between its ends round the world, is empty.
    let v = s.get(
        "/v1/datasets/seam/view?eye=0,44.9,3000&target=0,44.8999,500&fov=10",
        &[],
    );
    assert_eq!(v.status, 404, "{}", String::from_utf8_lossy(&v.body));
    drop(s);
    let _ = std::fs::remove_dir_all(data.parent().unwrap());
}

#[test]
fn world_schemes_refuse_sources_they_cannot_place() {
    let data = scratch("crs");
    // EPSG:32632 (UTM): not reprojected here.
    let utm = shared_data().join("dem/terra_elev_vinschgau.tif");
    let out = ingest(&utm, "v", &data, &["--scheme", "geodetic"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("EPSG:32632"));
    // A format that has no georeference at all: refused by its name, before it is read,
    // as the command line's error.
    let png = shared_data().join("dem/fuji.png");
    let out = ingest(
        &png,
        "j",
        &data,
        &["--scheme", "mercator", "--encoding", "terrain-rgb"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("fuji.png: a .png carries no georeference, so it cannot be placed on the globe"));
    // --max-zoom means nothing for a local grid: a usage error.
    let out = ingest(&utm, "v", &data, &["--max-zoom", "3"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!data.join("v.ztd").exists() && !data.join("j.ztd").exists());
}

#[test]
fn a_killed_ingest_leaves_the_previous_dataset_intact_and_served() {
    let data = scratch("killed");
    let small = shared_data().join("dem/terra_elev.tif");
    assert_success(&ingest(&small, "keep", &data, &[]));
    let before = std::fs::read(data.join("keep.ztd")).unwrap();

    // A long ingest under the same name (max-error mode, 226 geodetic tiles: ~3.6 s on an
    // idle 2-core machine), killed with SIGKILL mid-encode: no chance to clean up.
    let hgt = shared_data().join("dem/N44W072.hgt");
    let mut child = Command::new(zerotile_bin())
        .arg("ingest")
        .arg(&hgt)
        .args([
            "--name",
            "keep",
            "--quiet",
            "--precision",
            "0.1",
            "--scheme",
            "geodetic",
        ])
        .args(["--max-zoom", "11", "--data"])
        .arg(&data)
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert!(
        !status.success(),
        "the ingest finished before it was killed"
    );
    assert_eq!(std::fs::read(data.join("keep.ztd")).unwrap(), before);

    // The server still opens and serves it (a leftover temporary file is not a dataset).
    let s = zerotile_tests::server::Server::start(&data);
    let list = s.get("/v1/datasets", &[]).json();
    assert_eq!(list["datasets"][0]["name"], "keep");
    assert_eq!(list["datasets"].as_array().map(Vec::len), Some(1));
    drop(s);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn info_verify_finds_a_flipped_bit_and_names_the_tile() {
    let data = scratch("info");
    let hgt = shared_data().join("dem/N44W072.hgt");
    assert_success(&ingest(&hgt, "n44", &data, &["--precision", "1"]));
    let info = |extra: &[&str]| {
        Command::new(zerotile_bin())
            .args(["info", "n44", "--quiet", "--data"])
            .arg(&data)
            .args(extra)
            .output()
            .unwrap()
    };
    let json = |out: &std::process::Output| -> serde_json::Value {
        serde_json::from_slice(&out.stdout).unwrap()
    };

    let out = info(&["--verify", "--json"]);
    assert_success(&out);
    let r = json(&out);
    assert_eq!(r["tiles"], 25 + 9 + 4 + 1);
    let per_zoom: Vec<u64> = r["zooms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|z| z["tiles"].as_u64().unwrap())
        .collect();
    assert_eq!(per_zoom, [1, 4, 9, 25]);
    assert_eq!(r["failed"], serde_json::json!([]));
    assert_eq!(r["missing"], serde_json::json!([]));
    // Without --verify nothing is read past the header, and nothing is claimed about it.
    assert_eq!(json(&info(&["--json"]))["failed"], serde_json::Value::Null);

    // One flipped bit inside one tile's stream: that tile, and only it, fails.
    let file = data.join("n44.ztd");
    let mut bytes = std::fs::read(&file).unwrap();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    let e = c.entry(TileId { z: 3, x: 2, y: 1 }).unwrap();
    bytes[e.offset as usize + 40] ^= 0x10;
    std::fs::write(&file, &bytes).unwrap();
    let out = info(&["--verify", "--json"]);
    // 3: read, but a check failed (1 is for a file that cannot be read, below).
    assert_eq!(out.status.code(), Some(3));
    let failed = json(&out)["failed"].clone();
    assert_eq!(failed.as_array().unwrap().len(), 1, "{failed}");
    assert_eq!(failed[0]["tile"], "3/2/1");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("1 of 39 tiles failed"), "{stderr}");
    // The readable form names it too.
    let out = info(&["--verify"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("3/2/1") && text.contains("1 of 39"), "{text}");
    // A truncated copy is a bad copy too (3), though the open refuses it before any tile is
    // read; a dataset that is not there is not (1).
    std::fs::write(&file, &bytes[..bytes.len() / 2]).unwrap();
    let out = info(&["--verify"]);
    assert_eq!(out.status.code(), Some(3));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("truncated copy"), "{stderr}");
    std::fs::remove_file(&file).unwrap();
    let out = info(&["--verify"]);
    assert_eq!(out.status.code(), Some(1));
    // A store URL is refused with what to do instead, not "no such file".
    let out = Command::new(zerotile_bin())
        .args(["info", "s3://tiles/prod/n44.ztd"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("local files"));
    let _ = std::fs::remove_dir_all(&data);
}

/// Ingests terra_elev.tif as `name`, then replaces it with N44W072 under a file-size limit of
/// 64 KiB, far below the new container: with `trap` its write fails part-way (EFBIG), without
/// it the kernel kills the ingest mid-write (SIGXFSZ). Returns the data folder, the first
/// container's bytes and the second ingest's output.
fn replace_under_a_size_limit(tag: &str, name: &str, trap: bool) -> (PathBuf, Vec<u8>, Output) {
    let data = scratch(tag);
    assert_success(&ingest(
        &shared_data().join("dem/terra_elev.tif"),
        name,
        &data,
        &[],
    ));
    let before = std::fs::read(data.join(format!("{name}.ztd"))).unwrap();
    let cmd = ingest_command(
        &shared_data().join("dem/N44W072.hgt"),
        name,
        &data,
        &["--precision", "1"],
    );
    let trap = if trap { "trap '' XFSZ; " } else { "" };
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!("{trap}ulimit -f 128; exec \"$0\" \"$@\""))
        .arg(cmd.get_program())
        .args(cmd.get_args())
        .output()
        .unwrap();
    (data, before, out)
}

#[test]
fn a_write_that_fails_midway_leaves_the_previous_dataset_intact() {
    let (data, before, out) = replace_under_a_size_limit("ingest-efbig", "lux", true);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read(data.join("lux.ztd")).unwrap(), before);
    let names: Vec<String> = std::fs::read_dir(&data)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["lux.ztd"], "temporary files left behind");
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn an_ingest_killed_mid_write_leaves_the_previous_dataset_served() {
    use std::os::unix::process::ExitStatusExt;
    let (data, before, out) = replace_under_a_size_limit("ingest-xfsz", "keep", false);
    assert_eq!(
        out.status.signal(),
        Some(25),
        "killed by SIGXFSZ while writing: {:?}",
        out.status
    );
    assert_eq!(std::fs::read(data.join("keep.ztd")).unwrap(), before);
    let s = zerotile_tests::server::Server::start(&data);
    let list = s.get("/v1/datasets", &[]).json();
    assert_eq!(list["datasets"].as_array().map(Vec::len), Some(1));
    assert_eq!(s.get("/v1/datasets/keep/tiles/0/0/0.png", &[]).status, 200);
    drop(s);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn a_reingest_changes_the_tile_etags_and_the_dataset_version() {
    // Caches key on the ETag and on layer.json's `version`: new bytes under an old tag would be
    // served stale until they expire. (An identical re-ingest changes them too: the version
    // hashes the header, and the header holds the ingest's `created` time.)
    let data = scratch("reingest");
    let src = shared_data().join("dem/terra_elev.tif");
    let tags = |precision: &str| {
        assert_success(&ingest(&src, "e", &data, &["--precision", precision]));
        let s = zerotile_tests::server::Server::start(&data);
        let tile = s.get("/v1/datasets/e/tiles/0/0/0.json?threshold=8", &[]);
        assert_eq!(tile.status, 200, "{}", String::from_utf8_lossy(&tile.body));
        let about = s.get("/v1/datasets/e", &[]).json();
        (
            tile.header("etag").unwrap().to_string(),
            about["version"].as_str().unwrap().to_string(),
        )
    };
    let first = tags("1");
    let finer = tags("0.25");
    assert_ne!(finer.0, first.0, "tile ETag after a re-ingest");
    assert_ne!(finer.1, first.1, "dataset version after a re-ingest");
    let _ = std::fs::remove_dir_all(&data);
}
