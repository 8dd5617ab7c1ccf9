//! The DEFLATE a cold tile pays for, on the three real 257² tiles `terrain_mesh.py` meshes:
//! a terrain-RGB PNG resampled to 512² at each `PngCompression` effort, and gzip (level 6, as
//! the server sends `.terrain` to Cesium) of a quantized-mesh body meshed within 4 and 16 m.
//! Which DEFLATE backend runs is the workspace's flate2 feature (zlib-rs); building this bench
//! with flate2's default backend instead is the peer to compare it with. The bytes each case
//! writes are printed once before the timings, since the backends trade speed for size.
#![allow(
    clippy::expect_used,
    reason = "a bench without its data file should stop loudly"
)]

mod common;

use std::io::Write;

use common::{decode_and_mesh_at, terrain_mesh_tiles};
use criterion::{criterion_group, criterion_main, Criterion};
use zerotile_codec::bintree::{Hierarchy, DECODE_SHARE};
use zerotile_codec::ezw::{self, EncodeParams};
use zerotile_codec::formats::quantized_mesh::{self, QmOptions};
use zerotile_codec::formats::terrain_rgb::{self, PngCompression, RgbOptions};
use zerotile_codec::geo::tiling::TileGeo;
use zerotile_codec::raster::Encoding;
use zerotile_codec::wavelet::Wavelet;

fn gzip(raw: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(
        Vec::with_capacity(raw.len() / 2),
        flate2::Compression::default(),
    );
    enc.write_all(raw).expect("writing to a Vec");
    enc.finish().expect("writing to a Vec")
}

fn deflate(c: &mut Criterion) {
    let tiles = terrain_mesh_tiles();
    let hierarchy = Hierarchy::new(257).expect("257 = 2^8 + 1");

    // 512² grids, as the server resamples a tile for MapLibre.
    let grids: Vec<_> = tiles
        .iter()
        .map(|(_, h, _)| terrain_rgb::resample(h, 512).expect("resample"))
        .collect();
    let mut group = c.benchmark_group("terrain_rgb_512_three_tiles");
    group.sample_size(10);
    for effort in [
        PngCompression::Fast,
        PngCompression::Balanced,
        PngCompression::Best,
    ] {
        let opts = RgbOptions {
            compression: effort,
            ..RgbOptions::new(Encoding::TerrainRgb)
        };
        let encode_all = || {
            grids
                .iter()
                .map(|g| terrain_rgb::encode(g, &opts).expect("encode").len())
                .sum::<usize>()
        };
        eprintln!("terrain_rgb {effort:?}: {} bytes", encode_all());
        group.bench_function(format!("{effort:?}"), |b| b.iter(encode_all));
    }
    group.finish();

    let tile = TileGeo::geodetic(-72.0, 44.0, -71.75, 44.25);
    let mut group = c.benchmark_group("quantized_mesh_gzip_three_tiles");
    for budget in [4.0, 16.0] {
        let bodies: Vec<Vec<u8>> = tiles
            .iter()
            .map(|(_, heights, step)| {
                let stream = ezw::encode(heights, &EncodeParams::new(Wavelet::Cdf97, *step))
                    .expect("encode");
                let mesh = decode_and_mesh_at(&stream.bytes, &hierarchy, budget, DECODE_SHARE);
                quantized_mesh::encode(&mesh, &tile, &QmOptions::default()).expect("qm")
            })
            .collect();
        let raw: usize = bodies.iter().map(Vec::len).sum();
        let gzip_all = || bodies.iter().map(|b| gzip(b).len()).sum::<usize>();
        eprintln!(
            "quantized-mesh T = {budget} m: {raw} bytes, gzipped {}",
            gzip_all()
        );
        group.bench_function(format!("gzip6_T{budget}"), |b| b.iter(gzip_all));
    }
    group.finish();
}

criterion_group!(benches, deflate);
criterion_main!(benches);
