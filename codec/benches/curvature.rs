//! Curvature-error decimation at the paper's Table 1 bounds (ε = 0.15 / 0.20 / 0.25) on its
//! three models, each level timed from the input (the conservative figure: the nested run of
//! `curvature::levels` only pays the increments). Quadric simplification to the same face
//! count runs beside it as the in-process peer. The paper took 22–32 s per level on a 1999
//! R4400; the floor is < 100 ms per level for a 13k-face model.

#![allow(
    clippy::expect_used,
    reason = "a bench without its data file should stop loudly"
)]

mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use zerotile_codec::mesh::curvature::{self, CurvatureOptions, PAPER_LEVELS};
use zerotile_codec::mesh::{simplify, QemOptions};

fn bench(c: &mut Criterion) {
    let options = CurvatureOptions::default();
    for name in ["fandisk", "uv-sphere-5002", "vase-lathe"] {
        let input = common::mesh(&format!("{name}.obj"));
        let mut group = c.benchmark_group(format!("curvature_{name}"));
        group.sample_size(20);
        for e in PAPER_LEVELS {
            let faces = curvature::to_error(&input, e, &options)
                .expect("decimates")
                .face_count();
            group.bench_with_input(BenchmarkId::new("curvature", e), &e, |b, &e| {
                b.iter(|| curvature::to_error(&input, e, &options).expect("decimates"))
            });
            group.bench_with_input(BenchmarkId::new("qem_same_faces", e), &faces, |b, &n| {
                b.iter(|| simplify(&input, &QemOptions::to_faces(n)).expect("simplifies"))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
