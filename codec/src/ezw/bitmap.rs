//! Word-level row bitmaps over the subbands: one bit per coefficient, each band row padded to
//! whole 64-bit words (bits past the band's width are always zero). The passes find the
//! coefficients they must code with a few word operations per 64 coefficients (SPIHT's
//! insight that most of a plane is known-zero, done with bitmaps instead of lists), so a
//! pass costs what it codes rather than the grid's size.

/// The bits of word `w` of a row `cols` wide that hold coefficients.
#[inline]
pub fn valid(cols: usize, w: usize) -> u64 {
    let left = cols.saturating_sub(w * 64);
    if left >= 64 {
        u64::MAX
    } else {
        (1u64 << left) - 1
    }
}

/// Doubles every bit of `x`: bit i goes to bits 2i and 2i + 1 (a child row one level finer
/// has two columns per parent column).
#[inline]
pub fn spread(x: u32) -> u64 {
    let mut v = u64::from(x);
    v = (v | v << 16) & 0x0000_FFFF_0000_FFFF;
    v = (v | v << 8) & 0x00FF_00FF_00FF_00FF;
    v = (v | v << 4) & 0x0F0F_0F0F_0F0F_0F0F;
    v = (v | v << 2) & 0x3333_3333_3333_3333;
    v = (v | v << 1) & 0x5555_5555_5555_5555;
    v | v << 1
}

#[inline]
fn bit(row: &[u64], j: usize) -> bool {
    row.get(j / 64).is_some_and(|w| w >> (j % 64) & 1 == 1)
}

/// A child band row from its parent band row: bit j of `dst` (`dst_cols` wide) is bit
/// min(j >> depth, src_cols − 1) of `src` (`src_cols` wide, zero past it), the tree's
/// parent rule. Bits of `dst` past `dst_cols` are cleared.
pub fn expand(src: &[u64], src_cols: usize, depth: u32, dst: &mut [u64], dst_cols: usize) {
    match depth {
        0 => {
            for (w, d) in dst.iter_mut().enumerate() {
                *d = src.get(w).copied().unwrap_or(0);
            }
        }
        1 => {
            for (w, d) in dst.iter_mut().enumerate() {
                let half = src.get(w / 2).map_or(0, |s| (s >> (32 * (w % 2))) as u32);
                *d = spread(half);
            }
        }
        _ => {
            // Only very anisotropic grids hang a band several levels below its parent.
            dst.fill(0);
            for j in 0..dst_cols.min(src_cols << depth) {
                if bit(src, j >> depth) {
                    dst[j / 64] |= 1 << (j % 64);
                }
            }
        }
    }
    // The parent's last column also owns the remainder past 2^depth × its width.
    let owned = src_cols.checked_shl(depth).unwrap_or(usize::MAX);
    if src_cols > 0 && owned < dst_cols && bit(src, src_cols - 1) {
        for j in owned..dst_cols {
            dst[j / 64] |= 1 << (j % 64);
        }
    }
    // Only the last word reaches past the row.
    if let Some(last) = dst.len().checked_sub(1) {
        dst[last] &= valid(dst_cols, last);
    }
}

/// Coefficients of word `w` of a row with a set bit among their 8 neighbours, from that
/// row's words and the rows above and below (empty slices outside the band).
#[inline]
pub fn dilate(up: &[u64], row: &[u64], down: &[u64], w: usize) -> u64 {
    let column = |w: usize| {
        let at = |r: &[u64]| r.get(w).copied().unwrap_or(0);
        at(up) | at(row) | at(down)
    };
    let c = column(w);
    let left = if w > 0 { column(w - 1) >> 63 } else { 0 };
    let right = column(w + 1) << 63;
    c | c << 1 | c >> 1 | left | right
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slow_expand(src: &[bool], depth: u32, dst_cols: usize) -> Vec<bool> {
        (0..dst_cols)
            .map(|j| src[(j >> depth).min(src.len() - 1)])
            .collect()
    }

    fn pack(bits: &[bool]) -> Vec<u64> {
        let mut out = vec![0u64; bits.len().div_ceil(64)];
        for (j, &b) in bits.iter().enumerate() {
            if b {
                out[j / 64] |= 1 << (j % 64);
            }
        }
        out
    }

    #[test]
    fn expand_matches_the_parent_rule() {
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        for src_cols in [1usize, 2, 3, 31, 32, 33, 63, 64, 65, 100, 129] {
            for depth in 0..4u32 {
                for extra in [0usize, 1, 2, 5] {
                    let dst_cols = (src_cols << depth).saturating_sub(3) + extra;
                    if dst_cols == 0 {
                        continue;
                    }
                    let src: Vec<bool> = (0..src_cols)
                        .map(|_| {
                            s ^= s << 13;
                            s ^= s >> 7;
                            s ^= s << 17;
                            s & 1 == 1
                        })
                        .collect();
                    let mut dst = vec![u64::MAX; dst_cols.div_ceil(64)];
                    expand(&pack(&src), src_cols, depth, &mut dst, dst_cols);
                    assert_eq!(
                        dst,
                        pack(&slow_expand(&src, depth, dst_cols)),
                        "{src_cols} cols, depth {depth}, {dst_cols} out"
                    );
                }
            }
        }
    }

    #[test]
    fn dilate_reaches_across_words() {
        let up = [0u64, 0];
        let row = [1u64 << 63, 0];
        let down = [0u64, 1];
        assert_eq!(dilate(&up, &row, &down, 1), 0b11);
        assert_eq!(dilate(&up, &row, &down, 0), 0b11 << 62 | 1 << 63);
        assert_eq!(dilate(&[], &[0, 0], &[], 0), 0);
    }
}
