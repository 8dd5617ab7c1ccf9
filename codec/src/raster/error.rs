//! Why a heightmap could not be read, sorted by who is at fault (as image-rs does): the
//! filesystem, the file's bytes, our coverage of the format, a configured limit, or the
//! caller's options. Every variant names the file, so a message is useful on its own.

use std::path::{Path, PathBuf};

/// A heightmap file could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RasterError {
    /// The file could not be opened or read (missing, permissions, disk error).
    /// The cause is part of the message, not a `source`, so a chained report does not say
    /// it twice.
    #[error("{}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// The file's bytes are malformed or truncated.
    #[error("{}: malformed file: {message}", path.display())]
    Format { path: PathBuf, message: String },
    /// A valid file that zerotile does not read (a sample type, a layout, an extension).
    #[error("{}: unsupported: {message}", path.display())]
    Unsupported { path: PathBuf, message: String },
    /// The file asks for more than [`ReadOptions::max_samples`](super::ReadOptions) allows.
    #[error("{}: exceeds a limit: {message}", path.display())]
    Limit { path: PathBuf, message: String },
    /// The caller's options do not fit this file (an encoding, an array name).
    #[error("{}: {message}", path.display())]
    Parameter { path: PathBuf, message: String },
}

impl RasterError {
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            error: source,
        }
    }

    pub(crate) fn format(path: &Path, message: impl Into<String>) -> Self {
        Self::Format {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn unsupported(path: &Path, message: impl Into<String>) -> Self {
        Self::Unsupported {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn limit(path: &Path, message: impl Into<String>) -> Self {
        Self::Limit {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn parameter(path: &Path, message: impl Into<String>) -> Self {
        Self::Parameter {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    /// Sorts an I/O error met while decoding: running out of bytes or bad bytes is the file's
    /// fault, anything else is the filesystem's.
    pub(crate) fn from_read(path: &Path, source: std::io::Error) -> Self {
        match source.kind() {
            std::io::ErrorKind::UnexpectedEof => {
                Self::format(path, format!("truncated ({source})"))
            }
            std::io::ErrorKind::InvalidData => Self::format(path, source.to_string()),
            _ => Self::io(path, source),
        }
    }
}

/// Checks a `rows × cols` shape read from a header, before anything is allocated for it: an
/// empty raster is malformed, one above `max_samples` is refused. Returns the sample count.
pub(crate) fn check_shape(
    path: &Path,
    rows: u64,
    cols: u64,
    max_samples: usize,
) -> Result<usize, RasterError> {
    let too_big = || {
        RasterError::limit(
            path,
            format!(
                "{rows} × {cols} samples (rows × columns), more than the limit of \
                 {max_samples} (max_samples)"
            ),
        )
    };
    if rows == 0 || cols == 0 {
        return Err(RasterError::format(
            path,
            format!("empty raster ({rows} × {cols} samples, rows × columns)"),
        ));
    }
    let n = rows.checked_mul(cols).ok_or_else(too_big)?;
    match usize::try_from(n) {
        Ok(n) if n <= max_samples => Ok(n),
        _ => Err(too_big()),
    }
}
