//! Quadric simplification (arrays in, arrays out) on the benchmark meshes at the benchmark's
//! targets: fandisk → 978 faces, the Stanford bunny → 10 % (6,945), and the bunny after two
//! Loop subdivisions (1,111,216 faces) → 10 %. The peer, meshoptimizer's `simplify` on the same
//! inputs and targets, runs in `../shared/bench/object_mesh.py` (Python binding and npm build);
//! compare its medians with these. Metro distances are benched too (70 k vs 7 k faces): every
//! evaluation pays for them.

#![allow(
    clippy::expect_used,
    reason = "a bench without its data file should stop loudly"
)]

mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use zerotile_codec::mesh::subdivide::loop_subdivide;
use zerotile_codec::mesh::{simplify, surface_distance, DistanceOptions, QemOptions};

fn qem(c: &mut Criterion) {
    let fandisk = common::mesh("fandisk.obj");
    let bunny = common::mesh("stanford-bunny.obj");
    let mut group = c.benchmark_group("qem");
    for (name, input, target) in [("fandisk", &fandisk, 978), ("bunny", &bunny, 6945)] {
        let id = BenchmarkId::new(name, target);
        group.bench_with_input(id, &target, |b, &target| {
            b.iter(|| simplify(input, &QemOptions::to_faces(target)).expect("simplifies"))
        });
    }
    group.finish();

    // The 1.1 M-face bunny: a handful of runs is enough at ~1 s each.
    let big = loop_subdivide(&loop_subdivide(&bunny));
    let mut group = c.benchmark_group("qem_large");
    group.sample_size(10);
    let target = big.face_count() / 10;
    group.bench_with_input(BenchmarkId::new("bunny_x16", target), &target, |b, &t| {
        b.iter(|| simplify(&big, &QemOptions::to_faces(t)).expect("simplifies"))
    });
    group.finish();

    // Metro distances between the bunny and its 10 % version, 200 k samples a side.
    let (small, _) = simplify(&bunny, &QemOptions::to_faces(6945)).expect("simplifies");
    let mut group = c.benchmark_group("metro");
    group.sample_size(10);
    group.bench_function("bunny_70k_vs_7k", |b| {
        b.iter(|| surface_distance(&bunny, &small, &DistanceOptions::default()).expect("measures"))
    });
    group.finish();
}

criterion_group!(benches, qem);
criterion_main!(benches);
