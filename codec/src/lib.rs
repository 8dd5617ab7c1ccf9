//! zerotile's codec: heightmaps stored as embedded zerotree wavelet (EZW) streams, decoded only
//! as far as a viewer needs, and meshed straight from the zerotree the decoder builds.
//!
//! The pipeline, split by how long each piece of work lives:
//! - per dataset: [`raster`] reads a heightmap; [`wavelet`] transforms it; [`ezw`] codes it.
//! - per decoded tile: [`ezw`] decodes a stream prefix to a threshold.
//! - per threshold: [`zerotree`] turns the decoder's zerotree into a crack-free mesh, and
//!   [`tile`] stitches neighbouring tiles so their shared edges match.

pub mod bintree;
pub mod container;
pub mod error;
pub mod ezw;
mod fixtures;
pub mod formats;
pub mod geo;
pub mod grid;
pub mod mesh;
pub mod pyramid;
pub mod raster;
#[cfg(test)]
mod scratch;
pub mod tile;
pub mod wavelet;
pub mod zerotree;

pub use error::{DecodeError, Error, ParamError, Result};
pub use grid::Grid;
