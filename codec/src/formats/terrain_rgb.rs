//! Height tiles as RGB PNGs, in the two web-map encodings MapLibre's `raster-dem` sources
//! read, with resampling to a square tile of pixels.
//!
//! References:
//! - Mapbox Terrain-RGB v1: h = −10000 + 0.1 · (R · 65536 + G · 256 + B) metres, 0.1 m steps
//!   over −10000 … 1 667 721.5 m.
//! - Terrarium (Mapzen / AWS Terrain Tiles): h = R · 256 + G + B / 256 − 32768 metres,
//!   1/256 m steps over −32768 … 32767.996 m.
//! - MapLibre GL `raster-dem`: square tiles (512 px by default), pixel-is-area, so pixel
//!   (i, j) samples the tile's extent at its centre ((i + ½) / size, (j + ½) / size).
//!
//! Heights are rounded to the nearest code and clamped to the encodable range. zerotile's
//! tiles are (2^n + 1)² samples on the tile's edges ("pixel is point"), so resampling to
//! `size` pixels reads the grid bilinearly at grid coordinate (i + ½) · (cols − 1) / size.
//!
//! ```
//! use zerotile_codec::formats::terrain_rgb::{self, RgbOptions};
//! use zerotile_codec::raster::Encoding;
//! use zerotile_codec::Grid;
//!
//! let heights = Grid::new(2, 2, vec![0.0, 10.0, 20.0, 30.0]).unwrap();
//! let png = terrain_rgb::encode(&heights, &RgbOptions::new(Encoding::TerrainRgb))?;
//! let back = terrain_rgb::decode(&png, Encoding::TerrainRgb, 1 << 20)?;
//! assert_eq!(back.data(), heights.data());
//! # Ok::<(), terrain_rgb::TerrainRgbError>(())
//! ```

use std::io::Cursor;

use image::codecs::png::{CompressionType, FilterType, PngDecoder, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageDecoder, ImageEncoder};

use crate::error::ParamError;
use crate::grid::Grid;
use crate::raster::Encoding;

/// Largest tile side [`encode`] resamples to, pixels.
pub const MAX_SIZE: u32 = 4096;

/// Largest code a 24-bit pixel holds.
const MAX_CODE: f64 = 16_777_215.0;

/// How to write a height tile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbOptions {
    /// [`Encoding::TerrainRgb`] or [`Encoding::Terrarium`].
    pub encoding: Encoding,
    /// Resample to `size` × `size` pixels (MapLibre: 512 by default, 256 also common);
    /// `None` writes one pixel per grid sample.
    pub size: Option<u32>,
    /// Height written where the grid has no data (NaN), metres. 0 (sea level) is what web
    /// terrain tiles usually show outside their source.
    pub nodata_height: f64,
    /// DEFLATE effort: the same pixels either way, only the bytes and the time change.
    pub compression: PngCompression,
}

impl RgbOptions {
    /// One pixel per sample, no-data as 0 m, [`PngCompression::Balanced`].
    pub fn new(encoding: Encoding) -> Self {
        Self {
            encoding,
            size: None,
            nodata_height: 0.0,
            compression: PngCompression::Balanced,
        }
    }
}

/// How hard the PNG's DEFLATE stream is squeezed. Terrain-RGB tiles compress poorly (the
/// low byte carries decimetres), so the effort buys little. `Fast` is the `png` crate's
/// fdeflate with adaptive row filters; `Balanced` zlib level 6 (the zlib-rs backend) with
/// the Up filter, which beat the adaptive choice by 3 % on the three bench tiles; `Best` the
/// same level with four filters tried, keeping the smallest. Per 512² tile (`cargo bench
/// --bench deflate`, 2 busy cores): 6 ms for 423 kB, 28 ms for 322 kB, 96 ms for 322 kB
/// (Up won on all three; on 70 SRTM tiles `Best` wrote 0.6 % fewer bytes). Rendered on
/// request, `Fast` keeps a cold tile cheap; written once for a static host, `Balanced`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PngCompression {
    Fast,
    #[default]
    Balanced,
    Best,
}

impl std::str::FromStr for PngCompression {
    type Err = ParamError;

    /// Accepts `fast`, `balanced`, `best`, ASCII case-insensitive.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "fast" => Ok(Self::Fast),
            "balanced" => Ok(Self::Balanced),
            "best" => Ok(Self::Best),
            _ => Err(ParamError::OutOfRange {
                name: "PNG compression",
                expected: "one of fast, balanced, best",
                got: s.to_string(),
            }),
        }
    }
}

/// Why a height tile could not be written or read.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum TerrainRgbError {
    #[error("{name} must be {expected}, got {got}")]
    Parameter {
        name: &'static str,
        expected: &'static str,
        got: String,
    },
    #[error("PNG encoding failed: {0}")]
    Encode(String),
    #[error("not a readable PNG: {0}")]
    Decode(String),
    #[error("PNG of {width}×{height} exceeds the limit of {max_pixels} pixels")]
    Limit {
        width: u32,
        height: u32,
        max_pixels: u64,
    },
    #[error("unsupported PNG layout: {0} (RGB or RGBA, 8-bit, expected)")]
    Unsupported(String),
}

/// Encodes `heights` (row-major metres, row 0 north) as an RGB PNG.
pub fn encode(heights: &Grid<f64>, opts: &RgbOptions) -> Result<Vec<u8>, TerrainRgbError> {
    // Check the encoding, the no-data height and the size before any work.
    check_encoding(opts.encoding)?;
    if !opts.nodata_height.is_finite() {
        return Err(parameter(
            "nodata_height",
            "finite",
            opts.nodata_height.to_string(),
        ));
    }
    if heights.is_empty() {
        return Err(parameter("heights", "a non-empty grid", "0 samples".into()));
    }

    // Resample to the requested square, or keep the grid as it is.
    let resampled;
    let grid = match opts.size {
        None => heights,
        Some(size) => {
            resampled = resample(heights, size)?;
            &resampled
        }
    };
    let width = u32::try_from(grid.cols()).map_err(|_| too_big(grid))?;
    let height = u32::try_from(grid.rows()).map_err(|_| too_big(grid))?;

    // Heights → codes → bytes, then PNG.
    let mut rgb = Vec::with_capacity(grid.len() * 3);
    for &h in grid.data() {
        let h = if h.is_nan() { opts.nodata_height } else { h };
        rgb.extend_from_slice(&encode_height(opts.encoding, h)?);
    }
    let (level, filters): (_, &[FilterType]) = match opts.compression {
        PngCompression::Fast => (CompressionType::Fast, &[FilterType::Adaptive]),
        PngCompression::Balanced => (CompressionType::Default, &[FilterType::Up]),
        PngCompression::Best => (CompressionType::Default, &BEST_FILTERS),
    };
    let mut smallest: Option<Vec<u8>> = None;
    for &filter in filters {
        let png = write_png(&rgb, width, height, level, filter)?;
        if smallest.as_ref().is_none_or(|s| png.len() < s.len()) {
            smallest = Some(png);
        }
    }
    smallest.ok_or_else(|| TerrainRgbError::Encode("no PNG filter to try".into()))
}

/// One RGB PNG of `width` × `height` pixels at one DEFLATE level and row filter.
fn write_png(
    rgb: &[u8],
    width: u32,
    height: u32,
    level: CompressionType,
    filter: FilterType,
) -> Result<Vec<u8>, TerrainRgbError> {
    let mut png = Vec::new();
    PngEncoder::new_with_quality(&mut png, level, filter)
        .write_image(rgb, width, height, ExtendedColorType::Rgb8)
        .map_err(|e| TerrainRgbError::Encode(e.to_string()))?;
    Ok(png)
}

/// What [`PngCompression::Best`] tries, `Balanced`'s filter first. Higher zlib levels are
/// no help here: with the zlib-rs backend, levels 7–9 wrote 0.5–0.8 % more bytes than level 6
/// on the three bench tiles, for 2–6× the time, so `Best` spends its effort on the filter.
const BEST_FILTERS: [FilterType; 4] = [
    FilterType::Up,
    FilterType::Adaptive,
    FilterType::Sub,
    FilterType::Avg,
];

/// The heights, metres, an encoding's codes span: [`encode_height`] clamps past them, so a
/// caller can say so before it happens (Mapbox's floor, −10,000 m, is above the deepest
/// ocean trench; Terrarium's is not).
pub fn height_range(encoding: Encoding) -> Result<(f64, f64), TerrainRgbError> {
    Ok(match check_encoding(encoding)? {
        Rgb::Mapbox => (-10_000.0, -10_000.0 + MAX_CODE / 10.0),
        Rgb::Terrarium => (-32_768.0, -32_768.0 + MAX_CODE / 256.0),
    })
}

/// The pixel for height `h` metres: rounded to the nearest code, clamped to the encodable
/// range (±∞ clamp too; NaN is the caller's no-data and encodes as the lowest code).
pub fn encode_height(encoding: Encoding, h: f64) -> Result<[u8; 3], TerrainRgbError> {
    let code = match check_encoding(encoding)? {
        Rgb::Mapbox => ((h + 10_000.0) * 10.0).round(),
        Rgb::Terrarium => ((h + 32_768.0) * 256.0).round(),
    };
    // In 0..=2^24 − 1 after the clamp (NaN saturates to 0 in the cast).
    let code = code.clamp(0.0, MAX_CODE) as u32;
    Ok([(code >> 16) as u8, (code >> 8) as u8, code as u8])
}

/// Bilinear samples of `heights` at the pixel centres of a `size` × `size` tile spanning the
/// grid's extent edge to edge. A NaN neighbour with a non-zero weight makes the pixel NaN
/// (no data).
pub fn resample(heights: &Grid<f64>, size: u32) -> Result<Grid<f64>, TerrainRgbError> {
    if !(1..=MAX_SIZE).contains(&size) {
        return Err(parameter("size", "1 ..= 4096 pixels", size.to_string()));
    }
    if heights.is_empty() {
        return Err(parameter("heights", "a non-empty grid", "0 samples".into()));
    }
    let n = size as usize;

    // Per axis: the two grid indices and the weight of the second for each pixel centre.
    let taps = |samples: usize| -> Vec<(usize, usize, f64)> {
        (0..n)
            .map(|i| {
                if samples == 1 {
                    return (0, 0, 0.0);
                }
                let g = (i as f64 + 0.5) * (samples - 1) as f64 / n as f64;
                // g < samples − 1 for every centre, so the min only guards i0 + 1 against
                // rounding: it never binds (a mutation to `+ 2` changes nothing).
                let i0 = (g.floor() as usize).min(samples - 2);
                (i0, i0 + 1, g - i0 as f64)
            })
            .collect()
    };
    let (cols, rows) = (taps(heights.cols()), taps(heights.rows()));

    let mut out = Vec::with_capacity(n * n);
    for &(r0, r1, ty) in &rows {
        for &(c0, c1, tx) in &cols {
            let top = lerp(*heights.get(r0, c0), *heights.get(r0, c1), tx);
            let bottom = lerp(*heights.get(r1, c0), *heights.get(r1, c1), tx);
            out.push(lerp(top, bottom, ty));
        }
    }
    Grid::new(n, n, out).map_err(|e| parameter("size", "a grid shape", e.to_string()))
}

/// Reads an RGB or RGBA PNG back to heights (alpha ignored), refusing images over
/// `max_pixels` before decoding them.
pub fn decode(
    png: &[u8],
    encoding: Encoding,
    max_pixels: u64,
) -> Result<Grid<f64>, TerrainRgbError> {
    check_encoding(encoding)?;
    let decode_err = |e: image::ImageError| TerrainRgbError::Decode(e.to_string());

    // Size first: refuse before the decoder allocates.
    let mut decoder = PngDecoder::new(Cursor::new(png)).map_err(decode_err)?;
    let (width, height) = decoder.dimensions();
    if u64::from(width) * u64::from(height) > max_pixels {
        return Err(TerrainRgbError::Limit {
            width,
            height,
            max_pixels,
        });
    }
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(max_pixels.saturating_mul(8));
    decoder.set_limits(limits).map_err(decode_err)?;

    // Pixels → heights by the encoding's formula.
    let image = DynamicImage::from_decoder(decoder).map_err(decode_err)?;
    let heights: Vec<f64> = match &image {
        DynamicImage::ImageRgb8(img) => img
            .pixels()
            .filter_map(|p| encoding.decode_rgb(p.0))
            .collect(),
        DynamicImage::ImageRgba8(img) => img
            .pixels()
            .filter_map(|p| encoding.decode_rgb([p[0], p[1], p[2]]))
            .collect(),
        other => return Err(TerrainRgbError::Unsupported(format!("{:?}", other.color()))),
    };
    Grid::new(height as usize, width as usize, heights)
        .map_err(|e| TerrainRgbError::Decode(e.to_string()))
}

/// The two colour encodings.
enum Rgb {
    Mapbox,
    Terrarium,
}

fn check_encoding(encoding: Encoding) -> Result<Rgb, TerrainRgbError> {
    match encoding {
        Encoding::TerrainRgb => Ok(Rgb::Mapbox),
        Encoding::Terrarium => Ok(Rgb::Terrarium),
        other => Err(parameter(
            "encoding",
            "terrain-rgb or terrarium",
            other.to_string(),
        )),
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    if t == 0.0 {
        a
    } else {
        a + (b - a) * t
    }
}

fn too_big(heights: &Grid<f64>) -> TerrainRgbError {
    parameter(
        "heights",
        "at most 2^32 − 1 a side",
        format!("{}×{}", heights.rows(), heights.cols()),
    )
}

fn parameter(name: &'static str, expected: &'static str, got: String) -> TerrainRgbError {
    TerrainRgbError::Parameter {
        name,
        expected,
        got,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::shared_data;

    const BIG: u64 = 1 << 24;

    /// The ends [`height_range`] gives encode to the first and last code, and a height past
    /// either end clamps to it.
    #[test]
    fn height_range_is_what_the_codes_span() {
        for encoding in [Encoding::TerrainRgb, Encoding::Terrarium] {
            let (lo, hi) = height_range(encoding).unwrap();
            assert_eq!(encode_height(encoding, lo).unwrap(), [0, 0, 0]);
            assert_eq!(encode_height(encoding, hi).unwrap(), [255, 255, 255]);
            assert_eq!(encode_height(encoding, lo - 1000.0).unwrap(), [0, 0, 0]);
            assert_eq!(encode_height(encoding, hi + 1000.0).unwrap(), [255; 3]);
        }
        assert_eq!(
            height_range(Encoding::TerrainRgb).unwrap(),
            (-10_000.0, 1_667_721.5)
        );
        assert_eq!(
            height_range(Encoding::Terrarium).unwrap(),
            (-32_768.0, 32_767.99609375)
        );
        assert!(height_range(Encoding::Gray).is_err());
    }
    #[test]
    fn known_pixels_match_the_published_formulas() {
        assert_eq!(
            encode_height(Encoding::TerrainRgb, 0.0).unwrap(),
            [1, 134, 160]
        );
        assert_eq!(
            encode_height(Encoding::TerrainRgb, -2.3).unwrap(),
            [1, 134, 137]
        );
        assert_eq!(
            encode_height(Encoding::TerrainRgb, -10_000.0).unwrap(),
            [0, 0, 0]
        );
        assert_eq!(
            encode_height(Encoding::Terrarium, 0.0).unwrap(),
            [128, 0, 0]
        );
        assert_eq!(
            encode_height(Encoding::Terrarium, 1.5).unwrap(),
            [128, 1, 128]
        );
        // Nearest code, then clamped at both ends of the range.
        assert_eq!(
            encode_height(Encoding::TerrainRgb, 0.04).unwrap(),
            [1, 134, 160]
        );
        assert_eq!(
            encode_height(Encoding::TerrainRgb, 0.06).unwrap(),
            [1, 134, 161]
        );
        assert_eq!(
            encode_height(Encoding::TerrainRgb, -20_000.0).unwrap(),
            [0, 0, 0]
        );
        assert_eq!(
            encode_height(Encoding::TerrainRgb, 1e9).unwrap(),
            [255, 255, 255]
        );
        assert_eq!(
            encode_height(Encoding::Terrarium, 40_000.0).unwrap(),
            [255, 255, 255]
        );
        assert_eq!(
            encode_height(Encoding::Terrarium, f64::NEG_INFINITY).unwrap(),
            [0, 0, 0]
        );
        assert!(encode_height(Encoding::Gray, 0.0).is_err());
    }

    #[test]
    fn round_trip_is_within_half_a_step() {
        let heights: Vec<f64> = (0..40 * 30)
            .map(|k| -430.0 + 8848.86 * ((k * 7919) % 1000) as f64 / 1000.0 + 0.0123 * k as f64)
            .collect();
        let grid = Grid::new(30, 40, heights).unwrap();
        for encoding in [Encoding::TerrainRgb, Encoding::Terrarium] {
            let png = encode(&grid, &RgbOptions::new(encoding)).unwrap();
            let back = decode(&png, encoding, BIG).unwrap();
            assert_eq!((back.rows(), back.cols()), (30, 40));
            let worst = grid
                .data()
                .iter()
                .zip(back.data())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(worst <= encoding.step() / 2.0 + 1e-9, "{encoding}: {worst}");
        }
    }

    #[test]
    fn fuji_tile_decodes_and_re_encodes_exactly() {
        // Mapbox's own terrain-RGB tile of Mt Fuji (RGBA, 512²), 13.7–3751.0 m per the README.
        let png = std::fs::read(shared_data("dem/fuji.png")).unwrap();
        let fuji = decode(&png, Encoding::TerrainRgb, BIG).unwrap();
        assert_eq!((fuji.rows(), fuji.cols()), (512, 512));
        let lo = fuji.data().iter().copied().fold(f64::INFINITY, f64::min);
        let hi = fuji
            .data()
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        assert_eq!((lo, hi), (13.7, 3751.0));
        // Every height is a code already: writing and reading again changes nothing.
        let again = decode(
            &encode(&fuji, &RgbOptions::new(Encoding::TerrainRgb)).unwrap(),
            Encoding::TerrainRgb,
            BIG,
        )
        .unwrap();
        assert_eq!(again.data(), fuji.data());
    }

    /// The compression effort changes the bytes, never the heights: Mt Fuji written at each
    /// effort reads back the same; balanced gives fewer bytes than fast, and best, which also
    /// tries balanced's filter, never more than balanced.
    #[test]
    fn every_compression_writes_the_same_heights_in_fewer_bytes_for_more_effort() {
        let png = std::fs::read(shared_data("dem/fuji.png")).unwrap();
        let fuji = decode(&png, Encoding::TerrainRgb, BIG).unwrap();
        let sizes = [
            PngCompression::Fast,
            PngCompression::Balanced,
            PngCompression::Best,
        ]
        .map(|compression| {
            let opts = RgbOptions {
                compression,
                ..RgbOptions::new(Encoding::TerrainRgb)
            };
            let bytes = encode(&fuji, &opts).unwrap();
            let back = decode(&bytes, Encoding::TerrainRgb, BIG).unwrap();
            assert_eq!(back.data(), fuji.data(), "{compression:?}");
            bytes.len()
        });
        assert!(sizes[0] > sizes[1] && sizes[1] >= sizes[2], "{sizes:?}");

        // What each effort is, byte for byte: balanced is zlib level 6 with the Up filter,
        // best the smallest of the four filters at that level.
        let rgb: Vec<u8> = fuji
            .data()
            .iter()
            .flat_map(|&h| encode_height(Encoding::TerrainRgb, h).unwrap())
            .collect();
        let (cols, rows) = (fuji.cols() as u32, fuji.rows() as u32);
        let with = |filter| write_png(&rgb, cols, rows, CompressionType::Default, filter).unwrap();
        let effort = |compression| {
            let opts = RgbOptions {
                compression,
                ..RgbOptions::new(Encoding::TerrainRgb)
            };
            encode(&fuji, &opts).unwrap()
        };
        assert_eq!(effort(PngCompression::Balanced), with(FilterType::Up));
        let smallest = [
            FilterType::Up,
            FilterType::Adaptive,
            FilterType::Sub,
            FilterType::Avg,
        ]
        .map(with)
        .into_iter()
        .min_by_key(Vec::len)
        .unwrap();
        assert_eq!(effort(PngCompression::Best).len(), smallest.len());
    }

    #[test]
    fn resampling_reads_a_plane_exactly_at_pixel_centres() {
        // h = 3·col − 2·row + 100 over a 257² tile; bilinear is exact on a plane.
        let grid = Grid::new(
            257,
            257,
            (0..257 * 257)
                .map(|k| 3.0 * (k % 257) as f64 - 2.0 * (k / 257) as f64 + 100.0)
                .collect(),
        )
        .unwrap();
        for size in [256u32, 512] {
            let out = resample(&grid, size).unwrap();
            for (i, j) in [
                (0usize, 0usize),
                (17, 200),
                (size as usize - 1, size as usize - 1),
            ] {
                let g = |p: usize| (p as f64 + 0.5) * 256.0 / f64::from(size);
                let want = 3.0 * g(j) - 2.0 * g(i) + 100.0;
                assert!((out.get(i, j) - want).abs() < 1e-9, "{size}: ({i}, {j})");
            }
            let opts = RgbOptions {
                size: Some(size),
                ..RgbOptions::new(Encoding::Terrarium)
            };
            let back = decode(&encode(&grid, &opts).unwrap(), Encoding::Terrarium, BIG).unwrap();
            assert_eq!((back.rows(), back.cols()), (size as usize, size as usize));
            let worst = out
                .data()
                .iter()
                .zip(back.data())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(worst <= 1.0 / 512.0 + 1e-9);
        }
        // Off a plane the taps themselves show: each pixel is the chord of h = col² between
        // the two samples around its centre (a wrong pair would extrapolate another chord,
        // which on a plane gives the same value).
        let bent = Grid::new(
            257,
            257,
            (0..257 * 257).map(|k| ((k % 257) as f64).powi(2)).collect(),
        )
        .unwrap();
        let out = resample(&bent, 100).unwrap();
        for j in 0..100 {
            let g = (j as f64 + 0.5) * 256.0 / 100.0;
            let c0 = g.floor();
            let want = c0 * c0 + (g - c0) * (2.0 * c0 + 1.0);
            assert!((out.get(50, j) - want).abs() < 1e-6, "pixel {j}");
        }
        // A single sample fills the tile.
        let one = resample(&Grid::new(1, 1, vec![5.0]).unwrap(), 4).unwrap();
        assert!(one.data().iter().all(|&h| h == 5.0));
    }

    #[test]
    fn nodata_becomes_the_chosen_height() {
        let grid = Grid::new(1, 3, vec![f64::NAN, 12.0, f64::NAN]).unwrap();
        let opts = RgbOptions {
            nodata_height: -5.0,
            ..RgbOptions::new(Encoding::TerrainRgb)
        };
        let back = decode(&encode(&grid, &opts).unwrap(), Encoding::TerrainRgb, BIG).unwrap();
        assert_eq!(back.data(), &[-5.0, 12.0, -5.0]);
    }

    #[test]
    fn bad_parameters_and_bytes_are_errors() {
        let grid = Grid::new(2, 2, vec![0.0; 4]).unwrap();
        assert!(matches!(
            encode(&grid, &RgbOptions::new(Encoding::Gray)),
            Err(TerrainRgbError::Parameter { .. })
        ));
        let huge = RgbOptions {
            size: Some(MAX_SIZE + 1),
            ..RgbOptions::new(Encoding::TerrainRgb)
        };
        assert!(encode(&grid, &huge).is_err());
        let zero = RgbOptions {
            size: Some(0),
            ..RgbOptions::new(Encoding::TerrainRgb)
        };
        assert!(encode(&grid, &zero).is_err());
        let nan = RgbOptions {
            nodata_height: f64::NAN,
            ..RgbOptions::new(Encoding::TerrainRgb)
        };
        assert!(encode(&grid, &nan).is_err());
        let png = encode(&grid, &RgbOptions::new(Encoding::TerrainRgb)).unwrap();
        assert!(matches!(
            decode(&png, Encoding::TerrainRgb, 3),
            Err(TerrainRgbError::Limit { .. })
        ));
        // The limit counts pixels (width × height), and a PNG of exactly the limit decodes.
        let wide = encode(
            &Grid::new(3, 5, vec![1.0; 15]).unwrap(),
            &RgbOptions::new(Encoding::TerrainRgb),
        )
        .unwrap();
        assert_eq!(decode(&wide, Encoding::TerrainRgb, 15).unwrap().len(), 15);
        for max_pixels in [14, 10] {
            assert!(matches!(
                decode(&wide, Encoding::TerrainRgb, max_pixels),
                Err(TerrainRgbError::Limit {
                    width: 5,
                    height: 3,
                    ..
                })
            ));
        }
        // Cuts into the header or the image data (a clipped IEND trailer still decodes).
        for cut in [0, 8, 20, png.len() / 2] {
            assert!(
                decode(&png[..cut], Encoding::TerrainRgb, BIG).is_err(),
                "cut {cut}"
            );
        }
        assert!(decode(b"not a png at all", Encoding::TerrainRgb, BIG).is_err());
    }
}
