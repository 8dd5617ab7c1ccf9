//! SRTM `.hgt` tiles (NASA/USGS Shuttle Radar Topography Mission, "SRTM Topography" format
//! description, 2003): a square of big-endian int16 metres, rows north to south, with no header.
//! The side follows from the file size: 1201 (3″, SRTM3) or 3601 (1″, SRTM1). −32768 marks a
//! void.
//!
//! The name (`N44W072.hgt`) is the tile's south-west corner in whole degrees. Samples sit on
//! whole arc-second multiples and the tile includes both of its edges, so sample (0, 0) is
//! centred exactly on the north-west corner (lat 45, lon −72) and neighbouring tiles share an
//! edge row and column. This is "pixel is point" — the convention of [`Georef`].

use std::io::Read;
use std::path::Path;

use super::error::check_shape;
use super::{int_heights, open, Crs, Georef, Heightmap, RasterError, ReadOptions};
use crate::geo::VerticalDatum;
use crate::grid::Grid;

/// The two tile sides SRTM ships: 3″ (1201) and 1″ (3601) over one degree.
const SIDES: [usize; 2] = [1201, 3601];
/// SRTM's void value.
const VOID: i16 = i16::MIN;
/// Bytes per sample.
const SAMPLE_BYTES: usize = 2;

/// Reads an SRTM `.hgt` tile.
pub(super) fn read(path: &Path, opts: &ReadOptions) -> Result<Heightmap, RasterError> {
    let mut file = open(path)?;

    // The side from the size: the format has no header to ask.
    let len = file.metadata().map_err(|e| RasterError::io(path, e))?.len();
    let side = side_for_len(len).ok_or_else(|| {
        RasterError::format(
            path,
            format!(
                "an SRTM .hgt holds 1201² (3″) or 3601² (1″) int16 samples, \
                 {} or {} bytes; this file has {len}",
                byte_len(SIDES[0]),
                byte_len(SIDES[1])
            ),
        )
    })?;
    let n = check_shape(path, side as u64, side as u64, opts.max_samples)?;

    // Read exactly the expected bytes; a file that shrank since `metadata` is truncated.
    let mut bytes = vec![0u8; n * SAMPLE_BYTES];
    file.read_exact(&mut bytes)
        .map_err(|e| RasterError::from_read(path, e))?;

    // Decode big-endian samples; voids become NaN.
    let samples: Vec<i16> = bytes
        .chunks_exact(SAMPLE_BYTES)
        .map(|b| i16::from_be_bytes([b[0], b[1]]))
        .collect();
    let heights = Grid::new(side, side, int_heights(&samples, Some(VOID)))
        .map_err(|e| RasterError::format(path, e.to_string()))?;

    // Place it from the tile name, when the name is SRTM's.
    let georef = georef_from_name(path, side);
    // SRTM's heights are above the EGM96 geoid (the SRTM Data Specification, NASA JPL).
    Ok(Heightmap {
        vertical_datum: Some(VerticalDatum::Egm96),
        ..Heightmap::new(heights, Some(1.0), georef)
    })
}

fn byte_len(side: usize) -> usize {
    side * side * SAMPLE_BYTES
}

fn side_for_len(len: u64) -> Option<usize> {
    SIDES
        .into_iter()
        .find(|&side| u64::try_from(byte_len(side)).is_ok_and(|b| b == len))
}

/// Parses `[NS]dd[EW]ddd` at the start of the file stem (`N44W072`, `s13e034.SRTMGL1`) into
/// the south-west corner, and builds the centre-based georeference of a `side`² tile.
fn georef_from_name(path: &Path, side: usize) -> Option<Georef> {
    let stem = path.file_stem()?.to_str()?.get(..7)?.to_ascii_uppercase();
    let (lat_part, lon_part) = (stem.get(..3)?, stem.get(3..)?);
    let lat_sign = match lat_part.as_bytes().first()? {
        b'N' => 1.0,
        b'S' => -1.0,
        _ => return None,
    };
    let lon_sign = match lon_part.as_bytes().first()? {
        b'E' => 1.0,
        b'W' => -1.0,
        _ => return None,
    };
    let degrees = |digits: &str| -> Option<u8> {
        digits
            .bytes()
            .all(|b| b.is_ascii_digit())
            .then(|| digits.parse().ok())?
    };
    let lat = degrees(lat_part.get(1..)?)?;
    let lon = degrees(lon_part.get(1..)?)?;
    if lat >= 90 || lon > 180 {
        return None;
    }
    let south = lat_sign * f64::from(lat);
    let west = lon_sign * f64::from(lon);
    // `side − 1` intervals span the degree; the first sample is the north-west corner.
    let spacing = 1.0 / (side - 1) as f64;
    Some(Georef::north_up(
        Crs::Geographic,
        west,
        south + 1.0,
        spacing,
        spacing,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{scratch_dir, shared_data};

    #[test]
    fn reads_n44w072_heights_and_place() {
        let map = read(&shared_data("dem/N44W072.hgt"), &ReadOptions::default()).unwrap();
        assert_eq!((map.heights.rows(), map.heights.cols()), (1201, 1201));
        assert_eq!(map.min_max(), Some((115.0, 1908.0)));
        assert_eq!(map.nodata_count, 0);
        assert_eq!(map.step, Some(1.0));
        assert_eq!(map.vertical_datum, Some(VerticalDatum::Egm96));

        // Row 0 col 0 is centred on the tile's north-west corner; the last sample on its
        // south-east corner.
        let g = map.georef.unwrap();
        assert_eq!(g.crs, Crs::Geographic);
        assert_eq!(g.position(0.0, 0.0), (-72.0, 45.0));
        let (lon, lat) = g.position(1200.0, 1200.0);
        assert!(
            (lon + 71.0).abs() < 1e-12 && (lat - 44.0).abs() < 1e-12,
            "{lon} {lat}"
        );
    }

    #[test]
    fn parses_srtm_names_and_ignores_others() {
        let g = georef_from_name(Path::new("s13e034.SRTMGL1.hgt"), 3601).unwrap();
        assert_eq!(g.position(0.0, 0.0), (34.0, -12.0));
        assert_eq!(g.transform[1], 1.0 / 3600.0);
        assert_eq!(georef_from_name(Path::new("tile.hgt"), 1201), None);
        assert_eq!(georef_from_name(Path::new("N95W072.hgt"), 1201), None);
    }

    /// Longitudes run to 180 inclusive (W180 is the tile east of the antimeridian), not past.
    #[test]
    fn longitude_180_is_a_tile_and_181_is_not() {
        let g = georef_from_name(Path::new("S01W180.hgt"), 1201).unwrap();
        assert_eq!(g.position(0.0, 0.0), (-180.0, 0.0));
        assert!(georef_from_name(Path::new("N00E180.hgt"), 1201).is_some());
        assert_eq!(georef_from_name(Path::new("N00E181.hgt"), 1201), None);
        assert_eq!(georef_from_name(Path::new("N90E000.hgt"), 1201), None);
        assert!(georef_from_name(Path::new("N89E000.hgt"), 1201).is_some());
    }

    #[test]
    fn rejects_a_file_of_the_wrong_size() {
        let dir = scratch_dir("hgt_wrong_size");
        let path = dir.join("N44W072.hgt");
        std::fs::write(&path, vec![0u8; 1000 * 1000 * 2]).unwrap();
        let err = read(&path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Format { .. }), "{err}");
        assert!(err.to_string().contains("N44W072.hgt"), "{err}");
        assert!(err.to_string().contains("2000000"), "{err}");
    }

    #[test]
    fn maps_voids_to_nodata() {
        let dir = scratch_dir("hgt_voids");
        let path = dir.join("N00E000.hgt");
        let mut bytes = vec![0u8; byte_len(1201)];
        bytes[0..2].copy_from_slice(&VOID.to_be_bytes());
        bytes[2..4].copy_from_slice(&(-12i16).to_be_bytes());
        std::fs::write(&path, bytes).unwrap();
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(map.nodata_count, 1);
        assert!(map.heights.data()[0].is_nan());
        assert_eq!(map.min_max(), Some((-12.0, 0.0)));
    }

    #[test]
    fn honours_max_samples() {
        let opts = ReadOptions {
            max_samples: 1000,
            ..ReadOptions::default()
        };
        let err = read(&shared_data("dem/N44W072.hgt"), &opts).unwrap_err();
        assert!(matches!(err, RasterError::Limit { .. }), "{err}");
    }
}
