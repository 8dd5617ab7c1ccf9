//! The EZW coder on real tiles: decoding a 257² N44W072 tile to a threshold (the per-request
//! work a tile server does before meshing), encoding it, and the max-error encode (residual
//! cut search) on the 512² terrain-RGB Fuji tile and the 257² tile.
//!
//! The peer in the same run is the inverse 9/7 / 5/3 transform alone on the same tile: every
//! decode ends with one, so it is the floor the bit-plane passes add to.
#![allow(
    clippy::expect_used,
    reason = "a bench without its data file should stop loudly"
)]

mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use zerotile_codec::ezw::{self, DecodeLimit, EncodeParams};
use zerotile_codec::raster::{self, Encoding, ReadOptions};
use zerotile_codec::wavelet::{self, Layout, Wavelet};
use zerotile_codec::Grid;

const SIDE: usize = 257;
/// Decode thresholds (height units, metres): fine to coarse.
const THRESHOLDS: [f64; 4] = [0.5, 2.0, 8.0, 32.0];

/// fuji.png: 512² Mapbox terrain-RGB (0.1 m steps), what `terrain_codec.py` codes too.
fn fuji() -> (Grid<f64>, f64) {
    let opts = ReadOptions {
        encoding: Some(Encoding::TerrainRgb),
        ..ReadOptions::default()
    };
    let map = raster::read_heightmap(common::shared("dem/fuji.png"), &opts).expect("fuji.png");
    (map.heights, map.step.expect("terrain-RGB has a step"))
}

fn decode(c: &mut Criterion) {
    let g = common::n44w072_tile(SIDE);
    let mut group = c.benchmark_group("ezw_decode_to_T_257");
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        let enc = ezw::encode(&g, &EncodeParams::new(wavelet, 1.0)).expect("encode");
        for t in THRESHOLDS {
            let id = BenchmarkId::new(wavelet.name(), format!("T={t}"));
            group.bench_with_input(id, &t, |b, &t| {
                b.iter(|| {
                    ezw::decode(
                        &enc.bytes,
                        DecodeLimit::Threshold(t),
                        ezw::DEFAULT_MAX_SAMPLES,
                    )
                    .expect("decode")
                })
            });
        }
    }
    // The peer: the inverse transform every decode ends with.
    let layout = Layout::full(SIDE, SIDE);
    let mut coefficients = g.clone();
    wavelet::forward(&mut coefficients, Wavelet::Cdf97, &layout);
    group.bench_function("peer/inverse_cdf97_only", |b| {
        b.iter(|| {
            let mut c = coefficients.clone();
            wavelet::inverse(&mut c, Wavelet::Cdf97, &layout);
            c
        })
    });
    let mut integers = g.map(|&h| h as i32);
    wavelet::forward_int53(&mut integers, &layout);
    group.bench_function("peer/inverse_int53_only", |b| {
        b.iter(|| {
            let mut c = integers.clone();
            wavelet::inverse_int53(&mut c, &layout);
            c
        })
    });
    group.finish();
}

fn encode(c: &mut Criterion) {
    let g = common::n44w072_tile(SIDE);
    let mut group = c.benchmark_group("ezw_encode_257");
    group.sample_size(20);
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        group.bench_function(wavelet.name(), |b| {
            b.iter(|| ezw::encode(&g, &EncodeParams::new(wavelet, 1.0)).expect("encode"))
        });
    }
    group.finish();

    // Max-error mode searches the cut between wavelet prefix and residual pass.
    let mut group = c.benchmark_group("ezw_encode_max_error");
    group.sample_size(10);
    let (fuji, step) = fuji();
    for (name, heights, step, e) in [
        ("fuji_512_E=1", &fuji, step, 1.0),
        ("n44w072_257_E=2", &g, 1.0, 2.0),
    ] {
        let params = EncodeParams {
            max_error: Some(e),
            ..EncodeParams::new(Wavelet::Cdf97, step)
        };
        group.bench_function(name, |b| {
            b.iter(|| ezw::encode(heights, &params).expect("encode"))
        });
    }
    group.finish();
}

criterion_group!(benches, decode, encode);
criterion_main!(benches);
