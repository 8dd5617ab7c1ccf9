//! Cohen–Daubechies–Feauveau 9/7 by lifting: two predict/update pairs and a scaling.
//!
//! References: A. Cohen, I. Daubechies and J.-C. Feauveau, "Biorthogonal bases of compactly
//! supported wavelets", Comm. Pure Appl. Math. 45, 1992; I. Daubechies and W. Sweldens,
//! "Factoring wavelet transforms into lifting steps", J. Fourier Anal. Appl. 4(3), 1998 (the
//! factorisation used here); ISO/IEC 15444-1 (JPEG 2000 Part 1), Annex F, the irreversible
//! 9-7 filter (same α, β, γ, δ, K).
//!
//! ```text
//! d += α(s[i] + s[i+1]);  s += β(d[i−1] + d[i]);  d += γ(s[i] + s[i+1]);  s += δ(d[i−1] + d[i])
//! s ← s / K;  d ← d · K
//! ```
//!
//! Scaling: after the four steps a constant v reads s = v·(1 + 2β(1 + 2α)) = K·v and the
//! alternating signal reads d = 2v/K, so dividing s by K and multiplying d by K gives the JPEG
//! 2000 normalisation: low-pass DC gain 1 (a constant grid's LL equals the constant, as with
//! 5/3) and high-pass Nyquist gain 2 (a detail has the same meaning as a 5/3 detail). The
//! bands are therefore not orthonormal; [`super::band_norms`] reports the synthesis gains the
//! coder weights by.

use super::lifting::{predict, scale, update, Scheme};

const ALPHA: f64 = -1.586_134_342_059_924;
const BETA: f64 = -0.052_980_118_572_961;
const GAMMA: f64 = 0.882_911_075_530_934;
const DELTA: f64 = 0.443_506_852_043_971;
const K: f64 = 1.230_174_104_914_001;

/// Real-valued CDF 9/7, the lossy path.
pub(crate) struct Real;

impl Scheme<f64> for Real {
    #[inline]
    fn analyze(&self, s: &mut [f64], d: &mut [f64], w: usize) {
        predict(s, d, w, |x, a, b| x + ALPHA * (a + b));
        update(s, d, w, |x, a, b| x + BETA * (a + b));
        predict(s, d, w, |x, a, b| x + GAMMA * (a + b));
        update(s, d, w, |x, a, b| x + DELTA * (a + b));
        scale(s, 1.0 / K);
        scale(d, K);
    }

    #[inline]
    fn synthesize(&self, s: &mut [f64], d: &mut [f64], w: usize) {
        scale(s, K);
        scale(d, 1.0 / K);
        update(s, d, w, |x, a, b| x - DELTA * (a + b));
        predict(s, d, w, |x, a, b| x - GAMMA * (a + b));
        update(s, d, w, |x, a, b| x - BETA * (a + b));
        predict(s, d, w, |x, a, b| x - ALPHA * (a + b));
    }
}

#[cfg(test)]
mod tests {
    use super::super::{forward, Layout, Orientation, Wavelet};
    use super::*;
    use crate::Grid;

    #[test]
    fn k_is_the_dc_gain_of_the_lifting_steps() {
        assert!((1.0 + 2.0 * BETA * (1.0 + 2.0 * ALPHA) - K).abs() < 1e-12);
    }

    #[test]
    fn nyquist_signal_gives_detail_minus_two_everywhere() {
        // Symmetric extension keeps (−1)^c alternating at both ends, so even the boundary
        // details read exactly the Nyquist gain.
        let data = (0..11 * 11)
            .map(|k| if k % 11 % 2 == 0 { 10.0 } else { -10.0 })
            .collect();
        let mut g = Grid::new(11, 11, data).unwrap();
        let layout = Layout::new(11, 11, 1);
        forward(&mut g, Wavelet::Cdf97, &layout);
        let hl = layout.band(1, Orientation::HL);
        for r in 0..11 {
            for c in 0..11 {
                let want = if r < hl.rows && c >= hl.col0 {
                    -20.0
                } else {
                    0.0
                };
                assert!(
                    (g.get(r, c) - want).abs() < 1e-9,
                    "({r}, {c}): {}",
                    g.get(r, c)
                );
            }
        }
    }

    #[test]
    fn plane_interior_details_vanish_and_boundary_ones_do_not() {
        // The analysis high-pass has four vanishing moments, so a plane's interior details are
        // zero; but symmetric extension folds a ramp into a "V", which the second lifting pair
        // sees within two samples of each end.
        let (rows, cols) = (65, 65);
        let data = (0..rows * cols)
            .map(|k| 3.0 * (k / cols) as f64 - 2.0 * (k % cols) as f64)
            .collect();
        let mut g = Grid::new(rows, cols, data).unwrap();
        let layout = Layout::new(rows, cols, 1);
        forward(&mut g, Wavelet::Cdf97, &layout);
        let hl = layout.band(1, Orientation::HL);
        let mut boundary_max: f64 = 0.0;
        for i in 0..hl.rows {
            for j in 0..hl.cols {
                let v = g.get(hl.row0 + i, hl.col0 + j).abs();
                if (2..hl.cols - 2).contains(&j) {
                    assert!(v < 1e-9, "interior HL({i}, {j}) = {v}");
                } else {
                    boundary_max = boundary_max.max(v);
                }
            }
        }
        assert!(
            boundary_max > 1e-3,
            "boundary details of a ramp should not vanish"
        );
    }
}
