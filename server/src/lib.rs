//! zerotile's service and command line. The codec lives in `zerotile-codec`; this crate adds
//! the command line, evaluation and the HTTP
//! tile service ([`serve`]).

pub mod cli;
pub mod demo;
pub mod eval;
pub mod ingest;
pub mod serve;
