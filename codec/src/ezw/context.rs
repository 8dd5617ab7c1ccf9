//! Context modelling for the bit-plane passes, kept as JPEG 2000 coders keep it (ISO/IEC
//! 15444-1 Annex D; D. Taubman, "High performance scalable image compression with EBCOT",
//! IEEE TIP 2000): every coefficient carries a word of flags saying which of its 8 in-band
//! neighbours are significant (and the signs of two of them), updated once when a neighbour
//! becomes significant. A context is then one table lookup on that word instead of eight
//! bounds-checked neighbour reads per decision.
//!

use super::arith::{Prob, PROB_INIT};
use crate::wavelet::Orientation;

/// Neighbour significance bits: west, east, north, south and the four diagonals.
pub const W: u32 = 1 << 0;
pub const E: u32 = 1 << 1;
pub const N: u32 = 1 << 2;
pub const S: u32 = 1 << 3;
pub const NW: u32 = 1 << 4;
pub const NE: u32 = 1 << 5;
pub const SW: u32 = 1 << 6;
pub const SE: u32 = 1 << 7;
/// All eight neighbour bits.
pub const NEIGHBOURS: u32 = 0xFF;
/// The parent is significant. Never stored: the passes read it from the parent band's
/// bitmap and OR it in before a lookup, so a table index is `flags & 0xFF | parent << 8`.
pub const PARENT_SHIFT: u32 = 8;
/// The west / north neighbour is significant and negative (the sign context's inputs).
pub const W_NEG: u32 = 1 << 9;
pub const N_NEG: u32 = 1 << 10;

/// Context class of a band: LL, coarse details, level 2, level 1 (the finest bands have the
/// most zeros and the least correlation with their parents).
pub fn class(orientation: Option<Orientation>, level: usize) -> usize {
    match (orientation, level) {
        (None, _) => 0,
        (_, 1) => 3,
        (_, 2) => 2,
        _ => 1,
    }
}

/// Which neighbour pattern table a band uses: JPEG 2000 weighs the neighbours across the
/// band's high-pass direction first.
pub fn table_of(orientation: Option<Orientation>) -> usize {
    match orientation {
        Some(Orientation::HL) => 1,
        Some(Orientation::HH) => 2,
        _ => 0,
    }
}

/// Adaptive probabilities, per band class; they persist across passes and planes. Each set
/// is padded to a power of two so a masked index needs no bounds check.
#[derive(Clone)]
pub struct Contexts {
    /// Significance: 9 neighbourhood states × parent significant (18 used).
    pub sig: [[Prob; 32]; 4],
    /// Zerotree decision: 0, 1, ≥2 significant neighbours × parent significant (6 used).
    pub ztr: [[Prob; 8]; 4],
    /// Sign: the west (else north) neighbour is insignificant, positive, negative (3 used).
    pub sign: [[Prob; 4]; 4],
    /// Refinement: first (else second) refinement × fine band × ≥2 significant neighbours.
    pub refine: [Prob; 8],
}

impl Contexts {
    #[inline]
    pub fn sig(&mut self, class: usize, c: u8) -> &mut Prob {
        &mut self.sig[class & 3][usize::from(c) & 31]
    }

    #[inline]
    pub fn ztr(&mut self, class: usize, c: u8) -> &mut Prob {
        &mut self.ztr[class & 3][usize::from(c) & 7]
    }

    #[inline]
    pub fn sign(&mut self, class: usize, c: u8) -> &mut Prob {
        &mut self.sign[class & 3][usize::from(c) & 3]
    }

    #[inline]
    pub fn refine(&mut self, c: usize) -> &mut Prob {
        &mut self.refine[c & 7]
    }
}

impl Default for Contexts {
    fn default() -> Self {
        Self {
            sig: [[PROB_INIT; 32]; 4],
            ztr: [[PROB_INIT; 8]; 4],
            sign: [[PROB_INIT; 4]; 4],
            refine: [PROB_INIT; 8],
        }
    }
}

/// (horizontal 0..=2, vertical 0..=2, diagonal 0..=4) significant neighbours of a pattern.
const fn counts(pattern: usize) -> (usize, usize, usize) {
    const fn bit(pattern: usize, flag: u32) -> usize {
        (pattern >> flag.trailing_zeros()) & 1
    }
    (
        bit(pattern, W) + bit(pattern, E),
        bit(pattern, N) + bit(pattern, S),
        bit(pattern, NW) + bit(pattern, NE) + bit(pattern, SW) + bit(pattern, SE),
    )
}

/// JPEG 2000's significance context (ISO 15444-1 Table D.1) for LL/LH (`a` = horizontal,
/// `b` = vertical) and HL (swapped). Returns 0..=8.
const fn primary(a: usize, b: usize, d: usize) -> usize {
    if a == 2 {
        8
    } else if a == 1 {
        if b >= 1 {
            7
        } else if d >= 1 {
            6
        } else {
            5
        }
    } else if b == 2 {
        4
    } else if b == 1 {
        3
    } else if d >= 2 {
        2
    } else {
        d
    }
}

/// Table D.1's HH column: diagonals first.
const fn diagonal(hv: usize, d: usize) -> usize {
    match d {
        0 => {
            if hv >= 2 {
                2
            } else {
                hv
            }
        }
        1 => {
            if hv >= 2 {
                5
            } else {
                3 + hv
            }
        }
        2 => {
            if hv >= 1 {
                7
            } else {
                6
            }
        }
        _ => 8,
    }
}

const fn sig_table(table: usize) -> [u8; 512] {
    let mut out = [0u8; 512];
    let mut p = 0;
    while p < 512 {
        let (h, v, d) = counts(p & 0xFF);
        let state = match table {
            0 => primary(h, v, d),
            1 => primary(v, h, d),
            _ => diagonal(h + v, d),
        };
        out[p] = (state * 2 + (p >> PARENT_SHIFT)) as u8;
        p += 1;
    }
    out
}

const fn ztr_table() -> [u8; 512] {
    let mut out = [0u8; 512];
    let mut p = 0;
    while p < 512 {
        let (h, v, d) = counts(p & 0xFF);
        let n = if h + v + d >= 2 { 2 } else { h + v + d };
        out[p] = (n * 2 + (p >> PARENT_SHIFT)) as u8;
        p += 1;
    }
    out
}

/// Significance context within a class's 18, by [`table_of`] and `flags & 0x1FF`.
pub static SIG: [[u8; 512]; 3] = [sig_table(0), sig_table(1), sig_table(2)];
/// Zerotree context within a class's 6, by `flags & 0x1FF`.
pub static ZTR: [u8; 512] = ztr_table();

const fn sign_table() -> [u8; 16] {
    // Index bits: W, N, W_NEG, N_NEG.
    let mut out = [0u8; 16];
    let mut i = 0;
    while i < 16 {
        out[i] = if i & 1 != 0 {
            1 + ((i >> 2) & 1) as u8
        } else if i & 2 != 0 {
            1 + ((i >> 3) & 1) as u8
        } else {
            0
        };
        i += 1;
    }
    out
}

static SIGN: [u8; 16] = sign_table();

/// Sign context: the sign of the significant west neighbour, else of the north one, else 0.
/// A table lookup: the branches it replaces are coin tosses.
#[inline]
pub fn sign(flags: u32) -> u8 {
    let key = (flags & W) | (flags & N) >> 1 | (flags & (W_NEG | N_NEG)) >> 7;
    SIGN[key as usize & 15]
}

/// Refinement context: the first (else second) refinement of a coefficient, a fine band
/// (class ≥ 2), two or more significant neighbours.
#[inline]
pub fn refine(first: bool, class: usize, flags: u32) -> usize {
    let fine = class >= 2;
    let nbrs = flags & NEIGHBOURS;
    // x & (x − 1) clears the lowest set bit: non-zero iff two or more are set.
    let two = nbrs & nbrs.wrapping_sub(1) != 0;
    (usize::from(first) * 2 + usize::from(fine)) * 2 + usize::from(two)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Table D.1 spot checks: a lone horizontal neighbour in LL/LH is state 5, in HL state 3;
    /// three diagonals in HH are state 8; the parent bit is the low bit.
    #[test]
    fn tables_follow_jpeg2000_d1() {
        assert_eq!(SIG[0][W as usize], 10);
        assert_eq!(SIG[1][W as usize], 6);
        assert_eq!(SIG[2][(NW | NE | SE) as usize], 16);
        assert_eq!(SIG[2][(NW | N) as usize], 8);
        assert_eq!(SIG[0][1 << PARENT_SHIFT], 1);
        assert_eq!(SIG[0][(W | E | N | S) as usize], 16);
        assert_eq!(ZTR[(SW | SE | N) as usize | 1 << PARENT_SHIFT], 5);
    }

    #[test]
    fn sign_prefers_the_west_neighbour() {
        assert_eq!(sign(0), 0);
        assert_eq!(sign(N | N_NEG), 2);
        assert_eq!(sign(W | N | N_NEG), 1);
        assert_eq!(sign(W | W_NEG), 2);
    }

    /// The refinement context's three inputs each own a bit of the index: the first
    /// refinement, a fine band (detail levels 1 and 2, the bands with the most zeros), and
    /// two or more significant neighbours (one is not two; signs and the parent bit are not
    /// neighbours).
    #[test]
    fn refinement_contexts_keep_their_three_inputs_apart() {
        let patterns = [
            (0, false),
            (W, false),
            (SE | W_NEG | N_NEG, false),
            (NE | 1 << PARENT_SHIFT, false),
            (W | E, true),
            (N | SW, true),
            (NEIGHBOURS, true),
        ];
        for first in [false, true] {
            for level in 1..=4 {
                for o in [None, Some(Orientation::HL), Some(Orientation::HH)] {
                    let fine = o.is_some() && level <= 2;
                    for (flags, two) in patterns {
                        let c = refine(first, class(o, level), flags);
                        assert!(c < 8);
                        assert_eq!(
                            (c >> 2 == 1, c >> 1 & 1 == 1, c & 1 == 1),
                            (first, fine, two),
                            "first {first}, {o:?} level {level}, flags {flags:#x}"
                        );
                    }
                }
            }
        }
    }
}
