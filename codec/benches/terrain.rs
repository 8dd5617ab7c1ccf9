//! Per-request work on a real 257² tile (N44W072): decode the EZW stream to a threshold and
//! mesh the decoder's zerotree. The peer (Martini's createTile + getMesh on the same tile)
//! runs in `../shared/bench/terrain_mesh.py`; this bench gives the criterion medians.

#![allow(
    clippy::expect_used,
    reason = "a bench without its data file should stop loudly"
)]
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use zerotile_codec::ezw::{self, DecodeLimit, EncodeParams};
use zerotile_codec::wavelet::Wavelet;
use zerotile_codec::zerotree::{self, Complexity};
use zerotile_codec::Grid;

fn tile() -> Grid<f64> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/dem/N44W072.hgt"
    );
    let bytes = std::fs::read(path).expect("../shared/data/dem/N44W072.hgt");
    let data = bytes
        .chunks_exact(2)
        .map(|b| f64::from(i16::from_be_bytes([b[0], b[1]])))
        .collect();
    let dem = Grid::new(1201, 1201, data).expect("1201²");
    dem.crop(300, 500, 257, 257).expect("crop")
}

fn decode_and_mesh(c: &mut Criterion) {
    let g = tile();
    let mut group = c.benchmark_group("decode_to_T_and_mesh_257");
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        let enc = ezw::encode(&g, &EncodeParams::new(wavelet, 1.0)).expect("encode");
        for t in [1.0, 4.0, 16.0] {
            let id = BenchmarkId::new(wavelet.name(), format!("T={t}"));
            group.bench_with_input(id, &t, |b, &t| {
                b.iter(|| {
                    let d = ezw::decode(
                        &enc.bytes,
                        DecodeLimit::Threshold(t),
                        ezw::DEFAULT_MAX_SAMPLES,
                    )
                    .expect("decode");
                    let leaves = Complexity::new(&d.layout, &d.coefficients).leaves(t);
                    zerotree::triangulate(&leaves, &d.heights, None)
                })
            });
        }
    }
    group.finish();

    let mut group = c.benchmark_group("encode_257");
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        group.bench_function(wavelet.name(), |b| {
            b.iter(|| ezw::encode(&g, &EncodeParams::new(wavelet, 1.0)).expect("encode"))
        });
    }
    group.finish();
}

criterion_group!(benches, decode_and_mesh);
criterion_main!(benches);
