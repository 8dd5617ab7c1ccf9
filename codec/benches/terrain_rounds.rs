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
use std::time::Instant;

use common::decode_and_mesh_at;
use zerotile_codec::bintree::{Hierarchy, DECODE_SHARE};

const WARM_UP: usize = 5;

fn main() {
    let iterations = common::iterations_arg();
    let hierarchy = Hierarchy::new(257).expect("257 = 2^8 + 1");
    for (tile, wavelet, bytes) in common::terrain_mesh_streams() {
        for budget in common::BUDGETS {
            let run = || {
                let t = Instant::now();
                black_box(decode_and_mesh_at(&bytes, &hierarchy, budget, DECODE_SHARE));
                t.elapsed().as_secs_f64() * 1e3
            };
            for _ in 0..WARM_UP {
                run();
            }
            let mut ms: Vec<f64> = (0..iterations).map(|_| run()).collect();
            ms.sort_by(f64::total_cmp);
            println!(
                "{{\"tile\":\"{tile}\",\"wavelet\":\"{}\",\"budget\":{budget},\"ms\":{:.4}}}",
                wavelet.name(),
                ms[ms.len() / 2]
            );
        }
    }
}
