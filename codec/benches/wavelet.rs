//! The 2-D lifting transforms on a real 257² tile (N44W072), 8 levels: every tile request runs
//! one inverse. The peer in the same run is the textbook layout of the same 9/7 inverse: each
//! column gathered with a stride into a line, lifted interleaved with mirrored indices, and
//! scattered back; it shows what the row-vector column pass buys.
#![allow(
    clippy::expect_used,
    reason = "a bench without its data file should stop loudly"
)]

mod common;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use zerotile_codec::wavelet::{self, Layout, Wavelet};

const SIDE: usize = 257;

/// The textbook peer: strided column gather, interleaved in-place lifting, scatter.
mod strided {
    use zerotile_codec::wavelet::Layout;
    use zerotile_codec::Grid;

    const ALPHA: f64 = -1.586_134_342_059_924;
    const BETA: f64 = -0.052_980_118_572_961;
    const GAMMA: f64 = 0.882_911_075_530_934;
    const DELTA: f64 = 0.443_506_852_043_971;
    const K: f64 = 1.230_174_104_914_001;

    fn mirror(i: isize, n: isize) -> usize {
        (if i < 0 {
            -i
        } else if i >= n {
            2 * (n - 1) - i
        } else {
            i
        }) as usize
    }

    /// x[i] += c·(x[i−1] + x[i+1]) for every i of the given parity.
    fn lift(x: &mut [f64], parity: usize, c: f64) {
        let n = x.len() as isize;
        for i in (parity..x.len()).step_by(2) {
            let i = i as isize;
            x[i as usize] += c * (x[mirror(i - 1, n)] + x[mirror(i + 1, n)]);
        }
    }

    /// `[s | d]` in `line` → interleaved samples in `out`.
    fn synthesize(line: &[f64], out: &mut [f64]) {
        let (n, ns) = (line.len(), line.len().div_ceil(2));
        for (i, o) in out.iter_mut().enumerate() {
            *o = if i % 2 == 0 {
                line[i / 2] * K
            } else {
                line[ns + i / 2] / K
            };
        }
        lift(out, 0, -DELTA);
        lift(out, 1, -GAMMA);
        lift(out, 0, -BETA);
        lift(out, 1, -ALPHA);
        debug_assert!(n >= 2);
    }

    pub fn inverse_cdf97(grid: &mut Grid<f64>, layout: &Layout) {
        let cols = grid.cols();
        let mut line = vec![0.0; grid.rows().max(cols)];
        let mut out = line.clone();
        let data = grid.data_mut();
        for level in (1..=layout.levels()).rev() {
            let (h, w) = (layout.low_rows(level - 1), layout.low_cols(level - 1));
            if h >= 2 {
                for c in 0..w {
                    for r in 0..h {
                        line[r] = data[r * cols + c];
                    }
                    synthesize(&line[..h], &mut out[..h]);
                    for r in 0..h {
                        data[r * cols + c] = out[r];
                    }
                }
            }
            if w >= 2 {
                for r in 0..h {
                    line[..w].copy_from_slice(&data[r * cols..r * cols + w]);
                    synthesize(&line[..w], &mut out[..w]);
                    data[r * cols..r * cols + w].copy_from_slice(&out[..w]);
                }
            }
        }
    }
}

fn transforms(c: &mut Criterion) {
    let heights = common::n44w072_tile(SIDE);
    let layout = Layout::full(SIDE, SIDE);
    let ints = heights.map(|&h| h as i32);
    let coefficients = |wavelet| {
        let mut g = heights.clone();
        wavelet::forward(&mut g, wavelet, &layout);
        g
    };
    let (c97, c53) = (
        coefficients(Wavelet::Cdf97),
        coefficients(Wavelet::LeGall53),
    );
    let mut i53 = ints.clone();
    wavelet::forward_int53(&mut i53, &layout);

    // The peer must compute the same thing, or the comparison means nothing.
    let mut ours = c97.clone();
    wavelet::inverse(&mut ours, Wavelet::Cdf97, &layout);
    let mut peer = c97.clone();
    strided::inverse_cdf97(&mut peer, &layout);
    let gap = ours
        .data()
        .iter()
        .zip(peer.data())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(gap < 1e-9, "peer disagrees by {gap}");

    let mut group = c.benchmark_group("inverse_257x257_8_levels");
    group.bench_function("cdf97", |b| {
        b.iter_batched_ref(
            || c97.clone(),
            |g| wavelet::inverse(g, Wavelet::Cdf97, &layout),
            BatchSize::LargeInput,
        )
    });
    group.bench_function("cdf97_strided_peer", |b| {
        b.iter_batched_ref(
            || c97.clone(),
            |g| strided::inverse_cdf97(g, &layout),
            BatchSize::LargeInput,
        )
    });
    group.bench_function("legall53_real", |b| {
        b.iter_batched_ref(
            || c53.clone(),
            |g| wavelet::inverse(g, Wavelet::LeGall53, &layout),
            BatchSize::LargeInput,
        )
    });
    group.bench_function("legall53_int", |b| {
        b.iter_batched_ref(
            || i53.clone(),
            |g| wavelet::inverse_int53(g, &layout),
            BatchSize::LargeInput,
        )
    });
    group.finish();

    let mut group = c.benchmark_group("forward_257x257_8_levels");
    group.bench_function("cdf97", |b| {
        b.iter_batched_ref(
            || heights.clone(),
            |g| wavelet::forward(g, Wavelet::Cdf97, &layout),
            BatchSize::LargeInput,
        )
    });
    group.bench_function("legall53_real", |b| {
        b.iter_batched_ref(
            || heights.clone(),
            |g| wavelet::forward(g, Wavelet::LeGall53, &layout),
            BatchSize::LargeInput,
        )
    });
    group.bench_function("legall53_int", |b| {
        b.iter_batched_ref(
            || ints.clone(),
            |g| wavelet::forward_int53(g, &layout),
            BatchSize::LargeInput,
        )
    });
    group.finish();

    let mut group = c.benchmark_group("band_norms_257x257");
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        group.bench_function(wavelet.name(), |b| {
            b.iter(|| wavelet::band_norms(wavelet, &layout))
        });
    }
    group.finish();
}

criterion_group!(benches, transforms);
criterion_main!(benches);
