//! Encoder ↔ decoder round trips, the real tin-terrain tiles in shared/data, and bad bytes.

use glam::DVec3;

use super::*;
use crate::fixtures::{n44w072_crop, shared_data};
use crate::geo::{is_scaled_point_visible, BoundingSphere, Ellipsoid, Scheme, TileId, Tiling};
use crate::zerotree::TerrainMesh;

/// A full regular triangulation of a `rows` × `cols` grid, counter-clockwise seen from above
/// with north up (south-west, south-east, north-east; south-west, north-east, north-west).
fn grid_mesh(rows: usize, cols: usize, height: impl Fn(usize, usize) -> f64) -> TerrainMesh {
    let mut positions = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            positions.push([c as f64, r as f64, height(r, c)]);
        }
    }
    let id = |r: usize, c: usize| (r * cols + c) as u32;
    let mut triangles = Vec::new();
    for r in 0..rows - 1 {
        for c in 0..cols - 1 {
            let (nw, ne, sw, se) = (id(r, c), id(r, c + 1), id(r + 1, c), id(r + 1, c + 1));
            triangles.push([sw, se, ne]);
            triangles.push([sw, ne, nw]);
        }
    }
    let mesh = TerrainMesh {
        rows,
        cols,
        positions,
        triangles,
    };
    assert!(mesh.triangles.iter().all(|&t| mesh.signed_area2(t) > 0.0));
    mesh
}

fn bumpy(r: usize, c: usize) -> f64 {
    200.0 + 37.0 * ((r as f64) * 0.7).sin() * ((c as f64) * 0.4).cos() + (r * c % 5) as f64
}

fn all_extensions() -> QmOptions {
    QmOptions {
        octvertexnormals: true,
        watermask: Some(WaterMask::Grid(
            (0..65_536).map(|i| (i % 251) as u8).collect(),
        )),
        metadata: Some(serde_json::json!({
            "available": [[{"startX": 4, "startY": 2, "endX": 5, "endY": 3}]]
        })),
    }
}

fn uv_area2(m: &QuantizedMesh, [a, b, c]: [u32; 3]) -> i64 {
    let p = |i: u32| (i64::from(m.u[i as usize]), i64::from(m.v[i as usize]));
    let ((ax, ay), (bx, by), (cx, cy)) = (p(a), p(b), p(c));
    (bx - ax) * (cy - ay) - (cx - ax) * (by - ay)
}

fn ecef_of(m: &QuantizedMesh, i: usize, tile: &TileGeo) -> DVec3 {
    let [lon, lat, h] = m.lonlat_height(i, tile).unwrap();
    Ellipsoid::WGS84.to_ecef(lon, lat, h)
}

fn sample_tile(name: &str) -> Vec<u8> {
    let path = shared_data(&format!("dem/quantized-mesh/{name}"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn round_trip_preserves_every_field() {
    let mesh = grid_mesh(17, 17, bumpy);
    let tile = TileGeo::geodetic(10.0, 45.0, 10.5, 45.5);
    let opts = all_extensions();
    let m = decode(&encode(&mesh, &tile, &opts).unwrap()).unwrap();

    // Vertices: every grid sample once, at its quantised position and height.
    assert_eq!((m.vertex_count(), m.triangles.len()), (289, 512));
    let (lo, hi) = mesh.height_range().unwrap();
    assert!(f64::from(m.header.min_height) <= lo && f64::from(m.header.max_height) >= hi);
    assert!(
        f64::from(m.header.max_height) - hi < 1e-4 && lo - f64::from(m.header.min_height) < 1e-4
    );
    let step = (hi - lo) / 32767.0;
    let mut original_of = Vec::with_capacity(m.vertex_count());
    for i in 0..m.vertex_count() {
        let (u, v) = (u32::from(m.u[i]), u32::from(m.v[i]));
        let c = (f64::from(u) / 32767.0 * 16.0).round() as usize;
        let r = 16 - (f64::from(v) / 32767.0 * 16.0).round() as usize;
        assert_eq!(
            u,
            (c as f64 / 16.0 * 32767.0).round() as u32,
            "vertex {i} off the grid"
        );
        let orig = r * 17 + c;
        original_of.push(orig as u32);
        let h = m.height_m(i).unwrap();
        assert!(
            (h - mesh.positions[orig][2]).abs() <= step / 2.0 + 1e-6,
            "vertex {i}: {h}"
        );
    }

    // Triangles: the same triangles in the same order, renumbered.
    let back: Vec<[u32; 3]> = m
        .triangles
        .iter()
        .map(|t| t.map(|i| original_of[i as usize]))
        .collect();
    assert_eq!(back, mesh.triangles);

    // Edges: every border vertex, sorted along the border.
    for (list, on, key) in [
        (
            &m.west,
            Box::new(|i: usize| m.u[i] == 0) as Box<dyn Fn(usize) -> bool>,
            &m.v,
        ),
        (&m.south, Box::new(|i: usize| m.v[i] == 0), &m.u),
        (&m.east, Box::new(|i: usize| m.u[i] == QUANTIZED_MAX), &m.v),
        (&m.north, Box::new(|i: usize| m.v[i] == QUANTIZED_MAX), &m.u),
    ] {
        assert_eq!(list.len(), 17);
        assert!(list.iter().all(|&i| on(i as usize)));
        assert!(list
            .windows(2)
            .all(|w| key[w[0] as usize] < key[w[1] as usize]));
    }

    // Extensions: as given.
    assert_eq!(m.normals.as_ref().map(Vec::len), Some(289));
    assert_eq!(m.water_mask, opts.watermask);
    assert_eq!(m.metadata, opts.metadata);
    assert!(m.unknown_extensions.is_empty());
    // A one-byte mask (a tile all land or all water) too: its length is counted apart.
    for value in [0, 255] {
        let uniform = QmOptions {
            watermask: Some(WaterMask::Uniform(value)),
            ..all_extensions()
        };
        let u = decode(&encode(&mesh, &tile, &uniform).unwrap()).unwrap();
        assert_eq!(u.water_mask, Some(WaterMask::Uniform(value)));
        assert_eq!(u.metadata, opts.metadata);
    }

    // Header: the sphere holds what the client draws, and is that drawing's own sphere (the
    // decoded heights, not the mesh's, nor heights reconstructed any other way); the centre
    // is the tile's middle.
    let sphere_c = DVec3::from_array(m.header.bounding_sphere_center);
    let drawn: Vec<DVec3> = (0..m.vertex_count())
        .map(|i| ecef_of(&m, i, &tile))
        .collect();
    for p in &drawn {
        assert!(p.distance(sphere_c) <= m.header.bounding_sphere_radius + 1e-6);
    }
    let own = BoundingSphere::from_points(&drawn).unwrap();
    assert!(
        own.center.distance(sphere_c) < 1e-6
            && (own.radius - m.header.bounding_sphere_radius).abs() < 1e-6,
        "{own:?} against {:?}",
        m.header
    );
    let [lon, lat, h] = Ellipsoid::WGS84.to_geodetic(DVec3::from_array(m.header.center));
    assert!(
        (lon - 10.25).abs() < 1e-9
            && (lat - 45.25).abs() < 1e-9
            && (h - (lo + hi) / 2.0).abs() < 1e-3
    );
    assert!(m
        .header
        .horizon_occlusion_point
        .iter()
        .all(|v| v.is_finite()));
}

/// Without given normals, each vertex's normal is the area-weighted normal of the triangles
/// around it as the client draws them (decoded positions, ECEF), to oct's precision. A
/// ~1 km tile rising 300 m northwards and rippled east-west, slopes over 10 degrees: a
/// normal summed wrongly (cargo-mutants: `(b - a)` as `(b + a)` in the cross product, which
/// still points roughly up) is several degrees off.
#[test]
fn facet_normals_are_the_drawn_surfaces_area_weighted_normals() {
    let mesh = grid_mesh(17, 17, |r, c| {
        300.0 * (16 - r) as f64 / 16.0 + 60.0 * (c as f64 * 0.8).sin()
    });
    let tile = TileGeo::geodetic(6.0, 45.0, 6.01, 45.01);
    let opts = QmOptions {
        octvertexnormals: true,
        ..QmOptions::default()
    };
    let m = decode(&encode(&mesh, &tile, &opts).unwrap()).unwrap();
    let drawn: Vec<DVec3> = (0..m.vertex_count())
        .map(|i| ecef_of(&m, i, &tile))
        .collect();
    let mut sums = vec![DVec3::ZERO; drawn.len()];
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| drawn[i as usize]);
        for &i in t {
            sums[i as usize] += (b - a).cross(c - a);
        }
    }
    let normals = m.normals.as_ref().unwrap();
    let mut steepest: f64 = 0.0;
    for (i, (&n, s)) in normals.iter().zip(&sums).enumerate() {
        let want = s.normalize();
        let angle = oct_decode(n).angle_between(want).to_degrees();
        assert!(angle < 1.5, "vertex {i}: {angle} degrees off");
        steepest = steepest.max(want.angle_between(drawn[i].normalize()).to_degrees());
    }
    assert!(
        steepest > 10.0,
        "the tile is too flat to tell: {steepest} degrees"
    );
}

/// The header's f32 height range holds every f64 height: where the nearest f32 falls inside
/// the range (0.1 rounds up, 0.7 down; the other way round below zero) it steps outwards,
/// so no vertex quantises outside it, and by one f32 step at most.
#[test]
fn the_f32_height_range_is_rounded_outwards() {
    let tile = TileGeo::geodetic(10.0, 45.0, 10.5, 45.5);
    for (lo, hi) in [(0.1_f64, 0.7_f64), (-0.7, -0.1)] {
        // The premise: the nearest f32 of each end lies inside the range.
        assert!(f64::from(lo as f32) > lo && f64::from(hi as f32) < hi);
        let height = |r, c| match (r, c) {
            (0, 0) => lo,
            (2, 2) => hi,
            _ => (lo + hi) / 2.0,
        };
        let m = decode(&encode(&grid_mesh(3, 3, height), &tile, &QmOptions::default()).unwrap())
            .unwrap();
        let (min_h, max_h) = (m.header.min_height, m.header.max_height);
        assert!(
            f64::from(min_h) <= lo && f64::from(max_h) >= hi,
            "{min_h}..{max_h}"
        );
        assert_eq!(
            (min_h, max_h),
            ((lo as f32).next_down(), (hi as f32).next_up())
        );
    }
}

/// The horizon occlusion point lies along the bounding sphere's centre in scaled space, as
/// CesiumJS computes it, not along the tile's geographic centre: on a wide tile the two
/// directions part.
#[test]
fn the_occlusion_point_is_aimed_at_the_bounding_spheres_centre() {
    let e = Ellipsoid::WGS84;
    let tile = TileGeo::geodetic(0.0, 0.0, 90.0, 60.0);
    let m =
        decode(&encode(&grid_mesh(9, 9, bumpy), &tile, &QmOptions::default()).unwrap()).unwrap();
    let along = |p: [f64; 3]| e.to_scaled_space(DVec3::from_array(p)).normalize();
    let sphere = along(m.header.bounding_sphere_center);
    let centre = along(m.header.center);
    let hop = DVec3::from_array(m.header.horizon_occlusion_point);
    assert!(hop.is_finite(), "{hop}");
    assert!(
        sphere.cross(centre).length() > 1e-3,
        "the directions differ here"
    );
    assert!(hop.normalize().cross(sphere).length() < 1e-12, "{hop}");
}

#[test]
fn triangles_wind_counter_clockwise_in_uv() {
    let m = decode(
        &encode(
            &grid_mesh(9, 5, bumpy),
            &TileGeo::geodetic(-3.0, -2.0, -1.0, 0.0),
            &QmOptions::default(),
        )
        .unwrap(),
    )
    .unwrap();
    assert!(m.triangles.iter().all(|&t| uv_area2(&m, t) > 0));
}

#[test]
fn flat_tile_quantises_every_height_to_zero() {
    let m = decode(
        &encode(
            &grid_mesh(5, 5, |_, _| 123.25),
            &TileGeo::geodetic(0.0, 0.0, 1.0, 1.0),
            &QmOptions::default(),
        )
        .unwrap(),
    )
    .unwrap();
    assert_eq!((m.header.min_height, m.header.max_height), (123.25, 123.25));
    assert!(m.height.iter().all(|&h| h == 0));
    assert_eq!(m.height_m(7), Some(123.25));
}

#[test]
fn vertex_count_decides_index_width_and_padding() {
    let tile = TileGeo::geodetic(0.0, 0.0, 1.0, 1.0);
    // 255 × 257 = 65 535 vertices: 16-bit, and the index data starts right after them.
    let narrow = encode(&grid_mesh(255, 257, bumpy), &tile, &QmOptions::default()).unwrap();
    let n = 65_535usize;
    let t = u32::from_le_bytes(narrow[92 + 6 * n..96 + 6 * n].try_into().unwrap());
    assert_eq!(t as usize, 2 * 254 * 256);
    assert_eq!(
        narrow.len(),
        92 + 6 * n + 4 + 6 * t as usize + 4 * 4 + 2 * 2 * (255 + 257)
    );
    // 257² = 66 049 vertices: 32-bit, after 2 bytes of padding (92 + 6n ≡ 2 mod 4).
    let wide_mesh = grid_mesh(257, 257, bumpy);
    let wide = encode(&wide_mesh, &tile, &QmOptions::default()).unwrap();
    let n = 66_049usize;
    assert_eq!((92 + 6 * n) % 4, 2);
    assert_eq!(&wide[92 + 6 * n..94 + 6 * n], &[0, 0]);
    let t = u32::from_le_bytes(wide[94 + 6 * n..98 + 6 * n].try_into().unwrap());
    assert_eq!(t as usize, wide_mesh.triangles.len());
    assert_eq!(
        wide.len(),
        94 + 6 * n + 4 + 12 * t as usize + 4 * 4 + 4 * 4 * 257
    );
    for bytes in [&narrow, &wide] {
        let m = decode(bytes).unwrap();
        assert!(m.triangles.iter().all(|&t| uv_area2(&m, t) > 0));
    }
}

/// 256² = 65 536 vertices, which CesiumJS reads with 16-bit indices into a 32-bit array
/// (a RangeError): the tile gets one more vertex, unused, a copy of an interior one, and
/// 32-bit indices. The triangles, edges and heights are the mesh's.
#[test]
fn a_tile_of_exactly_65536_vertices_gets_one_more() {
    let tile = TileGeo::geodetic(0.0, 0.0, 1.0, 1.0);
    let mesh = grid_mesh(256, 256, bumpy);
    assert_eq!(mesh.positions.len(), 65_536);
    for opts in [
        QmOptions::default(),
        QmOptions {
            octvertexnormals: true,
            ..QmOptions::default()
        },
    ] {
        let bytes = encode(&mesh, &tile, &opts).unwrap();
        let n = 65_537usize;
        assert_eq!(
            u32::from_le_bytes(bytes[88..92].try_into().unwrap()) as usize,
            n
        );
        // 92 + 6n ≡ 2 mod 4: two bytes of padding before the 32-bit index data.
        let t = u32::from_le_bytes(bytes[94 + 6 * n..98 + 6 * n].try_into().unwrap());
        assert_eq!(t as usize, mesh.triangles.len());
        let m = decode(&bytes).unwrap();
        assert_eq!(m.u.len(), n);
        let (pad, copy) = (
            n - 1,
            (0..n - 1).find(|&i| m.u[i] == m.u[n - 1] && m.v[i] == m.v[n - 1]),
        );
        let copy = copy.expect("the extra vertex repeats one");
        assert_eq!(m.height[pad], m.height[copy]);
        assert!(m.triangles.iter().flatten().all(|&i| (i as usize) < pad));
        for edge in [&m.west, &m.south, &m.east, &m.north] {
            assert_eq!(edge.len(), 256);
            assert!(!edge.contains(&(pad as u32)));
        }
    }
}

#[test]
fn vertices_are_renumbered_by_first_use_and_unused_ones_go_last() {
    // Reversed vertex order, plus a vertex no triangle uses.
    let mut mesh = grid_mesh(3, 3, bumpy);
    mesh.positions.reverse();
    for t in &mut mesh.triangles {
        *t = t.map(|i| 8 - i);
    }
    mesh.positions.push([1.0, 1.0, 500.0]);
    let tile = TileGeo::geodetic(0.0, 0.0, 1.0, 1.0);
    let m = decode(&encode(&mesh, &tile, &QmOptions::default()).unwrap()).unwrap();
    assert_eq!(m.vertex_count(), 10);
    // The unused vertex is last and highest.
    assert_eq!(m.height[9], QUANTIZED_MAX);
    // With no triangle to lean on, its normal is the ellipsoid's there (near 0.5°, 0.5°:
    // about +X), not a fixed +Z.
    let lit = QmOptions {
        octvertexnormals: true,
        ..QmOptions::default()
    };
    let normals = decode(&encode(&mesh, &tile, &lit).unwrap())
        .unwrap()
        .normals
        .unwrap();
    let up = Ellipsoid::WGS84.surface_normal_at(Ellipsoid::WGS84.to_ecef(0.5, 0.5, 500.0));
    let got = oct_decode(normals[9]);
    assert!(got.angle_between(up.unwrap()) < 0.05, "{got}"); // oct bytes: ~1° steps
                                                             // Each decoded triangle sits where the original did.
    for (dt, ot) in m.triangles.iter().zip(&mesh.triangles) {
        for (&d, &o) in dt.iter().zip(ot) {
            let [x, y, _] = mesh.positions[o as usize];
            assert_eq!(m.u[d as usize], (x / 2.0 * 32767.0).round() as u16);
            assert_eq!(m.v[d as usize], ((2.0 - y) / 2.0 * 32767.0).round() as u16);
        }
    }
}

#[test]
fn mercator_rows_quantise_by_latitude() {
    let tiling = Tiling::new(Scheme::Mercator, 9).unwrap();
    let id = TileId::new(3, 2, 1);
    let tile = tiling.tile_geo(id).unwrap();
    let m =
        decode(&encode(&grid_mesh(9, 9, bumpy), &tile, &QmOptions::default()).unwrap()).unwrap();
    let lat_step = (tile.north - tile.south) / 32767.0;
    for i in 0..m.vertex_count() {
        let [lon, lat, _] = m.lonlat_height(i, &tile).unwrap();
        let c = ((lon - tile.west) / (tile.east - tile.west) * 8.0).round() as u32;
        // The row whose mercator latitude is nearest.
        let (row, want) = (0..9)
            .map(|r| (r, tiling.sample_lonlat(id, r, c).unwrap()[1]))
            .min_by(|a, b| (a.1 - lat).abs().total_cmp(&(b.1 - lat).abs()))
            .unwrap();
        assert!(
            (lat - want).abs() <= lat_step / 2.0 + 1e-9,
            "vertex {i} row {row}: {lat} vs {want}"
        );
    }
    // Mid rows are not mid latitudes on a mercator tile.
    let mid = (0..m.vertex_count())
        .find(|&i| m.u[i] == 0 && m.v[i] != 0 && m.v[i] != QUANTIZED_MAX)
        .unwrap();
    assert_ne!(u32::from(m.v[mid]) % 4096, 0);
}

#[test]
fn normals_of_a_flat_tile_are_the_ellipsoid_normal() {
    let tile = TileGeo::geodetic(30.0, 60.0, 30.1, 60.1);
    let opts = QmOptions {
        octvertexnormals: true,
        ..QmOptions::default()
    };
    let m = decode(&encode(&grid_mesh(5, 5, |_, _| 0.0), &tile, &opts).unwrap()).unwrap();
    let normals = m.normals.as_ref().unwrap();
    for (i, &n) in normals.iter().enumerate() {
        let [lon, lat, _] = m.lonlat_height(i, &tile).unwrap();
        let angle = oct_decode(n).angle_between(Ellipsoid::WGS84.surface_normal(lon, lat));
        assert!(
            angle.to_degrees() < 1.0,
            "vertex {i}: {}°",
            angle.to_degrees()
        );
    }
}

#[test]
fn srtm_tile_header_bounds_what_cesium_draws() {
    // A 257² crop of N44W072 (White Mountains), every sample a vertex: the real-data header.
    let grid = n44w072_crop(300, 500, 257);
    let mesh = grid_mesh(257, 257, |r, c| *grid.get(r, c));
    let deg = |samples: f64| samples / 1200.0;
    let tile = TileGeo::geodetic(
        -72.0 + deg(500.0),
        45.0 - deg(556.0),
        -72.0 + deg(756.0),
        45.0 - deg(300.0),
    );
    let m = decode(&encode(&mesh, &tile, &QmOptions::default()).unwrap()).unwrap();
    let (lo, hi) = mesh.height_range().unwrap();
    assert_eq!(
        (
            f64::from(m.header.min_height),
            f64::from(m.header.max_height)
        ),
        (lo, hi)
    );

    let e = Ellipsoid::WGS84;
    let points: Vec<DVec3> = (0..m.vertex_count())
        .map(|i| ecef_of(&m, i, &tile))
        .collect();
    let c = DVec3::from_array(m.header.bounding_sphere_center);
    assert!(points
        .iter()
        .all(|p| p.distance(c) <= m.header.bounding_sphere_radius + 1e-6));
    // The crop is ~16.9 km × 23.7 km: the sphere's radius is about half its diagonal.
    assert!(
        (14_000.0..16_000.0).contains(&m.header.bounding_sphere_radius),
        "{}",
        m.header.bounding_sphere_radius
    );

    // Culled by the occlusion point ⇒ every vertex hidden, for cameras all round the Earth.
    let hop = DVec3::from_array(m.header.horizon_occlusion_point);
    let mut culled = 0;
    for lon in (-180..180).step_by(20) {
        for lat in (-80..=80).step_by(20) {
            for h in [500.0, 50_000.0, 5e6] {
                let cam = e.to_ecef(f64::from(lon), f64::from(lat), h);
                if !is_scaled_point_visible(&e, cam, hop) {
                    culled += 1;
                    assert!(points.iter().step_by(97).all(|&p| !is_scaled_point_visible(
                        &e,
                        cam,
                        e.to_scaled_space(p)
                    )));
                }
            }
        }
    }
    assert!(culled > 100);
}

#[test]
fn neighbour_tiles_agree_on_their_shared_edge_within_quantisation() {
    // Two geodetic zoom-10 tiles side by side, cut from one SRTM grid so that the west
    // tile's last column is the east tile's first.
    let tiling = Tiling::new(Scheme::Geodetic, 129).unwrap();
    let grid = n44w072_crop(300, 500, 257);
    let (west_id, east_id) = (TileId::new(10, 600, 700), TileId::new(10, 601, 700));
    let tiles = [(west_id, 0), (east_id, 128)].map(|(id, col0)| {
        let mesh = grid_mesh(129, 129, |r, c| *grid.get(r, col0 + c));
        let geo = tiling.tile_geo(id).unwrap();
        (
            decode(&encode(&mesh, &geo, &QmOptions::default()).unwrap()).unwrap(),
            geo,
        )
    });
    let [(w, wg), (e, eg)] = &tiles;
    assert_eq!(wg.east, eg.west);
    // Same vertices (u = 32767 against u = 0, equal v); heights differ only by each tile's
    // own quantisation step, half a step each at most.
    let half_steps =
        |m: &QuantizedMesh| f64::from(m.header.max_height - m.header.min_height) / 65_534.0;
    let tolerance = half_steps(w) + half_steps(e) + 1e-6;
    assert_eq!(w.east.len(), 129);
    for (&a, &b) in w.east.iter().zip(&e.west) {
        let (pa, pb) = (ecef_of(w, a as usize, wg), ecef_of(e, b as usize, eg));
        let [lon_a, lat_a, h_a] = w.lonlat_height(a as usize, wg).unwrap();
        let [lon_b, lat_b, h_b] = e.lonlat_height(b as usize, eg).unwrap();
        assert_eq!((lon_a, lat_a), (lon_b, lat_b));
        assert!((h_a - h_b).abs() <= tolerance, "{h_a} vs {h_b}");
        assert!(pa.distance(pb) <= tolerance);
    }
}

#[test]
fn hemisphere_tile_has_no_occlusion_point_and_is_never_culled() {
    // Level-0 geodetic tile 0/0/0 (lon −180..0): no finite point exists.
    let m = decode(
        &encode(
            &grid_mesh(5, 5, bumpy),
            &TileGeo::geodetic(-180.0, -90.0, 0.0, 90.0),
            &QmOptions::default(),
        )
        .unwrap(),
    )
    .unwrap();
    let hop = DVec3::from_array(m.header.horizon_occlusion_point);
    assert!(hop.is_nan());
    let e = Ellipsoid::WGS84;
    for lon in [-90.0, 0.0, 90.0, 180.0] {
        assert!(is_scaled_point_visible(&e, e.to_ecef(lon, 0.0, 1e4), hop));
    }
}

/// (file, vertices, triangles, west/south/east/north list lengths), counted with an
/// independent Python reader of the README's layout.
const SAMPLES: [(&str, usize, usize, [usize; 4]); 3] = [
    ("7_20_80.terrain", 2481, 4791, [0, 94, 0, 0]),
    ("7_20_81.terrain", 409, 681, [0, 0, 0, 91]),
    ("13_1311_5175.terrain", 2238, 4164, [0, 80, 105, 118]),
];

#[test]
fn real_tin_terrain_tiles_decode_with_their_counts() {
    let merc = Tiling::new(Scheme::Mercator, 257).unwrap();
    for (name, n, t, edges) in SAMPLES {
        let m = decode(&sample_tile(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((m.vertex_count(), m.triangles.len()), (n, t), "{name}");
        let lens = [m.west.len(), m.south.len(), m.east.len(), m.north.len()];
        assert_eq!(lens, edges, "{name}");
        assert!(
            m.normals.is_none() && m.water_mask.is_none() && m.metadata.is_none(),
            "{name}"
        );

        // Sane header: ordered heights, a real sphere.
        let h = m.header;
        assert!(
            h.min_height.is_finite() && h.min_height <= h.max_height,
            "{name}: {h:?}"
        );
        assert!(h.bounding_sphere_radius > 0.0, "{name}");
        // tin-terrain wrote EPSG:3857 metres (not ECEF) into the centre: it lies inside the
        // tile's mercator bounds once TMS y is flipped to XYZ (the data README says
        // "geodetic"; the numbers say Web Mercator).
        let mut parts = name
            .trim_end_matches(".terrain")
            .split('_')
            .map(|s| s.parse::<u32>().unwrap());
        let (z, x, y_tms) = (
            parts.next().unwrap() as u8,
            parts.next().unwrap(),
            parts.next().unwrap(),
        );
        let b = merc
            .tile_bounds(TileId::new(z, x, (1 << z) - 1 - y_tms))
            .unwrap();
        let [cx, cy, _] = h.center;
        assert!(
            (b.min_x..=b.max_x).contains(&cx) && (b.min_y..=b.max_y).contains(&cy),
            "{name}: {h:?} vs {b:?}"
        );

        // Every non-degenerate triangle is counter-clockwise in (u, v), as the README says.
        let areas: Vec<i64> = m.triangles.iter().map(|&tri| uv_area2(&m, tri)).collect();
        assert!(
            areas.iter().all(|&a| a >= 0),
            "{name}: a clockwise triangle"
        );
        assert!(areas.iter().filter(|&&a| a == 0).count() <= 2, "{name}");

        // Edge lists name border vertices (tin-terrain swaps its south and north lists and
        // leaves them unsorted; clients re-sort, so only membership is checked).
        for &i in m.west.iter().chain(&m.south).chain(&m.east).chain(&m.north) {
            let (u, v) = (m.u[i as usize], m.v[i as usize]);
            assert!(
                u == 0 || u == QUANTIZED_MAX || v == 0 || v == QUANTIZED_MAX,
                "{name}: vertex {i}"
            );
        }
    }
}

#[test]
fn real_neighbour_tiles_share_their_common_edge() {
    // 7/20/80 and 7/20/81 (TMS) are north–south neighbours: 80's north edge is 81's south.
    let south = decode(&sample_tile("7_20_80.terrain")).unwrap();
    let north = decode(&sample_tile("7_20_81.terrain")).unwrap();
    let edge = |m: &QuantizedMesh, v: u16| {
        let mut e: Vec<(u16, u64)> = (0..m.vertex_count())
            .filter(|&i| m.v[i] == v)
            .map(|i| (m.u[i], m.height_m(i).unwrap().to_bits()))
            .collect();
        e.sort_unstable();
        e.dedup();
        e
    };
    let (a, b) = (edge(&south, QUANTIZED_MAX), edge(&north, 0));
    assert_eq!(a.len(), 89);
    assert_eq!(a, b);
}

#[test]
fn re_encoding_a_real_tile_reproduces_its_vertex_and_index_bytes() {
    for (name, ..) in SAMPLES {
        let bytes = sample_tile(name);
        let m = decode(&bytes).unwrap();
        // The decoded tile as a mesh on a 32768² grid whose columns and rows are u and v.
        let positions = (0..m.vertex_count())
            .map(|i| {
                [
                    f64::from(m.u[i]),
                    f64::from(QUANTIZED_MAX - m.v[i]),
                    m.height_m(i).unwrap(),
                ]
            })
            .collect();
        let mesh = TerrainMesh {
            rows: 32_768,
            cols: 32_768,
            positions,
            triangles: m.triangles.clone(),
        };
        let again = encode(
            &mesh,
            &TileGeo::geodetic(0.0, 0.0, 1.0, 1.0),
            &QmOptions::default(),
        )
        .unwrap();
        // The file is in first-use order already, so vertices and indices come out identical.
        let end = 92 + 6 * m.vertex_count() + 4 + 6 * m.triangles.len();
        let full_range = m.height.contains(&0) && m.height.contains(&QUANTIZED_MAX);
        if full_range {
            assert_eq!(&again[88..end], &bytes[88..end], "{name}");
        } else {
            // A tile whose heights do not reach its header's range re-quantises them: compare
            // u, v and the index data only.
            let n = m.vertex_count();
            assert_eq!(&again[88..92 + 4 * n], &bytes[88..92 + 4 * n], "{name}");
            assert_eq!(&again[92 + 6 * n..end], &bytes[92 + 6 * n..end], "{name}");
        }
    }
}

#[test]
fn every_strict_prefix_of_a_real_tile_is_an_error() {
    let bytes = sample_tile("7_20_81.terrain");
    for cut in 0..bytes.len() {
        assert!(
            decode(&bytes[..cut]).is_err(),
            "prefix of {cut} bytes decoded"
        );
    }
}

#[test]
fn truncated_extensions_are_errors() {
    let mesh = grid_mesh(5, 5, bumpy);
    let bytes = encode(
        &mesh,
        &TileGeo::geodetic(0.0, 0.0, 1.0, 1.0),
        &all_extensions(),
    )
    .unwrap();
    let full = decode(&bytes).unwrap();
    let bare = encode(
        &mesh,
        &TileGeo::geodetic(0.0, 0.0, 1.0, 1.0),
        &QmOptions::default(),
    )
    .unwrap()
    .len();
    let mut valid = Vec::new();
    for cut in 0..bytes.len() {
        // A cut between extensions is a valid tile with fewer of them; any other is an error.
        if let Ok(m) = decode(&bytes[..cut]) {
            assert_eq!(
                (&m.u, &m.triangles, &m.north),
                (&full.u, &full.triangles, &full.north)
            );
            assert!(m.metadata.is_none(), "cut {cut}");
            valid.push(cut);
        }
    }
    // Exactly three cuts fall between extensions: after the bare tile and after each of the
    // first two of the three extensions.
    assert_eq!(valid.len(), 3, "valid cuts from {:?}", valid.first());
    assert_eq!(valid[0], bare);
}

/// xorshift64*: a fixed-seed byte mutator, so a failure replays.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
}

#[test]
fn mutated_bytes_never_panic() {
    let encoded = encode(
        &grid_mesh(9, 9, bumpy),
        &TileGeo::geodetic(0.0, 0.0, 1.0, 1.0),
        &all_extensions(),
    )
    .unwrap();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for original in [sample_tile("7_20_81.terrain"), encoded] {
        for _ in 0..3000 {
            let mut bytes = original.clone();
            for _ in 0..1 + rng.next() % 8 {
                let at = (rng.next() % bytes.len() as u64) as usize;
                bytes[at] = rng.next() as u8;
            }
            // Either outcome is fine; a panic fails the test.
            let _ = decode(&bytes);
        }
    }
}

/// A hand-built tile from the README: 3 vertices, 1 triangle, empty edge lists.
fn minimal_tile() -> Vec<u8> {
    let mut b = vec![0u8; 88];
    b.extend_from_slice(&3u32.to_le_bytes());
    // u: 0, 32767, 0 → deltas 0, +32767, −32767 → zig-zag 0, 65534, 65533.
    for code in [0u16, 65_534, 65_533, 0, 0, 65_534, 0, 0, 0] {
        b.extend_from_slice(&code.to_le_bytes());
    }
    b.extend_from_slice(&1u32.to_le_bytes());
    for code in [0u16, 0, 0] {
        b.extend_from_slice(&code.to_le_bytes());
    }
    for _ in 0..4 {
        b.extend_from_slice(&0u32.to_le_bytes());
    }
    b
}

#[test]
fn malformed_fields_are_named_errors() {
    let ok = minimal_tile();
    let m = decode(&ok).unwrap();
    assert_eq!(
        (m.u.clone(), m.v.clone(), m.triangles.clone()),
        (vec![0, 32767, 0], vec![0, 0, 32767], vec![[0, 1, 2]])
    );
    let tri_at = 92 + 18 + 4;

    // A vertex count no input could hold: refused before allocating.
    let mut b = ok.clone();
    b[88..92].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        decode(&b),
        Err(QmError::Truncated {
            what: "vertex count",
            ..
        })
    ));
    // A first delta of −1.
    let mut b = ok.clone();
    b[92..94].copy_from_slice(&1u16.to_le_bytes());
    assert!(matches!(decode(&b), Err(QmError::Malformed(m)) if m.contains("outside 0..=32767")));
    // A high-water-mark code above the mark.
    let mut b = ok.clone();
    b[tri_at + 2..tri_at + 4].copy_from_slice(&5u16.to_le_bytes());
    assert!(matches!(decode(&b), Err(QmError::Malformed(m)) if m.contains("high-water mark")));
    // A fourth new vertex in a 3-vertex tile.
    let mut b = ok.clone();
    b[tri_at - 4..tri_at].copy_from_slice(&2u32.to_le_bytes());
    b.splice(tri_at + 6..tri_at + 6, [0u8; 6]);
    // (Index 3, the first one past the end, not a later one.)
    assert!(
        matches!(decode(&b), Err(QmError::Malformed(m)) if m.contains("index 3 is past the 3 vertices"))
    );
    // An edge index past the vertices: 3 is the first; 2 is the last vertex.
    let edge = |index: u16| {
        let mut b = ok.clone();
        let west = tri_at + 6;
        b[west..west + 4].copy_from_slice(&1u32.to_le_bytes());
        b.splice(west + 4..west + 4, index.to_le_bytes());
        decode(&b)
    };
    assert!(matches!(edge(3), Err(QmError::Malformed(m)) if m.contains("west edge index 3")));
    assert_eq!(edge(2).unwrap().west, vec![2]);

    // Extensions: lengths, sizes, JSON, repeats, unknown ids.
    let with = |id: u8, data: &[u8]| {
        let mut b = ok.clone();
        b.push(id);
        b.extend_from_slice(&(data.len() as u32).to_le_bytes());
        b.extend_from_slice(data);
        b
    };
    let mut b = with(1, &[1, 2, 3, 4, 5, 6]);
    assert_eq!(
        decode(&b).unwrap().normals,
        Some(vec![[1, 2], [3, 4], [5, 6]])
    );
    b.truncate(b.len() - 1);
    assert!(matches!(
        decode(&b),
        Err(QmError::Truncated {
            what: "extension data",
            ..
        })
    ));
    assert!(matches!(
        decode(&with(1, &[1, 2])),
        Err(QmError::Malformed(_))
    ));
    assert!(matches!(
        decode(&with(2, &[0, 0])),
        Err(QmError::Malformed(_))
    ));
    assert_eq!(
        decode(&with(2, &[255])).unwrap().water_mask,
        Some(WaterMask::Uniform(255))
    );
    let json = br#"{"a":1}"#;
    let mut meta = (json.len() as u32).to_le_bytes().to_vec();
    meta.extend_from_slice(json);
    assert_eq!(
        decode(&with(4, &meta)).unwrap().metadata,
        Some(serde_json::json!({"a": 1}))
    );
    let mut bad_json = meta.clone();
    bad_json[5] = b'!';
    assert!(
        matches!(decode(&with(4, &bad_json)), Err(QmError::Malformed(m)) if m.contains("not JSON"))
    );
    let mut long_json = meta.clone();
    long_json[0] = 200;
    assert!(matches!(
        decode(&with(4, &long_json)),
        Err(QmError::Truncated {
            what: "metadata JSON",
            ..
        })
    ));
    let mut trailing = meta.clone();
    trailing.push(b' ');
    assert!(
        matches!(decode(&with(4, &trailing)), Err(QmError::Malformed(m)) if m.contains("after its JSON"))
    );
    // One normal too many is as wrong as one too few.
    assert!(
        matches!(decode(&with(1, &[0; 8])), Err(QmError::Malformed(m)) if m.contains("8 bytes for 3"))
    );
    // Each extension at most once.
    for (id, data) in [(1, &[0u8; 6][..]), (2, &[0]), (4, &meta)] {
        let mut twice = with(id, data);
        twice.push(id);
        twice.extend_from_slice(&(data.len() as u32).to_le_bytes());
        twice.extend_from_slice(data);
        assert!(
            matches!(decode(&twice), Err(QmError::Malformed(m)) if m.contains(&format!("extension {id} appears twice"))),
            "extension {id}"
        );
    }
    assert_eq!(
        decode(&with(9, &[1, 2, 3])).unwrap().unknown_extensions,
        vec![9]
    );
    let mut stub = ok.clone();
    stub.extend_from_slice(&[1, 0, 0]);
    assert!(matches!(
        decode(&stub),
        Err(QmError::Truncated {
            what: "extension length",
            ..
        })
    ));
}

/// `got` is an encoding when `ok`, else the refusal of parameter `name`; `case` says which.
fn accepted_or_refused_as(
    got: Result<Vec<u8>, QmError>,
    ok: bool,
    name: &str,
    case: &dyn std::fmt::Debug,
) {
    match (got, ok) {
        (Ok(_), true) => {}
        (Err(QmError::Parameter { name: refused, .. }), false) => assert_eq!(refused, name),
        (got, _) => panic!(
            "{case:?}: expected ok = {ok}, got {:?}",
            got.map(|b| b.len())
        ),
    }
}

/// Each rule of the encoder's contract, checked at its edge: the last value it accepts and
/// the first it refuses, and the refusal names the rule.
#[test]
fn encoder_checks_each_rule_of_the_contract_at_its_edge() {
    let tile = TileGeo::geodetic(0.0, 0.0, 1.0, 1.0);
    let o = QmOptions::default();
    let good = grid_mesh(3, 3, bumpy);
    let outcome = |r: Result<Vec<u8>, QmError>| r.map(|bytes| decode(&bytes).map(|m| m.u.len()));

    // Meshes: (what changes, the message's words, or None where the edit is still valid).
    type Edit = fn(&mut TerrainMesh);
    let cases: [(&str, Edit, Option<&str>); 16] = [
        (
            "no triangles",
            |m| m.triangles.clear(),
            Some("no triangles"),
        ),
        ("index n", |m| m.triangles[2][1] = 9, Some("points past")),
        ("index n - 1", |m| m.triangles[2][1] = 8, None),
        (
            "NaN height",
            |m| m.positions[4][2] = f64::NAN,
            Some("not finite"),
        ),
        (
            "infinite x",
            |m| m.positions[4][0] = f64::INFINITY,
            Some("not finite"),
        ),
        (
            "x past the east edge",
            |m| m.positions[4][0] = 2.5,
            Some("outside"),
        ),
        (
            "y past the south edge",
            |m| m.positions[4][1] = 2.5,
            Some("outside"),
        ),
        (
            "x before the west edge",
            |m| m.positions[4][0] = -0.5,
            Some("outside"),
        ),
        (
            "y before the north edge",
            |m| m.positions[4][1] = -0.5,
            Some("outside"),
        ),
        (
            "height past f32",
            |m| m.positions[4][2] = 1e39,
            Some("does not fit an f32"),
        ),
        (
            "depth past f32",
            |m| m.positions[4][2] = -1e39,
            Some("does not fit an f32"),
        ),
        (
            "height f32::MAX",
            |m| m.positions[4][2] = f64::from(f32::MAX),
            None,
        ),
        ("one row", |m| m.rows = 1, Some("no area")),
        ("one column", |m| m.cols = 1, Some("no area")),
        ("2 rows", |m| *m = grid_mesh(2, 3, bumpy), None),
        ("2 columns", |m| *m = grid_mesh(3, 2, bumpy), None),
    ];
    for (name, edit, refused) in cases {
        let mut m = good.clone();
        edit(&mut m);
        match (outcome(encode(&m, &tile, &o)), refused) {
            (Err(QmError::InvalidMesh(s)), Some(words)) => {
                assert!(s.contains(words), "{name}: {s:?} does not say {words:?}");
            }
            (Ok(Ok(n)), None) => assert_eq!(n, m.positions.len(), "{name}"),
            (got, _) => panic!("{name}: expected {refused:?}, got {got:?}"),
        }
    }

    // Tile bounds: finite, west < east, −90 ≤ south < north ≤ 90.
    let geodetic = TileGeo::geodetic;
    for (bounds, ok) in [
        (geodetic(0.0, -90.0, 1.0, 90.0), true),
        (geodetic(1.0, 0.0, 0.0, 1.0), false),
        (geodetic(1.0, 0.0, 1.0, 1.0), false),
        (geodetic(0.0, 1.0, 1.0, 0.0), false),
        (geodetic(0.0, 1.0, 1.0, 1.0), false),
        (geodetic(0.0, -90.5, 1.0, 1.0), false),
        (geodetic(0.0, 0.0, 1.0, 90.5), false),
        (geodetic(0.0, 90.0, 1.0, 91.0), false),
        (geodetic(f64::NAN, 0.0, 1.0, 1.0), false),
        (geodetic(0.0, f64::NAN, 1.0, 1.0), false),
        (geodetic(0.0, 0.0, f64::INFINITY, 1.0), false),
        (geodetic(0.0, 0.0, 1.0, f64::NAN), false),
    ] {
        accepted_or_refused_as(encode(&good, &bounds, &o), ok, "tile bounds", &bounds);
    }

    // Given normals: one finite vector per vertex.
    let opts = QmOptions {
        octvertexnormals: true,
        ..QmOptions::default()
    };
    let mut normals = vec![DVec3::Z; 9];
    assert!(encode_with_normals(&good, &tile, &opts, Some(&normals)).is_ok());
    for bad in [&normals[..8], &[DVec3::Z; 10][..]] {
        let err = encode_with_normals(&good, &tile, &opts, Some(bad)).unwrap_err();
        assert!(
            matches!(&err, QmError::InvalidMesh(s) if s.contains("normals")),
            "{err}"
        );
    }
    normals[3] = DVec3::new(0.0, f64::NAN, 1.0);
    let err = encode_with_normals(&good, &tile, &opts, Some(&normals)).unwrap_err();
    assert!(
        matches!(&err, QmError::InvalidMesh(s) if s.contains("finite")),
        "{err}"
    );

    // A water mask grid: 256 × 256 bytes exactly.
    for (len, ok) in [
        (65_536, true),
        (65_535, false),
        (65_537, false),
        (100, false),
    ] {
        let mask = QmOptions {
            watermask: Some(WaterMask::Grid(vec![0; len])),
            ..QmOptions::default()
        };
        accepted_or_refused_as(encode(&good, &tile, &mask), ok, "water mask grid", &len);
    }
}

#[test]
fn given_normals_follow_their_vertices_through_the_renumbering() {
    // grid_mesh's first triangle is (sw, se, ne) = (3, 4, 1): first-use order is not the
    // mesh's order, so each normal must be looked up by the vertex's original index.
    let mesh = grid_mesh(3, 3, bumpy);
    let given: Vec<DVec3> = (0..9)
        .map(|i| {
            DVec3::new((0.6 * f64::from(i)).cos(), (0.6 * f64::from(i)).sin(), 0.4).normalize()
        })
        .collect();
    let opts = QmOptions {
        octvertexnormals: true,
        ..QmOptions::default()
    };
    let tile = TileGeo::geodetic(0.0, 0.0, 1.0, 1.0);
    let m = decode(&encode_with_normals(&mesh, &tile, &opts, Some(&given)).unwrap()).unwrap();
    let normals = m.normals.as_ref().unwrap();
    assert_eq!(normals.len(), 9);
    let mut originals = Vec::new();
    for (k, &n) in normals.iter().enumerate() {
        // The original vertex at this (u, v): column u / 32767 · 2, row 2 − v / 32767 · 2.
        let c = (f64::from(m.u[k]) / 32767.0 * 2.0).round() as usize;
        let r = 2 - (f64::from(m.v[k]) / 32767.0 * 2.0).round() as usize;
        originals.push(r * 3 + c);
        let want = given[r * 3 + c];
        let angle = oct_decode(n).angle_between(want).to_degrees();
        // Oct encoding in 8 bits per axis is within a degree; neighbours differ by 34°.
        assert!(angle < 1.0, "vertex {k} (row {r}, col {c}): {angle}°");
    }
    assert_ne!(
        originals,
        (0..9).collect::<Vec<_>>(),
        "renumbering is the identity"
    );
}

mod grid_normals {
    use super::*;
    use crate::bintree::{Hierarchy, TileErrors};
    use crate::tile::{stitched_mesh, Neighbourhood, TileView};
    use crate::Grid;

    /// A tile with no neighbour on any side.
    fn alone(center: TileView<'_>) -> Neighbourhood<'_> {
        Neighbourhood {
            center,
            north: None,
            south: None,
            west: None,
            east: None,
            corners: None,
        }
    }

    /// A flat grid's normals are the ellipsoid's, on a mercator tile too (rows not evenly
    /// spaced in latitude).
    #[test]
    fn a_flat_grid_has_the_ellipsoid_normal() {
        let n = 17;
        let h = Hierarchy::new(n).unwrap();
        let g = crate::Grid::new(n, n, vec![250.0; n * n]).unwrap();
        let errors = TileErrors::new(&h, &g);
        let hood = alone(TileView {
            heights: &g,
            errors: &errors,
        });
        let mesh = grid_mesh(n, n, |_, _| 250.0);
        let tiling = Tiling::new(Scheme::Mercator, 257).unwrap();
        for tile in [
            TileGeo::geodetic(30.0, 60.0, 30.1, 60.1),
            tiling.tile_geo(TileId::new(6, 20, 30)).unwrap(),
        ] {
            for (i, v) in grid_normals(&tile, &hood, &Diagonals::default(), &mesh)
                .iter()
                .enumerate()
            {
                let [x, y, _] = mesh.positions[i];
                let lon = tile.west + x / 16.0 * (tile.east - tile.west);
                let lat = tile.latitude_at(y / 16.0);
                let up = Ellipsoid::WGS84.surface_normal(lon, lat);
                // On the border the difference is one-sided: the chords' normal is that of
                // the point half a sample away (along both axes at a corner).
                let half =
                    0.5 * (tile.east - tile.west).max(tile.north - tile.south) / 16.0 * 2f64.sqrt();
                let angle = v.angle_between(up).to_degrees();
                assert!(angle <= half, "vertex {i}: {angle}° off, {half}° allowed");
            }
        }
    }

    /// On a geodetic root tile the north row is the pole: whatever its heights scatter,
    /// its vertices get the pole's normal, not one tipped sideways by the scatter.
    #[test]
    fn the_pole_row_points_up() {
        let n = 17;
        let h = Hierarchy::new(n).unwrap();
        let g = crate::Grid::new(n, n, (0..n * n).map(|k| (k % 7) as f64).collect()).unwrap();
        let errors = TileErrors::new(&h, &g);
        let hood = alone(TileView {
            heights: &g,
            errors: &errors,
        });
        let mesh = grid_mesh(n, n, |r, c| *g.get(r, c));
        let tile = TileGeo::geodetic(0.0, -90.0, 180.0, 90.0);
        let normals = grid_normals(&tile, &hood, &Diagonals::default(), &mesh);
        for (i, v) in normals
            .iter()
            .enumerate()
            .filter(|(i, _)| mesh.positions[*i][1] == 0.0)
        {
            assert!(
                v.angle_between(DVec3::Z).to_degrees() < 1e-6,
                "vertex {i}: {v}"
            );
        }
    }

    /// The guard on the grid's shape, from both sides: a 1×1 or a non-square centre gets
    /// +Z for every vertex, and a 2×2 one, the smallest with a difference each way, its
    /// slope's normal (heights rising 1000 m a sample eastwards, ~5.6 km at 60° N: the
    /// normal leans ~10° west of the ellipsoid's; +Z would be 30° off).
    #[test]
    fn only_degenerate_grids_fall_back_to_z() {
        let h = Hierarchy::new(3).unwrap();
        let errors = TileErrors::new(&h, &Grid::new(3, 3, vec![0.0; 9]).unwrap());
        let tile = TileGeo::geodetic(30.0, 60.0, 30.1, 60.1);
        let mesh = grid_mesh(2, 2, |_, _| 0.0);
        let normals = |g: &Grid<f64>| {
            let hood = alone(TileView {
                heights: g,
                errors: &errors,
            });
            grid_normals(&tile, &hood, &Diagonals::default(), &mesh)
        };
        for (rows, cols) in [(1, 1), (2, 3), (3, 2)] {
            let g = Grid::new(rows, cols, vec![5.0; rows * cols]).unwrap();
            assert_eq!(normals(&g), vec![DVec3::Z; 4], "{rows}×{cols}");
        }
        // Heights rising 1000 m a sample east (~5.6 km: ~10°) or north (row 0 is north,
        // ~11.1 km: ~5°): the normal leans away from the rise, by the slope's angle.
        let east = |lon: f64, _: f64| DVec3::new(-lon.sin(), lon.cos(), 0.0);
        let north = |lon: f64, lat: f64| {
            DVec3::new(-lat.sin() * lon.cos(), -lat.sin() * lon.sin(), lat.cos())
        };
        let slopes = [
            (
                [0.0, 1000.0, 0.0, 1000.0],
                east as fn(f64, f64) -> DVec3,
                8.0..12.0,
                "east",
            ),
            ([1000.0, 1000.0, 0.0, 0.0], north, 4.0..6.5, "north"),
        ];
        for (heights, rise, angles, towards) in slopes {
            let sloped = Grid::new(2, 2, heights.to_vec()).unwrap();
            for (i, v) in normals(&sloped).into_iter().enumerate() {
                let [x, y, _] = mesh.positions[i];
                let (lon, lat) = (30.0 + 0.1 * x, 60.1 - 0.1 * y);
                let up = Ellipsoid::WGS84.surface_normal(lon, lat);
                let angle = v.angle_between(up).to_degrees();
                assert!(
                    angles.contains(&angle),
                    "{towards}, vertex {i}: {angle}° off up"
                );
                let rise = rise(lon.to_radians(), lat.to_radians());
                assert!(v.dot(rise) < 0.0, "vertex {i} leans {towards}: {v}");
            }
        }
    }

    /// A non-finite height (a hole no fill reached) gives the four vertices whose stencils
    /// read it the ellipsoid's normal, never a NaN one, and leaves every other normal as it
    /// was, the hole's own too (its stencil reads only its neighbours).
    #[test]
    fn a_nan_height_gives_its_stencil_the_ellipsoid_normal() {
        let n = 17;
        let h = Hierarchy::new(n).unwrap();
        let g = n44w072_crop(300, 500, n);
        let mut holed = g.clone();
        let (hr, hc) = (6usize, 9usize);
        *holed.get_mut(hr, hc) = f64::NAN;
        let errors = TileErrors::new(&h, &g);
        let tile = TileGeo::geodetic(-72.0, 44.0, -71.99, 44.01);
        let mesh = grid_mesh(n, n, |r, c| *g.get(r, c));
        let normals = |g: &Grid<f64>| {
            let hood = alone(TileView {
                heights: g,
                errors: &errors,
            });
            grid_normals(&tile, &hood, &Diagonals::default(), &mesh)
        };
        let (plain, with_hole) = (normals(&g), normals(&holed));
        for (i, (p, q)) in plain.iter().zip(&with_hole).enumerate() {
            let [x, y, _] = mesh.positions[i];
            let (r, c) = (y as usize, x as usize);
            if r.abs_diff(hr) + c.abs_diff(hc) == 1 {
                let lon = tile.west + x / 16.0 * (tile.east - tile.west);
                let up = Ellipsoid::WGS84.surface_normal(lon, tile.latitude_at(y / 16.0));
                assert!((*q - up).length() < 1e-9, "({r}, {c}): {q} against up {up}");
                assert!(p.angle_between(up) > 1e-4, "({r}, {c}) was flat already");
            } else {
                assert_eq!(p, q, "({r}, {c})");
            }
        }
    }

    /// Two real tiles side by side, each meshed with the other as its east or west
    /// neighbour: every shared edge vertex gets the same normal from both (the corners
    /// aside: their samples past the corner lie in the diagonal tiles, which this test does
    /// not hand over; see the 3×3 test below).
    #[test]
    fn neighbours_give_a_shared_edge_the_same_normals() {
        let n = 17;
        let h = Hierarchy::new(n).unwrap();
        let (ga, gb) = (n44w072_crop(700, 700, n), n44w072_crop(700, 716, n));
        let (ea, eb) = (TileErrors::new(&h, &ga), TileErrors::new(&h, &gb));
        let view = |g, e| TileView {
            heights: g,
            errors: e,
        };
        let a = Neighbourhood {
            east: Some(view(&gb, &eb)),
            ..alone(view(&ga, &ea))
        };
        let b = Neighbourhood {
            west: Some(view(&ga, &ea)),
            ..alone(view(&gb, &eb))
        };
        let step = 16.0 / 1200.0;
        let tile_a = TileGeo::geodetic(
            -72.0 + 700.0 / 1200.0,
            44.0,
            -72.0 + 716.0 / 1200.0,
            44.0 + step,
        );
        let tile_b = TileGeo::geodetic(tile_a.east, 44.0, tile_a.east + step, 44.0 + step);
        let (ma, mb) = (
            stitched_mesh(&h, &a, 4.0).unwrap(),
            stitched_mesh(&h, &b, 4.0).unwrap(),
        );
        let (na, nb) = (
            grid_normals(&tile_a, &a, &Diagonals::default(), &ma),
            grid_normals(&tile_b, &b, &Diagonals::default(), &mb),
        );
        let edge = |m: &TerrainMesh, normals: &[DVec3], x: f64| -> Vec<(u64, DVec3)> {
            let mut v: Vec<(u64, DVec3)> = m
                .positions
                .iter()
                .zip(normals)
                .filter(|(p, _)| p[0] == x && p[1] > 0.0 && p[1] < 16.0)
                .map(|(p, &nv)| (p[1] as u64, nv))
                .collect();
            v.sort_by_key(|e| e.0);
            v
        };
        let (ra, rb) = (edge(&ma, &na, 16.0), edge(&mb, &nb, 0.0));
        assert!(ra.len() >= 2, "{ra:?}");
        assert_eq!(ra.len(), rb.len());
        for ((ya, va), (yb, vb)) in ra.iter().zip(&rb) {
            assert_eq!(ya, yb);
            assert!(va.angle_between(*vb) < 1e-9, "row {ya}: {va} vs {vb}");
        }
        // And the triangles' own normals, which the tiles used before, do not agree there.
        let facets = |m: &TerrainMesh, tile: &TileGeo| {
            let opts = QmOptions {
                octvertexnormals: true,
                ..QmOptions::default()
            };
            decode(&encode(m, tile, &opts).unwrap()).unwrap()
        };
        let (da, db) = (facets(&ma, &tile_a), facets(&mb, &tile_b));
        let worst = (0..da.u.len())
            .filter(|&i| da.u[i] == 32767 && da.v[i] != 0 && da.v[i] != 32767)
            .filter_map(|i| {
                let j = (0..db.u.len()).find(|&j| db.u[j] == 0 && db.v[j] == da.v[i])?;
                let (p, q) = (da.normals.as_ref()?[i], db.normals.as_ref()?[j]);
                Some(oct_decode(p).angle_between(oct_decode(q)).to_degrees())
            })
            .fold(0.0, f64::max);
        assert!(
            worst > 2.0,
            "facet normals agreed anyway ({worst}°): the test shows nothing"
        );
    }

    /// A 3×3 block of real tiles, each decoded with its own error (a different ripple on
    /// every tile, shared samples included), each meshed with every neighbour it has: the
    /// four tiles at each corner of the middle one give that corner one normal when they
    /// are handed their diagonal neighbours, and not without.
    #[test]
    fn the_four_tiles_at_a_corner_agree_on_its_normal_given_their_diagonals() {
        let n = 17;
        let last = n - 1;
        let h = Hierarchy::new(n).unwrap();
        let step = 16.0 / 1200.0;
        let raw: Vec<Vec<Grid<f64>>> = (0..3)
            .map(|i| {
                (0..3)
                    .map(|j| n44w072_crop(700 + 16 * i, 700 + 16 * j, n))
                    .collect()
            })
            .collect();
        let decoded: Vec<Vec<Grid<f64>>> = (0..3)
            .map(|i| {
                (0..3)
                    .map(|j| {
                        let mut g = raw[i][j].clone();
                        let seed = (3 * i + j) as f64 * 1.7;
                        for r in 0..n {
                            for c in 0..n {
                                *g.get_mut(r, c) +=
                                    0.4 * (seed + 0.37 * r as f64 + 0.91 * c as f64).sin();
                            }
                        }
                        g
                    })
                    .collect()
            })
            .collect();
        let errors: Vec<Vec<TileErrors>> = decoded
            .iter()
            .map(|row| row.iter().map(|g| TileErrors::new(&h, g)).collect())
            .collect();
        let view = |i: isize, j: isize| -> Option<TileView<'_>> {
            let (i, j) = (usize::try_from(i).ok()?, usize::try_from(j).ok()?);
            Some(TileView {
                heights: decoded.get(i)?.get(j)?,
                errors: &errors[i][j],
            })
        };
        // Per tile (row i from the north, column j), the normal at each of its corners:
        // NW, NE, SW, SE.
        let corner_normals = |i: usize, j: usize, with_diagonals: bool| -> [DVec3; 4] {
            let (si, sj) = (i as isize, j as isize);
            let g = &raw[i][j];
            let hood = Neighbourhood {
                center: view(si, sj).unwrap(),
                north: view(si - 1, sj),
                south: view(si + 1, sj),
                west: view(si, sj - 1),
                east: view(si, sj + 1),
                corners: Some([
                    *g.get(0, 0),
                    *g.get(0, last),
                    *g.get(last, 0),
                    *g.get(last, last),
                ]),
            };
            let diagonals = if with_diagonals {
                Diagonals {
                    nw: view(si - 1, sj - 1),
                    ne: view(si - 1, sj + 1),
                    sw: view(si + 1, sj - 1),
                    se: view(si + 1, sj + 1),
                }
            } else {
                Diagonals::default()
            };
            let west = -72.0 + (700 + 16 * j) as f64 / 1200.0;
            let north = 45.0 - (700 + 16 * i) as f64 / 1200.0;
            let tile = TileGeo::geodetic(west, north - step, west + step, north);
            let mesh = stitched_mesh(&h, &hood, 4.0).unwrap();
            let normals = grid_normals(&tile, &hood, &diagonals, &mesh);
            let l = last as f64;
            [(0.0, 0.0), (l, 0.0), (0.0, l), (l, l)].map(|(x, y)| {
                let k = mesh
                    .positions
                    .iter()
                    .position(|p| p[0] == x && p[1] == y)
                    .expect("a tile corner is a mesh vertex");
                normals[k]
            })
        };
        let spread = |with_diagonals: bool| -> f64 {
            let all: Vec<Vec<[DVec3; 4]>> = (0..3)
                .map(|i| {
                    (0..3)
                        .map(|j| corner_normals(i, j, with_diagonals))
                        .collect()
                })
                .collect();
            // The middle tile's corners, each seen from the four tiles around it (as their
            // SE, SW, NE and NW corners).
            let mut worst: f64 = 0.0;
            for (ci, cj) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let seen = [
                    all[ci][cj][3],
                    all[ci][cj + 1][2],
                    all[ci + 1][cj][1],
                    all[ci + 1][cj + 1][0],
                ];
                // Unit vectors: their difference is the angle (acos near 1 cannot resolve
                // below 1.5e-8).
                for v in &seen[1..] {
                    worst = worst.max((seen[0] - *v).length());
                }
            }
            worst
        };
        let with = spread(true);
        // Each tile places the samples from its own bounds: ECEF agrees to ~1e-11 relative.
        assert!(with < 1e-9, "corner normals differ by {with} rad");
        let without = spread(false);
        eprintln!("corner normal spread: {with:e} rad with diagonals, {without:e} without");
        assert!(
            without > 1e-4,
            "without diagonals the corners agree anyway ({without} rad): the test shows nothing"
        );
    }
}
