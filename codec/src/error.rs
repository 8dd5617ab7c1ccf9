//! Errors, sorted by who is at fault. Each module keeps a small enum; [`enum@Error`] folds them.

use thiserror::Error;

/// A parameter the caller chose is out of range.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ParamError {
    #[error("grid of {rows}×{cols} needs {} samples, got {len}", rows.saturating_mul(*cols))]
    GridShape {
        rows: usize,
        cols: usize,
        len: usize,
    },
    #[error("crop {size_r}×{size_c} at ({row}, {col}) does not fit in a {rows}×{cols} grid")]
    Crop {
        row: usize,
        col: usize,
        size_r: usize,
        size_c: usize,
        rows: usize,
        cols: usize,
    },
    #[error("{name} must be {expected}, got {got}")]
    OutOfRange {
        name: &'static str,
        expected: &'static str,
        got: String,
    },
}

/// Bytes from outside (a stream, a container) are malformed, truncated or exceed a limit.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum DecodeError {
    #[error("stream is truncated: {0}")]
    Truncated(&'static str),
    #[error("stream is malformed: {0}")]
    Malformed(String),
    #[error("stream exceeds a limit: {0}")]
    Limit(String),
    #[error("unsupported stream: {0}")]
    Unsupported(String),
}

/// The crate's one public error.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error(transparent)]
    Decode(#[from] DecodeError),
    #[error(transparent)]
    Raster(#[from] crate::raster::RasterError),
    #[error(transparent)]
    Container(#[from] crate::container::ContainerError),
    #[error(transparent)]
    Tiling(#[from] crate::geo::TilingError),
    #[error(transparent)]
    QuantizedMesh(#[from] crate::formats::quantized_mesh::QmError),
    #[error(transparent)]
    LayerJson(#[from] crate::formats::layer_json::LayerJsonError),
    #[error(transparent)]
    TerrainRgb(#[from] crate::formats::terrain_rgb::TerrainRgbError),
    #[error(transparent)]
    MeshBin(#[from] crate::formats::mesh_bin::MeshBinError),
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// `v` as the shortest text that reads back as `v`, in exponent form where the plain decimal
/// would run to dozens of digits (1e300 in 301 digits, a threshold of 1e-300 in 302): for
/// messages and headers that quote a number.
pub fn short(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-6..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}
