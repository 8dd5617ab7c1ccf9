//! Per-request work on real 257² tiles (N44W072 rows 300.., cols 500..; for
//! `decode_and_mesh_257` also fuji and jacksboro, terrain_mesh.py's other two): decode the EZW
//! stream for an error budget T (to T/8, as `eval terrain` does; heights only, as the
//! server decodes) and mesh it with the
//! exact-error bintree within the rest of the budget, 7T/8, as the server does. The peer, Martini's createTile +
//! getMesh on the same tile, runs in `../shared/bench/terrain_mesh.py` (pymartini and
//! @mapbox/martini); compare its medians with these.

#![allow(
    clippy::expect_used,
    reason = "a bench without its data file should stop loudly"
)]

mod common;

use common::decode_and_mesh_at;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use zerotile_codec::bintree::{self, Hierarchy, TileErrors, DECODE_SHARE};
use zerotile_codec::ezw::{self, EncodeParams};
use zerotile_codec::formats::quantized_mesh::{self, QmOptions};
use zerotile_codec::geo::TileGeo;
use zerotile_codec::tile::{Neighbourhood, TileView};
use zerotile_codec::wavelet::Wavelet;

fn decode_and_mesh(c: &mut Criterion) {
    let g = common::n44w072_tile(257);
    let hierarchy = Hierarchy::new(257).expect("257 = 2^8 + 1");
    let mut group = c.benchmark_group("decode_and_mesh_257");
    // N44W072 under the wavelet's name alone (the figures quoted since stop 9), the other
    // two tiles of terrain_mesh.py as TILE-wavelet: one tile is no speed figure.
    for (tile, wavelet, bytes) in common::terrain_mesh_streams() {
        let name = match tile {
            "N44W072" => wavelet.name().to_string(),
            _ => format!("{tile}-{}", wavelet.name()),
        };
        for budget in common::BUDGETS {
            let id = BenchmarkId::new(&name, format!("T={budget}"));
            group.bench_with_input(id, &budget, |b, &budget| {
                b.iter(|| decode_and_mesh_at(&bytes, &hierarchy, budget, DECODE_SHARE))
            });
        }
    }
    group.finish();

    // The server's split of the budget (read to T·share, mesh within T·(1 − share)) at the
    // shipped share and the next larger one: what a larger share saves in decode time, to set
    // against the triangles it costs (docs/terrain-mesh.md).
    let mut group = c.benchmark_group("decode_share_257");
    let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).expect("encode");
    for share in [DECODE_SHARE, 2.0 * DECODE_SHARE] {
        for budget in common::BUDGETS {
            let id = BenchmarkId::new(format!("share={share}"), format!("T={budget}"));
            group.bench_with_input(id, &budget, |b, &budget| {
                b.iter(|| decode_and_mesh_at(&enc.bytes, &hierarchy, budget, share))
            });
        }
    }
    group.finish();

    // The parts, so a regression says where it is.
    let mut group = c.benchmark_group("parts_257");
    group.bench_function("hierarchy_new", |b| b.iter(|| Hierarchy::new(257)));
    group.bench_function("tile_errors", |b| {
        b.iter(|| TileErrors::new(&hierarchy, &g))
    });
    for floor in [3.0, 12.0, 48.0] {
        group.bench_function(format!("tile_errors_above_{floor}"), |b| {
            b.iter(|| TileErrors::exact_above(&hierarchy, &g, floor))
        });
    }
    let errors = TileErrors::new(&hierarchy, &g);
    for tolerance in [2.0, 16.0] {
        group.bench_function(format!("extract_tol_{tolerance}"), |b| {
            b.iter(|| bintree::extract(&hierarchy, &errors, &g, tolerance, None))
        });
    }
    // Quantized-mesh normals for a tile with all four neighbours (the tile itself stands in
    // for them: the cost does not depend on their heights), against the triangles' own.
    let tile = TileGeo::geodetic(-71.6, 44.0, -71.4, 44.2);
    let view = TileView {
        heights: &g,
        errors: &errors,
    };
    let hood = Neighbourhood {
        center: view,
        north: Some(view),
        south: Some(view),
        west: Some(view),
        east: Some(view),
        corners: None,
    };
    let opts = QmOptions {
        octvertexnormals: true,
        ..QmOptions::default()
    };
    for tolerance in [2.0, 16.0] {
        let mesh = bintree::extract(&hierarchy, &errors, &g, tolerance, None);
        group.bench_function(format!("qm_grid_normals_tol_{tolerance}"), |b| {
            b.iter(|| {
                let normals = quantized_mesh::grid_normals(
                    &tile,
                    &hood,
                    &quantized_mesh::Diagonals::default(),
                    &mesh,
                );
                quantized_mesh::encode_with_normals(&mesh, &tile, &opts, Some(&normals))
            })
        });
        group.bench_function(format!("qm_facet_normals_tol_{tolerance}"), |b| {
            b.iter(|| quantized_mesh::encode(&mesh, &tile, &opts))
        });
    }
    group.finish();
}

criterion_group!(benches, decode_and_mesh);
criterion_main!(benches);
