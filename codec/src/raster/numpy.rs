//! NumPy arrays (NEP 1, "A simple file format for NumPy arrays"), decoded by the `npyz` crate:
//! a `.npy` holds one array, a `.npz` is a zip of `.npy` members named by key.
//!
//! A heightmap is a 2-D array of int8–32, uint8–32 or float32/64 (rows first, north row first);
//! NaN in a float array is no-data. From an `.npz` we read [`ReadOptions::npz_key`], else the
//! array named `elevation`, else the only 2-D array.
//!
//! Placement: `.npz` files such as matplotlib's `jacksboro_fault_dem.npz` store scalar bounds
//! next to the array (`xmin`, `ymin`, `ymax`, `dx`, `dy`, optional `xmax`). The extents decide
//! whether the bounds are cell edges (extent = n·d, matplotlib's case) or centres
//! (extent = (n − 1)·d). The file's `ymin` and `ymax` can be swapped (matplotlib's `ymin` is
//! the north edge), so north is the larger. No CRS is stored: bounds within ±180°/±90° read
//! as longitude/latitude.
//!
//! `npyz` trusts the header's shape (its product can overflow) and allocates the header's
//! declared length, so each header is read and checked here first, then handed to `npyz`.

use std::io::{BufReader, Cursor, Read};
use std::path::Path;

use npyz::npz::NpzArchive;
use npyz::{DType, NpyFile, Order, TypeChar};

use super::error::check_shape;
use super::{int_heights, open, Crs, Georef, Heightmap, RasterError, ReadOptions};
use crate::grid::Grid;

/// Longest `.npy` header accepted (NumPy itself refuses more than 10,000 bytes by default).
const MAX_HEADER_BYTES: usize = 1 << 16;
/// Deepest bracket nesting accepted in a header: a shape and a dtype need a few levels, and
/// the limit keeps a hostile header from exhausting the parser's stack.
const MAX_HEADER_DEPTH: usize = 16;
/// The array an `.npz` heightmap is found under when the caller names none.
const DEFAULT_KEY: &str = "elevation";
/// Relative slack when matching an extent against n·d or (n − 1)·d.
const EXTENT_TOLERANCE: f64 = 1e-6;

/// Reads a 2-D `.npy` array.
pub(super) fn read_npy(path: &Path, opts: &ReadOptions) -> Result<Heightmap, RasterError> {
    let npy = open_array(path, BufReader::new(open(path)?), "the array")?;
    let (heights, step) = read_2d(path, npy, "the array", opts.max_samples)?;
    Ok(Heightmap::new(heights, step, None))
}

/// Reads one 2-D array of an `.npz`, placed by its bounds keys when present.
pub(super) fn read_npz(path: &Path, opts: &ReadOptions) -> Result<Heightmap, RasterError> {
    let mut archive = NpzArchive::new(BufReader::new(open(path)?))
        .map_err(|e| RasterError::from_read(path, e))?;
    // Sorted: the zip's name table has no stable order, and messages list the keys.
    let mut keys: Vec<String> = archive.array_names().map(str::to_owned).collect();
    keys.sort();

    // Which array: the caller's, else `elevation`, else the only 2-D one.
    let key = choose_key(path, &mut archive, &keys, opts.npz_key.as_deref())?;
    let what = format!("array {key:?}");
    let npy = open_member(path, &mut archive, &key)?;
    let (heights, step) = read_2d(path, npy, &what, opts.max_samples)?;

    // Placement from the scalar bounds keys, when all are there and agree with the shape.
    let georef = bounds_georef(path, &mut archive, &keys, heights.rows(), heights.cols())?;
    Ok(Heightmap::new(heights, step, georef))
}

fn choose_key<R: Read + std::io::Seek>(
    path: &Path,
    archive: &mut NpzArchive<R>,
    keys: &[String],
    requested: Option<&str>,
) -> Result<String, RasterError> {
    let listing = || keys.join(", ");
    if let Some(key) = requested {
        return if keys.iter().any(|k| k == key) {
            Ok(key.to_owned())
        } else {
            Err(RasterError::parameter(
                path,
                format!("no array named {key:?}; its arrays are: {}", listing()),
            ))
        };
    }
    if keys.iter().any(|k| k == DEFAULT_KEY) {
        return Ok(DEFAULT_KEY.to_owned());
    }
    let mut two_d = Vec::new();
    for key in keys {
        if open_member(path, archive, key)?.shape().len() == 2 {
            two_d.push(key.clone());
        }
    }
    match two_d.as_slice() {
        [only] => Ok(only.clone()),
        [] => Err(RasterError::unsupported(
            path,
            format!("no 2-D array among its arrays: {}", listing()),
        )),
        several => Err(RasterError::parameter(
            path,
            format!(
                "several 2-D arrays ({}); name one (--key NAME)",
                several.join(", ")
            ),
        )),
    }
}

/// Opens the `.npz` member holding array `key`, its header checked.
fn open_member<'a, R: Read + std::io::Seek>(
    path: &Path,
    archive: &'a mut NpzArchive<R>,
    key: &str,
) -> Result<NpyFile<impl Read + 'a>, RasterError> {
    let name = npyz::npz::file_name_from_array_name(key);
    let member = archive
        .zip_archive()
        .by_name(&name)
        .map_err(|e| RasterError::format(path, format!("member {name}: {e}")))?;
    open_array(path, member, &format!("array {key:?}"))
}

/// An `.npy` stream whose header bytes were read (and checked) before `npyz` saw them.
type Replayed<R> = std::io::Chain<Cursor<Vec<u8>>, R>;

/// Reads and checks an `.npy` header from `reader`, then hands the same bytes to `npyz`.
fn open_array<R: Read>(
    path: &Path,
    mut reader: R,
    what: &str,
) -> Result<NpyFile<Replayed<R>>, RasterError> {
    let read_err = |e| RasterError::from_read(path, e);

    // Magic, version and header length (2 bytes in version 1, 4 in versions 2 and 3).
    let mut prefix = vec![0u8; 8];
    reader.read_exact(&mut prefix).map_err(read_err)?;
    if &prefix[..6] != b"\x93NUMPY" {
        return Err(RasterError::format(
            path,
            format!("{what} is not a .npy array (no \\x93NUMPY magic)"),
        ));
    }
    let len_bytes = match prefix[6] {
        1 => 2,
        2 | 3 => 4,
        v => {
            return Err(RasterError::unsupported(
                path,
                format!("{what}: .npy format version {v}"),
            ))
        }
    };
    let mut len = [0u8; 4];
    reader.read_exact(&mut len[..len_bytes]).map_err(read_err)?;
    prefix.extend_from_slice(&len[..len_bytes]);
    let header_len = u32::from_le_bytes(len) as usize;
    if header_len > MAX_HEADER_BYTES {
        return Err(RasterError::format(
            path,
            format!("{what}: a {header_len}-byte header (at most {MAX_HEADER_BYTES})"),
        ));
    }

    // The header text: bounded nesting, and a shape whose products cannot overflow.
    let start = prefix.len();
    prefix.resize(start + header_len, 0);
    reader.read_exact(&mut prefix[start..]).map_err(read_err)?;
    check_header(path, &prefix[start..], what)?;

    NpyFile::new(Cursor::new(prefix).chain(reader)).map_err(read_err)
}

/// Refuses a header that `npyz` could not parse safely: nesting deeper than
/// [`MAX_HEADER_DEPTH`], or a shape whose element count overflows u64.
fn check_header(path: &Path, header: &[u8], what: &str) -> Result<(), RasterError> {
    let malformed = |message: &str| RasterError::format(path, format!("{what}: {message}"));
    let mut depth = 0usize;
    for &b in header {
        match b {
            b'(' | b'[' | b'{' => depth += 1,
            b')' | b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
        if depth > MAX_HEADER_DEPTH {
            return Err(malformed("header nests too deeply"));
        }
    }
    let text = std::str::from_utf8(header).map_err(|_| malformed("header is not text"))?;
    let dims = shape_of(text).ok_or_else(|| malformed("header has no readable shape"))?;
    // Every prefix product `npyz` forms is at most the product of the non-zero dimensions.
    dims.iter()
        .filter(|&&d| d != 0)
        .try_fold(1u64, |acc, &d| acc.checked_mul(d))
        .map(|_| ())
        .ok_or_else(|| malformed("its shape's element count overflows"))
}

/// The dimensions in `'shape': (a, b, …)`.
fn shape_of(header: &str) -> Option<Vec<u64>> {
    let at = header
        .find("'shape'")
        .or_else(|| header.find("\"shape\""))?;
    let rest = header.get(at + "'shape'".len()..)?.trim_start();
    let rest = rest.strip_prefix(':')?.trim_start().strip_prefix('(')?;
    let inside = rest.get(..rest.find(')')?)?;
    inside
        .split(',')
        .map(str::trim)
        .filter(|d| !d.is_empty())
        // Python 2 wrote long integers with an `L` suffix.
        .map(|d| d.trim_end_matches('L').parse().ok())
        .collect()
}

/// Reads a 2-D array into heights (row-major, NaN for no-data) and its step.
fn read_2d<R: Read>(
    path: &Path,
    npy: NpyFile<R>,
    what: &str,
    max_samples: usize,
) -> Result<(Grid<f64>, Option<f64>), RasterError> {
    // Shape and order, checked before anything is allocated.
    let &[rows, cols] = npy.shape() else {
        return Err(RasterError::unsupported(
            path,
            format!(
                "{what} has shape {:?}; zerotile reads 2-D arrays",
                npy.shape()
            ),
        ));
    };
    check_shape(path, rows, cols, max_samples)?;
    let (rows, cols) = (rows as usize, cols as usize);
    let order = npy.order();

    // Samples in file order, as f64.
    let (samples, step) = read_samples(path, npy, what)?;

    // Fortran order stores columns first: transpose to row-major.
    if samples.len() != rows * cols {
        return Err(RasterError::format(
            path,
            format!(
                "{what}: {} samples for a {rows}×{cols} shape",
                samples.len()
            ),
        ));
    }
    let samples = match order {
        Order::C => samples,
        Order::Fortran => (0..rows * cols)
            .map(|i| samples[(i % cols) * rows + i / cols])
            .collect(),
    };
    let grid =
        Grid::new(rows, cols, samples).map_err(|e| RasterError::format(path, e.to_string()))?;
    Ok((grid, step))
}

/// All samples of `npy` as f64, with the step of its dtype (1 for integers, none for floats).
fn read_samples<R: Read>(
    path: &Path,
    npy: NpyFile<R>,
    what: &str,
) -> Result<(Vec<f64>, Option<f64>), RasterError> {
    let DType::Plain(dtype) = npy.dtype() else {
        return Err(RasterError::unsupported(
            path,
            format!("{what} has a structured dtype {}", npy.dtype().descr()),
        ));
    };
    let read_err = |e| RasterError::from_read(path, e);
    let ints = |v: Vec<f64>| Ok((v, Some(1.0)));
    match (dtype.type_char(), dtype.size_field()) {
        (TypeChar::Int, 1) => ints(int_heights(&npy.into_vec::<i8>().map_err(read_err)?, None)),
        (TypeChar::Int, 2) => ints(int_heights(&npy.into_vec::<i16>().map_err(read_err)?, None)),
        (TypeChar::Int, 4) => ints(int_heights(&npy.into_vec::<i32>().map_err(read_err)?, None)),
        (TypeChar::Uint, 1) => ints(int_heights(&npy.into_vec::<u8>().map_err(read_err)?, None)),
        (TypeChar::Uint, 2) => ints(int_heights(&npy.into_vec::<u16>().map_err(read_err)?, None)),
        (TypeChar::Uint, 4) => ints(int_heights(&npy.into_vec::<u32>().map_err(read_err)?, None)),
        (TypeChar::Float, 4) => {
            let v = npy.into_vec::<f32>().map_err(read_err)?;
            Ok((v.into_iter().map(f64::from).collect(), None))
        }
        (TypeChar::Float, 8) => Ok((npy.into_vec::<f64>().map_err(read_err)?, None)),
        _ => Err(RasterError::unsupported(
            path,
            format!(
                "{what} has dtype {dtype}; zerotile reads int8–32, uint8–32, float32 and float64"
            ),
        )),
    }
}

/// The georeference from scalar bounds keys, `None` when any is missing or they disagree
/// with the array's shape.
fn bounds_georef<R: Read + std::io::Seek>(
    path: &Path,
    archive: &mut NpzArchive<R>,
    keys: &[String],
    rows: usize,
    cols: usize,
) -> Result<Option<Georef>, RasterError> {
    let mut scalar = |key: &str| -> Result<Option<f64>, RasterError> {
        if !keys.iter().any(|k| k == key) {
            return Ok(None);
        }
        let npy = open_member(path, archive, key)?;
        if !npy.shape().is_empty() {
            return Ok(None);
        }
        let what = format!("array {key:?}");
        let (values, _) = match read_samples(path, npy, &what) {
            Ok(v) => v,
            // A bounds key of another type is not the convention we read: no placement.
            Err(RasterError::Unsupported { .. }) => return Ok(None),
            Err(e) => return Err(e),
        };
        Ok(values.first().copied().filter(|v| v.is_finite()))
    };
    let (Some(dx), Some(dy), Some(xmin), Some(ymin), Some(ymax)) = (
        scalar("dx")?,
        scalar("dy")?,
        scalar("xmin")?,
        scalar("ymin")?,
        scalar("ymax")?,
    ) else {
        return Ok(None);
    };
    let xmax = scalar("xmax")?;
    if dx <= 0.0 || dy <= 0.0 {
        return Ok(None);
    }

    // Edges or centres, from the extents; the west edge's kind follows x's extent when
    // there is an xmax, else y's.
    let (south, north) = (ymin.min(ymax), ymin.max(ymax));
    let Some(y_edges) = bounds_are_edges(north - south, rows, dy) else {
        return Ok(None);
    };
    let x_edges = match xmax {
        Some(xmax) => match bounds_are_edges(xmax - xmin, cols, dx) {
            Some(edges) => edges,
            None => return Ok(None),
        },
        None => y_edges,
    };
    let x0 = if x_edges { xmin + 0.5 * dx } else { xmin };
    let y0 = if y_edges { north - 0.5 * dy } else { north };
    // Degrees when the cell centres are longitudes in ±180° or, as global grids often run,
    // 0..360 (past 180° they go round the world, as a GeoTIFF's do). Centres, not `xmin`
    // plus the columns, which is half a cell past the east edge when the bounds are
    // centres: a grid of centres ending at 179.9° was refused as not degrees. Not the edges
    // either: a global grid's centres may start at -180° or 0°, its edge half a cell out.
    let (first, last) = (x0, x0 + (cols.max(1) - 1) as f64 * dx);
    let within = |lo: f64, hi: f64| first >= lo - DEGREE_SLACK && last <= hi + DEGREE_SLACK;
    let degrees = (within(-180.0, 180.0) || within(0.0, 360.0)) && south >= -90.0 && north <= 90.0;
    let crs = if degrees {
        Crs::Geographic
    } else {
        Crs::Unknown
    };
    Ok(Some(Georef::north_up(crs, x0, y0, dx, dy)))
}

/// Degrees a centre may pass a longitude range by: bounds stored as f32 (0.1 is 0.1000000015)
/// put the 1,800th centre 3e-6° out.
const DEGREE_SLACK: f64 = 1e-4;

/// `Some(true)` when `extent` spans `n` cells of size `d`, `Some(false)` when it spans `n − 1`
/// (bounds at the outer centres), `None` when neither.
fn bounds_are_edges(extent: f64, n: usize, d: f64) -> Option<bool> {
    let matches =
        |cells: usize| (extent - cells as f64 * d).abs() <= EXTENT_TOLERANCE * extent.abs().max(d);
    if matches(n) {
        Some(true)
    } else if n >= 1 && matches(n - 1) {
        Some(false)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{scratch_dir, shared_data};

    /// A `.npy` file: version 1 header for `descr` and `shape`, then `data`.
    fn npy_bytes(descr: &str, fortran: bool, shape: &str, data: &[u8]) -> Vec<u8> {
        let fortran = if fortran { "True" } else { "False" };
        let mut header =
            format!("{{'descr': '{descr}', 'fortran_order': {fortran}, 'shape': {shape}, }}");
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
        bytes.extend_from_slice(header.as_bytes());
        bytes.extend_from_slice(data);
        bytes
    }

    fn write_npy(test: &str, bytes: &[u8]) -> std::path::PathBuf {
        let path = scratch_dir(test).join(format!("{test}.npy"));
        std::fs::write(&path, bytes).unwrap();
        path
    }

    #[test]
    fn reads_jacksboro_elevation_with_its_bounds() {
        let map = read_npz(
            &shared_data("dem/jacksboro_fault_dem.npz"),
            &ReadOptions::default(),
        )
        .unwrap();
        assert_eq!((map.heights.rows(), map.heights.cols()), (344, 403));
        assert_eq!(map.min_max(), Some((236.0, 1076.0)));
        assert_eq!((map.step, map.nodata_count), (Some(1.0), 0));

        // Bounds are cell edges, 3″ apart; the north edge is the file's "ymin" (36.7329).
        let g = map.georef.unwrap();
        assert_eq!(g.crs, Crs::Geographic);
        let (lon, lat) = g.position(0.0, 0.0);
        let d = 1.0 / 1200.0;
        assert!((lon - (-84.41375 + d / 2.0)).abs() < 1e-9, "{lon}");
        assert!((lat - (36.73291666666667 - d / 2.0)).abs() < 1e-9, "{lat}");
        let (lon, lat) = g.position(343.0, 402.0);
        assert!((lon - (-84.07791666666667 - d / 2.0)).abs() < 1e-9, "{lon}");
        assert!((lat - (36.44625 + d / 2.0)).abs() < 1e-9, "{lat}");
    }

    /// An infinity is refused where it is read, naming the file and the sample: NaN is
    /// no-data and gets filled, an infinity is neither and once became a dataset whose
    /// height range was JSON null.
    #[test]
    fn infinite_heights_are_refused_by_file_and_sample() {
        for (test, bad) in [
            ("npy-inf", f64::INFINITY),
            ("npy-neginf", f64::NEG_INFINITY),
        ] {
            let data: Vec<u8> = [1.0, 2.0, 3.0, 4.0, bad, 6.0]
                .iter()
                .flat_map(|v: &f64| v.to_le_bytes())
                .collect();
            let path = write_npy(test, &npy_bytes("<f8", false, "(2, 3)", &data));
            let err = crate::raster::read_heightmap(&path, &ReadOptions::default()).unwrap_err();
            let message = err.to_string();
            assert!(matches!(err, RasterError::Format { .. }), "{message}");
            assert!(
                message.contains(&format!("{test}.npy"))
                    && message.contains("row 1, column 1")
                    && message.contains("not a finite height"),
                "{message}"
            );
        }
    }

    #[test]
    fn a_missing_npz_key_lists_the_keys() {
        let opts = ReadOptions {
            npz_key: Some("height".into()),
            ..ReadOptions::default()
        };
        let err = read_npz(&shared_data("dem/jacksboro_fault_dem.npz"), &opts).unwrap_err();
        assert!(matches!(err, RasterError::Parameter { .. }), "{err}");
        let message = err.to_string();
        assert!(
            message.contains("elevation") && message.contains("dx"),
            "{message}"
        );

        // A scalar key is not a heightmap.
        let opts = ReadOptions {
            npz_key: Some("dx".into()),
            ..ReadOptions::default()
        };
        let err = read_npz(&shared_data("dem/jacksboro_fault_dem.npz"), &opts).unwrap_err();
        assert!(matches!(err, RasterError::Unsupported { .. }), "{err}");
    }

    #[test]
    fn reads_a_small_npy_in_c_and_fortran_order() {
        let data: Vec<u8> = [1i16, 2, 3, -4, 5, 6]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let path = write_npy("npy_c", &npy_bytes("<i2", false, "(2, 3)", &data));
        let map = read_npy(&path, &ReadOptions::default()).unwrap();
        assert_eq!((map.heights.rows(), map.heights.cols()), (2, 3));
        assert_eq!(map.heights.data(), &[1.0, 2.0, 3.0, -4.0, 5.0, 6.0]);
        assert_eq!((map.step, map.georef), (Some(1.0), None));

        // The same bytes in Fortran order are the columns (1, 2), (3, −4), (5, 6).
        let path = write_npy("npy_f", &npy_bytes("<i2", true, "(2, 3)", &data));
        let map = read_npy(&path, &ReadOptions::default()).unwrap();
        assert_eq!(map.heights.data(), &[1.0, 3.0, 5.0, 2.0, -4.0, 6.0]);
    }

    #[test]
    fn float_nan_is_nodata() {
        let data: Vec<u8> = [1.5f64, f64::NAN]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect();
        let path = write_npy("npy_nan", &npy_bytes(">f8", false, "(1, 2)", &data));
        let map = read_npy(&path, &ReadOptions::default()).unwrap();
        assert_eq!((map.nodata_count, map.step), (1, None));
        assert_eq!(map.min_max(), Some((1.5, 1.5)));
    }

    #[test]
    fn refuses_other_shapes_and_dtypes() {
        let cases = [
            ("npy_3d", npy_bytes("<u1", false, "(1, 2, 2)", &[0; 4])),
            ("npy_1d", npy_bytes("<u1", false, "(4,)", &[0; 4])),
            ("npy_complex", npy_bytes("<c8", false, "(1, 1)", &[0; 8])),
            ("npy_i8", npy_bytes("<i8", false, "(1, 1)", &[0; 8])),
        ];
        for (name, bytes) in cases {
            let err = read_npy(&write_npy(name, &bytes), &ReadOptions::default()).unwrap_err();
            assert!(
                matches!(err, RasterError::Unsupported { .. }),
                "{name}: {err}"
            );
        }
    }

    #[test]
    fn hostile_headers_are_errors_not_panics() {
        let cases = [
            // 2^40 × 2^40 overflows u64: npyz alone would overflow computing its length.
            (
                "npy_overflow",
                npy_bytes("<u1", false, "(1099511627776, 1099511627776)", &[]),
            ),
            (
                "npy_deep",
                npy_bytes(
                    "<u1",
                    false,
                    &format!("{}1{}", "(".repeat(999), ")".repeat(999)),
                    &[],
                ),
            ),
            ("npy_noshape", b"\x93NUMPY\x01\x00\x04\x00{}  ".to_vec()),
            ("npy_magic", b"PK\x03\x04 not numpy".to_vec()),
        ];
        for (name, bytes) in cases {
            let err = read_npy(&write_npy(name, &bytes), &ReadOptions::default()).unwrap_err();
            assert!(matches!(err, RasterError::Format { .. }), "{name}: {err}");
        }
        // Large but representable: a limit, before any allocation.
        let bytes = npy_bytes("<u1", false, "(100000, 100000)", &[]);
        let err = read_npy(&write_npy("npy_large", &bytes), &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Limit { .. }), "{err}");
    }

    /// An `.npz` of `(name, .npy bytes)` members, stored uncompressed as NumPy's `savez` does.
    fn write_npz(test: &str, members: &[(&str, Vec<u8>)]) -> std::path::PathBuf {
        use std::io::Write;
        let path = scratch_dir(test).join(format!("{test}.npz"));
        let mut zip = npyz::zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
        let options = npyz::zip::write::FileOptions::default()
            .compression_method(npyz::zip::CompressionMethod::Stored);
        for (name, bytes) in members {
            zip.start_file(format!("{name}.npy"), options).unwrap();
            zip.write_all(bytes).unwrap();
        }
        zip.finish().unwrap();
        path
    }

    #[test]
    fn picks_the_only_2d_array_and_will_not_guess_between_several() {
        let scalar = npy_bytes("<f8", false, "()", &1.0f64.to_le_bytes());
        let grid = npy_bytes("|u1", false, "(2, 2)", &[1, 2, 3, 4]);
        let path = write_npz(
            "npz_only",
            &[("scale", scalar.clone()), ("dem", grid.clone())],
        );
        let map = read_npz(&path, &ReadOptions::default()).unwrap();
        assert_eq!(map.heights.data(), &[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(map.georef, None);

        // Two different 2-D arrays: no guess, and --key reads the one it names.
        let other = npy_bytes("|u1", false, "(2, 2)", &[5, 6, 7, 8]);
        let path = write_npz("npz_several", &[("a", grid.clone()), ("b", other)]);
        let err = read_npz(&path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Parameter { .. }), "{err}");
        assert!(err.to_string().contains("a, b"), "{err}");
        for (key, want) in [("a", [1.0, 2.0, 3.0, 4.0]), ("b", [5.0, 6.0, 7.0, 8.0])] {
            let opts = ReadOptions {
                npz_key: Some(key.into()),
                ..ReadOptions::default()
            };
            let map = read_npz(&path, &opts).unwrap();
            assert_eq!(map.heights.data(), &want, "--key {key}");
        }

        let path = write_npz("npz_none", &[("scale", scalar)]);
        let err = read_npz(&path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Unsupported { .. }), "{err}");
    }

    #[test]
    fn bounds_tell_edges_from_centres() {
        assert_eq!(bounds_are_edges(4.0, 4, 1.0), Some(true));
        assert_eq!(bounds_are_edges(3.0, 4, 1.0), Some(false));
        assert_eq!(bounds_are_edges(3.5, 4, 1.0), None);
        // One sample: equal bounds are its centre, bounds one cell apart its edges.
        assert_eq!(bounds_are_edges(0.0, 1, 1.0), Some(false));
        assert_eq!(bounds_are_edges(1.0, 1, 1.0), Some(true));
        // A cell size other than 1, and the relative slack: 1e-6 of the extent, not less.
        assert_eq!(bounds_are_edges(2.0, 4, 0.5), Some(true));
        assert_eq!(bounds_are_edges(1.5, 4, 0.5), Some(false));
        assert_eq!(bounds_are_edges(2.000_001, 4, 0.5), Some(true));
        assert_eq!(bounds_are_edges(2.000_01, 4, 0.5), None);
    }

    /// Every sample type we read, at its extremes, with the step of its kind; a missing arm
    /// would refuse the type as unsupported.
    #[test]
    fn reads_every_supported_dtype() {
        fn le<T: Copy, const N: usize>(values: &[T], bytes: fn(T) -> [u8; N]) -> Vec<u8> {
            values.iter().flat_map(|&v| bytes(v)).collect()
        }
        let cases = [
            (
                "|i1",
                le(&[i8::MIN, i8::MAX], i8::to_le_bytes),
                [-128.0, 127.0],
                Some(1.0),
            ),
            (
                "<i2",
                le(&[i16::MIN, i16::MAX], i16::to_le_bytes),
                [-32768.0, 32767.0],
                Some(1.0),
            ),
            (
                "<i4",
                le(&[i32::MIN, i32::MAX], i32::to_le_bytes),
                [-2_147_483_648.0, 2_147_483_647.0],
                Some(1.0),
            ),
            ("|u1", vec![0, u8::MAX], [0.0, 255.0], Some(1.0)),
            (
                "<u2",
                le(&[0, u16::MAX], u16::to_le_bytes),
                [0.0, 65535.0],
                Some(1.0),
            ),
            (
                "<u4",
                le(&[0, u32::MAX], u32::to_le_bytes),
                [0.0, 4_294_967_295.0],
                Some(1.0),
            ),
            (
                "<f4",
                le(&[1.5f32, -2.25], f32::to_le_bytes),
                [1.5, -2.25],
                None,
            ),
            (
                "<f8",
                le(&[1.5f64, -2.25], f64::to_le_bytes),
                [1.5, -2.25],
                None,
            ),
        ];
        for (descr, data, want, step) in cases {
            let name = format!("npy_dtype_{}", &descr[1..]);
            let path = write_npy(&name, &npy_bytes(descr, false, "(1, 2)", &data));
            let map = read_npy(&path, &ReadOptions::default()).unwrap();
            assert_eq!((map.heights.data(), map.step), (&want[..], step), "{descr}");
        }
    }

    /// The header checks on their own: nesting up to [`MAX_HEADER_DEPTH`], and shapes whose
    /// non-zero dimensions multiply past u64 (a zero dimension does not excuse the others).
    #[test]
    fn header_check_bounds_nesting_and_shape_products() {
        let path = Path::new("h.npy");
        let check = |header: String| check_header(path, header.as_bytes(), "the array");
        let nested = |depth: usize| {
            format!(
                "{{'shape': (1, 1), 'x': {}{}}}",
                "[".repeat(depth - 1),
                "]".repeat(depth - 1)
            )
        };
        check(nested(MAX_HEADER_DEPTH)).unwrap();
        let err = check(nested(MAX_HEADER_DEPTH + 1)).unwrap_err();
        assert!(err.to_string().contains("nests too deeply"), "{err}");

        check("{'shape': (2, 3), }".into()).unwrap();
        check("{'shape': (0, 4294967296, 4294967295), }".into()).unwrap();
        for shape in ["(4294967296, 4294967296)", "(0, 4294967296, 4294967296)"] {
            let err = check(format!("{{'shape': {shape}, }}")).unwrap_err();
            assert!(err.to_string().contains("overflows"), "{shape}: {err}");
        }
    }

    /// A header longer than [`MAX_HEADER_BYTES`] is refused by its declared length, before
    /// it is read; one of exactly that length is read.
    #[test]
    fn header_length_limit_is_inclusive() {
        let path = Path::new("long.npy");
        let version_2 = |len: u32, header: &[u8]| {
            let mut bytes = b"\x93NUMPY\x02\x00".to_vec();
            bytes.extend_from_slice(&len.to_le_bytes());
            bytes.extend_from_slice(header);
            bytes.push(0);
            bytes
        };
        let mut header = b"{'descr': '|u1', 'fortran_order': False, 'shape': (1, 1), }".to_vec();
        header.resize(MAX_HEADER_BYTES - 1, b' ');
        header.push(b'\n');
        let bytes = version_2(MAX_HEADER_BYTES as u32, &header);
        let npy = open_array(path, Cursor::new(bytes), "the array").unwrap();
        assert_eq!(npy.shape(), &[1, 1]);

        let too_long = MAX_HEADER_BYTES as u32 + 1;
        let Err(err) = open_array(path, Cursor::new(version_2(too_long, &header)), "the array")
        else {
            panic!("a {too_long}-byte header was read");
        };
        assert!(
            matches!(err, RasterError::Format { .. })
                && err.to_string().contains("a 65537-byte header"),
            "{err}"
        );
    }

    /// Bounds with `xmax`, at the outer centres, in metres: placed as given, CRS unknown.
    #[test]
    fn npz_bounds_at_centres_with_xmax_in_metres() {
        let grid = npy_bytes("|u1", false, "(2, 3)", &[1, 2, 3, 4, 5, 6]);
        let g = placed_by_bounds(
            "npz_centres",
            grid,
            [10.0, 5.0, 500_000.0, 500_020.0, 4_000_005.0, 4_000_000.0],
        );
        assert_eq!(g.crs, Crs::Unknown);
        assert_eq!(g.position(0.0, 0.0), (500_000.0, 4_000_005.0));
        assert_eq!(g.position(1.0, 2.0), (500_020.0, 4_000_000.0));
    }

    /// Bounds that do not make a placement: a spacing that is not positive (either one), an
    /// `xmax` that fits neither reading; and longitudes that run past 180° are not degrees.
    #[test]
    fn npz_bounds_that_place_nothing_or_are_not_degrees() {
        let scalar = |v: f64| npy_bytes("<f8", false, "()", &v.to_le_bytes());
        let npz = |test: &str, dx: f64, dy: f64, xmin: f64, xmax: Option<f64>| {
            let mut members = vec![
                ("elevation", npy_bytes("|u1", false, "(2, 3)", &[0; 6])),
                ("dx", scalar(dx)),
                ("dy", scalar(dy)),
                ("xmin", scalar(xmin)),
                ("ymin", scalar(10.0)),
                ("ymax", scalar(30.0)),
            ];
            if let Some(xmax) = xmax {
                members.push(("xmax", scalar(xmax)));
            }
            let path = write_npz(test, &members);
            read_npz(&path, &ReadOptions::default()).unwrap().georef
        };
        // Rows: 2 cells of 10 between latitudes 10 and 30 (edges).
        let g = npz("npz_deg", 10.0, 10.0, 140.0, None).unwrap();
        assert_eq!(
            (g.crs, g.position(0.0, 0.0)),
            (Crs::Geographic, (145.0, 25.0))
        );
        // A negative spacing would mirror the raster (a zero one is refused later anyway).
        assert_eq!(npz("npz_dxneg", -10.0, 10.0, 140.0, None), None);
        assert_eq!(npz("npz_dyneg", 10.0, -10.0, 140.0, None), None);
        assert_eq!(npz("npz_xmax", 10.0, 10.0, 140.0, Some(165.0)), None);
        // West edge 170°, east edge 200°: a 0..360 grid's longitudes, as README says.
        let g = npz("npz_east", 10.0, 10.0, 170.0, None).unwrap();
        assert_eq!(
            (g.crs, g.position(0.0, 0.0)),
            (Crs::Geographic, (175.0, 25.0))
        );
        // Centres from 160° to 180°, cells of 10, and from -180° to -160°: a global grid's
        // first or last centres, the edge half a cell past ±180.
        let g = npz("npz_centres_east", 10.0, 10.0, 160.0, Some(180.0)).unwrap();
        assert_eq!(
            (g.crs, g.position(0.0, 2.0)),
            (Crs::Geographic, (180.0, 25.0))
        );
        let g = npz("npz_centres_west", 10.0, 10.0, -180.0, Some(-160.0)).unwrap();
        assert_eq!(
            (g.crs, g.position(0.0, 0.0)),
            (Crs::Geographic, (-180.0, 25.0))
        );
        // A 0..360 grid's centres from 0°: its west edge is -5°.
        let g = npz("npz_centres_zero", 10.0, 10.0, 0.0, Some(20.0)).unwrap();
        assert_eq!(g.crs, Crs::Geographic);
        // Past 360°, or across -180° from the west: not longitudes.
        let g = npz("npz_past_360", 10.0, 10.0, 340.0, None).unwrap();
        assert_eq!(g.crs, Crs::Unknown);
        let g = npz("npz_past_west", 10.0, 10.0, -190.0, None).unwrap();
        assert_eq!(g.crs, Crs::Unknown);
    }

    /// Bounds at the cell centres from -10.1° to 179.9° (cells of 0.1): degrees. `xmin`
    /// plus the columns put the east edge at 180.05°, and the file was refused; from -10.1°
    /// it is no 0..360 grid either.
    #[test]
    fn npz_centres_up_to_the_antimeridian_are_degrees() {
        let cols = 1901;
        let grid = npy_bytes("|u1", false, &format!("(2, {cols})"), &vec![0; 2 * cols]);
        let g = placed_by_bounds(
            "npz_centres_179",
            grid,
            [0.1, 0.1, -10.1, 179.9, 10.0, 10.1],
        );
        assert_eq!(g.crs, Crs::Geographic);
    }

    /// The placement read from an `.npz` of `grid` (an `elevation` array's bytes) with the
    /// bounds `[dx, dy, xmin, xmax, ymin, ymax]`.
    fn placed_by_bounds(test: &str, grid: Vec<u8>, bounds: [f64; 6]) -> Georef {
        let scalar = |v: f64| npy_bytes("<f8", false, "()", &v.to_le_bytes());
        let names = ["dx", "dy", "xmin", "xmax", "ymin", "ymax"];
        let mut members = vec![("elevation", grid)];
        members.extend(names.into_iter().zip(bounds.map(scalar)));
        let path = write_npz(test, &members);
        read_npz(&path, &ReadOptions::default())
            .unwrap()
            .georef
            .unwrap()
    }
}
