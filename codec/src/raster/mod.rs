//! Heightmap readers. (Placeholder: being written.)

/// A heightmap file could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RasterError {
    #[error("{path}: {message}")]
    Format { path: String, message: String },
}
