//! The stream header. Everything the decoder needs to rebuild the scan comes first, including
//! the length of every pass segment, so that any prefix long enough to hold the header says
//! which passes it holds whole, and the error bound at every plane end. The bounds after
//! the other passes follow the stream in a trailer: a prefix does not pay for them.
//!
//! ```text
//! "ZTW2" | wavelet u8 | flags u8 | rows varint | cols varint | levels u8
//!        | step: code u8 [f64 if code = 0xFF] | offset: zigzag varint [f64 if flags bit 1]
//!        | qexp i8 | top plane u8 (255: empty) | segments varint
//!        | bit-packed, MSB first, padded to a byte:
//!        |     segment lengths (Exp-Golomb bit-length deltas per pass kind + mantissas)
//!        |     one error bound per complete plane (Exp-Golomb deltas of log codes)
//!        | [residual: bound f64 | length varint]                 (flags bit 0)
//! segment bytes … | residual bytes
//! | trailer: bit-packed error bounds after each propagation and refinement segment
//! ```
//! Each bit plane, from the top down, has three segments: propagation, refinement, cleanup
//! (see [`PassKind`]); all numbers little-endian. The header is paid for by every prefix,
//! so it is compact: the lengths grow about geometrically from plane to plane, so their
//! bit lengths are coded as small differences and only the bits under the leading one are
//! stored; common steps (1, 0.1, …, powers of two) take one byte.

use super::bound;
use crate::error::DecodeError;
use crate::wavelet::Wavelet;

pub const MAGIC: &[u8; 4] = b"ZTW2";
/// The first stream version, refused by name.
const OLD_MAGIC: &[u8; 4] = b"ZTW1";
const FLAG_RESIDUAL: u8 = 1;
const FLAG_OFFSET_F64: u8 = 2;
/// Step codes: 10^-c for c in 0..=22, 2^(c − 0x40 − 32) for c in 0x40..0x80, else an f64.
const STEP_F64: u8 = 0xFF;
const STEP_POW2: u8 = 0x40;
const DECIMAL_STEPS: [f64; 23] = [
    1e0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14,
    1e-15, 1e-16, 1e-17, 1e-18, 1e-19, 1e-20, 1e-21, 1e-22,
];
/// No segment is longer than 2^48 bytes; a longer one is malformed.
const MAX_LENGTH_BITS: u32 = 48;

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
    /// Per segment: the code of the bound on max |decoded − original| for a decode that
    /// stops right after it (see `bound`); `bound::UNKNOWN` until read (the header holds
    /// the cleanup passes' codes, the trailer the others').
    pub pass_errors: Vec<i32>,
    /// Max-error residual section: (bound in coder units, byte length).
    pub residual: Option<(f64, usize)>,
}

impl Header {
    pub fn write(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(MAGIC);
        out.push(self.wavelet.id());
        let offset_int = (self.offset.fract() == 0.0 && self.offset.abs() < 2f64.powi(53))
            .then_some(self.offset as i64);
        let mut flags = 0;
        if self.residual.is_some() {
            flags |= FLAG_RESIDUAL;
        }
        if offset_int.is_none() {
            flags |= FLAG_OFFSET_F64;
        }
        out.push(flags);
        put_varint(out, self.rows as u64);
        put_varint(out, self.cols as u64);
        out.push(self.levels as u8);
        let code = step_code(self.step);
        out.push(code);
        if code == STEP_F64 {
            out.extend_from_slice(&self.step.to_le_bytes());
        }
        match offset_int {
            Some(o) => put_varint(out, ((o << 1) ^ (o >> 63)) as u64),
            None => out.extend_from_slice(&self.offset.to_le_bytes()),
        }
        out.push(self.qexp as u8);
        out.push(self.top_plane.unwrap_or(u8::MAX));
        put_varint(out, self.segments.len() as u64);
        let mut bits = BitWriter::default();
        let mut last = [0u32; 3];
        for (s, &len) in self.segments.iter().enumerate() {
            // The bit length, as a change from the same pass one plane up, then the bits
            // under the leading one.
            let b = u64::BITS - (len as u64).leading_zeros();
            bits.signed(i64::from(b) - i64::from(last[s % 3]));
            last[s % 3] = b;
            // `>=` writes b − 1 = 0 bits for b = 1: the same.
            if b > 1 {
                bits.put(len as u64, b - 1);
            }
        }
        // Plane ends only: every prefix pays for the header.
        put_errors(&mut bits, &self.pass_errors, |s| s % 3 == 2);
        out.extend_from_slice(&bits.finish());
        if let Some((e, len)) = self.residual {
            out.extend_from_slice(&e.to_le_bytes());
            put_varint(out, len as u64);
        }
    }

    /// Parses a header; returns it and its length. Sizes are checked against `max_samples`
    /// before anything is allocated from them.
    pub fn read(bytes: &[u8], max_samples: usize) -> Result<(Self, usize), DecodeError> {
        let mut r = Reader { bytes, pos: 0 };
        let magic = r.take(4)?;
        if magic == OLD_MAGIC {
            // Version 1 had no error table and a different header: re-encode its source.
            return Err(DecodeError::Unsupported(
                "EZW stream version 1 (ZTW1): re-ingest the dataset with this version".into(),
            ));
        }
        if magic != MAGIC {
            return Err(DecodeError::Malformed(
                "not a zerotile EZW stream (bad magic)".into(),
            ));
        }
        let wid = r.u8()?;
        let wavelet = Wavelet::from_id(wid)
            .ok_or_else(|| DecodeError::Unsupported(format!("wavelet id {wid}")))?;
        let flags = r.u8()?;
        // The flags are distinct bits: `|` and `^` make the same mask.
        if flags & !(FLAG_RESIDUAL | FLAG_OFFSET_F64) != 0 {
            return Err(DecodeError::Unsupported(format!("header flags {flags:#x}")));
        }
        let rows = r.varint()?;
        let cols = r.varint()?;
        // Flat indices are u32 inside the coder.
        let limit = (max_samples as u64).min(u64::from(u32::MAX));
        let samples = rows.checked_mul(cols).filter(|&n| n <= limit);
        if rows == 0 || cols == 0 || samples.is_none() {
            return Err(DecodeError::Limit(format!(
                "{rows}×{cols} grid exceeds {limit} samples or is empty"
            )));
        }
        let levels = usize::from(r.u8()?);
        let step = match r.u8()? {
            STEP_F64 => r.f64()?,
            c if usize::from(c) < DECIMAL_STEPS.len() => DECIMAL_STEPS[usize::from(c)],
            c if (STEP_POW2..STEP_POW2 + 64).contains(&c) => {
                (2f64).powi(i32::from(c - STEP_POW2) - 32)
            }
            c => return Err(DecodeError::Malformed(format!("step code {c:#x}"))),
        };
        let offset = if flags & FLAG_OFFSET_F64 != 0 {
            r.f64()?
        } else {
            let z = r.varint()?;
            ((z >> 1) as i64 ^ -((z & 1) as i64)) as f64
        };
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
        if top_plane.is_some_and(|t| u32::from(t) > super::MAX_TOP_PLANE) {
            return Err(DecodeError::Malformed(format!("top bit plane {top}")));
        }
        let nseg = r.varint()?;
        let expected = top_plane.map_or(0, |t| 3 * (u64::from(t) + 1));
        if nseg > expected {
            return Err(DecodeError::Malformed(format!(
                "{nseg} segments for top plane {top}"
            )));
        }
        // At most 189 segments: the counts below are bounded.
        let mut bits = BitReader {
            bytes: &bytes[r.pos..],
            pos: 0,
        };
        let mut segments = Vec::with_capacity(nseg as usize);
        let mut last = [0u32; 3];
        for s in 0..nseg as usize {
            // The delta is the stream's word: a hostile one must not overflow the sum.
            let b = i64::from(last[s % 3])
                .checked_add(bits.signed()?)
                .and_then(|b| u32::try_from(b).ok())
                .filter(|&b| b <= MAX_LENGTH_BITS)
                .ok_or_else(|| DecodeError::Malformed(format!("segment {s} length")))?;
            last[s % 3] = b;
            // Deleting arm 1 changes nothing (the last arm gives 1 for b = 1, reading no bits),
            // nor does its `|` as `^` (get(b − 1) < 2^(b − 1)).
            let len = match b {
                0 => 0,
                1 => 1,
                _ => 1 << (b - 1) | bits.get(b - 1)?,
            };
            segments.push(len as usize);
        }
        let mut pass_errors = vec![bound::UNKNOWN; segments.len()];
        get_errors(&mut bits, &mut pass_errors, |s| s % 3 == 2)?;
        r.pos += bits.pos.div_ceil(8);
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
            pass_errors,
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

    /// Threshold of bit plane `k` in height units.
    pub fn plane_threshold(&self, k: u32) -> f64 {
        (2f64).powi(k as i32 + i32::from(self.qexp)) * self.step
    }

    /// Writes the trailer: the bounds after the propagation and refinement segments.
    pub fn write_trailer(&self, out: &mut Vec<u8>) {
        let mut bits = BitWriter::default();
        put_errors(&mut bits, &self.pass_errors, |s| s % 3 != 2);
        out.extend_from_slice(&bits.finish());
    }

    /// Reads the trailer (the bytes after the residual section) and returns its length. A
    /// stream cut before or inside it is still a valid prefix: those bounds then stay
    /// unknown (the `Err`).
    pub fn read_trailer(&mut self, bytes: &[u8]) -> Result<usize, DecodeError> {
        let mut bits = BitReader { bytes, pos: 0 };
        let mut errors = self.pass_errors.clone();
        get_errors(&mut bits, &mut errors, |s| s % 3 != 2)?;
        self.pass_errors = errors;
        Ok(bits.pos.div_ceil(8))
    }

    /// The error bound (height units) recorded for a decode that stops right after segment
    /// `s`, if the stream holds it.
    pub fn pass_error(&self, s: usize) -> Option<f64> {
        let q = *self.pass_errors.get(s)?;
        if q == bound::UNKNOWN {
            return None;
        }
        let k = u32::from(self.top_plane?).checked_sub((s / 3) as u32)?;
        Some(bound::value(q, self.plane_threshold(k)))
    }
}

/// One byte for the steps rasters use (1, 0.1, 0.01, …, 1/256), else [`STEP_F64`].
fn step_code(step: f64) -> u8 {
    if let Some(c) = DECIMAL_STEPS.iter().position(|&s| s == step) {
        return c as u8;
    }
    let e = step.log2();
    if e.fract() == 0.0 && (-32.0..32.0).contains(&e) && (2f64).powi(e as i32) == step {
        return STEP_POW2 + (e as i32 + 32) as u8;
    }
    STEP_F64
}

/// Codes the error bounds of the segments `pick` selects: 0 for an exact decode, else 1 + the
/// change of the code from the same pass kind one plane up (codes are relative to the plane's
/// threshold, and errors roughly halve with it: the changes are small).
fn put_errors(bits: &mut BitWriter, codes: &[i32], pick: impl Fn(usize) -> bool) {
    let mut prev = [0i32; 3];
    for (s, &q) in codes.iter().enumerate().filter(|&(s, _)| pick(s)) {
        if q == bound::ZERO {
            bits.unsigned(0);
        } else {
            bits.unsigned(1 + zigzag(i64::from(q) - i64::from(prev[s % 3])));
            prev[s % 3] = q;
        }
    }
}

/// Reads what [`put_errors`] wrote into the selected entries of `codes`.
fn get_errors(
    bits: &mut BitReader,
    codes: &mut [i32],
    pick: impl Fn(usize) -> bool,
) -> Result<(), DecodeError> {
    let mut prev = [0i64; 3];
    for (s, q) in codes.iter_mut().enumerate().filter(|(s, _)| pick(*s)) {
        let code = bits.unsigned()?;
        if code == 0 {
            *q = bound::ZERO;
            continue;
        }
        let v = code
            .checked_sub(1)
            .and_then(|z| prev[s % 3].checked_add(unzigzag(z)))
            .filter(|v| v.unsigned_abs() <= u64::from(bound::Q_LIMIT.unsigned_abs()))
            .ok_or_else(|| DecodeError::Malformed(format!("segment {s} error bound")))?;
        *q = v as i32;
        prev[s % 3] = v;
    }
    Ok(())
}

fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

fn unzigzag(z: u64) -> i64 {
    (z >> 1) as i64 ^ -((z & 1) as i64)
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

/// MSB-first bit packing with Exp-Golomb codes (H.264's ue(v)/se(v)).
#[derive(Default)]
struct BitWriter {
    out: Vec<u8>,
    /// Bits used in the last byte of `out` (0 = start a new byte).
    used: u32,
}

impl BitWriter {
    fn put(&mut self, v: u64, n: u32) {
        for i in (0..n).rev() {
            if self.used == 0 {
                self.out.push(0);
            }
            if v >> i & 1 == 1 {
                if let Some(last) = self.out.last_mut() {
                    *last |= 0x80 >> self.used;
                }
            }
            self.used = (self.used + 1) % 8;
        }
    }

    /// Exp-Golomb: v + 1 in binary, after as many zeros as it has bits less one.
    fn unsigned(&mut self, v: u64) {
        let x = u128::from(v) + 1;
        let n = u128::BITS - x.leading_zeros();
        self.put(0, n - 1);
        // x < 2^64 + 1: its low 64 bits and the leading one carry it.
        if n > 64 {
            self.put(1, 1);
            self.put(x as u64, 64);
        } else {
            self.put(x as u64, n);
        }
    }

    fn signed(&mut self, v: i64) {
        self.unsigned(zigzag(v));
    }

    fn finish(self) -> Vec<u8> {
        self.out
    }
}

struct BitReader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl BitReader<'_> {
    fn bit(&mut self) -> Result<u64, DecodeError> {
        let byte = self
            .bytes
            .get(self.pos / 8)
            .ok_or(DecodeError::Truncated("header"))?;
        let b = u64::from(byte >> (7 - self.pos % 8) & 1);
        self.pos += 1;
        Ok(b)
    }

    fn get(&mut self, n: u32) -> Result<u64, DecodeError> {
        let mut v = 0;
        for _ in 0..n {
            // The shifted bit is 0: `|` and `^` are the same.
            v = v << 1 | self.bit()?;
        }
        Ok(v)
    }

    fn unsigned(&mut self) -> Result<u64, DecodeError> {
        let mut zeros = 0;
        while self.bit()? == 0 {
            zeros += 1;
            if zeros > 64 {
                return Err(DecodeError::Malformed("Exp-Golomb code too long".into()));
            }
        }
        let rest = self.get(zeros)?;
        // 2^zeros + rest − 1, which fits in u64 for zeros ≤ 64 only when it does not overflow.
        (1u128 << zeros)
            .checked_add(u128::from(rest))
            .and_then(|x| u64::try_from(x - 1).ok())
            .ok_or_else(|| DecodeError::Malformed("Exp-Golomb code too large".into()))
    }

    fn signed(&mut self) -> Result<i64, DecodeError> {
        Ok(unzigzag(self.unsigned()?))
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
            offset: -12.0,
            qexp: -4,
            top_plane: Some(20),
            segments: vec![3, 0, 200, 1000, 70000, 1, 12, 13, 0],
            pass_errors: vec![40, 37, 41, 38, 36, 12, 20, 5, bound::ZERO],
            residual: Some((1.0, 77)),
        }
    }

    fn read_back(h: &Header) -> Result<Header, DecodeError> {
        let mut out = Vec::new();
        h.write(&mut out);
        Header::read(&out, 1 << 20).map(|(h, _)| h)
    }

    /// Plane k's threshold is 2^(k + qexp) steps in height units: plane −qexp's is one step.
    #[test]
    fn plane_thresholds_are_in_height_units() {
        let h = sample();
        assert_eq!((h.step, h.qexp), (0.1, -4));
        assert_eq!(h.plane_threshold(4), 0.1);
        assert_eq!(h.plane_threshold(20), 65536.0 * 0.1);
        assert_eq!(h.plane_threshold(0), 0.1 / 16.0);
    }

    /// The header's first bytes as docs/ezw-stream.md lays them out for other decoders: the
    /// wavelet byte's two values are read from the doc's layout line, so the doc and the
    /// writer cannot drift apart (the doc once had them swapped).
    #[test]
    fn the_wavelet_byte_is_as_documented() {
        let doc = include_str!("../../../docs/ezw-stream.md");
        let line = doc
            .lines()
            .find(|l| l.starts_with("\"ZTW2\" | wavelet u8 ("))
            .expect("the layout line");
        let named = |w: &str| -> u8 {
            let at = line.find(&format!(" = {w}")).expect(w);
            line[..at]
                .rsplit(['(', ' '])
                .next()
                .unwrap()
                .parse()
                .unwrap()
        };
        for (w, doc_name) in [(Wavelet::Cdf97, "9/7"), (Wavelet::LeGall53, "5/3")] {
            let mut out = Vec::new();
            Header {
                wavelet: w,
                ..sample()
            }
            .write(&mut out);
            assert_eq!(&out[..4], MAGIC);
            assert_eq!(out[4], named(doc_name), "{doc_name}: {line}");
        }
    }

    #[test]
    fn empty_grids_are_refused() {
        for (rows, cols) in [(0, 300), (257, 0), (0, 0)] {
            let h = Header {
                rows,
                cols,
                ..sample()
            };
            assert!(
                matches!(read_back(&h), Err(DecodeError::Limit(_))),
                "{rows}×{cols}"
            );
        }
    }

    /// Step codes past the decimal table (23..0x40) and the powers of two (0x80..0xFF) are
    /// refused; the last entries of both read as what they stand for.
    #[test]
    fn step_codes_outside_the_tables_are_refused() {
        let mut out = Vec::new();
        sample().write(&mut out);
        // Magic, wavelet, flags, rows and cols (two varint bytes each), levels.
        let at = 4 + 1 + 1 + 2 + 2 + 1;
        assert_eq!(out[at], step_code(0.1));
        for (code, step) in [(22, Some(1e-22)), (23, None), (0x3F, None)]
            .into_iter()
            .chain([(0x40, Some(2f64.powi(-32))), (0x7F, Some(2f64.powi(31)))])
            .chain([(0x80, None), (0xFE, None)])
        {
            out[at] = code;
            match (Header::read(&out, 1 << 20), step) {
                (Ok((h, _)), Some(step)) => assert_eq!(h.step, step, "code {code:#x}"),
                (Err(DecodeError::Malformed(_)), None) => {}
                (other, _) => panic!("code {code:#x}: {other:?}"),
            }
        }
    }

    /// The powers of two from 2^-32 to 2^31 take one byte, the rest an f64; all read back.
    #[test]
    fn power_of_two_steps_take_one_byte_in_range() {
        let len = |step: f64| {
            let h = Header { step, ..sample() };
            assert_eq!(read_back(&h).unwrap().step, step);
            let mut out = Vec::new();
            h.write(&mut out);
            out.len()
        };
        let one = len(1.0);
        for e in -40..=40 {
            let step = 2f64.powi(e);
            let extra = if (-32..32).contains(&e) { 0 } else { 8 };
            assert_eq!(len(step), one + extra, "2^{e}");
            assert_eq!(len(step * 3.0), one + 8, "3 · 2^{e}");
        }
    }

    /// Integer offsets below 2^53 are a zigzag varint; others an f64, and the flag says so.
    #[test]
    fn integer_offsets_take_a_varint() {
        let big = 2f64.powi(53);
        for (offset, as_f64) in [
            (-12.0, false),
            (3e15, false),
            (big - 1.0, false),
            (1.0 - big, false),
            (big, true),
            (-big, true),
            (0.5, true),
            (-1e300, true),
        ] {
            let h = Header { offset, ..sample() };
            let mut out = Vec::new();
            h.write(&mut out);
            assert_eq!(out[5] & FLAG_OFFSET_F64 != 0, as_f64, "{offset}");
            assert_eq!(read_back(&h).unwrap().offset, offset);
        }
    }

    /// Numbers the decoder would divide by or scale with must be finite, and the step and the
    /// residual bound positive.
    #[test]
    fn non_finite_and_non_positive_numbers_are_refused() {
        let bad = [0.0, -0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
        for x in bad {
            let refused = |h: Header| matches!(read_back(&h), Err(DecodeError::Malformed(_)));
            assert!(
                refused(Header {
                    step: x,
                    ..sample()
                }),
                "step {x}"
            );
            assert!(
                refused(Header {
                    residual: Some((x, 77)),
                    ..sample()
                }),
                "residual bound {x}"
            );
            if !x.is_finite() {
                assert!(
                    refused(Header {
                        offset: x,
                        ..sample()
                    }),
                    "offset {x}"
                );
            }
        }
    }

    #[test]
    fn header_round_trips() {
        let mut h = sample();
        for (step, offset) in [
            (0.1, -12.0),
            (1.0, 3e15),
            (1.0 / 256.0, 0.5),
            (0.37, -1e300),
        ] {
            h.step = step;
            h.offset = offset;
            let mut out = Vec::new();
            h.write(&mut out);
            let (mut back, len) = Header::read(&out, 1 << 20).unwrap();
            assert_eq!(len, out.len());
            // The header alone knows the plane ends' bounds; the trailer adds the rest.
            assert_eq!(back.pass_error(5), h.pass_error(5));
            assert_eq!(back.pass_error(3), None);
            let mut trailer = Vec::new();
            h.write_trailer(&mut trailer);
            assert!(back.read_trailer(&trailer[..trailer.len() - 1]).is_err());
            assert_eq!(back.pass_error(3), None);
            back.read_trailer(&trailer).unwrap();
            assert_eq!(back, h);
        }
    }

    #[test]
    fn common_steps_take_one_byte() {
        assert_eq!(step_code(1.0), 0);
        assert_eq!(step_code(0.1), 1);
        assert_eq!(step_code(1.0 / 256.0), STEP_POW2 + 24);
        assert_eq!(step_code(0.3), STEP_F64);
    }

    #[test]
    fn exp_golomb_round_trips_extremes() {
        let mut w = BitWriter::default();
        let values = [0u64, 1, 2, 7, 1 << 40, u64::MAX - 1, u64::MAX];
        for &v in &values {
            w.unsigned(v);
        }
        w.signed(i64::MIN);
        w.signed(-5);
        let bytes = w.finish();
        let mut r = BitReader {
            bytes: &bytes,
            pos: 0,
        };
        for &v in &values {
            assert_eq!(r.unsigned().unwrap(), v);
        }
        assert_eq!(r.signed().unwrap(), i64::MIN);
        assert_eq!(r.signed().unwrap(), -5);
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

    /// Numbers no encoder writes are refused, not decoded: more than three segments per
    /// plane, a top plane above 62 (magnitudes stay below 2^63), a quantiser exponent
    /// outside ±30 (thresholds 2^(k + qexp) would leave f64's range).
    #[test]
    fn impossible_planes_and_exponents_are_refused() {
        let read = |h: &Header| {
            let mut out = Vec::new();
            h.write(&mut out);
            Header::read(&out, 1 << 20)
        };
        assert!(read(&sample()).is_ok());
        let mut h = sample();
        h.segments = vec![1; 3 * 21 + 1];
        h.pass_errors = vec![bound::ZERO; h.segments.len()];
        assert!(
            matches!(read(&h), Err(DecodeError::Malformed(_))),
            "64 segments"
        );
        h.segments.pop();
        h.pass_errors.pop();
        assert!(read(&h).is_ok(), "63 segments for 21 planes");
        let mut h = sample();
        h.top_plane = Some(62);
        assert!(read(&h).is_ok(), "top plane 62");
        h.top_plane = Some(63);
        assert!(
            matches!(read(&h), Err(DecodeError::Malformed(_))),
            "top plane 63"
        );
        for qexp in [31, -31] {
            let mut h = sample();
            h.qexp = qexp;
            assert!(
                matches!(read(&h), Err(DecodeError::Malformed(_))),
                "qexp {qexp}"
            );
        }
    }
}
