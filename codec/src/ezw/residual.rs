//! The max-error pass: JPEG 2000 and plain EZW bound the RMS error, not the largest one, and
//! DEM users specify the largest. After the wavelet prefix, every sample's residual is
//! quantised to bins of width 2E (2E + 1 on integer grids, as JPEG-LS near-lossless does:
//! the decoded surface is rounded to the grid first), so |decoded − original| ≤ E holds for
//! every sample. The bin indices are mostly zero and are coded with neighbour contexts
//! (SPERR codes its outliers after the wavelet pass the same way in spirit).
//!
//! The encoder tries the plane boundaries as the cut between wavelet prefix and residual
//! and keeps the cheapest total. It does not decode to try a cut: the state a decoder holds
//! at a plane boundary follows from the encoder's final state (every coefficient found by
//! then is known exactly down to that plane), so a candidate costs one inverse transform
//! and one residual coding, which stops early once it cannot beat the best so far.

use super::arith::{Decoder, Encoder, Prob, PROB_INIT};
use crate::error::DecodeError;
use crate::grid::Grid;

const MODE_REAL: u8 = 0;
const MODE_INTEGER: u8 = 1;
/// Unary magnitude bins before the Exp-Golomb escape.
const UNARY: usize = 14;
/// Escape bits cap: magnitudes beyond 2^40 bins are not a heightmap.
const MAX_ESCAPE_BITS: u32 = 40;
/// Samples between two looks at the budget while coding a candidate.
const CHECK_EVERY: usize = 4096;

/// The chosen split between wavelet prefix and residual pass.
pub struct Cut {
    pub segments: usize,
    /// Bound in coder units.
    pub bound: f64,
    pub bytes: Vec<u8>,
}

/// Tries the cuts between wavelet prefix and residual pass (every plane boundary, and the
/// point after a plane's propagation and refinement passes) from the finest back while the
/// totals keep falling, and returns the cheapest. `heights_at(cut)` gives the centred
/// heights a decoder holds after the first `cut` segments (`segments` are their lengths).
pub fn choose_cut(
    heights_at: impl Fn(usize) -> Grid<f64>,
    segments: &[usize],
    units: &Grid<f64>,
    bound: f64,
) -> Cut {
    // `units` are centred coder units, the same the decoder reconstructs before the residual.
    let integer = units.data().iter().all(|u| u.fract() == 0.0) && bound >= 1.0;
    let bound = if integer { bound.floor() } else { bound };
    let mut best: Option<(usize, Cut)> = None;
    let mut worse_in_a_row = 0;
    for cut in (0..=segments.len()).rev().filter(|s| s % 3 != 1) {
        let prefix_len: usize = segments[..cut].iter().sum();
        // A candidate only counts while its total stays below the best: the residual
        // coder stops as soon as its output says it cannot.
        let budget = best.as_ref().map(|(t, _)| t.saturating_sub(prefix_len));
        let bytes = match budget {
            Some(b) if b <= 1 => None,
            _ => encode_residual(units, &heights_at(cut), bound, integer, budget),
        };
        match bytes {
            Some(bytes) => {
                worse_in_a_row = 0;
                best = Some((
                    prefix_len + bytes.len(),
                    Cut {
                        segments: cut,
                        bound,
                        bytes,
                    },
                ));
            }
            None => {
                worse_in_a_row += 1;
                // Totals are near-convex in the cut: stop after a clear turn.
                if worse_in_a_row >= 3 {
                    break;
                }
            }
        }
    }
    let mode = if integer { MODE_INTEGER } else { MODE_REAL };
    best.map_or(
        Cut {
            segments: 0,
            bound,
            bytes: vec![mode],
        },
        |(_, c)| c,
    )
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

/// Codes the residual bins of `units` over `decoded`. With a `budget`, gives up (`None`) as
/// soon as the section is sure to take `budget` bytes or more.
fn encode_residual(
    units: &Grid<f64>,
    decoded: &Grid<f64>,
    bound: f64,
    integer: bool,
    budget: Option<usize>,
) -> Option<Vec<u8>> {
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
    let mode = if integer { MODE_INTEGER } else { MODE_REAL };
    if q.iter().all(|&v| v == 0) {
        return Some(vec![mode]);
    }
    let mut m = Model::new();
    let mut enc = Encoder::new();
    for idx in 0..q.len() {
        if idx % CHECK_EVERY == 0 && budget.is_some_and(|b| 1 + enc.committed() >= b) {
            return None;
        }
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
                enc.encode_bypass((rest + 1) >> b & 1 == 1);
            }
        }
        enc.encode(&mut m.sign[sc], v < 0);
    }
    let mut out = vec![mode];
    out.extend(enc.finish());
    budget.is_none_or(|b| out.len() < b).then_some(out)
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
                rest = rest << 1 | u64::from(dec.decode_bypass());
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A real-valued decoded surface, as a 9/7 prefix leaves one.
    fn surface(rows: usize, cols: usize) -> Grid<f64> {
        let data = (0..rows * cols)
            .map(|k| ((k / cols) as f64 * 0.37).sin() * 20.0 + (k % cols) as f64 * 0.61)
            .collect();
        Grid::new(rows, cols, data).unwrap()
    }

    /// JPEG-LS near-lossless: on integer heights a bin holds 2E + 1 integers, so once the
    /// decoded surface is rounded every residual in [−E, E] is bin 0 and the section is its
    /// mode byte alone; one beyond E costs a bin, and every sample ends within E.
    #[test]
    fn integer_residuals_within_the_bound_cost_nothing() {
        let (rows, cols, e) = (17, 23, 2.0);
        let decoded = surface(rows, cols);
        let offsets = [-2.0, -1.0, 0.0, 1.0, 2.0];
        let within = decoded.map(|d| d.round());
        let mut units = within.clone();
        for (k, u) in units.data_mut().iter_mut().enumerate() {
            *u += offsets[k % offsets.len()];
        }
        let bytes = encode_residual(&units, &decoded, e, true, None).unwrap();
        assert_eq!(bytes, vec![MODE_INTEGER]);
        let mut back = decoded.clone();
        apply(&mut back, &bytes, e).unwrap();
        assert_eq!(back, within);

        for (k, u) in units.data_mut().iter_mut().enumerate() {
            *u += if k % 7 == 0 { 3.0 } else { 0.0 };
        }
        let bytes = encode_residual(&units, &decoded, e, true, None).unwrap();
        assert!(bytes.len() > 1);
        let mut back = decoded.clone();
        apply(&mut back, &bytes, e).unwrap();
        for (b, u) in back.data().iter().zip(units.data()) {
            assert!(b.fract() == 0.0 && (b - u).abs() <= e, "{b} for {u}");
        }
    }

    /// Real-valued bins are 2E wide: residuals strictly inside (−E, E) cost nothing, and
    /// larger ones come back within E.
    #[test]
    fn real_residuals_come_back_within_the_bound() {
        let (rows, cols, e) = (19, 11, 0.25);
        let decoded = surface(rows, cols);
        let near = decoded.map(|d| d + 0.2);
        let bytes = encode_residual(&near, &decoded, e, false, None).unwrap();
        assert_eq!(bytes, vec![MODE_REAL]);
        let far = Grid::new(
            rows,
            cols,
            (0..rows * cols)
                .map(|k| (k % 13) as f64 * 0.9 - 5.0)
                .collect(),
        )
        .unwrap();
        let mut units = decoded.map(|d| d.round());
        for (u, f) in units.data_mut().iter_mut().zip(far.data()) {
            *u += f;
        }
        let bytes = encode_residual(&units, &decoded, e, false, None).unwrap();
        let mut back = decoded.clone();
        apply(&mut back, &bytes, e).unwrap();
        for (b, u) in back.data().iter().zip(units.data()) {
            assert!((b - u).abs() <= e, "{b} for {u}");
        }
    }
}
