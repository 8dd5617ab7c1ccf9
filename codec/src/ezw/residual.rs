//! The max-error pass: JPEG 2000 and plain EZW bound the RMS error, not the largest one, and
//! DEM users specify the largest. After the wavelet prefix, every sample's residual is
//! quantised to bins of width 2E (2E + 1 on integer grids, as JPEG-LS near-lossless does:
//! the decoded surface is rounded to the grid first), so |decoded − original| ≤ E holds for
//! every sample. The bin indices are mostly zero and are coded with neighbour contexts
//! (SPERR codes its outliers after the wavelet pass the same way in spirit).
//!
//! The encoder tries every plane boundary as the cut between wavelet prefix and residual
//! and keeps the cheapest total.

use super::arith::{Decoder, Encoder, Prob, PROB_INIT};
use super::stream::Header;
use super::{decode_centered, DecodeLimit};
use crate::error::DecodeError;
use crate::grid::Grid;

const MODE_REAL: u8 = 0;
const MODE_INTEGER: u8 = 1;
/// Unary magnitude bins before the Exp-Golomb escape.
const UNARY: usize = 14;
/// Escape bits cap: magnitudes beyond 2^40 bins are not a heightmap.
const MAX_ESCAPE_BITS: u32 = 40;

/// The chosen split between wavelet prefix and residual pass.
pub struct Cut {
    pub segments: usize,
    /// Bound in coder units.
    pub bound: f64,
    pub bytes: Vec<u8>,
}

/// Tries each plane boundary and returns the cheapest (prefix + residual) split.
pub fn choose_cut(header: &Header, segments: &[Vec<u8>], units: &Grid<f64>, bound: f64) -> Cut {
    // `units` are centred coder units, the same the decoder reconstructs before the residual.
    let integer = units.data().iter().all(|u| u.fract() == 0.0) && bound >= 1.0;
    let bound = if integer { bound.floor() } else { bound };
    let mut best: Option<(usize, Cut)> = None;
    // Cut at each plane boundary (and after the propagation/refinement part of a plane).
    let cuts: Vec<usize> = (0..=segments.len()).filter(|s| s % 3 != 1).collect();
    let mut worse_in_a_row = 0;
    for &cut in cuts.iter().rev() {
        let prefix_len: usize = segments[..cut].iter().map(Vec::len).sum();
        let decoded = decoded_units(header, segments, cut);
        let Some(decoded) = decoded else { continue };
        let bytes = encode_residual(units, &decoded, bound, integer);
        let total = prefix_len + bytes.len();
        match &best {
            Some((t, _)) if *t <= total => {
                worse_in_a_row += 1;
                // Totals are near-convex in the cut: stop after a clear turn.
                if worse_in_a_row >= 3 {
                    break;
                }
            }
            _ => {
                worse_in_a_row = 0;
                best = Some((
                    total,
                    Cut {
                        segments: cut,
                        bound,
                        bytes,
                    },
                ));
            }
        }
    }
    best.map(|(_, c)| c).unwrap_or(Cut {
        segments: 0,
        bound,
        bytes: Vec::new(),
    })
}

/// Decodes the first `cut` segments, in centred coder units.
fn decoded_units(header: &Header, segments: &[Vec<u8>], cut: usize) -> Option<Grid<f64>> {
    let mut h = header.clone();
    h.segments = segments[..cut].iter().map(Vec::len).collect();
    h.residual = None;
    let mut bytes = Vec::new();
    h.write(&mut bytes);
    for s in &segments[..cut] {
        bytes.extend_from_slice(s);
    }
    decode_centered(&bytes, DecodeLimit::All, usize::MAX)
        .ok()
        .map(|(d, _)| d.heights)
}

struct Model {
    nonzero: [Prob; 9],
    magnitude: [[Prob; UNARY]; 2],
    escape: [Prob; 2 * MAX_ESCAPE_BITS as usize],
    sign: [Prob; 3],
}

impl Model {
    fn new() -> Self {
        Self {
            nonzero: [PROB_INIT; 9],
            magnitude: [[PROB_INIT; UNARY]; 2],
            escape: [PROB_INIT; 2 * MAX_ESCAPE_BITS as usize],
            sign: [PROB_INIT; 3],
        }
    }
}

/// Neighbour context from the already-coded bins: left, up, up-left, up-right.
#[inline]
fn context(q: &[i64], cols: usize, idx: usize) -> (usize, usize, usize) {
    let (r, c) = (idx / cols, idx % cols);
    let get = |ok: bool, i: usize| if ok { q[i] } else { 0 };
    let left = get(c > 0, idx.wrapping_sub(1));
    let up = get(r > 0, idx.wrapping_sub(cols));
    let ul = get(r > 0 && c > 0, idx.wrapping_sub(cols + 1));
    let ur = get(
        r > 0 && c + 1 < cols,
        idx.wrapping_sub(cols).wrapping_add(1),
    );
    let count = usize::from(left != 0) + usize::from(up != 0) + usize::from(ul != 0 || ur != 0);
    let big = usize::from(left.abs() > 1 || up.abs() > 1);
    let nz = (count * 2 + big).min(8);
    let sign = if left != 0 {
        1 + usize::from(left < 0)
    } else if up != 0 {
        1 + usize::from(up < 0)
    } else {
        0
    };
    (nz, big, sign)
}

fn encode_residual(units: &Grid<f64>, decoded: &Grid<f64>, bound: f64, integer: bool) -> Vec<u8> {
    let bin = if integer {
        2.0 * bound + 1.0
    } else {
        2.0 * bound
    };
    let cols = units.cols();
    let mut q = vec![0i64; units.len()];
    for (idx, (&u, &d)) in units.data().iter().zip(decoded.data()).enumerate() {
        let base = if integer { d.round() } else { d };
        let mut k = ((u - base) / bin).round();
        // Guard the float rounding edge so the bound is exact.
        if (u - (base + k * bin)).abs() > bound {
            k += (u - (base + k * bin)).signum();
        }
        q[idx] = k as i64;
    }
    if q.iter().all(|&v| v == 0) {
        return vec![if integer { MODE_INTEGER } else { MODE_REAL }];
    }
    let mut m = Model::new();
    let mut enc = Encoder::new();
    for idx in 0..q.len() {
        let (nz, big, sc) = context(&q, cols, idx);
        let v = q[idx];
        enc.encode(&mut m.nonzero[nz], v != 0);
        if v == 0 {
            continue;
        }
        let mag = v.unsigned_abs() - 1;
        let mut n = 0;
        while n < UNARY {
            let more = mag > n as u64;
            enc.encode(&mut m.magnitude[big][n], more);
            if !more {
                break;
            }
            n += 1;
        }
        if n == UNARY {
            // Exp-Golomb escape: bit count in unary, then the bits.
            let rest = mag - UNARY as u64;
            let bits = 64 - (rest + 1).leading_zeros();
            for b in 0..bits.min(MAX_ESCAPE_BITS) {
                enc.encode(&mut m.escape[b as usize], b + 1 < bits);
            }
            for b in (0..bits.saturating_sub(1)).rev() {
                enc.encode_even((rest + 1) >> b & 1 == 1);
            }
        }
        enc.encode(&mut m.sign[sc], v < 0);
    }
    let mut out = vec![if integer { MODE_INTEGER } else { MODE_REAL }];
    out.extend(enc.finish());
    out
}

/// Applies a residual section to heights in coder units (offset not yet added back).
pub fn apply(units: &mut Grid<f64>, bytes: &[u8], bound: f64) -> Result<(), DecodeError> {
    let (&mode, body) = bytes
        .split_first()
        .ok_or(DecodeError::Truncated("residual mode"))?;
    let integer = match mode {
        MODE_REAL => false,
        MODE_INTEGER => true,
        other => return Err(DecodeError::Malformed(format!("residual mode {other}"))),
    };
    let bin = if integer {
        2.0 * bound + 1.0
    } else {
        2.0 * bound
    };
    if integer {
        for u in units.data_mut() {
            *u = u.round();
        }
    }
    if body.is_empty() {
        return Ok(());
    }
    let cols = units.cols();
    let mut q = vec![0i64; units.len()];
    let mut m = Model::new();
    let mut dec = Decoder::new(body);
    for idx in 0..q.len() {
        let (nz, big, sc) = context(&q, cols, idx);
        if !dec.decode(&mut m.nonzero[nz]) {
            continue;
        }
        let mut mag = 0u64;
        while (mag as usize) < UNARY && dec.decode(&mut m.magnitude[big][mag as usize]) {
            mag += 1;
        }
        if mag as usize == UNARY {
            let mut bits = 1;
            while bits < MAX_ESCAPE_BITS && dec.decode(&mut m.escape[(bits - 1) as usize]) {
                bits += 1;
            }
            let mut rest = 1u64;
            for _ in 0..bits - 1 {
                rest = rest << 1 | u64::from(dec.decode_even());
            }
            mag += rest - 1;
        }
        let v = (mag + 1) as i64;
        q[idx] = if dec.decode(&mut m.sign[sc]) { -v } else { v };
    }
    for (u, &k) in units.data_mut().iter_mut().zip(&q) {
        *u += k as f64 * bin;
    }
    Ok(())
}
