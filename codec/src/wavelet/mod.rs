//! Lifting wavelet transforms. (Placeholder: transforms being written.)

pub mod subbands;

pub use subbands::{Band, Layout, Orientation};
