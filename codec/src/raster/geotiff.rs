//! GeoTIFF (OGC 19-008r4, "GeoTIFF Standard" 1.1) single-band elevation rasters, decoded by the
//! `tiff` crate (strips or tiles; uncompressed, LZW, deflate, PackBits; predictors).
//!
//! What we take from the GeoTIFF tags:
//! - placement from ModelTiepoint (33922) + ModelPixelScale (33550), or ModelTransformation
//!   (34264), read through GTRasterTypeGeoKey (1025): with "pixel is area" (1, the default)
//!   raster coordinate (0, 0) is the outer corner of the first pixel, with "pixel is point" (2)
//!   its centre. [`Georef`] is centre-based, so area rasters move by half a pixel;
//! - the CRS from ProjectedCSTypeGeoKey (3072), else GeographicTypeGeoKey (2048);
//! - the heights' datum from VerticalCSTypeGeoKey (4096): EGM96 (5773) is recorded;
//! - no-data from GDAL's GDAL_NODATA tag (42113, ASCII), compared in the sample type (a
//!   float32 raster's `-3.4e+38` is the f32 nearest to it); NaN is always no-data;
//! - band 1's scale and offset from GDAL's GDAL_METADATA tag (42112): heights are
//!   `sample · scale + offset`, no-data matched on the samples as stored ([`gdal_metadata`]);
//! - GDAL's internal no-data mask, an image after the heights, whose 0 pixels are no-data
//!   too ([`tiff_mask`]).
//!
//! [`gdal_metadata`]: super::gdal_metadata
//! [`tiff_mask`]: super::tiff_mask

use std::io::{BufReader, Read, Seek};
use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;
use tiff::{ColorType, TiffError};

use super::error::check_shape;
use super::gdal_metadata::{self, Scaling};
use super::{int_heights, open, tiff_mask, Crs, Georef, Heightmap, RasterError, ReadOptions};
use crate::geo::VerticalDatum;
use crate::grid::Grid;

/// GeoKey ids and values (GeoTIFF 1.1 §7).
const GT_RASTER_TYPE_GEO_KEY: u16 = 1025;
const RASTER_PIXEL_IS_POINT: u16 = 2;
const GEOGRAPHIC_TYPE_GEO_KEY: u16 = 2048;
const PROJECTED_CS_TYPE_GEO_KEY: u16 = 3072;
const VERTICAL_CS_TYPE_GEO_KEY: u16 = 4096;
/// EPSG's "EGM96 height", the vertical CRS of SRTM-derived GeoTIFFs that say theirs.
const EGM96_HEIGHT: u16 = 5773;
/// "User-defined": the CRS is spelled out in other keys, which we do not interpret.
const USER_DEFINED: u16 = 32767;
/// GDAL's own tag of band metadata as XML (the `tiff` crate names only GDAL_NODATA).
const GDAL_METADATA: u16 = 42112;

/// Reads a single-band GeoTIFF.
pub(super) fn read(path: &Path, opts: &ReadOptions) -> Result<Heightmap, RasterError> {
    let tiff_err = |e| tiff_error(path, e);
    let mut decoder = Decoder::new(BufReader::new(open(path)?))
        .map_err(tiff_err)?
        .with_limits(limits(opts.max_samples));

    // Size first: refuse before the decoder allocates the image.
    let (width, height) = decoder.dimensions().map_err(tiff_err)?;
    check_shape(path, u64::from(height), u64::from(width), opts.max_samples)?;

    // One band of elevations; colour images are not heightmaps.
    match decoder.colortype().map_err(tiff_err)? {
        ColorType::Gray(8 | 16 | 32 | 64) => {}
        ColorType::Gray(bits) => {
            return Err(RasterError::unsupported(
                path,
                format!("{bits}-bit samples; zerotile reads 8, 16, 32 and 64-bit samples"),
            ))
        }
        other => {
            return Err(RasterError::unsupported(
                path,
                format!("{other:?} image; zerotile reads single-band elevation GeoTIFFs"),
            ))
        }
    }

    // The GeoTIFF and GDAL tags.
    let nodata = gdal_nodata(&mut decoder, path)?;
    let scaling = gdal_scaling(&mut decoder, path)?;
    let keys = geo_keys(&mut decoder).map_err(tiff_err)?;
    let georef = georef(&mut decoder, &keys).map_err(tiff_err)?;
    let vertical_datum = vertical_datum(&keys);

    // Decode, and turn samples into heights with no-data as NaN.
    let (mut samples, step) = match decoder.read_image().map_err(tiff_err)? {
        DecodingResult::U8(v) => (int_heights(&v, int_nodata(nodata)), Some(1.0)),
        DecodingResult::I8(v) => (int_heights(&v, int_nodata(nodata)), Some(1.0)),
        DecodingResult::U16(v) => (int_heights(&v, int_nodata(nodata)), Some(1.0)),
        DecodingResult::I16(v) => (int_heights(&v, int_nodata(nodata)), Some(1.0)),
        DecodingResult::U32(v) => (int_heights(&v, int_nodata(nodata)), Some(1.0)),
        DecodingResult::I32(v) => (int_heights(&v, int_nodata(nodata)), Some(1.0)),
        DecodingResult::F32(v) => {
            // The declared value as the file stores it: the f32 nearest to the text.
            let nodata = nodata.map(f32_nodata);
            let heights = v
                .iter()
                .map(|&h| {
                    if h.is_nan() || Some(h) == nodata {
                        f64::NAN
                    } else {
                        f64::from(h)
                    }
                })
                .collect();
            (heights, None)
        }
        DecodingResult::F64(v) => {
            let heights = v
                .iter()
                .map(|&h| if Some(h) == nodata { f64::NAN } else { h })
                .collect();
            (heights, None)
        }
        DecodingResult::U64(_) | DecodingResult::I64(_) => {
            return Err(RasterError::unsupported(
                path,
                "64-bit integer samples; zerotile reads 8/16/32-bit integers and 32/64-bit floats",
            ))
        }
    };
    // GDAL's scale and offset: the samples were codes (and no-data matched as such).
    let step = match scaling {
        Some(s) => {
            samples.iter_mut().for_each(|h| *h = s.apply(*h));
            step.and_then(|_| s.int_step())
        }
        None => step,
    };
    // GDAL's internal mask: more no-data, read once the decoded samples are freed.
    tiff_mask::apply(&mut decoder, path, &mut samples, (width, height))?;
    let heights = Grid::new(height as usize, width as usize, samples)
        .map_err(|e| RasterError::format(path, e.to_string()))?;
    Ok(Heightmap {
        vertical_datum,
        ..Heightmap::new(heights, step, georef)
    })
}

/// The decoder's limits from ours. What it allocates is bounded by `decoding_buffer_size`: the
/// whole image in the widest sample type (and with it the size of a tag's values). A strip or
/// tile is streamed into that image, never buffered at its stored size, so its byte count
/// needs no bound of its own (a count past the file's end is a truncated file); the crate's
/// default of 128 MiB refused the single strip of any raster past it, such as a 6000²
/// float32 or a 9000² int16, well inside `max_samples`.
fn limits(max_samples: usize) -> Limits {
    let mut limits = Limits::default();
    limits.decoding_buffer_size = max_samples.saturating_mul(std::mem::size_of::<f64>());
    limits.intermediate_buffer_size = usize::MAX;
    limits
}

/// Sorts the `tiff` crate's errors by who is at fault.
pub(super) fn tiff_error(path: &Path, e: TiffError) -> RasterError {
    match e {
        TiffError::IoError(io) => RasterError::from_read(path, io),
        TiffError::UnsupportedError(u) => RasterError::unsupported(path, u.to_string()),
        // The image is checked against max_samples before it is decoded, so what is left to
        // trip the decoder's buffer limit is a tag.
        TiffError::LimitsExceeded => RasterError::limit(
            path,
            "a tag holds more values than the max_samples limit allows",
        ),
        e => RasterError::format(path, e.to_string()),
    }
}

/// A float32 raster's declared no-data value as a sample: the f32 nearest to it, and ±f32::MAX
/// for a value within 10⁻⁵ of it. Writers that print with `%g` store ±FLT_MAX, the usual
/// float void, as "-3.40282e+38", whose nearest f32 is not FLT_MAX (GDAL's own snap takes only
/// values within 10⁻¹⁰); no height is within a factor of 10³⁰ of it.
fn f32_nodata(n: f64) -> f32 {
    let max = f64::from(f32::MAX);
    if ((n.abs() - max) / max).abs() < 1e-5 {
        f32::MAX.copysign(n as f32)
    } else {
        n as f32
    }
}

/// GDAL_NODATA: the no-data value as decimal text, one for all bands.
fn gdal_nodata<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    path: &Path,
) -> Result<Option<f64>, RasterError> {
    let Some(value) = decoder
        .find_tag(Tag::GdalNodata)
        .map_err(|e| tiff_error(path, e))?
    else {
        return Ok(None);
    };
    let text = value.into_string().map_err(|e| tiff_error(path, e))?;
    let text = text.trim_matches(|c: char| c == '\0' || c.is_whitespace());
    text.parse::<f64>()
        .map(Some)
        .map_err(|_| RasterError::format(path, format!("GDAL_NODATA tag {text:?} is not a number")))
}

/// GDAL_METADATA's scale and offset of band 1, `None` when it sets neither.
fn gdal_scaling<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    path: &Path,
) -> Result<Option<Scaling>, RasterError> {
    // The `tiff` crate refuses a text tag that is not UTF-8 as an "invalid tag", naming
    // neither; said here, since the scale it may hold cannot be passed over.
    let not_text = |e| match e {
        TiffError::FormatError(tiff::TiffFormatError::InvalidTag) => RasterError::format(
            path,
            "its GDAL_METADATA tag (42112) is not UTF-8 text ending in a NUL, so the scale and \
             offset it may set cannot be read (GDAL writes it so; `gdalinfo` shows what it \
             holds)",
        ),
        e => tiff_error(path, e),
    };
    let Some(value) = decoder
        .find_tag(Tag::Unknown(GDAL_METADATA))
        .map_err(not_text)?
    else {
        return Ok(None);
    };
    let text = value.into_string().map_err(not_text)?;
    gdal_metadata::band1_scaling(&text).map_err(|e| RasterError::format(path, e))
}

/// An integer no-data value in the sample type, when the declared one is representable; a
/// value outside the type's range cannot match any sample.
fn int_nodata<T: TryFrom<i64>>(nodata: Option<f64>) -> Option<T> {
    let n = nodata?;
    // Integral and inside i64, so the cast is exact.
    let in_range = n.fract() == 0.0 && n.abs() <= 2f64.powi(53);
    in_range.then(|| T::try_from(n as i64).ok())?
}

/// The centre-based georeference from the GeoTIFF tags, `None` when there is none.
fn georef<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    keys: &[(u16, u16)],
) -> Result<Option<Georef>, TiffError> {
    // Raster space (0, 0): the first pixel's outer corner ("area") or its centre ("point").
    let centre_offset = if key(keys, GT_RASTER_TYPE_GEO_KEY) == Some(RASTER_PIXEL_IS_POINT) {
        0.0
    } else {
        0.5
    };
    let crs = match (
        key(keys, PROJECTED_CS_TYPE_GEO_KEY),
        key(keys, GEOGRAPHIC_TYPE_GEO_KEY),
    ) {
        (Some(code), _) | (None, Some(code)) if code != USER_DEFINED && code != 0 => {
            Crs::from_epsg(code)
        }
        _ => Crs::Unknown,
    };

    // An affine from raster (i, j) to model (x, y): x = a·i + b·j + c, y = d·i + e·j + f.
    let affine = if let Some(m) = f64_tag(decoder, Tag::ModelTransformationTag)? {
        // Row-major 4×4; the first two rows hold the 2-D part.
        match m.get(..8) {
            Some(&[a, b, _, c, d, e, _, f]) => Some([a, b, c, d, e, f]),
            _ => None,
        }
    } else {
        let scale = f64_tag(decoder, Tag::ModelPixelScaleTag)?;
        let tie = f64_tag(decoder, Tag::ModelTiepointTag)?;
        match (scale.as_deref(), tie.as_deref()) {
            // Tiepoint (i, j, k) ↦ (x, y, z); y grows north while j grows south.
            (Some(&[sx, sy, ..]), Some(&[i, j, _, x, y, ..])) => {
                Some([sx, 0.0, x - i * sx, 0.0, -sy, y + j * sy])
            }
            _ => None,
        }
    };

    // Sample (row, col) has its centre at raster (col + offset, row + offset).
    Ok(affine.map(|[a, b, c, d, e, f]| Georef {
        crs,
        transform: [
            c + centre_offset * (a + b),
            a,
            b,
            f + centre_offset * (d + e),
            d,
            e,
        ],
    }))
}

/// The heights' datum, where VerticalCSTypeGeoKey names EGM96's; another (EGM2008, a
/// national datum) is not one zerotile models, and is served as it is.
fn vertical_datum(keys: &[(u16, u16)]) -> Option<VerticalDatum> {
    (key(keys, VERTICAL_CS_TYPE_GEO_KEY) == Some(EGM96_HEIGHT)).then_some(VerticalDatum::Egm96)
}

/// The value of GeoKey `id`, if the directory holds it.
fn key(keys: &[(u16, u16)], id: u16) -> Option<u16> {
    keys.iter().find(|k| k.0 == id).map(|k| k.1)
}

/// The GeoKeyDirectory's short-valued keys as (id, value); others live in the double and
/// ASCII parameter tags, which we do not need.
fn geo_keys<R: Read + Seek>(decoder: &mut Decoder<R>) -> Result<Vec<(u16, u16)>, TiffError> {
    let Some(dir) = decoder.find_tag(Tag::GeoKeyDirectoryTag)? else {
        return Ok(Vec::new());
    };
    let dir = dir.into_u16_vec()?;
    // Header (version, revision, minor, count), then (id, location, count, value) per key.
    Ok(dir
        .get(4..)
        .unwrap_or_default()
        .chunks_exact(4)
        .filter(|k| k[1] == 0)
        .map(|k| (k[0], k[3]))
        .collect())
}

/// A tag of doubles, `None` when absent (the decoder's tag-size limit bounds its length).
fn f64_tag<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    tag: Tag,
) -> Result<Option<Vec<f64>>, TiffError> {
    decoder
        .find_tag(tag)?
        .map(tiff::decoder::ifd::Value::into_f64_vec)
        .transpose()
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use tiff::encoder::{colortype, DirectoryEncoder, TiffEncoder, TiffKindStandard};

    use super::*;
    use crate::fixtures::{scratch_dir, shared_data};

    fn read_dem(name: &str) -> Heightmap {
        read(
            &shared_data(&format!("dem/{name}")),
            &ReadOptions::default(),
        )
        .unwrap()
    }

    fn assert_close(got: f64, want: f64, tol: f64) {
        assert!((got - want).abs() <= tol, "got {got}, want {want} ± {tol}");
    }

    #[test]
    fn reads_terra_elev_int16_lzw_with_nodata() {
        let map = read_dem("terra_elev.tif");
        assert_eq!((map.heights.rows(), map.heights.cols()), (90, 95));
        assert_eq!(map.min_max(), Some((141.0, 547.0)));
        assert_eq!(map.step, Some(1.0));
        // GDAL_NODATA −32768 marks the area outside Luxembourg.
        assert_eq!(map.nodata_count, 3942);
        // Area raster: the tiepoint is the outer corner, the first centre half a pixel in.
        let g = map.georef.unwrap();
        assert_eq!(g.crs, Crs::Geographic);
        let (x, y) = g.position(0.0, 0.0);
        assert_close(x, 5.741666666666666 + 0.5 / 120.0, 1e-12);
        assert_close(y, 50.19166666666666 - 0.5 / 120.0, 1e-12);
        assert_close(g.transform[1], 1.0 / 120.0, 1e-15);
    }

    #[test]
    fn reads_vinschgau_float32_in_utm() {
        let map = read_dem("terra_elev_vinschgau.tif");
        assert_eq!((map.heights.rows(), map.heights.cols()), (194, 252));
        assert_eq!(map.step, None);
        let (lo, hi) = map.min_max().unwrap();
        assert!(
            (388.0..389.0).contains(&lo) && (3862.0..3864.0).contains(&hi),
            "{lo}..{hi}"
        );
        let g = map.georef.unwrap();
        assert_eq!(g.crs, Crs::Epsg(32632));
        assert_eq!(
            g.position(0.0, 0.0),
            (598_250.0 + 125.0, 5_193_000.0 - 125.0)
        );
    }

    #[test]
    fn reads_pysheds_tiled_tiff_with_its_declared_nodata() {
        let map = read_dem("pysheds_dem.tif");
        assert_eq!((map.heights.rows(), map.heights.cols()), (359, 367));
        // GDAL_NODATA −32768 is declared; no sample inside the image carries it (the edge
        // tiles' padding does, and is cut off).
        assert_eq!(map.nodata_count, 0);
        assert_eq!(map.min_max(), Some((147.0, 298.0)));
        assert_eq!(map.georef.unwrap().crs, Crs::Geographic);
    }

    #[test]
    fn reads_rio_rgbify_in_web_mercator() {
        let map = read_dem("rio_rgbify_elev.tif");
        assert_eq!((map.heights.rows(), map.heights.cols()), (512, 512));
        assert_eq!(map.step, None);
        let (lo, hi) = map.min_max().unwrap();
        assert_close(lo, 0.44, 0.01);
        assert_close(hi, 114.9, 0.05);
        let g = map.georef.unwrap();
        assert_eq!(g.crs, Crs::WebMercator);
        assert_close(g.transform[1], 6.721808968646656, 1e-12);
        assert_close(g.transform[5], -6.059025744365499, 1e-12);
    }

    type Directory<'a, 'w> = DirectoryEncoder<'a, &'w mut Cursor<Vec<u8>>, TiffKindStandard>;

    /// Writes a small int16 GeoTIFF with the extra tags `tags` writes.
    fn write_tiff(
        path: &Path,
        (width, height): (u32, u32),
        samples: &[i16],
        tags: impl FnOnce(&mut Directory<'_, '_>),
    ) {
        let mut bytes = Cursor::new(Vec::new());
        let mut tiff = TiffEncoder::new(&mut bytes).unwrap();
        let mut image = tiff.new_image::<colortype::GrayI16>(width, height).unwrap();
        tags(image.encoder());
        image.write_data(samples).unwrap();
        std::fs::write(path, bytes.into_inner()).unwrap();
    }

    #[test]
    fn pixel_is_point_places_the_tiepoint_on_the_first_centre() {
        let path = scratch_dir("tiff_point").join("point.tif");
        write_tiff(&path, (3, 2), &[1, 2, 3, 4, 5, -9999], |dir| {
            let keys: [u16; 12] = [1, 1, 0, 2, 1025, 0, 1, 2, 2048, 0, 1, 4326];
            dir.write_tag(Tag::GeoKeyDirectoryTag, &keys[..]).unwrap();
            dir.write_tag(Tag::ModelPixelScaleTag, &[0.5, 0.25, 0.0][..])
                .unwrap();
            let tie = [0.0, 0.0, 0.0, 10.0, 50.0, 0.0];
            dir.write_tag(Tag::ModelTiepointTag, &tie[..]).unwrap();
            dir.write_tag(Tag::GdalNodata, "-9999").unwrap();
        });
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(map.nodata_count, 1);
        assert_eq!(map.min_max(), Some((1.0, 5.0)));
        let g = map.georef.unwrap();
        assert_eq!(g, Georef::north_up(Crs::Geographic, 10.0, 50.0, 0.5, 0.25));
    }

    /// The placement of a 2 × 2 area raster whose only georeferencing is the
    /// ModelTransformation `m` (row-major 4 × 4).
    fn placed_by_transform(tag: &str, m: [f64; 16]) -> Georef {
        let path = scratch_dir(tag).join("transform.tif");
        write_tiff(&path, (2, 2), &[1, 2, 3, 4], |dir| {
            dir.write_tag(Tag::ModelTransformationTag, &m[..]).unwrap();
        });
        read(&path, &ReadOptions::default())
            .unwrap()
            .georef
            .unwrap()
    }

    #[test]
    fn model_transformation_places_an_area_raster() {
        #[rustfmt::skip]
        let g = placed_by_transform("tiff_transform", [
            2.0, 0.0, 0.0, 100.0,
            0.0, -2.0, 0.0, 200.0,
            0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 1.0,
        ]);
        assert_eq!(g.crs, Crs::Unknown);
        assert_eq!(g.position(0.0, 0.0), (101.0, 199.0));
        assert_eq!(g.to_gdal(), [100.0, 2.0, 0.0, 200.0, 0.0, -2.0]);
    }

    #[test]
    fn float_max_no_data_printed_short_is_float_max() {
        for (text, want) in [
            (-3.40282e38, -f32::MAX),
            (3.40282e38, f32::MAX),
            (-3.4028234663852886e38, -f32::MAX),
            (-3.4028e38, -f32::MAX),
            (-3.40e38, -3.40e38_f32),
            (-9999.0, -9999.0),
            (0.0, 0.0),
        ] {
            assert_eq!(f32_nodata(text), want, "{text}");
        }
        assert!(f32_nodata(f64::NAN).is_nan());
    }

    /// The whole reader: a float32 raster whose voids are -FLT_MAX, declared "-3.40282e+38".
    #[test]
    fn a_float32_void_declared_short_is_no_data() {
        let path = scratch_dir("tiff_fltmax").join("fltmax.tif");
        let samples = [1.5, -f32::MAX, 2.5, 3.0];
        write_tiff_as::<colortype::Gray32Float>(&path, (2, 2), &samples, |dir| {
            dir.write_tag(Tag::GdalNodata, "-3.40282e+38").unwrap();
        });
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(map.nodata_count, 1);
        assert_eq!(map.min_max(), Some((1.5, 3.0)));
    }

    #[test]
    fn nodata_outside_the_sample_type_matches_nothing() {
        assert_eq!(int_nodata::<u8>(Some(-32768.0)), None);
        assert_eq!(int_nodata::<i16>(Some(-32768.0)), Some(i16::MIN));
        assert_eq!(int_nodata::<i16>(Some(0.5)), None);
        assert_eq!(int_nodata::<i32>(Some(f64::NAN)), None);
    }

    /// One IFD entry: tag, type (2 ASCII, 3 SHORT or 4 LONG) and values.
    type Entry = (u16, u16, Vec<u32>);

    /// A little-endian TIFF written by hand, to say what an encoder would not: per image, its
    /// IFD entries and its strips' or tiles' bytes, stored before the IFD, whose offset and
    /// byte-count entries are added (tile ones when the entries give a TileWidth). An image
    /// without chunks gives its own offsets.
    fn tiff_of(images: &[(Vec<Entry>, Vec<Vec<u8>>)]) -> Vec<u8> {
        let mut out = b"II*\0".to_vec();
        // Where the next IFD's offset goes.
        let mut link = out.len();
        out.extend_from_slice(&[0; 4]);
        for (entries, chunks) in images {
            let mut entries = entries.clone();
            if !chunks.is_empty() {
                let mut offsets = Vec::new();
                for chunk in chunks {
                    offsets.push(out.len() as u32);
                    out.extend_from_slice(chunk);
                }
                let counts = chunks.iter().map(|c| c.len() as u32).collect();
                let tiled = entries.iter().any(|e| e.0 == 322);
                let (at, count) = if tiled { (324, 325) } else { (273, 279) };
                entries.extend([(at, 4, offsets), (count, 4, counts)]);
            }
            entries.sort_by_key(|e| e.0);
            // An IFD starts on a word; values past 4 bytes follow it.
            out.resize(out.len().next_multiple_of(2), 0);
            let ifd = out.len() as u32;
            out[link..link + 4].copy_from_slice(&ifd.to_le_bytes());
            let spill_at = out.len() + 2 + 12 * entries.len() + 4;
            let mut spill = Vec::new();
            out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
            for (tag, kind, values) in &entries {
                let mut bytes: Vec<u8> = values
                    .iter()
                    .flat_map(|&v| match kind {
                        2 => vec![v as u8],
                        3 => (v as u16).to_le_bytes().to_vec(),
                        _ => v.to_le_bytes().to_vec(),
                    })
                    .collect();
                out.extend_from_slice(&tag.to_le_bytes());
                out.extend_from_slice(&kind.to_le_bytes());
                out.extend_from_slice(&(values.len() as u32).to_le_bytes());
                if bytes.len() > 4 {
                    let at = (spill_at + spill.len()) as u32;
                    bytes.resize(bytes.len().next_multiple_of(2), 0);
                    spill.append(&mut bytes);
                    bytes = at.to_le_bytes().to_vec();
                }
                bytes.resize(4, 0);
                out.extend_from_slice(&bytes);
            }
            link = out.len();
            out.extend_from_slice(&[0; 4]);
            out.extend_from_slice(&spill);
        }
        out
    }

    /// The entries of a `rows × cols` image of one `bits`-bit sample a pixel in `format` (1
    /// unsigned, 2 signed, 3 float), uncompressed, in strips of `rows_per_strip` rows.
    fn gray(rows: u32, cols: u32, (bits, format): (u32, u32), rows_per_strip: u32) -> Vec<Entry> {
        vec![
            (256, 4, vec![cols]),           // ImageWidth
            (257, 4, vec![rows]),           // ImageLength
            (258, 3, vec![bits]),           // BitsPerSample
            (259, 3, vec![1]),              // Compression: none
            (262, 3, vec![1]),              // BlackIsZero
            (277, 3, vec![1]),              // SamplesPerPixel
            (278, 4, vec![rows_per_strip]), // RowsPerStrip
            (339, 3, vec![format]),         // SampleFormat
        ]
    }

    /// One strip of `rows × cols` samples at byte 4096 (after the header), of `strip_bytes`.
    fn one_strip(rows: u32, cols: u32, sample: (u32, u32), strip_bytes: u32) -> Vec<u8> {
        let mut entries = gray(rows, cols, sample, rows);
        entries.extend([(273, 4, vec![4096]), (279, 4, vec![strip_bytes])]);
        let mut bytes = tiff_of(&[(entries, Vec::new())]);
        assert!(bytes.len() <= 4096);
        bytes.resize(4096, 0);
        bytes
    }

    #[test]
    fn a_header_claiming_a_huge_raster_is_a_limit_not_an_allocation() {
        // 100000 × 100000 int16 samples in one strip.
        let bytes = one_strip(100_000, 100_000, (16, 2), 2_000_000_000);
        let path = scratch_dir("tiff_huge").join("huge.tif");
        std::fs::write(&path, bytes).unwrap();
        let err = read(&path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Limit { .. }), "{err}");
        assert!(err.to_string().contains("huge.tif"), "{err}");
    }

    /// One strip past the `tiff` crate's default intermediate limit (128 MiB) is read: a
    /// raster written whole (6000² float32, 9000² int16) was refused as past "the decoder's
    /// buffer limit", though far inside `max_samples`. 4096 × 4097 float64 is the smallest
    /// such strip in the fewest samples; the file is sparse, its samples all zero.
    #[test]
    fn a_single_strip_past_128_mib_is_read() {
        let (rows, cols) = (4096u32, 4097u32);
        let strip = u64::from(rows) * u64::from(cols) * 8;
        assert!(strip > 128 << 20);
        let path = scratch_dir("tiff_one_strip").join("one_strip.tif");
        std::fs::write(&path, one_strip(rows, cols, (64, 3), strip as u32)).unwrap();
        let file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
        file.set_len(4096 + strip).unwrap();
        let map = read(&path, &ReadOptions::default());
        std::fs::remove_file(&path).unwrap();
        let map = map.unwrap();
        assert_eq!((map.heights.rows(), map.heights.cols()), (4096, 4097));
        assert_eq!(map.min_max(), Some((0.0, 0.0)));
    }

    /// A strip byte count past the file's end is a truncated file (the strip is streamed, so
    /// the count allocates nothing), not a limit: it read as "exceeds a limit" before.
    #[test]
    fn a_strip_count_past_the_end_of_the_file_is_truncated() {
        let mut bytes = one_strip(2, 2, (16, 2), u32::MAX);
        bytes.extend_from_slice(&[1, 0, 2, 0]);
        let path = scratch_dir("tiff_short_strip").join("short.tif");
        std::fs::write(&path, bytes).unwrap();
        let err = read(&path, &ReadOptions::default()).unwrap_err();
        assert!(
            matches!(err, RasterError::Format { .. }) && err.to_string().contains("truncated"),
            "{err}"
        );
    }

    /// Writes a small GeoTIFF of colour type `C` with the extra tags `tags` writes.
    fn write_tiff_as<C: colortype::ColorType>(
        path: &Path,
        (width, height): (u32, u32),
        samples: &[C::Inner],
        tags: impl FnOnce(&mut Directory<'_, '_>),
    ) where
        [C::Inner]: tiff::encoder::TiffValue,
    {
        let mut bytes = Cursor::new(Vec::new());
        let mut tiff = TiffEncoder::new(&mut bytes).unwrap();
        let mut image = tiff.new_image::<C>(width, height).unwrap();
        tags(image.encoder());
        image.write_data(samples).unwrap();
        std::fs::write(path, bytes.into_inner()).unwrap();
    }

    #[test]
    fn uint16_nodata_is_matched_in_the_unsigned_type() {
        // 65535 is the usual no-data of unsigned DEMs; 40000 is above i16::MAX, so it must
        // read as an unsigned sample, not wrap.
        let path = scratch_dir("tiff_u16").join("u16.tif");
        write_tiff_as::<colortype::Gray16>(&path, (4, 1), &[100, 65535, 40000, 0], |dir| {
            dir.write_tag(Tag::GdalNodata, "65535").unwrap();
        });
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!((map.nodata_count, map.step), (1, Some(1.0)));
        assert!(map.heights.data()[1].is_nan());
        assert_eq!(map.min_max(), Some((0.0, 40000.0)));
    }

    #[test]
    fn float32_nodata_is_the_f32_nearest_to_the_declared_text() {
        // GDAL writes float32 no-data as decimal text; "-3.4e+38" is not an f32, so only a
        // comparison in the sample type (−3.4e38 rounded to f32) finds it. NaN is no-data too.
        let path = scratch_dir("tiff_f32").join("f32.tif");
        let samples = [12.5f32, -3.4e38, f32::NAN, 7.25, -9999.0];
        write_tiff_as::<colortype::Gray32Float>(&path, (5, 1), &samples, |dir| {
            dir.write_tag(Tag::GdalNodata, "-3.4e+38").unwrap();
        });
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!((map.nodata_count, map.step), (2, None));
        assert!(map.heights.data()[1].is_nan() && map.heights.data()[2].is_nan());
        // −9999 is a height here (not the declared no-data).
        assert_eq!(map.min_max(), Some((-9999.0, 12.5)));
    }

    #[test]
    fn float64_nodata_is_matched_exactly() {
        let path = scratch_dir("tiff_f64").join("f64.tif");
        let samples = [1.5f64, -9999.0, f64::NAN, 2.25];
        write_tiff_as::<colortype::Gray64Float>(&path, (4, 1), &samples, |dir| {
            dir.write_tag(Tag::GdalNodata, "-9999").unwrap();
        });
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!((map.nodata_count, map.step), (2, None));
        let h = map.heights.data();
        assert_eq!((h[0], h[3]), (1.5, 2.25));
        assert!(h[1].is_nan() && h[2].is_nan(), "{h:?}");
    }

    #[test]
    fn nodata_text_padded_with_whitespace_is_read() {
        // Writers pad the tag (GDAL's own files carry a NUL, which the decoder cuts off).
        let path = scratch_dir("tiff_pad").join("pad.tif");
        write_tiff(&path, (3, 1), &[7, -9999, 8], |dir| {
            dir.write_tag(Tag::GdalNodata, " -9999 \n").unwrap();
        });
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(map.nodata_count, 1);
        assert_eq!(map.min_max(), Some((7.0, 8.0)));
    }

    #[test]
    fn tag_sizes_are_bounded_by_max_samples() {
        // A tag's values are allocated before they are read; `max_samples` bounds that too, so
        // a tiny raster cannot ask for a huge tag. Here 16 doubles against 16 samples' bytes.
        let path = scratch_dir("tiff_tag_limit").join("tag.tif");
        write_tiff(&path, (2, 2), &[1, 2, 3, 4], |dir| {
            let m = [1.0; 16];
            dir.write_tag(Tag::ModelTransformationTag, &m[..]).unwrap();
        });
        assert!(read(&path, &ReadOptions::default()).is_ok());
        let small = ReadOptions {
            max_samples: 16,
            ..ReadOptions::default()
        };
        let err = read(&path, &small).unwrap_err();
        assert!(matches!(err, RasterError::Limit { .. }), "{err}");
    }

    #[test]
    fn user_defined_or_zero_crs_codes_are_unknown() {
        for (key, code, want) in [
            (PROJECTED_CS_TYPE_GEO_KEY, USER_DEFINED, Crs::Unknown),
            (PROJECTED_CS_TYPE_GEO_KEY, 0, Crs::Unknown),
            (GEOGRAPHIC_TYPE_GEO_KEY, USER_DEFINED, Crs::Unknown),
            (GEOGRAPHIC_TYPE_GEO_KEY, 0, Crs::Unknown),
            (PROJECTED_CS_TYPE_GEO_KEY, 32633, Crs::Epsg(32633)),
        ] {
            let path = scratch_dir("tiff_crs").join(format!("crs_{key}_{code}.tif"));
            write_tiff(&path, (2, 2), &[1, 2, 3, 4], |dir| {
                let keys: [u16; 8] = [1, 1, 0, 1, key, 0, 1, code];
                dir.write_tag(Tag::GeoKeyDirectoryTag, &keys[..]).unwrap();
                dir.write_tag(Tag::ModelPixelScaleTag, &[1.0, 1.0, 0.0][..])
                    .unwrap();
                let tie = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
                dir.write_tag(Tag::ModelTiepointTag, &tie[..]).unwrap();
            });
            let map = read(&path, &ReadOptions::default()).unwrap();
            assert_eq!(map.georef.unwrap().crs, want, "key {key} = {code}");
        }
    }

    #[test]
    fn an_egm96_vertical_crs_is_recorded_and_others_are_not() {
        for (keys, want) in [
            (vec![4096, 0, 1, EGM96_HEIGHT], Some(VerticalDatum::Egm96)),
            // EGM2008 height: not modelled, so not said.
            (vec![4096, 0, 1, 3855], None),
            (vec![2048, 0, 1, 4326], None),
        ] {
            let path = scratch_dir("tiff_vertical").join(format!("v{}.tif", keys[3]));
            write_tiff(&path, (2, 2), &[1, 2, 3, 4], |dir| {
                let mut all = vec![1, 1, 0, 1];
                all.extend(&keys);
                dir.write_tag(Tag::GeoKeyDirectoryTag, &all[..]).unwrap();
            });
            let map = read(&path, &ReadOptions::default()).unwrap();
            assert_eq!(map.vertical_datum, want, "{keys:?}");
        }
        // The shared GeoTIFFs do not say theirs.
        assert_eq!(read_dem("pysheds_dem.tif").vertical_datum, None);
    }

    #[test]
    fn a_tiepoint_away_from_the_raster_origin_is_moved_back_to_it() {
        // Tiepoint raster (2, 1) ↦ (10, 50): raster (0, 0) is 2 columns west and 1 row north.
        let path = scratch_dir("tiff_tie").join("tie.tif");
        write_tiff(&path, (3, 2), &[1, 2, 3, 4, 5, 6], |dir| {
            let keys: [u16; 8] = [1, 1, 0, 1, 1025, 0, 1, 2];
            dir.write_tag(Tag::GeoKeyDirectoryTag, &keys[..]).unwrap();
            dir.write_tag(Tag::ModelPixelScaleTag, &[0.5, 0.25, 0.0][..])
                .unwrap();
            let tie = [2.0, 1.0, 0.0, 10.0, 50.0, 0.0];
            dir.write_tag(Tag::ModelTiepointTag, &tie[..]).unwrap();
        });
        let g = read(&path, &ReadOptions::default())
            .unwrap()
            .georef
            .unwrap();
        assert_eq!(g, Georef::north_up(Crs::Unknown, 9.0, 50.25, 0.5, 0.25));
        assert_eq!(g.position(1.0, 2.0), (10.0, 50.0));
    }

    #[test]
    fn a_rotated_model_transformation_moves_the_centre_along_both_axes() {
        // Area raster: the first centre is raster (0.5, 0.5), so each model axis moves by half
        // of both its column and its row step.
        #[rustfmt::skip]
        let g = placed_by_transform("tiff_rotated", [
            2.0, 0.5, 0.0, 100.0,
            0.25, -2.0, 0.0, 200.0,
            0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 1.0,
        ]);
        assert_eq!(g.transform, [101.25, 2.0, 0.5, 199.125, 0.25, -2.0]);
        assert_eq!(g.to_gdal(), [100.0, 2.0, 0.5, 200.0, 0.25, -2.0]);
    }

    /// GDAL's scale and offset make the samples codes: a height is code · scale + offset, and
    /// no-data is matched on the codes. The codes were read as heights (100..2128 m where GDAL
    /// reads 250..1264 m).
    #[test]
    fn gdal_scale_and_offset_turn_samples_into_heights() {
        let dir = scratch_dir("tiff_scaled");
        let xml =
            "<GDALMetadata>\n  <Item name=\"OFFSET\" sample=\"0\" role=\"offset\">200</Item>\n  \
                   <Item name=\"SCALE\" sample=\"0\" role=\"scale\">0.5</Item>\n</GDALMetadata>";
        let path = dir.join("int16.tif");
        write_tiff(&path, (4, 1), &[100, 2128, -9999, 101], |dir| {
            dir.write_tag(Tag::Unknown(GDAL_METADATA), xml).unwrap();
            dir.write_tag(Tag::GdalNodata, "-9999").unwrap();
        });
        let map = read(&path, &ReadOptions::default()).unwrap();
        let h = map.heights.data();
        assert_eq!((h[0], h[1], h[3]), (250.0, 1264.0, 250.5));
        assert!(h[2].is_nan(), "{h:?}");
        // Half-metre codes from 200 m: heights are whole half metres.
        assert_eq!(map.step, Some(0.5));

        let path = dir.join("float32.tif");
        write_tiff_as::<colortype::Gray32Float>(&path, (2, 1), &[1.25, 3.0], |dir| {
            dir.write_tag(Tag::Unknown(GDAL_METADATA), xml).unwrap();
        });
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(
            (map.heights.data(), map.step),
            (&[200.625, 201.5][..], None)
        );

        // A scale that is no number is the file's fault, said with the item.
        let path = dir.join("bad.tif");
        write_tiff(&path, (1, 1), &[1], |dir| {
            let bad = "<GDALMetadata><Item name=\"SCALE\" sample=\"0\" role=\"scale\">x</Item></GDALMetadata>";
            dir.write_tag(Tag::Unknown(GDAL_METADATA), bad).unwrap();
        });
        let err = read(&path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Format { .. }), "{err}");
        assert!(err.to_string().contains("role=\"scale\">x</Item>"), "{err}");

        // Latin-1 text (ö as one byte) is refused naming the tag, not as "invalid tag".
        let latin1 = b"<GDALMetadata><Item name=\"DESCRIPTION\" sample=\"0\">H\xf6he</Item></GDALMetadata>\0";
        let mut entries = gray(1, 1, (16, 2), 1);
        entries.push((
            GDAL_METADATA,
            2,
            latin1.iter().map(|&b| u32::from(b)).collect(),
        ));
        let path = dir.join("latin1.tif");
        std::fs::write(&path, tiff_of(&[(entries, vec![int16_bytes(&[1])])])).unwrap();
        let err = read(&path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Format { .. }), "{err}");
        assert!(
            err.to_string()
                .contains("GDAL_METADATA tag (42112) is not UTF-8"),
            "{err}"
        );
    }

    /// A mask image's entries, `rows × cols`, 1 bit a pixel, with `compression`; its strips
    /// or tiles are the caller's to add. NewSubfileType 4: the full-resolution mask.
    fn mask_entries(rows: u32, cols: u32, compression: u32) -> Vec<Entry> {
        vec![
            (254, 4, vec![4]),           // NewSubfileType: transparency mask
            (256, 4, vec![cols]),        // ImageWidth
            (257, 4, vec![rows]),        // ImageLength
            (258, 3, vec![1]),           // BitsPerSample
            (259, 3, vec![compression]), // Compression
            (262, 3, vec![4]),           // PhotometricInterpretation: transparency mask
            (277, 3, vec![1]),           // SamplesPerPixel
        ]
    }

    /// The `rows × cols` block of `mask` (1 valid, 0 no-data) from (`row`, `col`), a bit a
    /// pixel from the high bit, each row padded to a byte; pixels outside `mask` are 0.
    fn packed(
        mask: &[Vec<u8>],
        (row, col): (usize, usize),
        (rows, cols): (usize, usize),
    ) -> Vec<u8> {
        let mut out = Vec::new();
        for r in row..row + rows {
            let mut bits = vec![0u8; cols.div_ceil(8)];
            for c in 0..cols {
                let valid = mask.get(r).and_then(|m| m.get(col + c)) == Some(&1);
                bits[c / 8] |= u8::from(valid) << (7 - c % 8);
            }
            out.extend(bits);
        }
        out
    }

    fn deflated(bytes: &[u8]) -> Vec<u8> {
        use std::io::Write;
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(bytes).unwrap();
        z.finish().unwrap()
    }

    /// PackBits with runs of 2 or more and one-byte literals, after a no-op header (128).
    fn packbits(bytes: &[u8]) -> Vec<u8> {
        let mut out = vec![128];
        let mut i = 0;
        while i < bytes.len() {
            let run = bytes[i..]
                .iter()
                .take(128)
                .take_while(|&&b| b == bytes[i])
                .count();
            if run >= 2 {
                out.extend([(257 - run) as u8, bytes[i]]);
            } else {
                out.extend([0, bytes[i]]);
            }
            i += run;
        }
        out
    }

    fn int16_bytes(samples: &[i16]) -> Vec<u8> {
        samples.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// The heights' positions that read as no-data.
    fn nodata_at(map: &Heightmap) -> Vec<(usize, usize)> {
        let cols = map.heights.cols();
        let data = map.heights.data();
        (0..data.len())
            .filter(|&k| data[k].is_nan())
            .map(|k| (k / cols, k % cols))
            .collect()
    }

    /// GDAL's internal mask (a 1-bit image after the heights, NewSubfileType 4, DEFLATE, as
    /// GDAL writes it) marks no-data beside GDAL_NODATA: its 0 pixels read as heights before
    /// (0 m pits). An overview and the overview's own mask before it are passed over.
    #[test]
    fn gdals_internal_mask_is_no_data() {
        let (rows, cols) = (3u32, 10u32);
        let mut samples: Vec<i16> = (1..=30).collect();
        samples[2 * 10 + 4] = -9999;
        let mut mask = vec![vec![1u8; 10]; 3];
        for (r, c) in [(0, 0), (1, 9), (2, 3)] {
            mask[r][c] = 0;
        }
        let mut heights = gray(rows, cols, (16, 2), rows);
        heights.push((42113, 2, b"-9999\0".iter().map(|&b| u32::from(b)).collect()));
        let mut overview = gray(2, 5, (16, 2), 2);
        overview.push((254, 4, vec![1]));
        let mut overview_mask = mask_entries(2, 5, 8);
        overview_mask[0].2 = vec![5];
        overview_mask.push((278, 4, vec![2]));
        // Two strips of 2 rows, the last with 1.
        let mut full_mask = mask_entries(rows, cols, 8);
        full_mask.push((278, 4, vec![2]));
        let strips = vec![
            deflated(&packed(&mask, (0, 0), (2, 10))),
            deflated(&packed(&mask, (2, 0), (1, 10))),
        ];
        let bytes = tiff_of(&[
            (heights, vec![int16_bytes(&samples)]),
            (overview, vec![vec![0; 20]]),
            (overview_mask, vec![deflated(&[0; 2])]),
            (full_mask, strips),
        ]);
        let path = scratch_dir("tiff_mask").join("mask.tif");
        std::fs::write(&path, bytes).unwrap();
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(nodata_at(&map), [(0, 0), (1, 9), (2, 3), (2, 4)]);
        assert_eq!(map.nodata_count, 4);
        assert_eq!(map.min_max(), Some((2.0, 30.0)));
    }

    /// A page after the heights that the decoder cannot open (no photometric tag, or RGB
    /// 5-6-5) ends the search for a mask: the file read before masks were looked for, and
    /// still does, with the heights as they are.
    #[test]
    fn a_page_after_the_heights_the_decoder_refuses_is_no_mask() {
        let samples = int16_bytes(&[1, 2, 3, 4, 5, 6]);
        let mut no_photometric = gray(2, 3, (8, 1), 2);
        no_photometric.retain(|e| e.0 != 262);
        let rgb565 = vec![
            (256, 4, vec![3]),
            (257, 4, vec![2]),
            (258, 3, vec![5, 6, 5]),
            (259, 3, vec![1]),
            (262, 3, vec![2]),
            (277, 3, vec![3]),
            (278, 4, vec![2]),
        ];
        let dir = scratch_dir("tiff_odd_page");
        for (name, page) in [("no_photometric", no_photometric), ("rgb565", rgb565)] {
            let bytes = tiff_of(&[
                (gray(2, 3, (16, 2), 2), vec![samples.clone()]),
                (page, vec![vec![0; 12]]),
            ]);
            let path = dir.join(format!("{name}.tif"));
            std::fs::write(&path, bytes).unwrap();
            let map =
                read(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(map.min_max(), Some((1.0, 6.0)), "{name}");
            assert_eq!(map.nodata_count, 0, "{name}");
        }
    }

    /// A tiled mask (a COG's) whose tiles run past the image, PackBits-coded: only the
    /// pixels inside the image count, the padding (0 here) does not.
    #[test]
    fn a_tiled_mask_is_read_inside_the_image_only() {
        let (rows, cols) = (18u32, 20u32);
        let mut mask = vec![vec![1u8; 20]; 18];
        let holes = [(0, 0), (3, 17), (15, 15), (16, 16), (17, 19)];
        for (r, c) in holes {
            mask[r][c] = 0;
        }
        let mut entries = mask_entries(rows, cols, 32773);
        entries.extend([(322, 4, vec![16]), (323, 4, vec![16])]);
        let tiles = [(0, 0), (0, 16), (16, 0), (16, 16)]
            .map(|at| packbits(&packed(&mask, at, (16, 16))))
            .to_vec();
        let heights = gray(rows, cols, (16, 2), rows);
        let bytes = tiff_of(&[(heights, vec![int16_bytes(&[7; 360])]), (entries, tiles)]);
        let path = scratch_dir("tiff_tiled_mask").join("tiled.tif");
        std::fs::write(&path, bytes).unwrap();
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(nodata_at(&map), holes);
    }

    /// An 8-bit mask reads 0 as no-data and anything else as data; a mask coded in a way not
    /// read here (LZW) is refused, not passed over, which would read its holes as heights.
    #[test]
    fn an_8_bit_mask_is_read_and_an_lzw_one_refused() {
        let heights = || gray(2, 3, (16, 2), 2);
        let mut entries = mask_entries(2, 3, 1);
        entries[3].2 = vec![8];
        entries.push((278, 4, vec![2]));
        let bytes = tiff_of(&[
            (heights(), vec![int16_bytes(&[1, 2, 3, 4, 5, 6])]),
            (entries.clone(), vec![vec![255, 0, 7, 0, 255, 1]]),
        ]);
        let dir = scratch_dir("tiff_mask_8");
        let path = dir.join("mask8.tif");
        std::fs::write(&path, bytes).unwrap();
        let map = read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(nodata_at(&map), [(0, 1), (1, 0)]);

        entries[4].2 = vec![5];
        let bytes = tiff_of(&[
            (heights(), vec![int16_bytes(&[1, 2, 3, 4, 5, 6])]),
            (entries, vec![vec![0; 6]]),
        ]);
        let path = dir.join("lzw.tif");
        std::fs::write(&path, bytes).unwrap();
        let err = read(&path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Unsupported { .. }), "{err}");
        assert!(
            err.to_string().contains("no-data mask") && err.to_string().contains("compression 5"),
            "{err}"
        );
    }
}
