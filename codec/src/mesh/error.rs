//! Object-mesh errors, sorted by who is at fault: the bytes (decode), the limits the caller set,
//! the mesh content (invalid), the caller's parameters, an unsupported format, the file system.

use thiserror::Error;

use crate::error::ParamError;

/// The one public error of [`crate::mesh`].
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum MeshError {
    /// Bytes from outside are malformed or truncated.
    #[error("{format}: {what}")]
    Decode { format: &'static str, what: String },
    /// The input is larger than [`crate::mesh::io::MeshLimits`] allow.
    #[error("mesh exceeds a limit: {what} is {got}, the limit is {limit}")]
    Limit {
        what: &'static str,
        got: u64,
        limit: u64,
    },
    /// The mesh decodes but cannot be used: the caller's data is wrong, not our parser.
    #[error(transparent)]
    Invalid(#[from] InvalidMesh),
    /// A parameter the caller chose is out of range.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// The format is known but this feature of it is not, or the format is unknown.
    #[error("unsupported mesh: {0}")]
    Unsupported(String),
    /// Writing would produce a file the format cannot express (e.g. a GLB above 4 GiB).
    #[error("cannot encode {format}: {what}")]
    Encode { format: &'static str, what: String },
    /// Reading or writing a mesh file failed. The cause is part of the message, not a
    /// `source`, so a chained report (anyhow's `{:#}`) does not say it twice.
    #[error("mesh i/o: {0}")]
    Io(std::io::Error),
}

impl From<std::io::Error> for MeshError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
}

/// Mesh content no repair can fix: geometry that is not numbers, faces that point nowhere.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum InvalidMesh {
    /// `first` counts from 0 in the mesh as read (PLY's and JSON's own order).
    #[error(
        "{count} {} NaN or infinite coordinates (first: vertex index {first}, from 0)",
        if *count == 1 { "vertex has" } else { "vertices have" }
    )]
    NonFiniteCoordinates { count: usize, first: usize },
    /// The same in an OBJ, named as the file numbers it: tobj renumbers the vertices the faces
    /// use, so an index in its order named a vertex the file did not have there.
    #[error(
        "{count} {} NaN or infinite coordinates (first: `v` statement {vertex}, line {line})",
        if *count == 1 { "vertex has" } else { "vertices have" }
    )]
    NonFiniteObjVertex {
        count: usize,
        vertex: usize,
        line: usize,
    },
    #[error(
        "{count} face indices are out of range for {vertices} vertices (first: face {face}, \
         index {index})"
    )]
    IndexOutOfRange {
        count: usize,
        face: usize,
        index: u64,
        vertices: usize,
    },
    #[error("the mesh has no faces")]
    Empty,
}

impl MeshError {
    pub(crate) fn decode(format: &'static str, what: impl Into<String>) -> Self {
        Self::Decode {
            format,
            what: what.into(),
        }
    }
}
