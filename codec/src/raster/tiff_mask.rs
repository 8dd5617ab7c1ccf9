//! GDAL's internal no-data mask in a GeoTIFF (GDAL RFC 15, "per-dataset" mask): an image of
//! the heights' size after them in the file, NewSubfileType (254) 4 ("transparency mask"),
//! one bit a pixel, 0 where the heights have no data. GDAL writes one for
//! `GDAL_TIFF_INTERNAL_MASK`, `gdal_translate -mask` and COGs of masked data, and readers that
//! follow GDAL treat its 0 pixels as no-data whatever their samples hold (here 0 m pits).
//!
//! The `tiff` crate decodes neither photometric 4 nor 1-bit samples, so the mask's strips or
//! tiles are read here: uncompressed, DEFLATE (what GDAL writes masks with) or PackBits.

use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use tiff::decoder::{ChunkType, Decoder};
use tiff::tags::Tag;

use super::geotiff::tiff_error;
use super::{open, RasterError};

/// NewSubfileType bits (TIFF 6.0 §8): a reduced-resolution copy (an overview), and a
/// transparency mask.
const FILETYPE_REDUCED: u32 = 1;
const FILETYPE_MASK: u32 = 4;
/// Images looked through for the mask. GDAL puts it right after the heights (a COG too);
/// overviews and their masks follow, a few dozen at most.
const MAX_IMAGES: usize = 256;
/// Compression tag values of the codings read here.
const NO_COMPRESSION: u16 = 1;
const DEFLATE: u16 = 8;
const OLD_DEFLATE: u16 = 32946;
const PACKBITS: u16 = 32773;

/// Sets to NaN (no-data) the heights the file's internal mask marks as missing; the heights
/// are the first image's, `width` × `height` row-major. Leaves `decoder` on another image.
///
/// # Errors
/// A mask that is malformed, whose size is not the heights', or coded in a way not read here
/// (its compression, bits or predictor) is an error: skipped, its pixels would be heights
/// again. A page the decoder cannot open ends the search instead ([`find_mask`]).
pub(super) fn apply<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    path: &Path,
    heights: &mut [f64],
    (width, height): (u32, u32),
) -> Result<(), RasterError> {
    let tiff_err = |e| tiff_error(path, e);
    if !find_mask(decoder).map_err(tiff_err)? {
        return Ok(());
    }
    let layout = layout(decoder, path, (width, height))?;
    let offsets =
        chunk_tag(decoder, layout.tiled, Tag::StripOffsets, Tag::TileOffsets).map_err(tiff_err)?;
    let counts = chunk_tag(
        decoder,
        layout.tiled,
        Tag::StripByteCounts,
        Tag::TileByteCounts,
    )
    .map_err(tiff_err)?;

    // Each strip or tile in turn, from a reader of our own (the decoder's is not public).
    let mut file = BufReader::new(open(path)?);
    let read_err = |e| RasterError::from_read(path, e);
    for (k, (&offset, &count)) in offsets.iter().zip(&counts).enumerate() {
        let chunk = layout.chunk(k);
        file.seek(SeekFrom::Start(offset)).map_err(read_err)?;
        let stored = (&mut file).take(count);
        let mut rows: Box<dyn Read + '_> = match layout.compression {
            DEFLATE | OLD_DEFLATE => Box::new(flate2::read::ZlibDecoder::new(stored)),
            PACKBITS => Box::new(PackBits::new(stored)),
            _ => Box::new(stored),
        };
        layout
            .unmask_chunk(&mut rows, chunk, heights, width)
            .map_err(read_err)?;
    }
    Ok(())
}

/// Moves `decoder` to the heights' full-resolution mask, if the file holds one.
///
/// The search stops, the heights read without a mask, at a page the decoder cannot open
/// (no photometric tag, a 5-6-5 RGB preview: the `tiff` crate refuses such a page as a
/// whole, NewSubfileType and all), as it stops after [`MAX_IMAGES`]: such pages follow the
/// heights in files that loaded before masks were read, and GDAL writes its mask before
/// anything of the kind, right after the heights.
fn find_mask<R: Read + Seek>(decoder: &mut Decoder<R>) -> Result<bool, tiff::TiffError> {
    for _ in 0..MAX_IMAGES {
        if !decoder.more_images() {
            break;
        }
        match decoder.next_image() {
            Ok(()) => {}
            // A page the crate will not open as an image: not read here either.
            Err(tiff::TiffError::FormatError(_) | tiff::TiffError::UnsupportedError(_)) => {
                return Ok(false)
            }
            // The file failing to read, or a page past the limits, is said.
            Err(e) => return Err(e),
        }
        let kind = decoder
            .find_tag_unsigned::<u32>(Tag::NewSubfileType)?
            .unwrap_or(0);
        // An overview's mask is reduced too.
        if kind & FILETYPE_MASK != 0 && kind & FILETYPE_REDUCED == 0 {
            return Ok(true);
        }
    }
    Ok(false)
}

/// How the mask's pixels are stored.
#[derive(Clone, Copy, Debug)]
struct Layout {
    tiled: bool,
    /// Pixels a stored row of a chunk holds (the image's width for strips).
    chunk_width: u32,
    /// Rows a chunk holds.
    chunk_rows: u32,
    /// Chunks across the image.
    across: u32,
    width: u32,
    height: u32,
    /// 1 (GDAL's) or 8 bits a pixel.
    bits: u16,
    /// The bits of each byte stored lowest first (FillOrder 2).
    lsb_first: bool,
    compression: u16,
}

/// Where a chunk's pixels go: first column and row, and how many of each hold image pixels.
#[derive(Clone, Copy, Debug)]
struct Chunk {
    col: u32,
    row: u32,
    cols: u32,
    rows: u32,
}

/// The mask's layout, refused when it is not one read here.
fn layout<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    path: &Path,
    (width, height): (u32, u32),
) -> Result<Layout, RasterError> {
    let tiff_err = |e| tiff_error(path, e);
    let unsupported = |what: String| {
        RasterError::unsupported(
            path,
            format!(
                "its no-data mask (the image after the heights, NewSubfileType 4) {what}; \
                 zerotile reads 1 or 8-bit masks, uncompressed, DEFLATE or PackBits, without \
                 a predictor (gdalwarp -dstnodata VALUE turns the mask into a no-data value)"
            ),
        )
    };
    let tag = |decoder: &mut Decoder<R>, tag: Tag, default: u16| {
        decoder
            .find_tag_unsigned::<u16>(tag)
            .map(|v| v.unwrap_or(default))
    };
    let mask_size = decoder.dimensions().map_err(tiff_err)?;
    if mask_size != (width, height) {
        return Err(unsupported(format!(
            "is {} × {} pixels (columns × rows), not the heights' {width} × {height}",
            mask_size.0, mask_size.1
        )));
    }
    let bits = tag(decoder, Tag::BitsPerSample, 1).map_err(tiff_err)?;
    let samples = tag(decoder, Tag::SamplesPerPixel, 1).map_err(tiff_err)?;
    let compression = tag(decoder, Tag::Compression, NO_COMPRESSION).map_err(tiff_err)?;
    let predictor = tag(decoder, Tag::Predictor, 1).map_err(tiff_err)?;
    let fill_order = tag(decoder, Tag::FillOrder, 1).map_err(tiff_err)?;
    if !matches!(bits, 1 | 8) || samples != 1 {
        return Err(unsupported(format!(
            "has {samples} samples of {bits} bits a pixel"
        )));
    }
    if !matches!(
        compression,
        NO_COMPRESSION | DEFLATE | OLD_DEFLATE | PACKBITS
    ) {
        return Err(unsupported(format!("has compression {compression}")));
    }
    if predictor != 1 {
        return Err(unsupported(format!("has predictor {predictor}")));
    }
    let tiled = matches!(decoder.get_chunk_type(), ChunkType::Tile);
    // The decoder has checked these are not 0, and that the offsets count the chunks.
    let (chunk_width, chunk_rows) = decoder.chunk_dimensions();
    Ok(Layout {
        tiled,
        chunk_width,
        chunk_rows,
        across: width.div_ceil(chunk_width),
        width,
        height,
        bits,
        lsb_first: fill_order == 2,
        compression,
    })
}

/// The strip or tile offsets or byte counts, whichever the layout uses.
fn chunk_tag<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    tiled: bool,
    strip: Tag,
    tile: Tag,
) -> Result<Vec<u64>, tiff::TiffError> {
    decoder.get_tag_u64_vec(if tiled { tile } else { strip })
}

impl Layout {
    /// The `k`th chunk's place (chunks run across, then down).
    fn chunk(&self, k: usize) -> Chunk {
        let k = u32::try_from(k).unwrap_or(u32::MAX);
        let (x, y) = (k % self.across, k / self.across);
        let col = x.saturating_mul(self.chunk_width);
        let row = y.saturating_mul(self.chunk_rows);
        Chunk {
            col,
            row,
            cols: self.chunk_width.min(self.width.saturating_sub(col)),
            rows: self.chunk_rows.min(self.height.saturating_sub(row)),
        }
    }

    /// Reads a chunk's rows from `rows` (decompressed) and sets the heights its 0 pixels
    /// cover to NaN. Only the pixels inside the image are kept: a tile's padding right of
    /// them is skipped, and rows below them are not read.
    fn unmask_chunk(
        &self,
        rows: &mut dyn Read,
        chunk: Chunk,
        heights: &mut [f64],
        width: u32,
    ) -> io::Result<()> {
        // Each stored row starts on a byte.
        let row_bytes = |pixels: u32| (u64::from(pixels) * u64::from(self.bits)).div_ceil(8);
        let inside = row_bytes(chunk.cols);
        let padding = row_bytes(self.chunk_width) - inside;
        let mut row = vec![0u8; usize::try_from(inside).unwrap_or(usize::MAX)];
        for r in 0..chunk.rows {
            rows.read_exact(&mut row)?;
            io::copy(&mut (&mut *rows).take(padding), &mut io::sink())?;
            let start = (chunk.row + r) as usize * width as usize + chunk.col as usize;
            let Some(out) = heights.get_mut(start..start + chunk.cols as usize) else {
                break;
            };
            for (c, h) in out.iter_mut().enumerate() {
                let valid = if self.bits == 1 {
                    let byte = row[c / 8];
                    let byte = if self.lsb_first {
                        byte.reverse_bits()
                    } else {
                        byte
                    };
                    byte & (0x80 >> (c % 8)) != 0
                } else {
                    row[c] != 0
                };
                if !valid {
                    *h = f64::NAN;
                }
            }
        }
        Ok(())
    }
}

/// PackBits (TIFF 6.0 §9, Apple's run-length coding) as a reader: a header byte n < 128 is
/// followed by n + 1 literal bytes, n > 128 (as i8, −127..−1) by one byte repeated 1 − n
/// times, and 128 is skipped.
struct PackBits<R> {
    inner: R,
    literal: usize,
    run: usize,
    byte: u8,
}

impl<R: Read> PackBits<R> {
    fn new(inner: R) -> Self {
        Self {
            inner,
            literal: 0,
            run: 0,
            byte: 0,
        }
    }
}

impl<R: Read> Read for PackBits<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            if self.literal > 0 {
                let n = buf.len().min(self.literal);
                let got = self.inner.read(&mut buf[..n])?;
                if got == 0 {
                    return Err(io::ErrorKind::UnexpectedEof.into());
                }
                self.literal -= got;
                return Ok(got);
            }
            if self.run > 0 {
                let n = buf.len().min(self.run);
                buf[..n].fill(self.byte);
                self.run -= n;
                return Ok(n);
            }
            let mut header = [0u8];
            if self.inner.read(&mut header)? == 0 {
                return Ok(0);
            }
            match header[0] {
                n @ 0..=127 => self.literal = usize::from(n) + 1,
                128 => {}
                n => {
                    let mut byte = [0u8];
                    self.inner.read_exact(&mut byte)?;
                    self.byte = byte[0];
                    self.run = 257 - usize::from(n);
                }
            }
        }
    }
}
