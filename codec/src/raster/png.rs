//! PNG heightmaps, decoded by the `image` crate: gray values are heights (8- or 16-bit), or
//! RGB carries 24-bit codes in Mapbox terrain-RGB or Terrarium form ([`Encoding`]). A
//! transparent pixel (alpha 0) is no-data, as web-map tiles mark areas outside the source.
//!
//! A PNG does not say which encoding it uses, so colour PNGs need one from the caller; PNGs
//! carry no georeference.

use std::io::BufReader;
use std::path::Path;

use image::codecs::png::PngDecoder;
use image::{DynamicImage, ImageDecoder, ImageError};

use super::error::check_shape;
use super::{open, Encoding, Heightmap, RasterError, ReadOptions};
use crate::grid::Grid;

/// Reads a PNG heightmap.
pub(super) fn read(path: &Path, opts: &ReadOptions) -> Result<Heightmap, RasterError> {
    let image_err = |e| image_error(path, e);
    let mut decoder = PngDecoder::new(BufReader::new(open(path)?)).map_err(image_err)?;

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
        (DynamicImage::ImageLuma8(img), None | Some(Encoding::Gray)) => {
            (img.pixels().map(|p| f64::from(p[0])).collect(), 1.0)
        }
        (DynamicImage::ImageLumaA8(img), None | Some(Encoding::Gray)) => {
            (img.pixels().map(|p| gray(p[0], p[1] == 0)).collect(), 1.0)
        }
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
                    "{:?} PNG; zerotile reads 8/16-bit gray and 8-bit RGB(A) heightmaps",
                    other.color()
                ),
            ))
        }
    };
    let heights = Grid::new(height as usize, width as usize, heights)
        .map_err(|e| RasterError::format(path, e.to_string()))?;
    Ok(Heightmap::new(heights, Some(step), None))
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
