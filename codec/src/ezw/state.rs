//! What encoder and decoder both know about the coefficients after each decision, laid out
//! for the passes: bitmaps to find work by the word, flag words for contexts, and the
//! significant coefficients as a list in the order they were found (the refinement pass
//! walks it front to back; dequantisation touches only its entries).

use super::context::{self, Contexts};
use super::tree::{Tree, TreeBand};
use crate::wavelet::Wavelet;

/// One significant coefficient as a decoder knows it.
#[derive(Clone, Copy, Debug)]
pub struct Known {
    /// Magnitude bits known so far, in quantisation steps of the weighted domain.
    pub mag: u64,
    /// Flat Mallat index.
    pub idx: u32,
    /// Scan-order band.
    pub band: u8,
    /// Lowest bit plane known.
    pub known: u8,
    pub neg: bool,
}

/// Per-layout facts both sides derive from the header.
pub struct Plan {
    pub tree: Tree,
    /// Per band: bit planes below this are known to be zero (integer 5/3 bands weighted by a
    /// shift); 0 for real-valued bands.
    pub shifts: Vec<u8>,
    /// Per band: context class (see [`context::class`]) and neighbour table.
    pub class: Vec<usize>,
    pub table: Vec<usize>,
}

impl Plan {
    pub fn new(tree: Tree, shifts: Vec<u8>) -> Self {
        let class = tree
            .bands
            .iter()
            .map(|b| context::class(b.orientation, b.level))
            .collect();
        let table = tree
            .bands
            .iter()
            .map(|b| context::table_of(b.orientation))
            .collect();
        Self {
            tree,
            shifts,
            class,
            table,
        }
    }

    /// The shifts a stream with this wavelet uses on this tree.
    pub fn shifts_for(wavelet: Wavelet, layout: &crate::wavelet::Layout) -> Vec<u8> {
        match wavelet {
            Wavelet::LeGall53 => super::quantize::integer_shifts(layout),
            Wavelet::Cdf97 => vec![0; layout.bands_coarse_to_fine().len()],
        }
    }
}

/// The decoder's (and the encoder's mirror of the decoder's) knowledge.
pub struct State {
    /// Per coefficient (flat Mallat index): its neighbours' significance and two of their
    /// signs (see [`context`] for the bits).
    pub flags: Vec<u16>,
    /// Band bitmaps (see [`Tree`]): significant; coded by this plane's propagation pass;
    /// covered by a zerotree or coded as a zerotree root in this plane's cleanup pass.
    pub sig: Vec<u64>,
    pub visited: Vec<u64>,
    pub cover: Vec<u64>,
    /// Band bitmap of the coefficients with children (they code a zerotree decision).
    pub parents: Vec<u64>,
    /// Significant coefficients per band and per band row: a pass skips the bands and rows
    /// where nothing can be coded in O(1). Updated at the end of each row ([`Self::count`]).
    pub band_sig: Vec<u32>,
    pub row_sig: Vec<u32>,
    /// This plane's cleanup pass left every coefficient of the band / band row covered by a
    /// zerotree (its `cover` words are then not written: readers look here first).
    pub band_covered: Vec<bool>,
    pub row_covered: Vec<bool>,
    /// Significant coefficients in the order found.
    pub found: Vec<Known>,
    /// How many of `found` the current plane's refinement pass refines (those found at
    /// higher planes).
    pub refine_count: usize,
    pub ctx: Contexts,
    /// Scratch: the current band row's parents' significance and zerotree cover, and the
    /// (band, parent row) they were expanded for (two child rows share a parent row).
    pub parent_sig: Vec<u64>,
    pub parent_cover: Vec<u64>,
    parent_key: Option<(usize, usize)>,
    cols: usize,
}

impl State {
    /// A state with nothing significant.
    pub fn new(plan: &Plan) -> Self {
        let t = &plan.tree;
        let n = t.bands.iter().map(|b| b.rows * b.cols).sum();
        let mut parents = vec![0u64; t.words];
        for (bi, b) in t.bands.iter().enumerate() {
            for i in 0..b.rows {
                let with_children = t.children_cols(bi, i).min(b.cols);
                let words = &mut parents[b.word0 + i * b.words..][..b.words];
                for (w, word) in words.iter_mut().enumerate() {
                    *word = super::bitmap::valid(with_children, w);
                }
            }
        }
        Self {
            flags: vec![0; n],
            sig: vec![0; t.words],
            visited: vec![0; t.words],
            cover: vec![0; t.words],
            parents,
            band_sig: vec![0; t.bands.len()],
            row_sig: vec![0; t.band_rows],
            band_covered: vec![false; t.bands.len()],
            row_covered: vec![false; t.band_rows],
            // Every coefficient may become significant: one allocation, bounded by the grid.
            found: Vec::with_capacity(n),
            refine_count: 0,
            ctx: Contexts::default(),
            parent_sig: vec![0; t.max_row_words],
            parent_cover: vec![0; t.max_row_words],
            parent_key: None,
            cols: t.cols,
        }
    }

    /// Starts a pass: parent bands change between passes.
    pub fn start_pass(&mut self) {
        self.parent_key = None;
    }

    /// Loads `parent_sig` (and `parent_cover` when `cover`) for row `i` of band `bi`: bit j is
    /// the state of coefficient (i, j)'s parent. All zero for the LL band. Within a pass a
    /// parent band is final before its children are scanned, so a loaded row stays valid.
    #[inline]
    pub fn load_parents(&mut self, tree: &Tree, bi: usize, i: usize, cover: bool) {
        let b = &tree.bands[bi];
        let words = b.words;
        let Some(pi) = b.parent else {
            self.parent_sig[..words].fill(0);
            self.parent_cover[..words].fill(0);
            return;
        };
        let pr = tree.parent_row(bi, i);
        if self.parent_key == Some((bi, pr)) {
            return;
        }
        self.parent_key = Some((bi, pr));
        let p = &tree.bands[pi];
        let row = p.word0 + pr * p.words;
        let src = &self.sig[row..row + p.words];
        super::bitmap::expand(src, p.cols, b.depth, &mut self.parent_sig[..words], b.cols);
        if cover {
            let src = &self.cover[row..row + p.words];
            super::bitmap::expand(
                src,
                p.cols,
                b.depth,
                &mut self.parent_cover[..words],
                b.cols,
            );
        }
    }

    /// Coefficient (i, j) of band `bi` (flat index `idx`, bit `bit` of bitmap word `word`)
    /// becomes significant at plane `k`: mark it, list it, and tell its in-band neighbours.
    /// The caller adds it to `row_sig` / `band_sig` once per row.
    #[allow(clippy::too_many_arguments)] // the coordinates the caller already holds
    #[inline(always)]
    pub fn become_significant(
        &mut self,
        bi: usize,
        b: &TreeBand,
        (word, bit): (usize, usize),
        (i, j): (usize, usize),
        idx: usize,
        k: u32,
        neg: bool,
    ) {
        self.sig[word] |= 1 << bit;
        self.found.push(Known {
            mag: 1 << k,
            idx: idx as u32,
            band: bi as u8,
            known: k as u8,
            neg,
        });
        let cols = self.cols;
        let (up, down) = (i > 0, i + 1 < b.rows);
        let (left, right) = (j > 0, j + 1 < b.cols);
        let f = &mut self.flags;
        let (w_neg, n_neg) = if neg {
            (context::W_NEG as u16, context::N_NEG as u16)
        } else {
            (0, 0)
        };
        // Each neighbour records this coefficient under the direction it sees it in.
        if up && down && left && right {
            // Inside the band (the common case): one window, no edge tests.
            let win = &mut f[idx - cols - 1..idx + cols + 2];
            win[0] |= context::SE as u16;
            win[1] |= context::S as u16;
            win[2] |= context::SW as u16;
            win[cols] |= context::E as u16;
            win[cols + 2] |= context::W as u16 | w_neg;
            win[2 * cols] |= context::NE as u16;
            win[2 * cols + 1] |= context::N as u16 | n_neg;
            win[2 * cols + 2] |= context::NW as u16;
            return;
        }
        if left {
            f[idx - 1] |= context::E as u16;
        }
        if right {
            f[idx + 1] |= context::W as u16 | w_neg;
        }
        if up {
            let u = idx - cols;
            f[u] |= context::S as u16;
            if left {
                f[u - 1] |= context::SE as u16;
            }
            if right {
                f[u + 1] |= context::SW as u16;
            }
        }
        if down {
            let d = idx + cols;
            f[d] |= context::N as u16 | n_neg;
            if left {
                f[d - 1] |= context::NE as u16;
            }
            if right {
                f[d + 1] |= context::NW as u16;
            }
        }
    }

    /// Counts `events` new significant coefficients in row `i` of band `bi`.
    #[inline]
    pub fn count(&mut self, bi: usize, b: &TreeBand, i: usize, events: u32) {
        if events > 0 {
            self.row_sig[b.row_id0 + i] += events;
            self.band_sig[bi] += events;
        }
    }

    /// Whether coefficient (i, j) of band `b` is significant.
    #[inline]
    pub fn is_significant(&self, b: &TreeBand, i: usize, j: usize) -> bool {
        self.sig[b.word0 + i * b.words + j / 64] >> (j % 64) & 1 == 1
    }
}
