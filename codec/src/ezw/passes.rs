//! The three passes of a bit plane T = 2^k, written once for both directions: the encoder
//! supplies each bit from the true magnitudes, the decoder reads it, and both keep the same
//! [`State`] so their contexts can never drift apart.
//!
//! - **Propagation** (JPEG 2000's significance propagation, Taubman 2000): coefficients with
//!   a significant neighbour or parent code their significance first, the likeliest bits.
//! - **Refinement** (Shapiro's subordinate pass): bit k of every coefficient that became
//!   significant at an earlier threshold, in the order they were found.
//! - **Cleanup** (Shapiro's dominant pass): coarse → fine bands, raster order inside a band.
//!   Every coefficient not yet significant, not coded by the propagation pass and not inside
//!   a zerotree coded earlier in this pass gets POS / NEG (significant, with its sign), ZTR
//!   (zerotree root: it and every descendant not yet significant stay below T, and its
//!   descendants get no symbol this pass) or IZ (isolated zero). Coefficients without
//!   children only code significance.
//!
//! Symbols are binarised (significant?, sign, zerotree?) and coded with the contexts of
//! [`context`]. The passes find their coefficients with the word bitmaps of [`State`]: a
//! zerotree's cover reaches its children as one bit per 64 in the parent band's bitmap, and
//! runs of coefficients with nothing to code cost one word operation.

use super::arith::{Decoder, Encoder, Prob};
use super::bitmap;
use super::context;
use super::state::{Plan, State};
use super::tree::NO_PARENT;

/// Direction-agnostic bit channel.
pub trait BitIo {
    /// Encoder: codes `bit()` and returns it. Decoder: returns the decoded bit, or `None`
    /// once a truncated segment can no longer be decoded exactly.
    fn bit(&mut self, p: &mut Prob, bit: impl FnOnce() -> bool) -> Option<bool>;
    /// The same at fixed even odds, without a context.
    fn bypass(&mut self, bit: impl FnOnce() -> bool) -> Option<bool>;
}

/// The encoder's channel. It counts the binary decisions it codes: the decoder's work per
/// pass is one decision after another, so the count is what a decode of the pass costs (the
/// decoder itself does not count: an add per decision would be on its critical path).
#[derive(Default)]
pub struct EncodeIo {
    pub enc: Encoder,
    pub decisions: u64,
}

impl BitIo for EncodeIo {
    #[inline]
    fn bit(&mut self, p: &mut Prob, bit: impl FnOnce() -> bool) -> Option<bool> {
        let b = bit();
        self.enc.encode(p, b);
        self.decisions += 1;
        Some(b)
    }

    #[inline]
    fn bypass(&mut self, bit: impl FnOnce() -> bool) -> Option<bool> {
        let b = bit();
        self.enc.encode_bypass(b);
        self.decisions += 1;
        Some(b)
    }
}

/// The decoder's channel. `CUT`: the segment is a truncated prefix, so every decision first
/// checks that no padding byte has entered the coder's window (a whole segment's
/// termination makes zero padding valid to the end, and skips the check).
pub struct DecodeIo<'a, const CUT: bool> {
    pub dec: Decoder<'a>,
}

impl<const CUT: bool> BitIo for DecodeIo<'_, CUT> {
    #[inline]
    fn bit(&mut self, p: &mut Prob, _bit: impl FnOnce() -> bool) -> Option<bool> {
        if CUT && !self.dec.reliable() {
            return None;
        }
        Some(self.dec.decode(p))
    }

    #[inline]
    fn bypass(&mut self, _bit: impl FnOnce() -> bool) -> Option<bool> {
        if CUT && !self.dec.reliable() {
            return None;
        }
        Some(self.dec.decode_bypass())
    }
}

/// The encoder's knowledge: true magnitudes and signs (flat Mallat index).
pub struct Truth<'a> {
    pub mag: &'a [u64],
    pub neg: &'a [bool],
    pub parent: Vec<u32>,
    /// Per coefficient, for the current cleanup pass: it or a descendant becomes significant.
    pub sub_new: Vec<bool>,
}

impl Truth<'_> {
    /// Prepares `sub_new` for the cleanup pass of plane `k` from the state before it.
    pub fn prepare(&mut self, plan: &Plan, state: &State, k: u32) {
        self.sub_new.clear();
        self.sub_new.resize(self.mag.len(), false);
        let t = &plan.tree;
        // Finer bands first, so every descendant has reported before its ancestor is read.
        for b in t.bands.iter().rev() {
            for i in 0..b.rows {
                let row = (b.row0 + i) * t.cols + b.col0;
                for j in 0..b.cols {
                    let idx = row + j;
                    if self.mag[idx] >> k != 0 && !state.is_significant(b, i, j) {
                        self.sub_new[idx] = true;
                    }
                    let p = self.parent[idx];
                    if self.sub_new[idx] && p != NO_PARENT {
                        self.sub_new[p as usize] = true;
                    }
                }
            }
        }
    }
}

/// Significance (and sign, if significant) of coefficient `idx` with flags `f` (parent bit
/// included). Returns the sign if it became significant.
#[allow(clippy::too_many_arguments)] // the hot loop's locals, passed as they are
#[inline(always)]
fn significance<I: BitIo>(
    io: &mut I,
    state: &mut State,
    truth: Option<&Truth>,
    class: usize,
    table: &[u8; 512],
    f: u32,
    idx: usize,
    k: u32,
) -> Option<Option<bool>> {
    let c = table[(f & 0x1FF) as usize];
    let significant = io.bit(state.ctx.sig(class, c), || {
        truth.is_some_and(|t| t.mag[idx] >> k != 0)
    })?;
    if !significant {
        return Some(None);
    }
    let negative = io.bit(state.ctx.sign(class, context::sign(f)), || {
        truth.is_some_and(|t| t.neg[idx])
    })?;
    Some(Some(negative))
}

/// Significance-propagation pass at bit plane `k`: the coefficients most likely to become
/// significant, those with a significant neighbour or parent, code their significance
/// first, so a stream cut part-way through a plane has spent its bytes where they buy the
/// most. Returns `None` if the input ran out part-way.
#[inline(never)] // a pass is a loop of its own: keep its registers for the coder
pub fn propagation<I: BitIo>(
    mut io: I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
) -> (I, Option<()>) {
    // The coder lives in this frame (not behind a reference) so it can stay in registers.
    let done = propagation_with(&mut io, plan, state, truth, k);
    (io, done)
}

#[inline(always)]
fn propagation_with<I: BitIo>(
    io: &mut I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
) -> Option<()> {
    let t = &plan.tree;
    state.refine_count = state.found.len();
    state.visited.fill(0);
    state.start_pass();
    for (bi, b) in t.bands.iter().enumerate() {
        let parent_sig = b.parent.map_or(0, |p| state.band_sig[p]);
        if b.is_empty() || k < u32::from(plan.shifts[bi]) || state.band_sig[bi] + parent_sig == 0 {
            // Nothing significant in or above the band: no candidates.
            continue;
        }
        let (class, table) = (plan.class[bi], &context::SIG[plan.table[bi]]);
        for i in 0..b.rows {
            // A row without a significant neighbour row or parent row has no candidates
            // (and gains none: news only spreads from coded candidates).
            let rows =
                &state.row_sig[b.row_id0 + i.saturating_sub(1)..b.row_id0 + (i + 2).min(b.rows)];
            let parents = t.parent_row_id(bi, i).map_or(0, |r| state.row_sig[r]);
            if parents == 0 && rows.iter().all(|&n| n == 0) {
                continue;
            }
            state.load_parents(t, bi, i, false);
            let row = b.word0 + i * b.words;
            let base = (b.row0 + i) * t.cols + b.col0;
            let mut events = 0;
            for w in 0..b.words {
                // Candidates: a significant neighbour (in the current state: this row's
                // earlier words already hold this pass's news) or a significant parent.
                let up = if i > 0 { row - b.words } else { row };
                let down = if i + 1 < b.rows { row + b.words } else { row };
                let cand = bitmap::dilate(
                    &state.sig[up..up + b.words],
                    &state.sig[row..row + b.words],
                    &state.sig[down..down + b.words],
                    w,
                ) | state.parent_sig[w];
                let mut todo = cand & !state.sig[row + w] & bitmap::valid(b.cols, w);
                // Everything the loop touches besides the coder is re-read from memory (L1):
                // the coder's state is what must stay in registers.
                state.visited[row + w] = todo;
                let word = base + w * 64;
                while todo != 0 {
                    let bit = todo.trailing_zeros() as usize;
                    todo &= todo - 1;
                    let idx = word + bit;
                    let parent = (state.parent_sig[w] >> bit & 1) as u32;
                    let f = u32::from(state.flags[idx]) | parent << context::PARENT_SHIFT;
                    if let Some(neg) = significance(io, state, truth, class, table, f, idx, k)? {
                        let j = w * 64 + bit;
                        state.become_significant(bi, b, (row + w, bit), (i, j), idx, k, neg);
                        events += 1;
                        // The east neighbour now has a significant neighbour too.
                        let east = (2u64 << bit) & !state.sig[row + w] & bitmap::valid(b.cols, w);
                        todo |= east;
                        state.visited[row + w] |= east;
                    }
                }
            }
            state.count(bi, b, i, events);
        }
    }
    Some(())
}

/// Refinement (subordinate) pass at bit plane `k`: bit k of every coefficient found at a
/// higher plane. Returns `None` if the input ran out part-way.
#[inline(never)] // a pass is a loop of its own: keep its registers for the coder
pub fn refinement<I: BitIo>(
    mut io: I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
) -> (I, Option<()>) {
    let done = refinement_with(&mut io, plan, state, truth, k);
    (io, done)
}

#[inline(always)]
fn refinement_with<I: BitIo>(
    io: &mut I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
) -> Option<()> {
    let State {
        flags, found, ctx, ..
    } = state;
    for e in &mut found[..state.refine_count] {
        let idx = e.idx as usize;
        let band = usize::from(e.band);
        if k < u32::from(plan.shifts[band]) {
            // Below the band's integer resolution the bit is known to be zero.
            e.known = k as u8;
            continue;
        }
        // Every coefficient here is known down to plane k + 1. Its first two refinement
        // bits lean towards 0 (magnitudes fall off within each interval); later ones are coin
        // tosses and bypass the contexts, which would only add adaptation noise.
        let above = e.mag >> (k + 1);
        let truth_bit = || truth.is_some_and(|t| t.mag[idx] >> k & 1 == 1);
        let bit = if above < 4 {
            let c = context::refine(above == 1, plan.class[band], u32::from(flags[idx]));
            io.bit(ctx.refine(c), truth_bit)?
        } else {
            io.bypass(truth_bit)?
        };
        e.mag |= u64::from(bit) << k;
        e.known = k as u8;
    }
    Some(())
}

/// Cleanup (dominant) pass at bit plane `k`: every coefficient the propagation pass did not
/// reach, with zerotrees. Returns `None` if the input ran out part-way.
#[inline(never)] // a pass is a loop of its own: keep its registers for the coder
pub fn cleanup<I: BitIo>(
    mut io: I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
) -> (I, Option<()>) {
    // The coder lives in this frame (not behind a reference) so it can stay in registers.
    let done = cleanup_with(&mut io, plan, state, truth, k);
    (io, done)
}

#[inline(always)]
fn cleanup_with<I: BitIo>(
    io: &mut I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
) -> Option<()> {
    let t = &plan.tree;
    state.start_pass();
    for (bi, b) in t.bands.iter().enumerate() {
        if b.is_empty() {
            continue;
        }
        // Under a band-wide zerotree cover nothing is coded (early planes: most bands).
        if b.parent.is_some_and(|p| state.band_covered[p]) {
            state.band_covered[bi] = true;
            continue;
        }
        let (class, table) = (plan.class[bi], &context::SIG[plan.table[bi]]);
        let may_be_significant = k >= u32::from(plan.shifts[bi]);
        let mut band_covered = true;
        for i in 0..b.rows {
            let row_id = b.row_id0 + i;
            if t.parent_row_id(bi, i).is_some_and(|r| state.row_covered[r]) {
                state.row_covered[row_id] = true;
                continue;
            }
            state.load_parents(t, bi, i, true);
            let mut row_covered = true;
            let mut events = 0;
            let row = b.word0 + i * b.words;
            let base = (b.row0 + i) * t.cols + b.col0;
            for w in 0..b.words {
                let covered = state.parent_cover[w];
                let valid = bitmap::valid(b.cols, w);
                let visited = state.visited[row + w];
                // A coefficient the propagation pass coded, or one below its band's integer
                // resolution, has only a zerotree decision left, and none without children.
                let parents = state.parents[row + w];
                let open = if may_be_significant {
                    !visited | parents
                } else {
                    parents
                };
                let mut todo = !covered & !state.sig[row + w] & valid & open;
                let parent_sig = state.parent_sig[w];
                let mut roots = 0u64;
                while todo != 0 {
                    let bit = todo.trailing_zeros() as usize;
                    todo &= todo - 1;
                    let j = w * 64 + bit;
                    let idx = base + j;
                    let parent = (parent_sig >> bit & 1) as u32;
                    let f = u32::from(state.flags[idx]) | parent << context::PARENT_SHIFT;
                    if may_be_significant && visited >> bit & 1 == 0 {
                        if let Some(neg) = significance(io, state, truth, class, table, f, idx, k)?
                        {
                            state.become_significant(bi, b, (row + w, bit), (i, j), idx, k, neg);
                            events += 1;
                            continue;
                        }
                    }
                    if parents >> bit & 1 == 1 {
                        let c = context::ZTR[(f & 0x1FF) as usize];
                        let zerotree = io.bit(state.ctx.ztr(class, c), || {
                            truth.is_some_and(|t| !t.sub_new[idx])
                        })?;
                        if zerotree {
                            roots |= 1 << bit;
                        }
                    }
                }
                // The children's cover: under a zerotree already, or a root coded now.
                let cover = (covered | roots) & valid;
                state.cover[row + w] = cover;
                row_covered &= cover == valid;
            }
            state.count(bi, b, i, events);
            state.row_covered[row_id] = row_covered;
            band_covered &= row_covered;
        }
        state.band_covered[bi] = band_covered;
    }
    Some(())
}
