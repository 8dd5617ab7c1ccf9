//! Heightmap readers: one file per format, chosen by the file's extension.
//!
//! | extension | reader | samples | georeference |
//! |---|---|---|---|
//! | `.hgt` | `hgt`: SRTM 1″/3″ tile | int16, −32768 = void | tile name (`N44W072`) |
//! | `.tif` `.tiff` | `geotiff`: `tiff` crate | 1 band, (u)int8–32, float32/64 | GeoTIFF tags |
//! | `.png` | `png`: `image` crate | gray 1–16-bit, terrain-RGB, Terrarium | none |
//! | `.asc` | `ascii_grid`: ESRI ASCII grid | decimal text | header |
//! | `.npy` `.npz` | `numpy`: `npyz` crate | 2-D (u)int8–32, float32/64 | `.npz` bounds keys |
//!
//! Every reader returns the same [`Heightmap`]: rows top (north) to bottom, no-data as NaN, the
//! native height step, and a [`Georef`] mapping sample centres. Nothing is allocated for a
//! raster before its size is checked against [`ReadOptions::max_samples`], and malformed bytes
//! are a [`RasterError`], never a panic.
//!
//! ```no_run
//! use zerotile_codec::raster::{self, Encoding, ReadOptions};
//!
//! let opts = ReadOptions { encoding: Some(Encoding::TerrainRgb), ..ReadOptions::default() };
//! let map = raster::read_heightmap("fuji.png", &opts)?;
//! println!("{:?} m", map.min_max());
//! # Ok::<(), raster::RasterError>(())
//! ```

mod ascii_grid;
mod encoding;
mod error;
mod gdal_metadata;
mod georef;
mod geotiff;
mod heightmap;
mod hgt;
mod numpy;
mod png;
mod tiff_mask;

use std::fs::File;
use std::path::Path;

pub use encoding::{Encoding, Misread};
pub use error::RasterError;
pub use georef::{Crs, Georef};
pub use heightmap::Heightmap;

/// Default for [`ReadOptions::max_samples`]: 2^28 samples (2 GiB of f64 heights, a
/// 16384² raster), far above any single tile's source.
pub const DEFAULT_MAX_SAMPLES: usize = 1 << 28;

/// The extensions [`read_heightmap`] knows, for messages.
pub const EXTENSIONS: &str = ".hgt, .tif, .tiff, .png, .asc, .npy, .npz";

/// How to read a heightmap. Options that do not apply to a file's format are ignored.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadOptions {
    /// How a PNG encodes heights. Needed for colour PNGs; gray PNGs read as
    /// [`Encoding::Gray`] when it is `None`.
    pub encoding: Option<Encoding>,
    /// Which array of an `.npz` to read; `None` picks `elevation`, else the only 2-D array.
    pub npz_key: Option<String>,
    /// The largest raster accepted, in samples; a larger one is a [`RasterError::Limit`]
    /// before anything is allocated for it.
    pub max_samples: usize,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            encoding: None,
            npz_key: None,
            max_samples: DEFAULT_MAX_SAMPLES,
        }
    }
}

/// Reads the heightmap at `path`, choosing the reader by extension (case-insensitive).
///
/// # Errors
/// [`RasterError::Io`] when the file cannot be read, [`RasterError::Format`] when its bytes
/// are malformed or truncated, [`RasterError::Unsupported`] for an extension, sample type or
/// layout zerotile does not read, [`RasterError::Limit`] above `opts.max_samples`, and
/// [`RasterError::Parameter`] when `opts` do not fit the file (a colour PNG without an
/// encoding, an `.npz` key it does not hold).
pub fn read_heightmap(
    path: impl AsRef<Path>,
    opts: &ReadOptions,
) -> Result<Heightmap, RasterError> {
    let path = path.as_ref();
    let map = match extension(path).as_str() {
        "hgt" => hgt::read(path, opts),
        "tif" | "tiff" => geotiff::read(path, opts),
        "png" => png::read(path, opts),
        "asc" => ascii_grid::read(path, opts),
        "npy" => numpy::read_npy(path, opts),
        "npz" => numpy::read_npz(path, opts),
        _ => Err(RasterError::unsupported(
            path,
            format!("unknown heightmap extension; zerotile reads {EXTENSIONS}"),
        )),
    }?;
    // NaN is no-data (filled later); an infinity is neither a height nor marked missing,
    // and once slipped into a dataset's height range as JSON null.
    let h = &map.heights;
    if let Some(i) = h.data().iter().position(|v| v.is_infinite()) {
        return Err(RasterError::format(
            path,
            format!(
                "row {}, column {}: {} is not a finite height (mark no-data as NaN or the \
                 file's no-data value)",
                i / h.cols(),
                i % h.cols(),
                h.data()[i]
            ),
        ));
    }
    Ok(map)
}

/// The lower-case extension [`read_heightmap`] chooses the reader by ("" for none).
pub fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default()
}

/// Opens `path` for reading, naming it in the error.
fn open(path: &Path) -> Result<File, RasterError> {
    let file = File::open(path).map_err(|e| RasterError::io(path, e))?;
    // A folder opens for reading on Unix; a reader that sizes the data from the file's
    // length (.hgt) then reported the folder's own size as the file's.
    if file.metadata().is_ok_and(|m| m.is_dir()) {
        return Err(RasterError::io(
            path,
            std::io::Error::new(std::io::ErrorKind::IsADirectory, "is a folder, not a file"),
        ));
    }
    Ok(file)
}

/// Converts integer samples to heights, mapping `nodata` (when the file declares one) to NaN.
fn int_heights<T: Copy + PartialEq + Into<f64>>(samples: &[T], nodata: Option<T>) -> Vec<f64> {
    samples
        .iter()
        .map(|&v| {
            if Some(v) == nodata {
                f64::NAN
            } else {
                v.into()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests;
