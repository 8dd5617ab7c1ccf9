//! ESRI ASCII grids (`.asc`, "ARC/INFO ASCII GRID", ESRI ArcGIS documentation "ESRI ASCII
//! raster format"): a `key value` header, then `nrows × ncols` decimal values, north row first,
//! separated by any whitespace.
//!
//! Header keys, in any order and any case: `ncols`, `nrows`, `xllcorner` or `xllcenter`,
//! `yllcorner` or `yllcenter`, `cellsize` (or GDAL's `dx` and `dy`), optional `nodata_value`.
//! The `ll` position is the lower-left cell's outer corner or its centre; [`Georef`] is
//! centre-based, so a corner moves by half a cell. The format names no CRS.
//!
//! The text is read as a stream of whitespace-separated tokens of bounded length, so a file
//! of any size is read in memory proportional to the raster it declares.

use std::io::{BufRead, BufReader};
use std::path::Path;

use super::error::check_shape;
use super::{open, Crs, Georef, Heightmap, RasterError, ReadOptions};
use crate::grid::Grid;

/// The longest token we accept: any decimal number fits, and a longer one means a binary or
/// corrupt file.
const MAX_TOKEN: usize = 64;

/// Reads an ESRI ASCII grid.
pub(super) fn read(path: &Path, opts: &ReadOptions) -> Result<Heightmap, RasterError> {
    let mut tokens = Tokens::new(BufReader::new(open(path)?));

    // The header, up to the first token that is a number where a key belongs.
    let (header, first_value) = read_header(path, &mut tokens)?;
    let n = check_shape(
        path,
        header.nrows as u64,
        header.ncols as u64,
        opts.max_samples,
    )?;

    // Exactly nrows × ncols values; no-data becomes NaN.
    let mut heights = Vec::with_capacity(n);
    let mut all_integers = true;
    let mut next = first_value;
    while let Some(token) = next {
        if heights.len() == n {
            return Err(RasterError::format(
                path,
                format!(
                    "line {}: more than the {n} values nrows × ncols declares",
                    token.line
                ),
            ));
        }
        let value = token.number(path)?;
        if value.is_infinite() {
            return Err(RasterError::format(
                path,
                format!(
                    "line {}: {:?} is not a finite height",
                    token.line, token.text
                ),
            ));
        }
        if Some(value) == header.nodata || value.is_nan() {
            heights.push(f64::NAN);
        } else {
            all_integers &= value.fract() == 0.0;
            heights.push(value);
        }
        next = tokens.next(path)?;
    }
    if heights.len() < n {
        return Err(RasterError::format(
            path,
            format!(
                "truncated: {} values where nrows × ncols declares {n} ({} × {})",
                heights.len(),
                header.nrows,
                header.ncols
            ),
        ));
    }

    // Grid, step and placement.
    let heights = Grid::new(header.nrows, header.ncols, heights)
        .map_err(|e| RasterError::format(path, e.to_string()))?;
    let step = all_integers.then_some(1.0);
    Ok(Heightmap::new(heights, step, header.georef()))
}

/// The header's values.
#[derive(Debug, Default)]
struct Header {
    ncols: usize,
    nrows: usize,
    /// Lower-left x and y, and whether they are the cell's centre (else its corner).
    xll: Option<(f64, bool)>,
    yll: Option<(f64, bool)>,
    dx: Option<f64>,
    dy: Option<f64>,
    nodata: Option<f64>,
}

impl Header {
    /// Centre of the north-west cell and the spacings.
    fn georef(&self) -> Option<Georef> {
        let ((xll, x_centre), (yll, y_centre)) = (self.xll?, self.yll?);
        let (dx, dy) = (self.dx?, self.dy?);
        let x0 = if x_centre { xll } else { xll + 0.5 * dx };
        let south_centre = if y_centre { yll } else { yll + 0.5 * dy };
        let y0 = south_centre + (self.nrows.saturating_sub(1)) as f64 * dy;
        Some(Georef::north_up(Crs::Unknown, x0, y0, dx, dy))
    }
}

/// Parses `key value` pairs until a key position holds a number, which it returns as the first
/// value.
fn read_header<R: BufRead>(
    path: &Path,
    tokens: &mut Tokens<R>,
) -> Result<(Header, Option<Token>), RasterError> {
    let mut header = Header::default();
    let mut ncols = None;
    let mut nrows = None;
    let first_value = loop {
        let Some(key) = tokens.next(path)? else {
            break None;
        };
        if key.text.parse::<f64>().is_ok() {
            break Some(key);
        }
        let Some(value) = tokens.next(path)? else {
            return Err(RasterError::format(
                path,
                format!("line {}: header key {:?} has no value", key.line, key.text),
            ));
        };
        match key.text.to_ascii_lowercase().as_str() {
            "ncols" => ncols = Some(value.count(path, "ncols")?),
            "nrows" => nrows = Some(value.count(path, "nrows")?),
            "xllcorner" => header.xll = Some((value.number(path)?, false)),
            "xllcenter" | "xllcentre" => header.xll = Some((value.number(path)?, true)),
            "yllcorner" => header.yll = Some((value.number(path)?, false)),
            "yllcenter" | "yllcentre" => header.yll = Some((value.number(path)?, true)),
            "cellsize" => {
                let size = value.number(path)?;
                (header.dx, header.dy) = (Some(size), Some(size));
            }
            "dx" => header.dx = Some(value.number(path)?),
            "dy" => header.dy = Some(value.number(path)?),
            "nodata_value" => header.nodata = Some(value.number(path)?),
            _ => {
                return Err(RasterError::format(
                    path,
                    format!(
                        "line {}: unknown header key {:?} (expected ncols, nrows, \
                         xllcorner/xllcenter, yllcorner/yllcenter, cellsize, nodata_value)",
                        key.line, key.text
                    ),
                ))
            }
        }
    };
    let missing = |key: &str| RasterError::format(path, format!("header has no {key}"));
    header.ncols = ncols.ok_or_else(|| missing("ncols"))?;
    header.nrows = nrows.ok_or_else(|| missing("nrows"))?;
    Ok((header, first_value))
}

/// One whitespace-separated token and the line it starts on.
#[derive(Debug)]
struct Token {
    text: String,
    line: usize,
}

impl Token {
    fn number(&self, path: &Path) -> Result<f64, RasterError> {
        self.text.parse().map_err(|_| {
            RasterError::format(
                path,
                format!("line {}: {:?} is not a number", self.line, self.text),
            )
        })
    }

    fn count(&self, path: &Path, key: &str) -> Result<usize, RasterError> {
        self.text.parse().map_err(|_| {
            RasterError::format(
                path,
                format!(
                    "line {}: {key} must be a positive integer, got {:?}",
                    self.line, self.text
                ),
            )
        })
    }
}

/// Whitespace-separated tokens of at most [`MAX_TOKEN`] bytes, read straight from the buffer.
struct Tokens<R> {
    reader: R,
    line: usize,
}

impl<R: BufRead> Tokens<R> {
    fn new(reader: R) -> Self {
        Self { reader, line: 1 }
    }

    fn next(&mut self, path: &Path) -> Result<Option<Token>, RasterError> {
        let mut text = Vec::new();
        let mut line = self.line;
        loop {
            let buf = self
                .reader
                .fill_buf()
                .map_err(|e| RasterError::from_read(path, e))?;
            if buf.is_empty() {
                break;
            }
            let mut used = 0;
            let mut done = false;
            for &b in buf {
                if b.is_ascii_whitespace() {
                    if !text.is_empty() {
                        done = true;
                        break;
                    }
                    if b == b'\n' {
                        self.line += 1;
                    }
                } else {
                    if text.is_empty() {
                        line = self.line;
                    }
                    if text.len() == MAX_TOKEN {
                        return Err(RasterError::format(
                            path,
                            format!("line {line}: a token longer than {MAX_TOKEN} bytes"),
                        ));
                    }
                    text.push(b);
                }
                used += 1;
            }
            self.reader.consume(used);
            if done {
                break;
            }
        }
        if text.is_empty() {
            return Ok(None);
        }
        let text = String::from_utf8(text)
            .map_err(|_| RasterError::format(path, format!("line {line}: not text")))?;
        Ok(Some(Token { text, line }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::scratch_dir;

    fn read_text(name: &str, text: &str) -> Result<Heightmap, RasterError> {
        let path = scratch_dir(&format!("asc_{name}")).join(format!("{name}.asc"));
        std::fs::write(&path, text).unwrap();
        read(&path, &ReadOptions::default())
    }

    #[test]
    fn reads_a_small_grid_with_nodata_and_corner_placement() {
        let text = "NCOLS 3\nnrows 2\nxllcorner 100\nYLLCORNER 200\ncellsize 10\n\
                    NODATA_value -9999\n1 2 3\n4 -9999\n6\n";
        let map = read_text("small", text).unwrap();
        assert_eq!((map.heights.rows(), map.heights.cols()), (2, 3));
        assert_eq!(map.heights.data()[..4], [1.0, 2.0, 3.0, 4.0]);
        assert!(map.heights.data()[4].is_nan());
        assert_eq!((map.nodata_count, map.step), (1, Some(1.0)));
        // Lower-left corner (100, 200), two 10-unit rows: the top-left centre is (105, 215).
        let g = map.georef.unwrap();
        assert_eq!(g.crs, Crs::Unknown);
        assert_eq!(g.position(0.0, 0.0), (105.0, 215.0));
        assert_eq!(g.position(1.0, 2.0), (125.0, 205.0));
    }

    #[test]
    fn centre_placement_and_decimals_have_no_integer_step() {
        let text = "xllcenter 0.5\nyllcenter 0.5\nncols 2\nnrows 1\ncellsize 1\n1.5 2\n";
        let map = read_text("centre", text).unwrap();
        assert_eq!(map.step, None);
        assert_eq!(map.georef.unwrap().position(0.0, 0.0), (0.5, 0.5));
    }

    /// GDAL writes `dx` and `dy` instead of `cellsize` when the cells are not square.
    #[test]
    fn gdal_dx_and_dy_place_non_square_cells() {
        let text = "ncols 2\nnrows 3\nxllcorner 10\nyllcorner 20\ndx 2\nDY 5\n1 2\n3 4\n5 6\n";
        let map = read_text("dxdy", text).unwrap();
        let g = map.georef.unwrap();
        // West edge 10, 2 wide: centres at x 11 and 13. South edge 20, 5 high: centres at
        // y 22.5, 27.5 and 32.5, north row first.
        assert_eq!(g.position(0.0, 0.0), (11.0, 32.5));
        assert_eq!(g.position(2.0, 1.0), (13.0, 22.5));
    }

    #[test]
    fn too_few_values_is_a_truncation_error() {
        let err = read_text("few", "ncols 2\nnrows 2\ncellsize 1\n1 2\n3\n").unwrap_err();
        assert!(matches!(err, RasterError::Format { .. }), "{err}");
        assert!(err.to_string().contains("3 values") && err.to_string().contains("few.asc"));
    }

    #[test]
    fn too_many_values_names_the_line() {
        let err = read_text("many", "ncols 2\nnrows 1\n1 2\n3\n").unwrap_err();
        assert!(err.to_string().contains("line 4"), "{err}");
    }

    #[test]
    fn a_word_among_values_names_the_line() {
        let err = read_text("word", "ncols 2\nnrows 2\n1 2\n3 x\n").unwrap_err();
        assert!(err.to_string().contains("line 4") && err.to_string().contains("\"x\""));
    }

    #[test]
    fn header_errors_are_format_errors() {
        for (name, text) in [
            ("nocols", "nrows 1\n1\n"),
            ("negative", "ncols -2\nnrows 1\n1 2\n"),
            ("unknown", "ncols 1\nnrows 1\ncolour red\n1\n"),
            ("empty", "ncols 0\nnrows 5\n"),
            ("long", &format!("ncols 1\nnrows 1\n{}\n", "9".repeat(100))),
        ] {
            let err = read_text(name, text).unwrap_err();
            assert!(matches!(err, RasterError::Format { .. }), "{name}: {err}");
        }
    }

    #[test]
    fn a_huge_declared_size_is_a_limit() {
        let err = read_text("huge", "ncols 100000000\nnrows 100000000\n1\n").unwrap_err();
        assert!(matches!(err, RasterError::Limit { .. }), "{err}");
    }
}
