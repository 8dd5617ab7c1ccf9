//! Shapiro's two passes per threshold T = 2^k, written once for both directions: the
//! encoder supplies each bit from the true magnitudes, the decoder reads it, and both keep
//! the same [`State`] so their contexts can never drift apart.
//!
//! - **Dominant pass**: coarse → fine bands, raster order inside a band. Every coefficient
//!   not yet significant and not inside a zerotree coded earlier in this pass gets a symbol:
//!   POS / NEG (significant, with its sign), ZTR (zerotree root: it and every descendant not
//!   yet significant stay below T; its descendants get no symbol this pass) or IZ (isolated
//!   zero). Coefficients without children only code significance.
//! - **Subordinate pass**: one refinement bit (bit k) for every coefficient that became
//!   significant at an earlier threshold, in the order they were found.
//!
//! Symbols are binarised (significant?, sign, zerotree?) and coded with context-adaptive
//! probabilities: the context is the band's class, how many of the 8 neighbours are already
//! significant, and whether the parent is (the statistics EBCOT and SPIHT exploit).

use super::arith::{Decoder, Encoder, Prob, PROB_INIT};
use super::tree::{Tree, NO_PARENT};
use crate::wavelet::Orientation;

/// Direction-agnostic bit channel.
pub trait BitIo {
    /// Encoder: codes `bit()` and returns it. Decoder: returns the decoded bit, or `None`
    /// once a truncated segment can no longer be decoded exactly.
    fn bit(&mut self, p: &mut Prob, bit: impl FnOnce() -> bool) -> Option<bool>;
}

pub struct EncodeIo(pub Encoder);

impl BitIo for EncodeIo {
    #[inline]
    fn bit(&mut self, p: &mut Prob, bit: impl FnOnce() -> bool) -> Option<bool> {
        let b = bit();
        self.0.encode(p, b);
        Some(b)
    }
}

pub struct DecodeIo<'a> {
    pub dec: Decoder<'a>,
    /// The segment is whole: its termination makes zero padding valid to the end.
    pub complete: bool,
}

impl BitIo for DecodeIo<'_> {
    #[inline]
    fn bit(&mut self, p: &mut Prob, _bit: impl FnOnce() -> bool) -> Option<bool> {
        if !self.complete && !self.dec.reliable() {
            return None;
        }
        Some(self.dec.decode(p))
    }
}

const SIG_CTX: usize = 4 * 9 * 2;
const ZTR_CTX: usize = 4 * 3 * 2;
const SIGN_CTX: usize = 4 * 3;
const REF_CTX: usize = 2 * 2 * 2;

/// Adaptive probabilities; they persist across passes.
#[derive(Clone)]
pub struct Contexts {
    sig: [Prob; SIG_CTX],
    ztr: [Prob; ZTR_CTX],
    sign: [Prob; SIGN_CTX],
    refine: [Prob; REF_CTX],
}

impl Default for Contexts {
    fn default() -> Self {
        Self {
            sig: [PROB_INIT; SIG_CTX],
            ztr: [PROB_INIT; ZTR_CTX],
            sign: [PROB_INIT; SIGN_CTX],
            refine: [PROB_INIT; REF_CTX],
        }
    }
}

/// What both sides know about every coefficient.
pub struct State {
    pub sig: Vec<bool>,
    pub neg: Vec<bool>,
    /// Magnitude bits known so far (in quantisation steps).
    pub mag: Vec<u64>,
    /// Lowest bit plane known, valid where `sig`.
    pub known: Vec<u8>,
    /// Significant coefficients in the order they were found.
    pub found: Vec<u32>,
    /// Pass stamp of the zerotree that covers a coefficient.
    covered: Vec<u16>,
    /// Pass stamp of the propagation pass that already coded a coefficient's significance.
    visited: Vec<u16>,
    pub ctx: Contexts,
    cols: usize,
}

impl State {
    pub fn new(n: usize, cols: usize) -> Self {
        Self {
            cols,
            sig: vec![false; n],
            neg: vec![false; n],
            mag: vec![0; n],
            known: vec![0; n],
            found: Vec::new(),
            covered: vec![0; n],
            visited: vec![0; n],
            ctx: Contexts::default(),
        }
    }
}

/// Per-layout facts both sides derive from the header.
pub struct Plan {
    pub tree: Tree,
    /// Per band: bit planes below this are known to be zero (integer 5/3 bands weighted by a
    /// shift); 0 for real-valued bands.
    pub shifts: Vec<u8>,
    /// Per coefficient: it has at least one child.
    pub has_children: Vec<bool>,
}

impl Plan {
    pub fn new(tree: Tree, shifts: Vec<u8>) -> Self {
        let has_children = (0..tree.parent.len())
            .map(|idx| !tree.children(idx).is_empty())
            .collect();
        Self {
            tree,
            shifts,
            has_children,
        }
    }

    /// Context class of a band: LL, coarse details, level 2, level 1.
    #[inline]
    fn class(&self, bi: usize) -> usize {
        let b = &self.tree.bands[bi];
        match (b.orientation, b.level) {
            (None, _) => 0,
            (_, 1) => 3,
            (_, 2) => 2,
            _ => 1,
        }
    }
}

/// The encoder's knowledge: true magnitudes and signs.
pub struct Truth<'a> {
    pub mag: &'a [u64],
    pub neg: &'a [bool],
    /// Per coefficient, for the current pass: it or a descendant becomes significant now.
    pub sub_new: Vec<bool>,
}

impl Truth<'_> {
    /// Prepares `sub_new` for bit plane `k` from the state at the start of the pass.
    pub fn prepare(&mut self, plan: &Plan, state: &State, k: u32) {
        self.sub_new.clear();
        self.sub_new.resize(self.mag.len(), false);
        let t = &plan.tree;
        for b in t.bands.iter().rev() {
            for i in 0..b.rows {
                let row = (b.row0 + i) * t.cols + b.col0;
                for idx in row..row + b.cols {
                    if !state.sig[idx] && self.mag[idx] >> k != 0 {
                        self.sub_new[idx] = true;
                    }
                    if self.sub_new[idx] && t.parent[idx] != NO_PARENT {
                        self.sub_new[t.parent[idx] as usize] = true;
                    }
                }
            }
        }
    }
}

/// Significant neighbours inside the band: (horizontal 0..2, vertical 0..2, diagonal 0..4).
#[inline]
fn neighbours(
    state: &State,
    cols: usize,
    b_rows: usize,
    b_cols: usize,
    idx: usize,
    i: usize,
    j: usize,
) -> (usize, usize, usize) {
    let s = &state.sig;
    let up = i > 0;
    let down = i + 1 < b_rows;
    let left = j > 0;
    let right = j + 1 < b_cols;
    let h = usize::from(left && s[idx - 1]) + usize::from(right && s[idx + 1]);
    let mut v = 0;
    let mut d = 0;
    if up {
        let u = idx - cols;
        v += usize::from(s[u]);
        d += usize::from(left && s[u - 1]) + usize::from(right && s[u + 1]);
    }
    if down {
        let w = idx + cols;
        v += usize::from(s[w]);
        d += usize::from(left && s[w - 1]) + usize::from(right && s[w + 1]);
    }
    (h, v, d)
}

/// JPEG 2000's significance context (ISO 15444-1 Table D.1): which neighbours matter depends
/// on the band's orientation. Returns 0..=8.
#[inline]
fn significance_context(
    orientation: Option<Orientation>,
    (h, v, d): (usize, usize, usize),
) -> usize {
    let primary = |a: usize, b: usize| match (a, b, d) {
        (2, _, _) => 8,
        (1, 1.., _) => 7,
        (1, 0, 1..) => 6,
        (1, 0, 0) => 5,
        (0, 2, _) => 4,
        (0, 1, _) => 3,
        (0, 0, 2..) => 2,
        (0, 0, 1) => 1,
        _ => 0,
    };
    match orientation {
        Some(Orientation::HL) => primary(v, h),
        Some(Orientation::HH) => match (d, h + v) {
            (3.., _) => 8,
            (2, 1..) => 7,
            (2, 0) => 6,
            (1, 2..) => 5,
            (1, 1) => 4,
            (1, 0) => 3,
            (0, 2..) => 2,
            (0, 1) => 1,
            _ => 0,
        },
        _ => primary(h, v),
    }
}

/// Significance-propagation pass at bit plane `k` (JPEG 2000's fractional bit planes): the
/// coefficients most likely to become significant, those with a significant neighbour or
/// parent, code their significance first, so a stream cut part-way through a plane has
/// spent its bytes where they buy the most.
pub fn propagation<I: BitIo>(
    io: &mut I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
    stamp: u16,
) -> Option<()> {
    let t = &plan.tree;
    let cols = t.cols;
    for (bi, b) in t.bands.iter().enumerate() {
        if k < u32::from(plan.shifts[bi]) {
            continue;
        }
        let class = plan.class(bi);
        for i in 0..b.rows {
            for j in 0..b.cols {
                let idx = (b.row0 + i) * cols + b.col0 + j;
                if state.sig[idx] {
                    continue;
                }
                let parent_sig = t.parent[idx] != NO_PARENT && state.sig[t.parent[idx] as usize];
                let hvd = neighbours(state, cols, b.rows, b.cols, idx, i, j);
                if hvd == (0, 0, 0) && !parent_sig {
                    continue;
                }
                state.visited[idx] = stamp;
                code_significance(
                    io,
                    state,
                    truth,
                    idx,
                    k,
                    class,
                    b.orientation,
                    hvd,
                    parent_sig,
                    i,
                    j,
                )?;
            }
        }
    }
    Some(())
}

/// Significance bit and, if significant, sign; updates the state. Returns whether significant.
#[allow(clippy::too_many_arguments)] // the context inputs, computed once by the caller
#[inline]
fn code_significance<I: BitIo>(
    io: &mut I,
    state: &mut State,
    truth: Option<&Truth>,
    idx: usize,
    k: u32,
    class: usize,
    orientation: Option<Orientation>,
    hvd: (usize, usize, usize),
    parent_sig: bool,
    i: usize,
    j: usize,
) -> Option<bool> {
    let c = (class * 9 + significance_context(orientation, hvd)) * 2 + usize::from(parent_sig);
    let significant = io.bit(&mut state.ctx.sig[c], || {
        truth.is_some_and(|t| t.mag[idx] >> k != 0)
    })?;
    if significant {
        let cols = state.cols;
        let sc = class * 3 + sign_context(state, cols, idx, j, i);
        let negative = io.bit(&mut state.ctx.sign[sc], || {
            truth.is_some_and(|t| t.neg[idx])
        })?;
        state.sig[idx] = true;
        state.neg[idx] = negative;
        state.mag[idx] = 1 << k;
        state.known[idx] = k as u8;
        state.found.push(idx as u32);
    }
    Some(significant)
}

/// Dominant (cleanup) pass at bit plane `k`: every coefficient the propagation pass did not
/// reach, with zerotrees. Returns `None` if the input ran out part-way.
pub fn dominant<I: BitIo>(
    io: &mut I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
    stamp: u16,
) -> Option<()> {
    let t = &plan.tree;
    let cols = t.cols;
    for (bi, b) in t.bands.iter().enumerate() {
        let class = plan.class(bi);
        let may_be_significant = k >= u32::from(plan.shifts[bi]);
        for i in 0..b.rows {
            for j in 0..b.cols {
                let idx = (b.row0 + i) * cols + b.col0 + j;
                if state.covered[idx] == stamp {
                    for &c in t.children(idx) {
                        state.covered[c as usize] = stamp;
                    }
                    continue;
                }
                if state.sig[idx] {
                    continue;
                }
                let parent_sig = t.parent[idx] != NO_PARENT && state.sig[t.parent[idx] as usize];
                let hvd = neighbours(state, cols, b.rows, b.cols, idx, i, j);
                let nbr = (hvd.0 + hvd.1 + hvd.2).min(2);
                if may_be_significant
                    && state.visited[idx] != stamp
                    && code_significance(
                        io,
                        state,
                        truth,
                        idx,
                        k,
                        class,
                        b.orientation,
                        hvd,
                        parent_sig,
                        i,
                        j,
                    )?
                {
                    continue;
                }
                if plan.has_children[idx] {
                    let c = (class * 3 + nbr) * 2 + usize::from(parent_sig);
                    let zerotree = io.bit(&mut state.ctx.ztr[c], || {
                        truth.is_some_and(|t| !t.sub_new[idx])
                    })?;
                    if zerotree {
                        for &c in t.children(idx) {
                            state.covered[c as usize] = stamp;
                        }
                    }
                }
            }
        }
    }
    Some(())
}

/// Sign context: the sign of the already significant left or upper neighbour, if any.
#[inline]
fn sign_context(state: &State, cols: usize, idx: usize, j: usize, i: usize) -> usize {
    let look = |n: usize| {
        if state.sig[n] {
            1 + usize::from(state.neg[n])
        } else {
            0
        }
    };
    if j > 0 && state.sig[idx - 1] {
        look(idx - 1)
    } else if i > 0 {
        look(idx - cols)
    } else {
        0
    }
}

/// Subordinate pass at bit plane `k`: bit k of every coefficient found at a higher plane.
pub fn subordinate<I: BitIo>(
    io: &mut I,
    plan: &Plan,
    state: &mut State,
    truth: Option<&Truth>,
    k: u32,
) -> Option<()> {
    let t = &plan.tree;
    for n in 0..state.found.len() {
        let idx = state.found[n] as usize;
        if u32::from(state.known[idx]) <= k {
            continue;
        }
        let bi = t.band_of[idx] as usize;
        if k < u32::from(plan.shifts[bi]) {
            // Below the band's integer resolution the bit is known to be zero.
            state.known[idx] = k as u8;
            continue;
        }
        let first = u32::from(state.known[idx]) == k + 1 && state.mag[idx] >> (k + 1) == 1;
        let fine = plan.class(bi) >= 2;
        let b = &t.bands[bi];
        let (i, j) = ((idx / t.cols) - b.row0, (idx % t.cols) - b.col0);
        let (h, v, d) = neighbours(state, t.cols, b.rows, b.cols, idx, i, j);
        let nbr = h + v + d >= 2;
        let c = (usize::from(first) * 2 + usize::from(fine)) * 2 + usize::from(nbr);
        let bit = io.bit(&mut state.ctx.refine[c], || {
            truth.is_some_and(|t| t.mag[idx] >> k & 1 == 1)
        })?;
        if bit {
            state.mag[idx] |= 1 << k;
        }
        state.known[idx] = k as u8;
    }
    Some(())
}
