//! One round of the paired speed comparison (`terrain-peer/rounds.py`): the median time of
//! `decode_and_mesh_257`'s work (the same function the criterion bench times) for every
//! tile, wavelet and budget, one JSON object a line.
//!
//! Criterion's whole group takes minutes, and on a shared machine the load drifts between
//! it and a peer run after it. rounds.py instead alternates short runs of this and of
//! Martini, several times, so both sides of each ratio see the same minute of the machine.
//!
//! usage: `cargo bench -p zerotile-codec --bench terrain_rounds -- [ITERATIONS]` (default 31,
//! after 5 untimed).

#![allow(
    clippy::expect_used,
    clippy::print_stdout,
    reason = "a bench binary: its output is the report, and a missing data file stops it"
)]

mod common;

use std::hint::black_box;

use common::decode_and_mesh_at;
use zerotile_codec::bintree::{Hierarchy, DECODE_SHARE};

fn main() {
    let iterations = common::iterations_arg();
    let hierarchy = Hierarchy::new(257).expect("257 = 2^8 + 1");
    for (tile, wavelet, bytes) in common::terrain_mesh_streams() {
        for budget in common::BUDGETS {
            let ms = common::median_ms(iterations, || {
                black_box(decode_and_mesh_at(&bytes, &hierarchy, budget, DECODE_SHARE));
            });
            println!(
                "{{\"tile\":\"{tile}\",\"wavelet\":\"{}\",\"budget\":{budget},\"ms\":{:.4}}}",
                wavelet.name(),
                ms
            );
        }
    }
}
