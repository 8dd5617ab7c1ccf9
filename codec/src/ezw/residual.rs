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
    // Each `< 0` sees a non-zero bin: `<= 0` is the same.
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
        // On a bin edge `round` can take the far bin by an ulp: step back toward u. (On some
        // edges both bins miss the bound by an ulp of u; no bin does better.)
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
        // How often this looks (`%` as `/` or `+`, `==` as `!=`, `1 +` as `1 *`) only changes
        // how soon a hopeless candidate stops: `out` ends at least 1 + committed bytes long,
        // so the check after the loop refuses whatever this one would.
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
            // Exp-Golomb escape: bit count in unary, then the bits. The decoder stops at
            // MAX_ESCAPE_BITS without a flag to end the count, so none is written there
            // (E ≥ range × 2^-40 keeps real residuals near 2^38 bins at most).
            let rest = mag - UNARY as u64;
            let bits = 64 - (rest + 1).leading_zeros();
            debug_assert!(bits <= MAX_ESCAPE_BITS, "{mag} bins past the escape");
            for b in 0..bits.min(MAX_ESCAPE_BITS - 1) {
                enc.encode(&mut m.escape[b as usize], b + 1 < bits);
            }
            for b in (0..bits.saturating_sub(1)).rev() {
                enc.encode_bypass((rest + 1) >> b & 1 == 1);
            }
        }
        // v is not 0 here: `<=` would do as well.
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
            // `bits + 1` or `bits / 1` for `bits - 1` shifts every flag to another fresh
            // slot of the same history (the array has room): the same decisions.
            while bits < MAX_ESCAPE_BITS && dec.decode(&mut m.escape[(bits - 1) as usize]) {
                bits += 1;
            }
            let mut rest = 1u64;
            for _ in 0..bits - 1 {
                // The shifted bit is 0: `|` and `^` are the same.
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

    /// Heights and decoded values on a 0.1 grid with E = 0.1: an odd number of tenths apart
    /// is a bin edge, where `round` can take the far bin by an ulp, and the guard steps back
    /// toward the height. Within E up to an ulp: on some edges both bins miss E by one.
    #[test]
    fn residuals_on_a_bin_edge_step_back_within_the_bound() {
        let (n, e) = (61, 0.1);
        let tenth = |i: usize| i as f64 / 10.0 - 3.0;
        let units = Grid::new(n, n, (0..n * n).map(|k| tenth(k % n)).collect()).unwrap();
        let decoded = Grid::new(n, n, (0..n * n).map(|k| tenth(k / n)).collect()).unwrap();
        let far_bin = units
            .data()
            .iter()
            .zip(decoded.data())
            .filter(|&(&u, &d)| (u - (d + ((u - d) / (2.0 * e)).round() * 2.0 * e)).abs() > e)
            .count();
        assert!(
            far_bin > 100,
            "{far_bin} samples where rounding takes the far bin"
        );
        let bytes = encode_residual(&units, &decoded, e, false, None).unwrap();
        let mut back = decoded.clone();
        apply(&mut back, &bytes, e).unwrap();
        for (b, u) in back.data().iter().zip(units.data()) {
            assert!((b - u).abs() <= e + 1e-15, "{b} for {u}");
        }
    }

    /// The escape holds magnitudes up to 2^40 bins: 40 escape bits, the last without the
    /// flag that would end a longer count (the decoder reads at most 39 flags).
    #[test]
    fn magnitudes_up_to_the_escape_cap_round_trip() {
        let e = 0.5;
        let bins = [
            15.0,
            16.0,
            2f64.powi(39) - 1.0,
            2f64.powi(39) + 20.0,
            -(2f64.powi(40) - 7.0),
            2f64.powi(40),
            3.0,
        ];
        let units = Grid::new(1, bins.len(), bins.to_vec()).unwrap();
        let decoded = units.map(|_| 0.0);
        let bytes = encode_residual(&units, &decoded, e, false, None).unwrap();
        let mut back = decoded.clone();
        apply(&mut back, &bytes, e).unwrap();
        assert_eq!(back, units);
    }

    /// A bin's context is its left, up, up-left and up-right neighbours inside the grid and
    /// nothing across a row's ends: checked against the same rule written on (row, column)
    /// pairs, on sparse random bins of every shape up to 5 × 6. A wrong context still
    /// round-trips (both sides share it) and only costs bytes, so nothing else notices.
    #[test]
    fn context_reads_the_four_coded_neighbours_inside_the_grid() {
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        for rows in 1..=5 {
            for cols in 1..=6 {
                let q: Vec<i64> = (0..rows * cols)
                    .map(|_| {
                        s ^= s << 13;
                        s ^= s >> 7;
                        s ^= s << 17;
                        [0, 0, 0, 1, -1, 2, -2, 3, -3][(s % 9) as usize]
                    })
                    .collect();
                let at = |r: isize, c: isize| {
                    let inside = (0..rows as isize).contains(&r) && (0..cols as isize).contains(&c);
                    if inside {
                        q[r as usize * cols + c as usize]
                    } else {
                        0
                    }
                };
                for idx in 0..q.len() {
                    let (r, c) = ((idx / cols) as isize, (idx % cols) as isize);
                    let (left, up) = (at(r, c - 1), at(r - 1, c));
                    let diagonal = at(r - 1, c - 1) != 0 || at(r - 1, c + 1) != 0;
                    let count =
                        usize::from(left != 0) + usize::from(up != 0) + usize::from(diagonal);
                    let big = usize::from(left.abs() > 1 || up.abs() > 1);
                    let sign = match (left, up) {
                        (0, 0) => 0,
                        (0, v) | (v, _) => 1 + usize::from(v < 0),
                    };
                    assert_eq!(
                        context(&q, cols, idx),
                        (2 * count + big, big, sign),
                        "{rows}x{cols} at ({r}, {c}) of {q:?}"
                    );
                }
            }
        }
    }

    /// Integer heights with E ≥ 1 take the JPEG-LS bins (the mode byte says so, the bound is
    /// floored, the decoded heights are integers); real heights, or E < 1, take 2E-wide bins
    /// and keep E. Either way every sample ends within the bound the cut reports.
    #[test]
    fn the_cut_takes_integer_bins_only_for_integer_heights() {
        let (rows, cols) = (13, 9);
        let integer = surface(rows, cols).map(|h| h.round());
        let real = surface(rows, cols);
        let rough = |cut: usize| surface(rows, cols).map(|h| h * 0.5 + cut as f64);
        for (units, e, mode, bound) in [
            (&integer, 2.5, MODE_INTEGER, 2.0),
            (&integer, 0.5, MODE_REAL, 0.5),
            (&real, 2.5, MODE_REAL, 2.5),
        ] {
            let cut = choose_cut(rough, &[], units, e);
            assert_eq!(
                (cut.segments, cut.bytes[0], cut.bound),
                (0, mode, bound),
                "E = {e}"
            );
            let mut back = rough(0);
            apply(&mut back, &cut.bytes, cut.bound).unwrap();
            for (b, u) in back.data().iter().zip(units.data()) {
                assert!((b - u).abs() <= bound, "E = {e}: {b} for {u}");
                assert!(mode == MODE_REAL || b.fract() == 0.0, "E = {e}: {b}");
            }
        }
    }

    /// The cut is the cheapest total (prefix + residual) of those tried; three cuts in a row
    /// that cannot beat it end the search; of two equal totals the finer cut, which keeps
    /// more of the progressive prefix, stays.
    #[test]
    fn the_cut_is_the_cheapest_total_and_the_search_stops_past_it() {
        let (rows, cols, e) = (24, 24, 0.25);
        let units = surface(rows, cols);
        let noise = |k: usize, amp: f64| ((k * 7919 % 31) as f64 - 15.0) / 15.0 * amp;
        // The prefix error halves per plane: totals fall, then rise past the best cut.
        let near = |cut: usize| {
            let amp = 64.0 / f64::powi(2.0, (cut / 3) as i32);
            let mut g = units.clone();
            for (k, u) in g.data_mut().iter_mut().enumerate() {
                *u += noise(k, amp);
            }
            g
        };
        let segments = [3, 2, 40, 5, 5, 80, 10, 10, 160, 20, 20, 320, 40, 40, 640];
        let total = |cut: usize| {
            let res = encode_residual(&units, &near(cut), e, false, None).unwrap();
            segments[..cut].iter().sum::<usize>() + res.len()
        };
        let best = (0..=segments.len())
            .filter(|s| s % 3 != 1)
            .map(total)
            .min()
            .unwrap();
        let tried = std::cell::RefCell::new(Vec::new());
        let cut = choose_cut(
            |c| {
                tried.borrow_mut().push(c);
                near(c)
            },
            &segments,
            &units,
            e,
        );
        assert_eq!(
            total(cut.segments),
            best,
            "cut {} of {:?}",
            cut.segments,
            tried
        );
        assert_eq!(
            segments[..cut.segments].iter().sum::<usize>() + cut.bytes.len(),
            best
        );

        // Only the finest cut is exact, and every coarser one costs more than it saves.
        tried.borrow_mut().clear();
        let exact_at_end = |c: usize| if c == 12 { units.clone() } else { near(0) };
        let cut = choose_cut(
            |c| {
                tried.borrow_mut().push(c);
                exact_at_end(c)
            },
            &[1; 12],
            &units,
            e,
        );
        assert_eq!((cut.segments, cut.bytes.len()), (12, 1));
        assert_eq!(
            *tried.borrow(),
            [12, 11, 9, 8],
            "three worse cuts end the search"
        );

        // Ties keep the finer cut: empty refinement and cleanup passes make cuts 3 and 2 total
        // 11 bytes, and a 3-byte-shorter first pass makes cut 0 total as much as cut 3.
        let exact_past_0 = |c: usize| if c == 0 { near(0) } else { units.clone() };
        let cut = choose_cut(exact_past_0, &[10, 0, 0], &units, e);
        assert_eq!((cut.segments, cut.bytes.len()), (3, 1), "cut 2 is as short");
        let at_0 = encode_residual(&units, &near(0), e, false, None)
            .unwrap()
            .len();
        let cut = choose_cut(exact_past_0, &[at_0 - 1, 0, 0], &units, e);
        assert_eq!((cut.segments, cut.bytes.len()), (3, 1), "cut 0 is as short");
    }
}
