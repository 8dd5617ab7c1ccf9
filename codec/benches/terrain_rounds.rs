//! One round of the paired speed comparison (`terrain-peer/rounds.py`): the median time of
//! `decode_and_mesh_257`'s work (the same function the criterion bench times) for every
//! tile, wavelet and budget, one JSON object a line.
//!
//! Criterion's whole group takes minutes, and on a shared machine the load drifts between
//! it and a peer run after it. rounds.py instead alternates short runs of this and of
//! Martini, several times, so both sides of each ratio see the same minute of the machine.
//!
//! usage: `cargo bench -p zerotile-codec --bench terrain_rounds -- [ITERATIONS] [parts]`
//! (default 31, after 5 untimed). With `parts`, each line also gives the median of each of
//! the three steps timed alone (decode, exact errors, extraction): which one a ratio above 1
//! should send you to. rounds.py does not ask for them (they double a round's time).

#![allow(
    clippy::expect_used,
    clippy::print_stdout,
    reason = "a bench binary: its output is the report, and a missing data file stops it"
)]

mod common;

use std::hint::black_box;

use common::decode_and_mesh_at;
use zerotile_codec::bintree::{self, Hierarchy, TileErrors, DECODE_SHARE};
use zerotile_codec::ezw;

fn main() {
    let iterations = common::iterations_arg();
    let parts = std::env::args().any(|a| a == "parts");
    let hierarchy = Hierarchy::new(257).expect("257 = 2^8 + 1");
    for (tile, wavelet, bytes) in common::terrain_mesh_streams() {
        for budget in common::BUDGETS {
            let ms = common::median_ms(iterations, || {
                black_box(decode_and_mesh_at(&bytes, &hierarchy, budget, DECODE_SHARE));
            });
            if !parts {
                println!(
                    "{{\"tile\":\"{tile}\",\"wavelet\":\"{}\",\"budget\":{budget},\"ms\":{ms:.4}}}",
                    wavelet.name(),
                );
                continue;
            }
            let (limit, tolerance) = common::split(budget, DECODE_SHARE);
            let decode = || ezw::decode_heights(&bytes, limit, ezw::DEFAULT_MAX_SAMPLES);
            let decode_ms = common::median_ms(iterations, || {
                black_box(decode().expect("decode"));
            });
            let heights = decode().expect("decode").heights;
            let errors_ms = common::median_ms(iterations, || {
                black_box(TileErrors::exact_above(&hierarchy, &heights, tolerance));
            });
            let errors = TileErrors::exact_above(&hierarchy, &heights, tolerance);
            let extract_ms = common::median_ms(iterations, || {
                black_box(bintree::extract(
                    &hierarchy, &errors, &heights, tolerance, None,
                ));
            });
            println!(
                "{{\"tile\":\"{tile}\",\"wavelet\":\"{}\",\"budget\":{budget},\"ms\":{ms:.4},\
                 \"decode_ms\":{decode_ms:.4},\"errors_ms\":{errors_ms:.4},\"extract_ms\":{extract_ms:.4}}}",
                wavelet.name(),
            );
        }
    }
}
