//! How far the decode + mesh of a 257² tile is from the range coder's own floor: for each of
//! terrain_mesh.py's tiles, wavelets and budgets, the decisions the passes read (the pass
//! table counts them), the real decode's median time, the bare range decoder's median time
//! for as many decisions, and the errors + extraction the mesh adds, in one process.
//!
//! The bare decoder is branch-free in the decoded bit, so its time per decision does not
//! depend on which bits a stream holds: one skewed sequence stands for every stream.
//!
//! usage: `cargo bench -p zerotile-codec --bench decode_floor -- [ITERATIONS]` (default 31)

#![allow(
    clippy::expect_used,
    clippy::print_stdout,
    reason = "a bench binary: its output is the report, and a missing data file stops it"
)]

mod common;

use std::hint::black_box;

use zerotile_codec::bintree::{self, Hierarchy, TileErrors, DECODE_SHARE};
use zerotile_codec::ezw::arith::{Decoder, Encoder, PROB_INIT};
use zerotile_codec::ezw::{self, DecodeLimit, EncodeParams};
use zerotile_codec::wavelet::Wavelet;

/// `n` decisions over 16 contexts, about 0.7 bits each (the streams' own rate), coded.
fn skewed_stream(n: usize) -> (Vec<u8>, Vec<u8>) {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut ctx = [PROB_INIT; 16];
    let mut enc = Encoder::new();
    let mut contexts = Vec::with_capacity(n);
    for _ in 0..n {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let c = (x >> 8) as usize % 16;
        let p_one = 0.02 + 0.4 * c as f64 / 16.0;
        let bit = ((x >> 40) as f64) < p_one * (1u64 << 24) as f64;
        enc.encode(&mut ctx[c], bit);
        contexts.push(c as u8);
    }
    (enc.finish(), contexts)
}

fn main() {
    let iterations = common::iterations_arg();
    let hierarchy = Hierarchy::new(257).expect("257 = 2^8 + 1");
    println!("| tile | wavelet | T | decisions | decode ms | bare coder ms | decode − coder ms | errors + extract ms |");
    println!("|---|---|---|---|---|---|---|---|");
    for (tile, heights, step) in common::terrain_mesh_tiles() {
        for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
            let enc = ezw::encode(&heights, &EncodeParams::new(wavelet, step)).expect("encode");
            for budget in common::BUDGETS {
                let depth = budget * DECODE_SHARE;
                let decisions: u64 = enc
                    .passes
                    .iter()
                    .filter(|p| p.threshold >= depth)
                    .map(|p| p.decisions)
                    .sum();
                let limit = DecodeLimit::Threshold(depth);
                let decode = || ezw::decode_heights(&enc.bytes, limit, ezw::DEFAULT_MAX_SAMPLES);
                let decode_ms = common::median_ms(iterations, || {
                    black_box(decode().expect("decode"));
                });
                let (bytes, contexts) = skewed_stream(decisions as usize);
                let coder_ms = common::median_ms(iterations, || {
                    let mut ctx = [PROB_INIT; 16];
                    let mut dec = Decoder::new(&bytes);
                    let mut ones = 0u32;
                    for &c in &contexts {
                        ones += u32::from(dec.decode(&mut ctx[usize::from(c)]));
                    }
                    black_box(ones);
                });
                let d = decode().expect("decode");
                let tolerance = budget * (1.0 - DECODE_SHARE);
                let mesh_ms = common::median_ms(iterations, || {
                    let errors = TileErrors::exact_above(&hierarchy, &d.heights, tolerance);
                    black_box(bintree::extract(
                        &hierarchy, &errors, &d.heights, tolerance, None,
                    ));
                });
                println!(
                    "| {tile} | {} | {budget} | {decisions} | {decode_ms:.3} | {coder_ms:.3} | {:.3} | {mesh_ms:.3} |",
                    wavelet.name(),
                    decode_ms - coder_ms
                );
            }
        }
    }
}
