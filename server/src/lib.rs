//! zerotile's service and command line. The codec lives in `zerotile-codec`; this crate adds
//! the command line, evaluation and the HTTP
//! tile service ([`serve`]).

// Request handling and ingest take user input: an out-of-range index must be an error, not a
// panic. (The codec's kernels index validated buffers; its parsers are fuzzed instead.)
#![cfg_attr(not(test), warn(clippy::indexing_slicing))]

pub mod cli;
pub mod demo;
pub mod eval;
pub mod export;
mod fixtures;
pub mod info;
pub mod ingest;
pub mod regular_file;
pub mod serve;
pub mod swap_dir;
pub mod usage;
