//! PNG heightmaps, decoded by the `image` crate: gray values are heights (1, 2, 4, 8 or 16-bit,
//! as stored), or RGB carries 24-bit codes in Mapbox terrain-RGB or Terrarium form
//! ([`Encoding`]). A transparent pixel (alpha 0) is no-data, as web-map tiles mark areas
//! outside the source.
//!
//! A PNG does not say which encoding it uses, so colour PNGs need one from the caller; PNGs
//! carry no georeference.

use std::io::{BufReader, Read, Seek};
use std::path::Path;

use image::codecs::png::PngDecoder;
use image::{DynamicImage, ImageDecoder, ImageError};

use super::error::check_shape;
use super::{open, Encoding, Heightmap, RasterError, ReadOptions};
use crate::grid::Grid;

/// Reads a PNG heightmap.
pub(super) fn read(path: &Path, opts: &ReadOptions) -> Result<Heightmap, RasterError> {
    let image_err = |e| image_error(path, e);
    let mut file = BufReader::new(open(path)?);
    let widened = widened_gray(&mut file).map_err(|e| RasterError::from_read(path, e))?;
    let mut decoder = PngDecoder::new(file).map_err(image_err)?;

    // Size first: refuse before the decoder allocates the image.
    let (width, height) = decoder.dimensions();
    check_shape(path, u64::from(height), u64::from(width), opts.max_samples)?;
    let mut limits = image::Limits::default();
    // Four 16-bit channels per sample at most.
    limits.max_alloc = Some(
        u64::try_from(opts.max_samples)
            .unwrap_or(u64::MAX)
            .saturating_mul(8),
    );
    decoder.set_limits(limits).map_err(image_err)?;

    // Decode, then read heights the way the pixel layout and the encoding say.
    let image = DynamicImage::from_decoder(decoder).map_err(image_err)?;
    let (heights, step) = match (image, opts.encoding) {
        (DynamicImage::ImageLuma8(img), None | Some(Encoding::Gray)) => (
            img.pixels().map(|p| f64::from(p[0] / widened)).collect(),
            1.0,
        ),
        (DynamicImage::ImageLumaA8(img), None | Some(Encoding::Gray)) => (
            img.pixels()
                .map(|p| gray(p[0] / widened, p[1] == 0))
                .collect(),
            1.0,
        ),
        (DynamicImage::ImageLuma16(img), None | Some(Encoding::Gray)) => {
            (img.pixels().map(|p| f64::from(p[0])).collect(), 1.0)
        }
        (DynamicImage::ImageLumaA16(img), None | Some(Encoding::Gray)) => {
            (img.pixels().map(|p| gray(p[0], p[1] == 0)).collect(), 1.0)
        }
        (
            DynamicImage::ImageLuma8(_)
            | DynamicImage::ImageLumaA8(_)
            | DynamicImage::ImageLuma16(_)
            | DynamicImage::ImageLumaA16(_),
            Some(encoding),
        ) => {
            return Err(RasterError::parameter(
                path,
                format!("a gray PNG cannot hold {encoding} heights; read it as gray (no encoding)"),
            ))
        }
        (DynamicImage::ImageRgb8(_) | DynamicImage::ImageRgba8(_), None) => {
            return Err(RasterError::parameter(
                path,
                "a colour PNG encodes heights in its RGB channels: \
                 pass the encoding (--encoding terrain-rgb|terrarium)",
            ))
        }
        // Gray was asked for by name: "pass the encoding" would read as if it had not been.
        (DynamicImage::ImageRgb8(_) | DynamicImage::ImageRgba8(_), Some(Encoding::Gray)) => {
            return Err(RasterError::parameter(
                path,
                "a colour (RGB) PNG, which gray cannot read: its heights are in the RGB \
                 channels, which terrain-rgb and terrarium read (--encoding terrain-rgb|terrarium)",
            ))
        }
        (DynamicImage::ImageRgb8(img), Some(encoding)) => (
            colour(
                path,
                encoding,
                img.pixels().map(|p| ([p[0], p[1], p[2]], false)),
            )?,
            encoding.step(),
        ),
        (DynamicImage::ImageRgba8(img), Some(encoding)) => (
            colour(
                path,
                encoding,
                img.pixels().map(|p| ([p[0], p[1], p[2]], p[3] == 0)),
            )?,
            encoding.step(),
        ),
        (other, _) => {
            return Err(RasterError::unsupported(
                path,
                format!(
                    "{:?} PNG; zerotile reads 1 to 16-bit gray and 8-bit RGB(A) heightmaps",
                    other.color()
                ),
            ))
        }
    };
    let heights = Grid::new(height as usize, width as usize, heights)
        .map_err(|e| RasterError::format(path, e.to_string()))?;
    Ok(Heightmap::new(heights, Some(step), None))
}

/// What the decoder multiplied a gray sample of under 8 bits by: it widens them to 8 bits over
/// the full range (a 4-bit 7 becomes 119), and heights are the samples as stored, as GDAL
/// reads them. 1 for any other PNG. Read from the IHDR, which the `image` crate does not
/// pass on; the reader is left at the start.
fn widened_gray(file: &mut (impl Read + Seek)) -> std::io::Result<u8> {
    let mut head = Vec::with_capacity(26);
    file.by_ref().take(26).read_to_end(&mut head)?;
    file.rewind()?;
    // The signature (8 bytes), then IHDR: length, type, width, height, bit depth, colour type.
    Ok(match head.get(12..26) {
        Some([b'I', b'H', b'D', b'R', .., depth @ (1 | 2 | 4), 0]) => 255 / ((1 << depth) - 1),
        _ => 1,
    })
}

fn gray(value: impl Into<f64>, transparent: bool) -> f64 {
    if transparent {
        f64::NAN
    } else {
        value.into()
    }
}

/// Decodes RGB(A) pixels (with whether each is transparent), refusing an encoding that reads
/// the opaque pixels' median code as no place on Earth while the other reads it as terrain.
fn colour(
    path: &Path,
    encoding: Encoding,
    pixels: impl Iterator<Item = ([u8; 3], bool)>,
) -> Result<Vec<f64>, RasterError> {
    let mut heights = Vec::with_capacity(pixels.size_hint().0);
    let mut codes = Vec::with_capacity(pixels.size_hint().0);
    for (pixel, transparent) in pixels {
        match encoding.decode_rgb(pixel) {
            Some(h) if !transparent => {
                heights.push(h);
                codes.push(u32::from_be_bytes([0, pixel[0], pixel[1], pixel[2]]));
            }
            _ => heights.push(f64::NAN),
        }
    }
    if codes.is_empty() {
        return Ok(heights);
    }
    let middle = codes.len() / 2;
    let [_, r, g, b] = codes.select_nth_unstable(middle).1.to_be_bytes();
    match encoding.misread([r, g, b]) {
        None => Ok(heights),
        Some(m) => Err(RasterError::parameter(
            path,
            format!(
                "read as {encoding}, its median height is {:.0} m, and as {} it is {:.0} m: \
                 this looks like a {} PNG (--encoding {})",
                m.asked, m.other, m.instead, m.other, m.other
            ),
        )),
    }
}

/// Sorts the `image` crate's errors by who is at fault.
fn image_error(path: &Path, e: ImageError) -> RasterError {
    match e {
        ImageError::IoError(io) => RasterError::from_read(path, io),
        ImageError::Limits(l) => RasterError::limit(path, l.to_string()),
        ImageError::Unsupported(u) => RasterError::unsupported(path, u.to_string()),
        ImageError::Parameter(p) => RasterError::parameter(path, p.to_string()),
        e => RasterError::format(path, e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use image::{GrayImage, Rgb, RgbImage, Rgba, RgbaImage};

    use super::*;
    use crate::fixtures::{scratch_dir, shared_data};

    fn opts(encoding: Option<Encoding>) -> ReadOptions {
        ReadOptions {
            encoding,
            ..ReadOptions::default()
        }
    }

    #[test]
    fn reads_fuji_as_terrain_rgb() {
        let path = shared_data("dem/fuji.png");
        let map = read(&path, &opts(Some(Encoding::TerrainRgb))).unwrap();
        assert_eq!((map.heights.rows(), map.heights.cols()), (512, 512));
        assert_eq!(map.min_max(), Some((13.7, 3751.0)));
        assert_eq!(map.step, Some(0.1));
        assert_eq!(map.nodata_count, 0);
        assert_eq!(map.georef, None);
    }

    #[test]
    fn fuji_read_as_terrarium_is_told_it_is_terrain_rgb() {
        let path = shared_data("dem/fuji.png");
        let err = read(&path, &opts(Some(Encoding::Terrarium))).unwrap_err();
        assert!(matches!(err, RasterError::Parameter { .. }), "{err}");
        let message = err.to_string();
        assert!(
            message.contains("fuji.png") && message.contains("--encoding terrain-rgb"),
            "{message}"
        );
    }

    #[test]
    fn a_terrarium_png_read_as_terrain_rgb_is_told_so_and_transparency_is_left_out() {
        let path = scratch_dir("png_misread").join("terrarium.png");
        // Three opaque pixels at 0, 1.5 and 1000 m in Terrarium, and two transparent ones
        // whose codes would move the median to terrain-RGB's own range were they counted.
        let mut img = RgbaImage::new(5, 1);
        img.put_pixel(0, 0, Rgba([128, 0, 0, 255]));
        img.put_pixel(1, 0, Rgba([128, 1, 128, 255]));
        img.put_pixel(2, 0, Rgba([131, 232, 0, 255]));
        img.put_pixel(3, 0, Rgba([1, 134, 160, 0]));
        img.put_pixel(4, 0, Rgba([1, 134, 160, 0]));
        img.save(&path).unwrap();
        let message = read(&path, &opts(Some(Encoding::TerrainRgb)))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("as terrarium it is 2 m") && message.contains("--encoding terrarium"),
            "{message}"
        );
        let map = read(&path, &opts(Some(Encoding::Terrarium))).unwrap();
        assert_eq!(map.nodata_count, 2);
    }

    #[test]
    fn a_colour_png_without_an_encoding_says_which_to_pass() {
        let path = shared_data("dem/fuji.png");
        for encoding in [None, Some(Encoding::Gray)] {
            let err = read(&path, &opts(encoding)).unwrap_err();
            assert!(matches!(err, RasterError::Parameter { .. }), "{err}");
            let message = err.to_string();
            assert!(
                message.contains("fuji.png") && message.contains("terrain-rgb"),
                "{message}"
            );
        }
    }

    #[test]
    fn gray_asked_of_a_colour_png_says_it_is_colour() {
        let path = shared_data("dem/fuji.png");
        let message = read(&path, &opts(Some(Encoding::Gray)))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("colour") && message.contains("gray cannot read"),
            "{message}"
        );
        assert!(!message.contains("pass the encoding"), "{message}");
    }

    #[test]
    fn reads_gray_and_refuses_a_colour_encoding_for_it() {
        let path = scratch_dir("png_gray").join("gray.png");
        GrayImage::from_raw(3, 2, vec![0, 1, 2, 250, 254, 255])
            .unwrap()
            .save(&path)
            .unwrap();
        let map = read(&path, &opts(None)).unwrap();
        assert_eq!(map.heights.data(), &[0.0, 1.0, 2.0, 250.0, 254.0, 255.0]);
        assert_eq!(map.step, Some(1.0));
        let err = read(&path, &opts(Some(Encoding::TerrainRgb))).unwrap_err();
        assert!(matches!(err, RasterError::Parameter { .. }), "{err}");
    }

    #[test]
    fn reads_terrarium_and_transparent_pixels_as_nodata() {
        let dir = scratch_dir("png_terrarium");
        let path = dir.join("terrarium.png");
        let mut img = RgbaImage::new(2, 1);
        img.put_pixel(0, 0, Rgba([128, 1, 128, 255]));
        img.put_pixel(1, 0, Rgba([128, 1, 128, 0]));
        img.save(&path).unwrap();
        let map = read(&path, &opts(Some(Encoding::Terrarium))).unwrap();
        assert_eq!(map.heights.data()[0], 1.5);
        assert!(map.heights.data()[1].is_nan());
        assert_eq!((map.nodata_count, map.step), (1, Some(1.0 / 256.0)));

        // RGB without alpha: every pixel is valid.
        let path = dir.join("terrain_rgb.png");
        RgbImage::from_pixel(2, 2, Rgb([1, 134, 160]))
            .save(&path)
            .unwrap();
        let map = read(&path, &opts(Some(Encoding::TerrainRgb))).unwrap();
        assert_eq!(map.min_max(), Some((0.0, 0.0)));
    }

    /// A gray PNG of `depth` (1, 2 or 4) bits holding `rows` (each sample below 2^depth), with
    /// `trns` its transparent gray value, written by hand: the `image` crate writes no gray
    /// below 8 bits.
    fn low_bit_gray_png(depth: u8, rows: &[&[u8]], trns: Option<u16>) -> Vec<u8> {
        use std::io::Write;
        fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
            out.extend_from_slice(&(data.len() as u32).to_be_bytes());
            let start = out.len();
            out.extend_from_slice(kind);
            out.extend_from_slice(data);
            let crc = crc32fast::hash(&out[start..]);
            out.extend_from_slice(&crc.to_be_bytes());
        }
        let width = rows[0].len();
        let mut raw = Vec::new();
        for row in rows {
            // Filter type 0, then the samples packed from the high bit, the last byte padded.
            raw.push(0);
            let per_byte = usize::from(8 / depth);
            for byte in row.chunks(per_byte) {
                let packed = byte
                    .iter()
                    .enumerate()
                    .fold(0u8, |acc, (k, &v)| acc | v << (8 - depth * (k as u8 + 1)));
                raw.push(packed);
            }
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        let mut ihdr = Vec::new();
        ihdr.extend_from_slice(&(width as u32).to_be_bytes());
        ihdr.extend_from_slice(&(rows.len() as u32).to_be_bytes());
        ihdr.extend_from_slice(&[depth, 0, 0, 0, 0]); // gray, deflate, filter 0, no interlace
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        chunk(&mut png, b"IHDR", &ihdr);
        if let Some(t) = trns {
            chunk(&mut png, b"tRNS", &t.to_be_bytes());
        }
        chunk(&mut png, b"IDAT", &z.finish().unwrap());
        chunk(&mut png, b"IEND", &[]);
        png
    }

    /// Gray below 8 bits reads the samples as stored, as GDAL does: the decoder widened them
    /// to 8 bits, so a 4-bit 7 was a height of 119 m.
    #[test]
    fn gray_below_8_bits_reads_the_samples_as_stored() {
        let dir = scratch_dir("png_low_bit");
        for depth in [1u8, 2, 4] {
            let top = (1u8 << depth) - 1;
            // 5 columns: no whole number of bytes at any of these depths.
            let rows: [&[u8]; 2] = [&[0, top, 1, top / 2, 0], &[top, 0, top, 1, 1]];
            let path = dir.join(format!("gray{depth}.png"));
            std::fs::write(&path, low_bit_gray_png(depth, &rows, None)).unwrap();
            let map = read(&path, &opts(None)).unwrap();
            let want: Vec<f64> = rows.concat().iter().map(|&v| f64::from(v)).collect();
            assert_eq!(map.heights.data(), &want[..], "{depth}-bit");
            assert_eq!(map.step, Some(1.0));
        }
        // With tRNS: its gray value is no-data, the others read as stored.
        let path = dir.join("gray4_trns.png");
        std::fs::write(&path, low_bit_gray_png(4, &[&[3, 7, 15]], Some(7))).unwrap();
        let map = read(&path, &opts(None)).unwrap();
        let d = map.heights.data();
        assert_eq!((d[0], d[2], map.nodata_count), (3.0, 15.0, 1));
        assert!(d[1].is_nan(), "{d:?}");
    }

    #[test]
    fn reads_16_bit_gray_and_transparent_gray_as_nodata() {
        use image::{ImageBuffer, Luma, LumaA};
        let dir = scratch_dir("png_gray16");
        // Values above 255 and with distinct bytes: a byte-swapped or 8-bit read differs.
        let path = dir.join("gray16.png");
        ImageBuffer::<Luma<u16>, Vec<u16>>::from_raw(2, 2, vec![0, 300, 0x1234, 65535])
            .unwrap()
            .save(&path)
            .unwrap();
        let map = read(&path, &opts(None)).unwrap();
        assert_eq!(map.heights.data(), &[0.0, 300.0, 4660.0, 65535.0]);
        assert_eq!((map.step, map.nodata_count), (Some(1.0), 0));

        // Gray + alpha: alpha 0 is no-data, any other alpha keeps the height.
        let path = dir.join("gray16_alpha.png");
        let pixels = vec![1000, 65535, 2000, 0, 3000, 1];
        ImageBuffer::<LumaA<u16>, Vec<u16>>::from_raw(3, 1, pixels)
            .unwrap()
            .save(&path)
            .unwrap();
        let map = read(&path, &opts(Some(Encoding::Gray))).unwrap();
        let d = map.heights.data();
        assert_eq!((d[0], d[2]), (1000.0, 3000.0));
        assert!(d[1].is_nan());
        assert_eq!(map.nodata_count, 1);
    }
}
