//! The stream header. Everything the decoder needs to rebuild the scan comes first, including
//! the length of every pass segment, so that any prefix long enough to hold the header says
//! which passes it holds whole.
//!
//! ```text
//! "ZTW1" | wavelet u8 | flags u8 | rows varint | cols varint | levels u8 | step f64 | offset f64
//!        | qexp i8 | top plane u8 | segments varint | length varint × segments
//!        | [residual: max_error f64 | length varint]            (flags bit 0)
//! segment bytes … | residual bytes
//! ```
//! Each bit plane, from the top down, has three segments: propagation, refinement, cleanup
//! (see [`PassKind`]); all numbers little-endian.

use crate::error::DecodeError;
use crate::wavelet::Wavelet;

pub const MAGIC: &[u8; 4] = b"ZTW1";
const FLAG_RESIDUAL: u8 = 1;

/// The three passes of a bit plane, in stream order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    /// Significance of coefficients next to significant ones.
    Propagation,
    /// One more magnitude bit of coefficients significant at a higher plane (subordinate pass).
    Refinement,
    /// Shapiro's dominant pass over the rest, with zerotrees.
    Cleanup,
}

/// Parsed header.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    pub wavelet: Wavelet,
    pub rows: usize,
    pub cols: usize,
    pub levels: usize,
    /// Height units per coder unit.
    pub step: f64,
    /// Subtracted (in coder units) before the transform.
    pub offset: f64,
    /// Quantisation step of weighted coefficients is 2^qexp coder units.
    pub qexp: i8,
    /// Highest bit plane, `None` when every coefficient is zero.
    pub top_plane: Option<u8>,
    pub segments: Vec<usize>,
    /// Max-error residual section: (bound in coder units, byte length).
    pub residual: Option<(f64, usize)>,
}

impl Header {
    pub fn write(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(MAGIC);
        out.push(self.wavelet.id());
        out.push(if self.residual.is_some() {
            FLAG_RESIDUAL
        } else {
            0
        });
        put_varint(out, self.rows as u64);
        put_varint(out, self.cols as u64);
        out.push(self.levels as u8);
        out.extend_from_slice(&self.step.to_le_bytes());
        out.extend_from_slice(&self.offset.to_le_bytes());
        out.push(self.qexp as u8);
        out.push(self.top_plane.unwrap_or(u8::MAX));
        put_varint(out, self.segments.len() as u64);
        for &s in &self.segments {
            put_varint(out, s as u64);
        }
        if let Some((e, len)) = self.residual {
            out.extend_from_slice(&e.to_le_bytes());
            put_varint(out, len as u64);
        }
    }

    /// Parses a header; returns it and its length. Sizes are checked against `max_samples`
    /// before anything is allocated from them.
    pub fn read(bytes: &[u8], max_samples: usize) -> Result<(Self, usize), DecodeError> {
        let mut r = Reader { bytes, pos: 0 };
        if r.take(4)? != MAGIC {
            return Err(DecodeError::Malformed(
                "not a zerotile EZW stream (bad magic)".into(),
            ));
        }
        let wid = r.u8()?;
        let wavelet = Wavelet::from_id(wid)
            .ok_or_else(|| DecodeError::Unsupported(format!("wavelet id {wid}")))?;
        let flags = r.u8()?;
        if flags & !FLAG_RESIDUAL != 0 {
            return Err(DecodeError::Unsupported(format!("header flags {flags:#x}")));
        }
        let rows = r.varint()?;
        let cols = r.varint()?;
        let samples = rows.checked_mul(cols).filter(|&n| n <= max_samples as u64);
        if rows == 0 || cols == 0 || samples.is_none() {
            return Err(DecodeError::Limit(format!(
                "{rows}×{cols} grid exceeds {max_samples} samples or is empty"
            )));
        }
        let levels = usize::from(r.u8()?);
        let step = r.f64()?;
        let offset = r.f64()?;
        if !(step.is_finite() && step > 0.0 && offset.is_finite()) {
            return Err(DecodeError::Malformed(format!(
                "step {step} / offset {offset}"
            )));
        }
        let qexp = r.u8()? as i8;
        if !(-30..=30).contains(&qexp) {
            return Err(DecodeError::Malformed(format!("quantiser exponent {qexp}")));
        }
        let top = r.u8()?;
        let top_plane = (top != u8::MAX).then_some(top);
        if top_plane.is_some_and(|t| t > 62) {
            return Err(DecodeError::Malformed(format!("top bit plane {top}")));
        }
        let nseg = r.varint()?;
        let expected = top_plane.map_or(0, |t| 3 * (u64::from(t) + 1));
        if nseg > expected {
            return Err(DecodeError::Malformed(format!(
                "{nseg} segments for top plane {top}"
            )));
        }
        let mut segments = Vec::with_capacity(nseg as usize);
        for _ in 0..nseg {
            segments.push(r.varint()? as usize);
        }
        let residual = if flags & FLAG_RESIDUAL != 0 {
            let e = r.f64()?;
            if !(e.is_finite() && e > 0.0) {
                return Err(DecodeError::Malformed(format!("residual bound {e}")));
            }
            Some((e, r.varint()? as usize))
        } else {
            None
        };
        let header = Self {
            wavelet,
            rows: rows as usize,
            cols: cols as usize,
            levels,
            step,
            offset,
            qexp,
            top_plane,
            segments,
            residual,
        };
        Ok((header, r.pos))
    }

    /// Bit plane coded by segment `s`, and which pass it is.
    pub fn segment_plane(&self, s: usize) -> (u32, PassKind) {
        let top = u32::from(self.top_plane.unwrap_or(0));
        let kind = match s % 3 {
            0 => PassKind::Propagation,
            1 => PassKind::Refinement,
            _ => PassKind::Cleanup,
        };
        (top.saturating_sub((s / 3) as u32), kind)
    }
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], DecodeError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or(DecodeError::Truncated("header"))?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn u8(&mut self) -> Result<u8, DecodeError> {
        Ok(self.take(1)?[0])
    }

    fn f64(&mut self) -> Result<f64, DecodeError> {
        let mut b = [0u8; 8];
        b.copy_from_slice(self.take(8)?);
        Ok(f64::from_le_bytes(b))
    }

    fn varint(&mut self) -> Result<u64, DecodeError> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.u8()?;
            v |= u64::from(b & 0x7F) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(DecodeError::Malformed("varint longer than 64 bits".into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Header {
        Header {
            wavelet: Wavelet::Cdf97,
            rows: 257,
            cols: 300,
            levels: 8,
            step: 0.1,
            offset: -12.5,
            qexp: -4,
            top_plane: Some(20),
            segments: vec![3, 0, 200, 1000, 70000],
            residual: Some((1.0, 77)),
        }
    }

    #[test]
    fn header_round_trips() {
        let h = sample();
        let mut out = Vec::new();
        h.write(&mut out);
        let (back, len) = Header::read(&out, 1 << 20).unwrap();
        assert_eq!(back, h);
        assert_eq!(len, out.len());
    }

    #[test]
    fn every_truncation_of_a_header_is_an_error() {
        let mut out = Vec::new();
        sample().write(&mut out);
        for cut in 0..out.len() {
            assert!(
                Header::read(&out[..cut], 1 << 20).is_err(),
                "cut at {cut} parsed"
            );
        }
    }

    #[test]
    fn oversized_grid_is_refused_before_allocation() {
        let mut h = sample();
        h.rows = 1 << 30;
        h.cols = 1 << 30;
        let mut out = Vec::new();
        h.write(&mut out);
        assert!(matches!(
            Header::read(&out, 1 << 26),
            Err(DecodeError::Limit(_))
        ));
    }
}
