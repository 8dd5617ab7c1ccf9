//! What raising a tile's heights to the ellipsoid (EGM96, `geo::geoid`) adds to a
//! quantized-mesh request, on a real 257² tile (N44W072, T = 4 m and 16 m, a zoom-10
//! geodetic tile's 0.176° box). The peers in the same run are the request's own parts:
//! decode + mesh, and the quantized-mesh encoding. Also what a place's first tile pays to
//! evaluate its lattice nodes (`patch_cold`), and why a tile fetches its nodes once
//! (`shared_nodes`: each vertex on its own, a lock on the process's node cache per node read).
#![allow(
    clippy::expect_used,
    reason = "a bench without its data file should stop loudly"
)]

mod common;

use std::time::{Duration, Instant};

use common::decode_and_mesh_at;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use zerotile_codec::bintree::{Hierarchy, DECODE_SHARE};
use zerotile_codec::formats::quantized_mesh::{self, QmOptions};
use zerotile_codec::geo::geoid::{self, lattice_for, undulation_exact};
use zerotile_codec::geo::TileGeo;
use zerotile_codec::zerotree::TerrainMesh;

/// A zoom-10 geodetic tile's box over N44W072.
const WEST: f64 = -71.71875;
const SOUTH: f64 = 44.296_875;
const SPAN: f64 = 0.175_781_25;

/// Each vertex's longitude and latitude over `tile`, as the server computes them.
fn places(mesh: &TerrainMesh, tile: &TileGeo) -> Vec<(f64, f64)> {
    let last = (mesh.cols - 1) as f64;
    mesh.positions
        .iter()
        .map(|&[c, r, _]| {
            let t = c / last;
            (
                tile.west * (1.0 - t) + tile.east * t,
                tile.latitude_at(r / last),
            )
        })
        .collect()
}

fn geoid(c: &mut Criterion) {
    let hierarchy = Hierarchy::new(257).expect("257 = 2^8 + 1");
    let (_, _, bytes) = common::terrain_mesh_streams()
        .into_iter()
        .next()
        .expect("N44W072 9/7");
    let tile = TileGeo::geodetic(WEST, SOUTH, WEST + SPAN, SOUTH + SPAN);
    let lattice = lattice_for(SPAN);
    let opts = QmOptions::default();
    let mut group = c.benchmark_group("geoid_257");
    for budget in [4.0, 16.0] {
        let mesh = decode_and_mesh_at(&bytes, &hierarchy, budget, DECODE_SHARE);
        let at = places(&mesh, &tile);
        let label = format!("T={budget},{}v", mesh.positions.len());
        group.bench_function(BenchmarkId::new("raise", &label), |b| {
            b.iter(|| {
                let patch = lattice.patch(tile.west, tile.south, tile.east, tile.north);
                let mut raised = mesh.clone();
                geoid::raise(&mut raised, &tile, &patch);
                raised
            })
        });
        // Each vertex on its own through the shared nodes: what `raise` saves.
        group.bench_with_input(BenchmarkId::new("shared_nodes", &label), &at, |b, at| {
            b.iter(|| {
                at.iter()
                    .map(|&(lon, lat)| lattice.undulation(lon, lat))
                    .sum::<f64>()
            })
        });
        group.bench_function(BenchmarkId::new("decode_and_mesh", &label), |b| {
            b.iter(|| decode_and_mesh_at(&bytes, &hierarchy, budget, DECODE_SHARE))
        });
        group.bench_function(BenchmarkId::new("qm_encode", &label), |b| {
            b.iter(|| quantized_mesh::encode(&mesh, &tile, &opts).expect("encode"))
        });
    }
    // A first tile somewhere new: every node of its patch evaluated. Each iteration takes a
    // box 1.1° from any before it, so no node is cached yet.
    let mut fresh = 0u32;
    group.sample_size(10);
    group.bench_function("patch_cold_z10", |b| {
        b.iter_custom(|iters| {
            let mut spent = Duration::ZERO;
            for _ in 0..iters {
                let (k, row) = (f64::from(fresh % 300), f64::from(fresh / 300 % 100));
                fresh += 1;
                let (w, s) = (-179.0 + 1.1 * k, -55.0 + 1.1 * row);
                let t = Instant::now();
                let patch = lattice.patch(w, s, w + SPAN, s + SPAN);
                spent += t.elapsed();
                std::hint::black_box(patch);
            }
            spent
        })
    });
    group.bench_function("undulation_exact", |b| {
        b.iter(|| undulation_exact(std::hint::black_box(-71.63), 44.41))
    });
    group.finish();
}

criterion_group!(benches, geoid);
criterion_main!(benches);
