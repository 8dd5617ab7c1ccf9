//! LeGall 5/3 by lifting: one predict (linear interpolation) and one update step.
//!
//! References: D. Le Gall and A. Tabatabai, "Sub-band coding of digital images using symmetric
//! short kernel filters and arithmetic coding techniques", ICASSP 1988; I. Daubechies and
//! W. Sweldens, "Factoring wavelet transforms into lifting steps", 1998; ISO/IEC 15444-1
//! (JPEG 2000 Part 1), Annex F, the reversible 5-3 filter:
//!
//! ```text
//! d[i] = x[2i+1] − ⌊(x[2i] + x[2i+2]) / 2⌋
//! s[i] = x[2i]   + ⌊(d[i−1] + d[i] + 2) / 4⌋
//! ```
//!
//! The predict is linear interpolation, so a detail says how far the surface leaves the
//! bilinear patch of its cell (DESIGN §2.2). Gains: low-pass 1 at DC, high-pass 2 at Nyquist.
//!
//! The integer form wraps on i32 overflow instead of panicking: forward and inverse evaluate
//! the same rounding function of the same values, so the round trip stays exact for every
//! input (a corrupt stream can hand the inverse anything; it gets garbage heights, never a
//! panic). The coefficients are JPEG 2000's while no sum overflows: the 2-D analysis gain of
//! 5/3 is at most ≈ 8.1 (L1 norm of any coefficient's analysis filter, 257², any level
//! count), so samples within ±2^26 are safe and the codec's ±2^20 has 64× headroom.

use super::lifting::{predict, update, Scheme};

/// Reversible integer 5/3 (floor rounding), the lossless path.
pub(crate) struct Integer;

impl Scheme<i32> for Integer {
    #[inline]
    fn analyze(&self, s: &mut [i32], d: &mut [i32], w: usize) {
        predict(s, d, w, |x, a, b| x.wrapping_sub(a.wrapping_add(b) >> 1));
        update(s, d, w, |x, a, b| {
            x.wrapping_add(a.wrapping_add(b).wrapping_add(2) >> 2)
        });
    }

    #[inline]
    fn synthesize(&self, s: &mut [i32], d: &mut [i32], w: usize) {
        update(s, d, w, |x, a, b| {
            x.wrapping_sub(a.wrapping_add(b).wrapping_add(2) >> 2)
        });
        predict(s, d, w, |x, a, b| x.wrapping_add(a.wrapping_add(b) >> 1));
    }
}

/// Real-valued 5/3: the same steps without rounding, for lossy coding on the 5/3 basis.
pub(crate) struct Real;

impl Scheme<f64> for Real {
    #[inline]
    fn analyze(&self, s: &mut [f64], d: &mut [f64], w: usize) {
        predict(s, d, w, |x, a, b| x - 0.5 * (a + b));
        update(s, d, w, |x, a, b| x + 0.25 * (a + b));
    }

    #[inline]
    fn synthesize(&self, s: &mut [f64], d: &mut [f64], w: usize) {
        update(s, d, w, |x, a, b| x - 0.25 * (a + b));
        predict(s, d, w, |x, a, b| x + 0.5 * (a + b));
    }
}

#[cfg(test)]
mod tests {
    use super::super::testutil::{grid_i32, Rng};
    use super::super::{forward, forward_int53, inverse_int53, Layout, Orientation, Wavelet};
    use crate::Grid;

    fn plane(rows: usize, cols: usize, a: i32, b: i32, c0: i32) -> Grid<i32> {
        let data = (0..rows * cols)
            .map(|k| a * (k / cols) as i32 + b * (k % cols) as i32 + c0)
            .collect();
        Grid::new(rows, cols, data).unwrap()
    }

    fn detail_values(g: &Grid<i32>, layout: &Layout) -> Vec<(usize, usize, i32)> {
        let mut out = Vec::new();
        for level in 1..=layout.levels() {
            for o in Orientation::ALL {
                let band = layout.band(level, o);
                for i in 0..band.rows {
                    for j in 0..band.cols {
                        let v = *g.get(band.row0 + i, band.col0 + j);
                        if v != 0 {
                            out.push((band.row0 + i, band.col0 + j, v));
                        }
                    }
                }
            }
        }
        out
    }

    #[test]
    fn hand_computed_one_dimensional_example() {
        // x = [1, 5, 2, 8, 3]: d0 = 5 − ⌊3/2⌋ = 4, d1 = 8 − ⌊5/2⌋ = 6;
        // s0 = 1 + ⌊(4+4+2)/4⌋ = 3, s1 = 2 + ⌊(4+6+2)/4⌋ = 5, s2 = 3 + ⌊(6+6+2)/4⌋ = 6.
        let mut g = Grid::new(1, 5, vec![1, 5, 2, 8, 3]).unwrap();
        let layout = Layout::new(1, 5, 1);
        forward_int53(&mut g, &layout);
        assert_eq!(g.data(), &[3, 5, 6, 4, 6]);
        inverse_int53(&mut g, &layout);
        assert_eq!(g.data(), &[1, 5, 2, 8, 3]);
    }

    #[test]
    fn plane_on_a_two_to_the_n_plus_one_tile_leaves_only_the_corners() {
        // Every level of 257 has odd length (257, 129, …, 3), so no predict ever reaches past
        // the boundary and linear interpolation reproduces the plane: every detail is zero
        // and the 2×2 LL is the plane at the four corners.
        let (a, b, c0) = (7, -3, 1000);
        let mut g = plane(257, 257, a, b, c0);
        let layout = Layout::full(257, 257);
        forward_int53(&mut g, &layout);
        assert_eq!(detail_values(&g, &layout), vec![]);
        let corner = |r: i32, c: i32| a * r + b * c + c0;
        assert_eq!(g.data()[..2], [corner(0, 0), corner(0, 256)]);
        assert_eq!(g.row(1)[..2], [corner(256, 0), corner(256, 256)]);
    }

    #[test]
    fn plane_on_an_even_side_leaves_details_only_on_the_far_boundary() {
        // With an even length the last odd sample's right neighbour mirrors (x[n] = x[n−2]), so
        // interpolation sees a fold, not the plane: after one level the only non-zero details
        // sit in the last column of HL/HH and the last row of LH/HH.
        let mut g = plane(64, 96, 5, 2, -40);
        let layout = Layout::new(64, 96, 1);
        forward_int53(&mut g, &layout);
        let nonzero = detail_values(&g, &layout);
        assert!(!nonzero.is_empty());
        for (r, c, v) in nonzero {
            assert!(r == 63 || c == 95, "interior detail {v} at ({r}, {c})");
        }
    }

    #[test]
    fn real_53_reproduces_a_plane_exactly_like_the_integer_one() {
        let g = plane(129, 65, 3, 11, 7);
        let layout = Layout::full(129, 65);
        let mut int = g.clone();
        forward_int53(&mut int, &layout);
        let mut real = g.map(|&v| f64::from(v));
        forward(&mut real, Wavelet::LeGall53, &layout);
        assert_eq!(real, int.map(|&v| f64::from(v)));
    }

    #[test]
    fn mallat_placement_low_pass_of_a_plane_is_the_plane_at_even_samples() {
        // Pins the layout: LL(i, j) is sample (2i, 2j); HL/LH/HH hold the odd positions.
        let f = |r: usize, c: usize| (r * 1000 + c) as i32;
        let data = (0..257 * 257).map(|k| f(k / 257, k % 257)).collect();
        let mut g = Grid::new(257, 257, data).unwrap();
        let layout = Layout::new(257, 257, 1);
        forward_int53(&mut g, &layout);
        let ll = layout.ll();
        assert_eq!((ll.rows, ll.cols), (129, 129));
        for i in 0..ll.rows {
            for j in 0..ll.cols {
                assert_eq!(*g.get(i, j), f(2 * i, 2 * j), "LL({i}, {j})");
            }
        }
        assert_eq!(detail_values(&g, &layout), vec![]);
    }

    #[test]
    fn nyquist_row_gives_detail_minus_two_and_zero_low_pass() {
        // x = v·(−1)^c: every odd sample departs by −2v from its neighbours' mean.
        let data = (0..9 * 9)
            .map(|k| if k % 9 % 2 == 0 { 10 } else { -10 })
            .collect();
        let mut g = Grid::new(9, 9, data).unwrap();
        let layout = Layout::new(9, 9, 1);
        forward_int53(&mut g, &layout);
        let hl = layout.band(1, Orientation::HL);
        for r in 0..9 {
            for c in 0..9 {
                let in_hl = r < hl.rows && c >= hl.col0;
                // Low-pass: 10 + ⌊(−20 − 20 + 2) / 4⌋ = 0; columns are constant, so LH = HH = 0.
                let want = if in_hl { -20 } else { 0 };
                assert_eq!(*g.get(r, c), want, "({r}, {c})");
            }
        }
    }

    #[test]
    fn overflowing_coefficients_still_round_trip_without_panicking() {
        let mut rng = Rng(99);
        let data = (0..33 * 17).map(|_| rng.next() as i32).collect();
        let original = Grid::new(33, 17, data).unwrap();
        let layout = Layout::full(33, 17);
        let mut g = original.clone();
        inverse_int53(&mut g, &layout);
        forward_int53(&mut g, &layout);
        assert_eq!(g, original);
        let mut g = grid_i32(33, 17, i32::MAX, 5);
        let before = g.clone();
        forward_int53(&mut g, &layout);
        inverse_int53(&mut g, &layout);
        assert_eq!(g, before);
    }
}
