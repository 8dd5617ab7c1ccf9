//! Embedded Zerotree Wavelet coder (Shapiro, "Embedded image coding using zerotrees of
//! wavelet coefficients", IEEE TSP 1993), as DESIGN.md §2.3 adapts it for heightmaps:
//! lifting wavelets, per-subband weights, context-adaptive binary arithmetic coding, a flush
//! and a recorded byte offset at the end of every pass, and an optional max-error residual
//! pass that bounds |decoded − original| (as the SPERR coder does).
//!
//! Any prefix of a stream decodes: whole passes exactly, and the cut pass up to the last
//! symbol its bytes determine. Decoding "to threshold T" reads the passes with T_k ≥ T.

mod arith;
mod passes;
mod quantize;
mod residual;
mod stream;
mod tree;

use crate::error::{DecodeError, ParamError};
use crate::grid::Grid;
use crate::wavelet::{self, Layout, Wavelet};
pub use stream::{Header, PassKind};

use passes::{DecodeIo, EncodeIo, Plan, State, Truth};
use tree::Tree;

/// Quantisation step of the real-valued path, as a power of two of coder units: fine enough
/// that the last planes reach well below one height step.
const REAL_QEXP: i8 = -4;
/// Integer 5/3 coefficients are kept below this so the inverse lifting cannot overflow i32;
/// a height range under half of it keeps every real coefficient inside.
const INT53_LIMIT: f64 = (1u32 << 20) as f64;
/// Default bound on decoded grid size (samples); a header asking for more is refused.
pub const DEFAULT_MAX_SAMPLES: usize = 1 << 26;

/// How to encode.
#[derive(Clone, Debug)]
pub struct EncodeParams {
    pub wavelet: Wavelet,
    /// Height units per coder unit. Lossless (5/3) needs heights that are integer multiples
    /// of it; elsewhere it only sets the scale thresholds are reported in.
    pub step: f64,
    /// Decomposition levels; `None` = as deep as the grid allows.
    pub levels: Option<usize>,
    /// Guarantee |decoded − original| ≤ this (height units) with a residual pass.
    pub max_error: Option<f64>,
}

impl EncodeParams {
    pub fn new(wavelet: Wavelet, step: f64) -> Self {
        Self {
            wavelet,
            step,
            levels: None,
            max_error: None,
        }
    }
}

/// One coded pass and where it ends.
#[derive(Clone, Debug, PartialEq)]
pub struct PassInfo {
    pub plane: u32,
    pub kind: PassKind,
    /// The pass's threshold in height units (weighted-coefficient domain).
    pub threshold: f64,
    /// Byte offset in the stream just after this pass.
    pub end: usize,
}

/// An encoded stream and its pass table.
#[derive(Clone, Debug)]
pub struct Encoded {
    pub bytes: Vec<u8>,
    pub header_len: usize,
    pub passes: Vec<PassInfo>,
}

/// How much of a stream to decode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DecodeLimit {
    /// Everything, residual pass included.
    All,
    /// Every pass whose threshold is ≥ T (height units); no residual pass.
    Threshold(f64),
    /// The first `n` bytes of the stream (header included).
    Bytes(usize),
}

/// A decoded grid and the zerotree state that produced it.
#[derive(Clone, Debug)]
pub struct Decoded {
    pub heights: Grid<f64>,
    /// Where the decoded wavelet coefficient is nonzero (Mallat layout): the zerotree map.
    pub significant: Grid<bool>,
    /// The dequantised coefficients (Mallat layout, unweighted, height units; the LL band
    /// still carries the stream's offset): what the mesher reads the zerotree from, so it
    /// can cut leaves at any threshold at or above the decoded one.
    pub coefficients: Grid<f64>,
    pub layout: Layout,
    /// Threshold (height units) of the last pass decoded, whole or in part.
    pub threshold: f64,
    /// Stream bytes the decode used.
    pub bytes_used: usize,
    /// The residual pass was applied: the max-error bound holds.
    pub bounded: bool,
}

/// Encodes `heights` (finite values, height units).
pub fn encode(heights: &Grid<f64>, params: &EncodeParams) -> Result<Encoded, ParamError> {
    // Validate: the coder's contract is finite heights on a positive step.
    if !(params.step.is_finite() && params.step > 0.0) {
        return Err(out_of_range("step", "finite and > 0", params.step));
    }
    if heights.is_empty() {
        return Err(out_of_range("grid size", "at least 1 sample", 0.0));
    }
    if let Some(bad) = heights.data().iter().find(|h| !h.is_finite()) {
        return Err(out_of_range("height", "finite (fill no-data first)", *bad));
    }
    if let Some(e) = params.max_error {
        if !(e.is_finite() && e > 0.0) {
            return Err(out_of_range("max_error", "finite and > 0", e));
        }
    }
    let (rows, cols) = (heights.rows(), heights.cols());
    let layout = Layout::new(
        rows,
        cols,
        params.levels.unwrap_or(wavelet::subbands::MAX_LEVELS),
    );
    // Coder units; values within 1e-6 of an integer are integers (0.1 m steps divide inexactly).
    let units = heights.map(|h| {
        let u = h / params.step;
        if (u - u.round()).abs() < 1e-6 {
            u.round()
        } else {
            u
        }
    });

    // Transform around the mid-range so the LL band is small.
    let (lo, hi) = units
        .data()
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let offset = ((lo + hi) / 2.0).round();
    let centered = units.map(|u| u - offset);
    if params.wavelet == Wavelet::LeGall53 && (hi - lo) * 2.0 >= INT53_LIMIT {
        return Err(out_of_range(
            "height range / step",
            "below 2^19 for the integer 5/3 path",
            hi - lo,
        ));
    }
    let tree = Tree::new(&layout);
    let (mags, negs, shifts, qexp) = forward_magnitudes(&centered, params.wavelet, &layout, &tree);
    let plan = Plan::new(tree, shifts);

    // Bit planes from the top down, two flushed segments each.
    let max = mags.iter().copied().max().unwrap_or(0);
    let top_plane = (max > 0).then(|| 63 - max.leading_zeros());
    let mut segments: Vec<Vec<u8>> = Vec::new();
    let mut state = State::new(mags.len(), cols);
    let mut truth = Truth {
        mag: &mags,
        neg: &negs,
        sub_new: Vec::new(),
    };
    if let Some(top) = top_plane {
        for k in (0..=top).rev() {
            let stamp = (top - k + 1) as u16;
            let mut io = EncodeIo(arith::Encoder::new());
            passes::propagation(&mut io, &plan, &mut state, Some(&truth), k, stamp);
            segments.push(io.0.finish());
            let mut io = EncodeIo(arith::Encoder::new());
            passes::subordinate(&mut io, &plan, &mut state, Some(&truth), k);
            segments.push(io.0.finish());
            truth.prepare(&plan, &state, k);
            let mut io = EncodeIo(arith::Encoder::new());
            passes::dominant(&mut io, &plan, &mut state, Some(&truth), k, stamp);
            segments.push(io.0.finish());
        }
    }

    let mut header = Header {
        wavelet: params.wavelet,
        rows,
        cols,
        levels: layout.levels(),
        step: params.step,
        offset,
        qexp,
        top_plane: top_plane.map(|t| t as u8),
        segments: segments.iter().map(Vec::len).collect(),
        residual: None,
    };

    // Max-error mode: keep the cheapest wavelet prefix + residual pass.
    let residual = params
        .max_error
        .map(|e| residual::choose_cut(&header, &segments, &centered, e / params.step));
    if let Some(cut) = &residual {
        header.segments.truncate(cut.segments);
        segments.truncate(cut.segments);
        header.residual = Some((cut.bound, cut.bytes.len()));
    }

    let mut bytes = Vec::new();
    header.write(&mut bytes);
    let header_len = bytes.len();
    let mut passes = Vec::with_capacity(segments.len());
    for (s, seg) in segments.iter().enumerate() {
        bytes.extend_from_slice(seg);
        let (plane, kind) = header.segment_plane(s);
        passes.push(PassInfo {
            plane,
            kind,
            threshold: plane_threshold(&header, plane),
            end: bytes.len(),
        });
    }
    if let Some(cut) = residual {
        bytes.extend_from_slice(&cut.bytes);
    }
    Ok(Encoded {
        bytes,
        header_len,
        passes,
    })
}

/// Decodes a stream prefix. Never panics on malformed input; sizes are bounded by
/// `max_samples`.
pub fn decode(
    bytes: &[u8],
    limit: DecodeLimit,
    max_samples: usize,
) -> Result<Decoded, DecodeError> {
    let (mut decoded, header) = decode_centered(bytes, limit, max_samples)?;
    for h in decoded.heights.data_mut() {
        *h = (*h + header.offset) * header.step;
    }
    for c in decoded.coefficients.data_mut() {
        *c *= header.step;
    }
    Ok(decoded)
}

/// [`decode`] with heights left in centred coder units (what the residual pass works in).
fn decode_centered(
    bytes: &[u8],
    limit: DecodeLimit,
    max_samples: usize,
) -> Result<(Decoded, Header), DecodeError> {
    let prefix = match limit {
        DecodeLimit::Bytes(n) => &bytes[..n.min(bytes.len())],
        _ => bytes,
    };
    let (header, header_len) = Header::read(prefix, max_samples)?;
    let layout = Layout::new(header.rows, header.cols, header.levels);
    if layout.levels() != header.levels {
        return Err(DecodeError::Malformed(format!(
            "{} levels on a {}×{} grid",
            header.levels, header.rows, header.cols
        )));
    }
    let tree = Tree::new(&layout);
    let shifts = match header.wavelet {
        Wavelet::LeGall53 => quantize::integer_shifts(&layout),
        Wavelet::Cdf97 => vec![0; tree.bands.len()],
    };
    let plan = Plan::new(tree, shifts);
    let mut state = State::new(header.rows * header.cols, header.cols);

    // Replay the passes the prefix holds.
    let mut pos = header_len;
    let mut last_plane = header.top_plane.map(u32::from);
    let mut stopped = false;
    for (s, &len) in header.segments.iter().enumerate() {
        let (plane, kind) = header.segment_plane(s);
        if let DecodeLimit::Threshold(t) = limit {
            if plane_threshold(&header, plane) < t {
                break;
            }
        }
        let end = pos.saturating_add(len);
        // A whole segment may be empty (its bits were all zeros, trimmed by termination).
        let complete = end <= prefix.len();
        if !complete && pos >= prefix.len() {
            break;
        }
        let seg = &prefix[pos..end.min(prefix.len())];
        let mut io = DecodeIo {
            dec: arith::Decoder::new(seg),
            complete,
        };
        let stamp = (s / 3 + 1) as u16;
        let done = match kind {
            PassKind::Propagation => {
                passes::propagation(&mut io, &plan, &mut state, None, plane, stamp)
            }
            PassKind::Refinement => passes::subordinate(&mut io, &plan, &mut state, None, plane),
            PassKind::Cleanup => passes::dominant(&mut io, &plan, &mut state, None, plane, stamp),
        };
        last_plane = Some(plane);
        pos = end.min(prefix.len());
        if done.is_none() || !complete {
            stopped = true;
            break;
        }
    }

    // Coefficients back to heights.
    let (mut heights, coefficients) = inverse_magnitudes(&header, &layout, &plan, &state);
    let mut bounded = false;
    if let (DecodeLimit::All, Some((bound, len)), false) = (limit, header.residual, stopped) {
        let seg_end: usize = header_len + header.segments.iter().sum::<usize>();
        let res = prefix
            .get(seg_end..)
            .ok_or(DecodeError::Truncated("residual pass"))?;
        if res.len() < len {
            return Err(DecodeError::Truncated("residual pass"));
        }
        residual::apply(&mut heights, &res[..len], bound)?;
        bounded = true;
        pos = seg_end + len;
    }
    let significant = Grid::new(header.rows, header.cols, state.sig)
        .map_err(|e| DecodeError::Malformed(e.to_string()))?;
    let threshold = last_plane.map_or(f64::INFINITY, |p| plane_threshold(&header, p));
    Ok((
        Decoded {
            heights,
            significant,
            coefficients,
            layout,
            threshold,
            bytes_used: pos,
            bounded,
        },
        header,
    ))
}

/// Threshold of bit plane `k` in height units.
fn plane_threshold(header: &Header, k: u32) -> f64 {
    (2f64).powi(k as i32 + i32::from(header.qexp)) * header.step
}

fn out_of_range(name: &'static str, expected: &'static str, got: f64) -> ParamError {
    ParamError::OutOfRange {
        name,
        expected,
        got: got.to_string(),
    }
}

/// Forward transform and quantisation to weighted integer magnitudes.
fn forward_magnitudes(
    centered: &Grid<f64>,
    wavelet: Wavelet,
    layout: &Layout,
    tree: &Tree,
) -> (Vec<u64>, Vec<bool>, Vec<u8>, i8) {
    let n = centered.len();
    let mut mags = vec![0u64; n];
    let mut negs = vec![false; n];
    match wavelet {
        Wavelet::LeGall53 => {
            let mut g = centered.map(|&u| u.round() as i32);
            wavelet::forward_int53(&mut g, layout);
            let shifts = quantize::integer_shifts(layout);
            for (idx, &c) in g.data().iter().enumerate() {
                mags[idx] = u64::from(c.unsigned_abs()) << shifts[tree.band_of[idx] as usize];
                negs[idx] = c < 0;
            }
            (mags, negs, shifts, 0)
        }
        Wavelet::Cdf97 => {
            let mut g = centered.clone();
            wavelet::forward(&mut g, Wavelet::Cdf97, layout);
            let weights = quantize::real_weights(Wavelet::Cdf97, layout);
            // Keep magnitudes below 2^40 whatever the data's range.
            let peak = g
                .data()
                .iter()
                .enumerate()
                .map(|(i, c)| c.abs() * weights[tree.band_of[i] as usize])
                .fold(0.0, f64::max);
            let mut qexp = REAL_QEXP;
            while peak / (2f64).powi(i32::from(qexp)) >= (1u64 << 40) as f64 && qexp < 30 {
                qexp += 1;
            }
            let q = (2f64).powi(i32::from(qexp));
            for (idx, &c) in g.data().iter().enumerate() {
                mags[idx] = (c.abs() * weights[tree.band_of[idx] as usize] / q) as u64;
                negs[idx] = c < 0.0;
            }
            (mags, negs, vec![0; tree.bands.len()], qexp)
        }
    }
}

/// Dequantisation and inverse transform: heights and unweighted coefficients, both in coder
/// units with the offset not yet added back.
fn inverse_magnitudes(
    header: &Header,
    layout: &Layout,
    plan: &Plan,
    state: &State,
) -> (Grid<f64>, Grid<f64>) {
    let (rows, cols) = (header.rows, header.cols);
    let signed = |idx: usize, v: f64| if state.neg[idx] { -v } else { v };
    match header.wavelet {
        Wavelet::LeGall53 => {
            let mut g = Grid::<i32>::zeros(rows, cols);
            for (idx, c) in g.data_mut().iter_mut().enumerate() {
                if state.sig[idx] {
                    let s = plan.shifts[plan.tree.band_of[idx] as usize];
                    let v = quantize::reconstruct(state.mag[idx], state.known[idx], Some(s))
                        / (1u64 << s) as f64;
                    *c = signed(idx, v.round()).clamp(-INT53_LIMIT, INT53_LIMIT) as i32;
                }
            }
            let coefficients = g.map(|&v| f64::from(v));
            wavelet::inverse_int53(&mut g, layout);
            (g.map(|&v| f64::from(v)), coefficients)
        }
        Wavelet::Cdf97 => {
            let weights = quantize::real_weights(Wavelet::Cdf97, layout);
            let q = (2f64).powi(i32::from(header.qexp));
            let mut g = Grid::<f64>::zeros(rows, cols);
            for (idx, c) in g.data_mut().iter_mut().enumerate() {
                if state.sig[idx] {
                    let v = quantize::reconstruct(state.mag[idx], state.known[idx], None) * q
                        / weights[plan.tree.band_of[idx] as usize];
                    *c = signed(idx, v);
                }
            }
            let coefficients = g.clone();
            wavelet::inverse(&mut g, Wavelet::Cdf97, layout);
            (g, coefficients)
        }
    }
}

#[cfg(test)]
mod tests;
