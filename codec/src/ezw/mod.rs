//! Embedded Zerotree Wavelet coder (Shapiro, "Embedded image coding using zerotrees of
//! wavelet coefficients", IEEE TSP 1993), as DESIGN.md §2.3 adapts it for heightmaps:
//! lifting wavelets, per-subband weights, context-adaptive binary arithmetic coding, a flush
//! and a recorded byte offset at the end of every pass, and an optional max-error residual
//! pass that bounds |decoded − original| (as the SPERR coder does).
//!
//! Any prefix of a stream decodes: whole passes exactly, and the cut pass up to the last
//! symbol its bytes determine. Decoding "to threshold T" reads the passes with T_k ≥ T.

pub mod arith;
mod bitmap;
mod bound;
mod context;
mod passes;
mod quantize;
mod reconstruct;
mod residual;
mod state;
mod stream;
mod tree;

use crate::error::{DecodeError, ParamError};
use crate::grid::Grid;
use crate::wavelet::{self, Layout, Wavelet};
pub use stream::{Header, PassKind};

use passes::{DecodeIo, EncodeIo, Truth};
use reconstruct::{Dequantiser, INT53_LIMIT};
use state::{Known, Plan, State};
use tree::Tree;

/// Default bound on decoded grid size (samples); a header asking for more is refused.
pub const DEFAULT_MAX_SAMPLES: usize = 1 << 26;

/// The height range, in steps, a tile of `wavelet` can be coded with: below 2^19 for the
/// integer 5/3 path ([`encode`] refuses more); for 9/7, 2^52 (f64 holds whole numbers
/// exactly to 2^53, and the bit planes end not far above). A caller checks its whole range
/// against it before work that [`encode`] would refuse tile by tile.
pub fn max_range_steps(wavelet: Wavelet) -> f64 {
    match wavelet {
        Wavelet::LeGall53 => INT53_LIMIT / 2.0,
        Wavelet::Cdf97 => (1u64 << 52) as f64,
    }
}

/// The smallest max-error bound [`encode`] takes for heights spanning `range` at `step`: a
/// caller checks it once, with its flag's name, before work [`encode`] would refuse tile by
/// tile.
pub fn min_max_error(step: f64, range: f64) -> f64 {
    step * min_bound_units(range / step)
}

/// [`min_max_error`] in steps, for heights spanning `range_units` steps.
fn min_bound_units(range_units: f64) -> f64 {
    MIN_BOUND_UNITS.max(range_units.max(1.0) * MIN_BOUND_OF_RANGE)
}

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
    /// An upper bound of max |decoded − original| (height units) for a decode that stops
    /// right after this pass, as the stream records it: measured by the encoder, rounded up
    /// by at most 4.4 %, so a server can promise a mesh error without measuring.
    pub max_error: f64,
    /// Binary decisions (context-coded and bypass) the pass codes: what decoding it costs,
    /// one serial step of the range decoder each.
    pub decisions: u64,
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
    /// An upper bound of max |heights − original| (height units) that holds for this
    /// decode: the residual bound E when `bounded` (up to the last bit of the final
    /// (units + offset) · step product), the stream's recorded bound when the decode stopped
    /// exactly at a pass end (always at a plane end; after the other passes when the input
    /// still holds the trailer), else `None` (a pass decoded in part, or none at all).
    pub max_error: Option<f64>,
}

impl Decoded {
    /// What [`decode_heights`] would have given, and the coefficients: for a caller that
    /// needs the zerotree's coefficients but not its significance map.
    pub fn split_coefficients(self) -> (DecodedHeights, Grid<f64>) {
        let heights = DecodedHeights {
            heights: self.heights,
            layout: self.layout,
            threshold: self.threshold,
            bytes_used: self.bytes_used,
            bounded: self.bounded,
            max_error: self.max_error,
        };
        (heights, self.coefficients)
    }
}

/// A decode's heights without the zerotree state, for meshers that read only heights (the
/// server's bintree): [`decode_heights`] skips the coefficient grid's copy, the significance
/// map and their rescaling. The fields mean what [`Decoded`]'s do.
#[derive(Clone, Debug)]
pub struct DecodedHeights {
    pub heights: Grid<f64>,
    pub layout: Layout,
    pub threshold: f64,
    pub bytes_used: usize,
    pub bounded: bool,
    pub max_error: Option<f64>,
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
    if heights.len() > u32::MAX as usize {
        return Err(out_of_range(
            "grid size",
            "below 2^32 samples",
            heights.len() as f64,
        ));
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
    if params.wavelet == Wavelet::LeGall53 && hi - lo >= max_range_steps(Wavelet::LeGall53) {
        return Err(out_of_range(
            "height range / step",
            "below 2^19 for the integer 5/3 path (the 9/7 wavelet takes any range)",
            hi - lo,
        ));
    }
    // The residual pass snaps each height to a bin of 2E: a bin below the heights' float
    // resolution cannot hold the bound, and the pass would keep a broken promise silently.
    if let Some(e) = params.max_error {
        let e_units = e / params.step;
        if e_units < min_bound_units(hi - lo) {
            return Err(out_of_range(
                "max_error",
                "at least step x 2^-20 and height range x 2^-40 (lossless gives exact heights)",
                e,
            ));
        }
    }
    let (mags, negs, qexp) = quantize::forward(&centered, params.wavelet, &layout);
    let plan = Plan::new(
        Tree::new(&layout),
        Plan::shifts_for(params.wavelet, &layout),
    );
    let dq = Dequantiser::new(params.wavelet, &layout, qexp);
    let mut header = Header {
        wavelet: params.wavelet,
        rows,
        cols,
        levels: layout.levels(),
        step: params.step,
        offset,
        qexp,
        top_plane: None,
        segments: Vec::new(),
        pass_errors: Vec::new(),
        residual: None,
    };

    // Bit planes from the top down, three flushed segments each. At every plane end the
    // encoder decodes itself (its state is the decoder's) and records the error bound.
    let max = mags.iter().copied().max().unwrap_or(0);
    let top_plane = (max > 0).then(|| 63 - max.leading_zeros());
    if top_plane.is_some_and(|t| t > MAX_TOP_PLANE) {
        return Err(out_of_range(
            "height range / step",
            "small enough for 63 bit planes (a no-data sentinel such as -3.4e38 left in the \
             heights, or a step far too fine)",
            hi - lo,
        ));
    }
    header.top_plane = top_plane.map(|t| t as u8);
    let mut segments: Vec<Vec<u8>> = Vec::new();
    let mut state = State::new(&plan);
    let mut truth = Truth {
        mag: &mags,
        neg: &negs,
        parent: plan.tree.parents(),
        sub_new: Vec::new(),
    };
    // Found-list lengths after each plane's propagation and cleanup passes (top first):
    // the max-error search rebuilds any plane boundary's state from them.
    let mut found_after = Vec::new();
    // Binary decisions each segment coded.
    let mut decisions: Vec<u64> = Vec::new();
    if let Some(top) = top_plane {
        for k in (0..=top).rev() {
            // After every pass the encoder decodes itself (its state is the decoder's) and
            // records the error bound of a decode that stops there.
            let t_k = header.plane_threshold(k);
            let bound_now = |state: &State| {
                let found = state.found.iter().copied();
                let decoded = dq.heights(dq.coefficients(&plan, &layout, found), &layout);
                bound::quantise_up(
                    max_height_error(&decoded, heights, offset, params.step),
                    t_k,
                )
            };
            let (io, _) =
                passes::propagation(EncodeIo::default(), &plan, &mut state, Some(&truth), k);
            decisions.push(io.decisions);
            segments.push(io.enc.finish());
            header.pass_errors.push(bound_now(&state));
            let after_propagation = state.found.len();
            let (io, _) =
                passes::refinement(EncodeIo::default(), &plan, &mut state, Some(&truth), k);
            decisions.push(io.decisions);
            segments.push(io.enc.finish());
            header.pass_errors.push(bound_now(&state));
            truth.prepare(&plan, &state, k);
            let (io, _) = passes::cleanup(EncodeIo::default(), &plan, &mut state, Some(&truth), k);
            decisions.push(io.decisions);
            segments.push(io.enc.finish());
            header.pass_errors.push(bound_now(&state));
            found_after.push((after_propagation, state.found.len()));
        }
    }
    header.segments = segments.iter().map(Vec::len).collect();

    // Max-error mode: keep the cheapest wavelet prefix + residual pass.
    let residual = params.max_error.map(|e| {
        // The state a decoder holds after `cut` segments, from the final state: every
        // coefficient found by then is known exactly down to that plane.
        let at_cut = |cut: usize| {
            let p = cut.saturating_sub(1) / 3;
            let k = top_plane.map_or(0, |t| t.saturating_sub(p as u32));
            let found = match (cut, found_after.get(p)) {
                (0, _) | (_, None) => 0,
                (c, Some(&(prop, _))) if c % 3 == 2 => prop,
                (_, Some(&(_, clean))) => clean,
            };
            let entries = state.found[..found].iter().map(|e| Known {
                mag: e.mag >> k << k,
                known: k as u8,
                ..*e
            });
            dq.heights(dq.coefficients(&plan, &layout, entries), &layout)
        };
        residual::choose_cut(at_cut, &header.segments, &centered, e / params.step)
    });
    if let Some(cut) = &residual {
        header.segments.truncate(cut.segments);
        segments.truncate(cut.segments);
        header.pass_errors.truncate(cut.segments);
        header.residual = Some((cut.bound, cut.bytes.len()));
    }

    // Assemble: header, segments, residual; the pass table says where each pass ends.
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
            threshold: header.plane_threshold(plane),
            end: bytes.len(),
            // Always recorded for an encoded pass; infinity would only say "no bound".
            max_error: header.pass_error(s).unwrap_or(f64::INFINITY),
            decisions: decisions[s],
        });
    }
    if let Some(cut) = residual {
        bytes.extend_from_slice(&cut.bytes);
    }
    header.write_trailer(&mut bytes);
    Ok(Encoded {
        bytes,
        header_len,
        passes,
    })
}

/// max |(decoded + offset) · step − original|: the error a decoder's output will have (the
/// same arithmetic as [`decode`]).
fn max_height_error(decoded: &Grid<f64>, original: &Grid<f64>, offset: f64, step: f64) -> f64 {
    decoded
        .data()
        .iter()
        .zip(original.data())
        .map(|(&d, &h)| ((d + offset) * step - h).abs())
        .fold(0.0, f64::max)
}

/// Decodes a stream prefix. Never panics on malformed input; sizes are bounded by
/// `max_samples`.
pub fn decode(
    bytes: &[u8],
    limit: DecodeLimit,
    max_samples: usize,
) -> Result<Decoded, DecodeError> {
    // The zerotree state, taken before the coefficients become heights.
    let tree = |found: &[Known], coefficients: &Grid<f64>| {
        let mut significant = Grid::new(
            coefficients.rows(),
            coefficients.cols(),
            vec![false; coefficients.len()],
        )
        .map_err(|e| DecodeError::Malformed(e.to_string()))?;
        for e in found {
            significant.data_mut()[e.idx as usize] = true;
        }
        Ok((significant, coefficients.clone()))
    };
    let (d, (significant, mut coefficients), header) =
        decode_centered(bytes, limit, max_samples, tree)?;
    let d = to_height_units(d, &header);
    for c in coefficients.data_mut() {
        *c *= header.step;
    }
    Ok(Decoded {
        heights: d.heights,
        significant,
        coefficients,
        layout: d.layout,
        threshold: d.threshold,
        bytes_used: d.bytes_used,
        bounded: d.bounded,
        max_error: d.max_error,
    })
}

/// [`decode`] without the zerotree state: the same heights, bit for bit, for less work.
pub fn decode_heights(
    bytes: &[u8],
    limit: DecodeLimit,
    max_samples: usize,
) -> Result<DecodedHeights, DecodeError> {
    let (d, (), header) = decode_centered(bytes, limit, max_samples, |_, _| Ok(()))?;
    Ok(to_height_units(d, &header))
}

fn to_height_units(mut d: DecodedHeights, header: &Header) -> DecodedHeights {
    for h in d.heights.data_mut() {
        *h = (*h + header.offset) * header.step;
    }
    d
}

/// Where the trailer starts: after the header, every pass and the residual section.
fn trailer_start(header: &Header, header_len: usize) -> Option<usize> {
    header
        .segments
        .iter()
        .chain(header.residual.as_ref().map(|(_, len)| len))
        .try_fold(header_len, |end, &len| end.checked_add(len))
}

/// The length of the whole stream `bytes` starts with, by its own header and trailer, or
/// `None` when `bytes` stops before the end of its trailer.
///
/// A decode accepts any prefix (that is the point of an embedded stream), so it cannot tell
/// a stored stream that lost its tail from a deliberate prefix; this can. A result below
/// `bytes.len()` means something else follows the stream.
pub fn whole_len(bytes: &[u8], max_samples: usize) -> Result<Option<usize>, DecodeError> {
    let (mut header, header_len) = Header::read(bytes, max_samples)?;
    let Some(start) = trailer_start(&header, header_len) else {
        return Ok(None);
    };
    let Some(rest) = bytes.get(start..) else {
        return Ok(None);
    };
    Ok(header.read_trailer(rest).ok().map(|len| start + len))
}

/// [`decode`] with heights left in centred coder units (what the residual pass works in),
/// and whatever `keep` takes from the significant coefficients and their grid (coder units)
/// before the grid becomes the heights.
fn decode_centered<T>(
    bytes: &[u8],
    limit: DecodeLimit,
    max_samples: usize,
    keep: impl FnOnce(&[Known], &Grid<f64>) -> Result<T, DecodeError>,
) -> Result<(DecodedHeights, T, Header), DecodeError> {
    let prefix = match limit {
        DecodeLimit::Bytes(n) => &bytes[..n.min(bytes.len())],
        _ => bytes,
    };
    let (mut header, header_len) = Header::read(prefix, max_samples)?;
    // The trailer (bounds after the propagation and refinement passes) follows the residual
    // section. It is read from the whole input, not the prefix: it says nothing about the
    // heights, only how far they can be off. A stream cut before it just lacks those bounds.
    // Unreadable means cut short (or damaged): no bounds, the decode stands.
    let trailer_end = trailer_start(&header, header_len).and_then(|start| {
        let len = header.read_trailer(bytes.get(start..)?).ok()?;
        Some(start + len)
    });
    let layout = Layout::new(header.rows, header.cols, header.levels);
    if layout.levels() != header.levels {
        return Err(DecodeError::Malformed(format!(
            "{} levels on a {}×{} grid",
            header.levels, header.rows, header.cols
        )));
    }
    let plan = Plan::new(
        Tree::new(&layout),
        Plan::shifts_for(header.wavelet, &layout),
    );
    let mut state = State::new(&plan);

    // Replay the passes the prefix holds.
    let mut pos = header_len;
    let mut last_plane = header.top_plane.map(u32::from);
    let mut stopped = false;
    // Segments decoded whole, while nothing of the next one has been decoded.
    let mut at_pass_end = 0;
    for (s, &len) in header.segments.iter().enumerate() {
        let (plane, kind) = header.segment_plane(s);
        if let DecodeLimit::Threshold(t) = limit {
            if header.plane_threshold(plane) < t {
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
        let dec = arith::Decoder::new(seg);
        let done = if complete {
            decode_pass(DecodeIo::<false> { dec }, kind, &plan, &mut state, plane)
        } else {
            decode_pass(DecodeIo::<true> { dec }, kind, &plan, &mut state, plane)
        };
        at_pass_end = if complete { s + 1 } else { 0 };
        last_plane = Some(plane);
        pos = end.min(prefix.len());
        if done.is_none() || !complete {
            stopped = true;
            break;
        }
    }

    // Coefficients back to heights.
    let dq = Dequantiser::new(header.wavelet, &layout, header.qexp);
    let coefficients = dq.coefficients(&plan, &layout, state.found.iter().copied());
    let kept = keep(&state.found, &coefficients)?;
    let mut heights = dq.heights(coefficients, &layout);
    let mut max_error = at_pass_end
        .checked_sub(1)
        .and_then(|s| header.pass_error(s));
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
        max_error = Some(bound * header.step);
        pos = seg_end + len;
    }
    if let (DecodeLimit::All, false, Some(end)) = (limit, stopped, trailer_end) {
        // A whole stream was read, trailer included.
        pos = end;
    }
    let threshold = last_plane.map_or(f64::INFINITY, |p| header.plane_threshold(p));
    Ok((
        DecodedHeights {
            heights,
            layout,
            threshold,
            bytes_used: pos,
            bounded,
            max_error,
        },
        kept,
        header,
    ))
}

/// Runs one pass of the decoder.
fn decode_pass<I: passes::BitIo>(
    io: I,
    kind: PassKind,
    plan: &Plan,
    state: &mut State,
    plane: u32,
) -> Option<()> {
    let (_, done) = match kind {
        PassKind::Propagation => passes::propagation(io, plan, state, None, plane),
        PassKind::Refinement => passes::refinement(io, plan, state, None, plane),
        PassKind::Cleanup => passes::cleanup(io, plan, state, None, plane),
    };
    done
}

/// The deepest top bit plane a stream may have ([`stream::Header`] refuses more): the
/// magnitudes are u64, and a saturated one would read as plane 63.
const MAX_TOP_PLANE: u32 = 62;

/// The smallest max-error bound, in steps, and as a fraction of the height range (in steps):
/// far above f64's resolution of the heights, so the residual's bins stay exact.
const MIN_BOUND_UNITS: f64 = 1.0 / (1u64 << 20) as f64;
const MIN_BOUND_OF_RANGE: f64 = 1.0 / (1u64 << 40) as f64;

fn out_of_range(name: &'static str, expected: &'static str, got: f64) -> ParamError {
    ParamError::OutOfRange {
        name,
        expected,
        got: crate::error::short(got),
    }
}

#[cfg(test)]
mod tests;
