//! ESRI ASCII grids (`.asc`, "ARC/INFO ASCII GRID", ESRI ArcGIS documentation "ESRI ASCII
//! raster format"): a `key value` header, then `nrows × ncols` decimal values, north row first,
//! separated by any whitespace.
//!
//! Header keys, in any order and any case: `ncols`, `nrows`, `xllcorner` or `xllcenter`,
//! `yllcorner` or `yllcenter`, `cellsize` (or GDAL's `dx` and `dy`), optional `nodata_value`.
//! The `ll` position is the lower-left cell's outer corner or its centre; [`Georef`] is
//! centre-based, so a corner moves by half a cell. The format names no CRS; the `.prj` file
//! GIS tools write beside it (WKT, ESRI's or OGC's) does, and is read for the two CRSs the
//! world tilings take: WGS 84 longitude/latitude (EPSG:4326) and Web Mercator (EPSG:3857).
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
    let georef = header.georef().map(|g| Georef {
        crs: sidecar_crs(path),
        ..g
    });
    Ok(Heightmap::new(heights, step, georef))
}

/// The longest `.prj` read: a WKT CRS is a few kilobytes.
const MAX_PRJ_BYTES: u64 = 64 * 1024;

/// The CRS the `.prj` beside `path` names, [`Crs::Unknown`] when there is none or it names
/// another.
fn sidecar_crs(path: &Path) -> Crs {
    use std::io::Read as _;
    let mut text = String::new();
    let read = ["prj", "PRJ"].iter().find_map(|ext| {
        let f = std::fs::File::open(path.with_extension(ext)).ok()?;
        f.take(MAX_PRJ_BYTES).read_to_string(&mut text).ok()
    });
    match read {
        Some(_) => crs_of_wkt(&text),
        None => Crs::Unknown,
    }
}

/// Recognises WGS 84 geographic and Web Mercator in WKT 1 (OGC's or ESRI's) or WKT 2, by the
/// names those CRSs go by; anything else is [`Crs::Unknown`] (ingest then says to reproject).
fn crs_of_wkt(wkt: &str) -> Crs {
    let w: String = wkt
        .to_ascii_uppercase()
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect();
    let projected = ["PROJCS[", "PROJCRS[", "PROJECTEDCRS["]
        .iter()
        .any(|k| w.starts_with(k));
    let geographic = ["GEOGCS[", "GEOGCRS[", "GEOGRAPHICCRS[", "GEODCRS["]
        .iter()
        .any(|k| w.starts_with(k));
    let wgs84 = ["WGS84", "WGS_84", "WGS_1984"]
        .iter()
        .any(|k| w.contains(k));
    if projected {
        let mercator = [
            "PSEUDO-MERCATOR",
            "PSEUDO_MERCATOR",
            "WEB_MERCATOR",
            "MERCATOR_AUXILIARY_SPHERE",
            "POPULAR_VISUALISATION",
        ]
        .iter()
        .any(|k| w.contains(k));
        if mercator && wgs84 {
            return Crs::WebMercator;
        }
    } else if geographic && wgs84 {
        return Crs::Geographic;
    }
    Crs::Unknown
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
                let size = value.size(path, "cellsize")?;
                (header.dx, header.dy) = (Some(size), Some(size));
            }
            "dx" => header.dx = Some(value.size(path, "dx")?),
            "dy" => header.dy = Some(value.size(path, "dy")?),
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

    /// A cell size: the grid runs east and north from the lower-left corner, so a negative
    /// one (which GeoTIFF uses for north-up rows) would mirror the data out of the cell the
    /// corner names.
    fn size(&self, path: &Path, key: &str) -> Result<f64, RasterError> {
        match self.number(path)? {
            v if v.is_finite() && v > 0.0 => Ok(v),
            _ => Err(RasterError::format(
                path,
                format!(
                    "line {}: {key} must be a positive number, got {:?}",
                    self.line, self.text
                ),
            )),
        }
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

    /// The CRS comes from a `.prj` beside the grid, as GIS tools write it (ESRI's WKT here,
    /// OGC's and WKT 2 below); without one, or naming another CRS, it stays unknown.
    #[test]
    fn a_prj_beside_the_grid_names_its_crs() {
        let text = "ncols 2\nnrows 2\nxllcorner -72\nyllcorner 44\ncellsize 0.001\n1 2\n3 4\n";
        let crs = |name: &str, prj: Option<&str>| {
            let dir = scratch_dir(&format!("asc_prj_{name}"));
            let path = dir.join("g.asc");
            std::fs::write(&path, text).unwrap();
            let _ = std::fs::remove_file(dir.join("g.prj"));
            if let Some(p) = prj {
                std::fs::write(dir.join("g.prj"), p).unwrap();
            }
            read(&path, &ReadOptions::default())
                .unwrap()
                .georef
                .unwrap()
                .crs
        };
        const ESRI_WGS84: &str = r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;
        const OGC_WGS84: &str = r#"GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4326"]]"#;
        const WKT2_WGS84: &str = "GEOGCRS[\"WGS 84\",\n  DATUM[\"World Geodetic System 1984\",\n    ELLIPSOID[\"WGS 84\",6378137,298.257223563]],\n  CS[ellipsoidal,2],\n  ID[\"EPSG\",4326]]";
        const ESRI_WEB: &str = r#"PROJCS["WGS_1984_Web_Mercator_Auxiliary_Sphere",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Mercator_Auxiliary_Sphere"],UNIT["Meter",1.0]]"#;
        const OGC_WEB: &str = r#"PROJCS["WGS 84 / Pseudo-Mercator",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]]],PROJECTION["Mercator_1SP"],AUTHORITY["EPSG","3857"]]"#;
        const UTM: &str = r#"PROJCS["WGS 84 / UTM zone 32N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]]],PROJECTION["Transverse_Mercator"],AUTHORITY["EPSG","32632"]]"#;
        const NAD83: &str = r#"GEOGCS["NAD83",DATUM["North_American_Datum_1983",SPHEROID["GRS 1980",6378137,298.257222101]],UNIT["degree",0.0174532925199433]]"#;
        assert_eq!(crs("none", None), Crs::Unknown);
        for (name, prj, want) in [
            ("esri_wgs84", ESRI_WGS84, Crs::Geographic),
            ("ogc_wgs84", OGC_WGS84, Crs::Geographic),
            ("wkt2_wgs84", WKT2_WGS84, Crs::Geographic),
            ("esri_web", ESRI_WEB, Crs::WebMercator),
            ("ogc_web", OGC_WEB, Crs::WebMercator),
            ("utm", UTM, Crs::Unknown),
            ("nad83", NAD83, Crs::Unknown),
            ("junk", "not a CRS", Crs::Unknown),
        ] {
            assert_eq!(crs(name, Some(prj)), want, "{name}");
        }
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

    /// A cell size of 0 or less, or not a number, is refused by its line: a negative one
    /// mirrored the grid into the cell west and south of the corner it names.
    #[test]
    fn cell_sizes_must_be_positive() {
        for (key, value, line) in [
            ("cellsize", "-0.01", 5),
            ("cellsize", "0", 5),
            ("cellsize", "inf", 5),
            ("dx", "-2", 5),
            ("DY", "0", 6),
        ] {
            let header = match key {
                "cellsize" => format!("cellsize {value}\n"),
                "dx" => format!("dx {value}\ndy 1\n"),
                _ => format!("dx 1\n{key} {value}\n"),
            };
            let text = format!("ncols 2\nnrows 1\nxllcorner 10\nyllcorner 46\n{header}1 2\n");
            let err = read_text("neg", &text).unwrap_err();
            let want = format!(
                "line {line}: {} must be a positive number, got \"{value}\"",
                key.to_ascii_lowercase()
            );
            assert!(err.to_string().ends_with(&want), "{key} {value}: {err}");
            assert!(err.to_string().contains("neg.asc"), "{err}");
        }
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
