//! Coefficients ↔ the integer magnitudes the bit planes code, with per-subband weights.
//!
//! Bit-plane coding spends bits in order of magnitude, so a coefficient's magnitude must
//! reflect what it does to the heights. Subbands differ by up to ~60× (5/3) and ~130× (9/7)
//! in synthesis L2 energy, so each band is weighted by its synthesis norm (relative to the
//! smallest): then the threshold order is the order of squared-error reduction.
//! The integer 5/3 path weights by a power-of-two shift instead, which keeps it reversible.

use crate::grid::Grid;
use crate::wavelet::{self, band_norms, Layout, Wavelet};

/// Quantisation step of the real-valued path, as a power of two of coder units: fine enough
/// that the last planes reach well below one height step.
const REAL_QEXP: i8 = -4;

/// Per-band weights (scan order) for the real-valued path: synthesis L2 norm over the smallest.
pub fn real_weights(wavelet: Wavelet, layout: &Layout) -> Vec<f64> {
    let norms = band_norms(wavelet, layout);
    let min = norms
        .iter()
        .map(|n| n.l2)
        .filter(|&v| v > 0.0)
        .fold(f64::INFINITY, f64::min);
    norms
        .iter()
        .map(|n| {
            if n.l2 > 0.0 && min.is_finite() {
                n.l2 / min
            } else {
                1.0
            }
        })
        .collect()
}

/// Per-band shifts (scan order) for the integer 5/3 path: log2 of the weight, rounded.
pub fn integer_shifts(layout: &Layout) -> Vec<u8> {
    real_weights(Wavelet::LeGall53, layout)
        .iter()
        .map(|w| w.log2().round().clamp(0.0, 24.0) as u8)
        .collect()
}

/// Reconstruction point inside the known interval [mag, mag + 2^known): its midpoint.
/// Magnitudes stay below 2^63 (the top plane is at most 62), so the signed conversions,
/// one instruction each, are exact wherever the unsigned ones would be.
#[inline]
pub fn reconstruct(mag: u64, known: u8) -> f64 {
    (mag as i64) as f64 + ((1i64 << known) as f64) * 0.5
}

/// The integer 5/3 coefficient of a band weighted by `shift`: the bits below the shift are
/// known zeros, so the midpoint of the rest, unweighted and rounded to an integer (half up).
///
/// In integers: the midpoint is (2·mag + 2^known − 2^shift) / 2, so the coefficient is that
/// numerator over 2^(shift+1), rounded by adding half the divisor. The float form it replaced
/// called libm's `round` once per coefficient (3 % of a 5/3 decode, perf); both agree wherever the
/// float one is exact (below 2^53), which `integer_reconstruction_matches_the_float_form`
/// checks across every plane and shift.
#[inline]
pub fn reconstruct_integer(mag: u64, known: u8, shift: u8) -> f64 {
    let (known, shift) = (u32::from(known.min(63)), u32::from(shift.min(62)));
    let mut twice = u128::from(mag) << 1;
    // `>=` is equivalent: at known == shift the added term is 0. So is `1 << shift` as
    // `1 >> shift` below: magnitudes hold no bits under `known`, so with known > shift the
    // numerator is a multiple of 2^(shift+1) and an extra 2^shift never changes the quotient.
    if known > shift {
        twice += (1u128 << known) - (1u128 << shift);
    }
    let q = (twice + (1u128 << shift)) >> (shift + 1);
    // Below 2^64 always; callers clamp to 2^20. The signed conversion is one instruction.
    i64::try_from(q).unwrap_or(i64::MAX) as f64
}

/// Forward transform and quantisation to weighted integer magnitudes (flat Mallat index),
/// signs and the quantiser exponent.
pub fn forward(
    centered: &Grid<f64>,
    wavelet: Wavelet,
    layout: &Layout,
) -> (Vec<u64>, Vec<bool>, i8) {
    let n = centered.len();
    let mut mags = vec![0u64; n];
    let mut negs = vec![false; n];
    let band_of = band_index(layout);
    match wavelet {
        Wavelet::LeGall53 => {
            let mut g = centered.map(|&u| u.round() as i32);
            wavelet::forward_int53(&mut g, layout);
            let shifts = integer_shifts(layout);
            for (idx, &c) in g.data().iter().enumerate() {
                mags[idx] = u64::from(c.unsigned_abs()) << shifts[band_of[idx] as usize];
                // `c <= 0` is equivalent (and below): a zero coefficient has magnitude 0, is
                // never significant, and its sign is never coded.
                negs[idx] = c < 0;
            }
            (mags, negs, 0)
        }
        Wavelet::Cdf97 => {
            let mut g = centered.clone();
            wavelet::forward(&mut g, Wavelet::Cdf97, layout);
            let weights = real_weights(Wavelet::Cdf97, layout);
            // Keep magnitudes below 2^40 whatever the data's range.
            let peak = g
                .data()
                .iter()
                .enumerate()
                .map(|(i, c)| c.abs() * weights[band_of[i] as usize])
                .fold(0.0, f64::max);
            let mut qexp = REAL_QEXP;
            while peak / (2f64).powi(i32::from(qexp)) >= (1u64 << 40) as f64 && qexp < 30 {
                qexp += 1;
            }
            let q = (2f64).powi(i32::from(qexp));
            for (idx, &c) in g.data().iter().enumerate() {
                mags[idx] = (c.abs() * weights[band_of[idx] as usize] / q) as u64;
                negs[idx] = c < 0.0;
            }
            (mags, negs, qexp)
        }
    }
}

/// Scan-order band index of every coefficient (flat Mallat index).
fn band_index(layout: &Layout) -> Vec<u8> {
    let mut band_of = vec![0u8; layout.rows() * layout.cols()];
    for (bi, b) in layout.bands_coarse_to_fine().iter().enumerate() {
        for i in 0..b.rows {
            let row = (b.row0 + i) * layout.cols() + b.col0;
            band_of[row..row + b.cols].fill(bi as u8);
        }
    }
    band_of
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The float form the integer one replaced.
    fn float_form(mag: u64, known: u8, shift: u8) -> f64 {
        let point = if known <= shift {
            (mag as i64) as f64
        } else {
            (mag as i64) as f64 + ((1i64 << known) - (1i64 << shift)) as f64 * 0.5
        };
        (point / (1i64 << shift) as f64).round()
    }

    #[test]
    fn integer_reconstruction_matches_the_float_form() {
        let mut checked = 0;
        for shift in 0..=24u8 {
            for known in 0..=50u8 {
                // Magnitudes as the decoder holds them: bits at and above `known` only.
                for top in [0u64, 1, 2, 3, 5, 7, 100, 12_345, (1 << 20) - 1] {
                    let mag = top << known;
                    if mag >> known != top || mag >= 1 << 53 {
                        continue;
                    }
                    assert_eq!(
                        reconstruct_integer(mag, known, shift),
                        float_form(mag, known, shift),
                        "mag {mag} known {known} shift {shift}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 5_000, "{checked}");
        // Hostile magnitudes neither panic nor wrap.
        assert!(reconstruct_integer(u64::MAX, 63, 24) > 0.0);
        assert!(reconstruct_integer(u64::MAX, 255, 255) > 0.0);
    }

    /// A coefficient known down to plane k lies in [mag, mag + 2^k): the decoder's point is
    /// the interval's middle, which halves the worst error of taking its low end.
    #[test]
    fn reconstruction_is_the_middle_of_the_known_interval() {
        assert_eq!(reconstruct(8, 3), 12.0);
        assert_eq!(reconstruct(1, 0), 1.5);
        for known in 0..=40u8 {
            for top in [1u64, 2, 3, 1000] {
                let mag = top << known;
                let width = (1u64 << known) as f64;
                assert_eq!(
                    reconstruct(mag, known),
                    mag as f64 + width / 2.0,
                    "{mag} {known}"
                );
            }
        }
    }

    /// Bands are weighted by their synthesis L2 norm over the smallest one, so the lightest
    /// band weighs 1, the LL band (the heaviest norm) the most, and a unit of weighted
    /// magnitude is worth the same height energy in every band; the 5/3 shifts are those
    /// weights' rounded log2.
    #[test]
    fn weights_are_the_synthesis_norms_over_the_smallest() {
        let layout = Layout::full(257, 257);
        for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
            let norms = band_norms(wavelet, &layout);
            let smallest = norms.iter().map(|n| n.l2).fold(f64::INFINITY, f64::min);
            let weights = real_weights(wavelet, &layout);
            for (k, (w, n)) in weights.iter().zip(&norms).enumerate() {
                assert!(
                    (w * smallest - n.l2).abs() <= 1e-12 * n.l2,
                    "{wavelet:?} band {k}"
                );
                assert!(*w >= 1.0 && *w <= weights[0], "{wavelet:?} band {k}: {w}");
            }
            assert!(weights.contains(&1.0) && weights[0] > 10.0, "{wavelet:?}");
        }
        let weights = real_weights(Wavelet::LeGall53, &layout);
        for (s, w) in integer_shifts(&layout).iter().zip(weights) {
            assert_eq!(f64::from(*s), w.log2().round());
        }
    }

    /// A one-row grid's LH and HH bands are empty (norm 0): they weigh 1, and the others are
    /// over the smallest non-zero norm, so no weight is 0 or infinite (the dequantiser
    /// divides by them).
    #[test]
    fn empty_bands_weigh_one_and_do_not_set_the_scale() {
        for (rows, cols) in [(1, 257), (65, 1), (1, 17)] {
            let layout = Layout::full(rows, cols);
            for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
                let norms = band_norms(wavelet, &layout);
                let smallest = norms
                    .iter()
                    .map(|n| n.l2)
                    .filter(|&v| v > 0.0)
                    .fold(f64::INFINITY, f64::min);
                assert!(smallest.is_finite(), "{rows}x{cols}");
                let weights = real_weights(wavelet, &layout);
                let bands = layout.bands_coarse_to_fine();
                assert!(bands.iter().any(|b| b.is_empty()), "{rows}x{cols}");
                for ((w, n), b) in weights.iter().zip(&norms).zip(&bands) {
                    let at = format!("{wavelet:?} {rows}x{cols} {b:?}");
                    if b.is_empty() {
                        assert_eq!(*w, 1.0, "{at}");
                    } else {
                        assert_eq!(*w, n.l2 / smallest, "{at}");
                        assert!(w.is_finite() && *w >= 1.0, "{at}: {w}");
                    }
                }
            }
        }
    }

    /// The 9/7 quantiser steps 2^qexp from 2^-4 up, to the first one that keeps every
    /// weighted magnitude below 2^40: so above 2^-4 the largest is at least 2^39. It stops at
    /// 2^30, the largest exponent a stream may hold (the reader refuses 31).
    #[test]
    fn real_magnitudes_stay_below_2_40_with_the_finest_step() {
        let layout = Layout::full(33, 17);
        let bump = Grid::new(
            33,
            17,
            (0..33 * 17)
                .map(|k| (((k * 37) % 101) as f64 - 50.0) / 50.0)
                .collect(),
        )
        .unwrap();
        let mut seen = Vec::new();
        for scale in [1.0, 1e3, 1e9, 1e11, 3e12, 1e15, 1e17] {
            let g = bump.map(|&v| v * scale);
            let (mags, negs, qexp) = forward(&g, Wavelet::Cdf97, &layout);
            let max = mags.iter().copied().max().unwrap();
            let at = format!("scale {scale}: qexp {qexp}, max {max}");
            assert!((-4..=30).contains(&qexp), "{at}");
            assert!(max < 1 << 40, "{at}");
            if qexp > -4 {
                assert!(max >= 1 << 39, "{at}");
            }
            // Signs: a coefficient that codes anything has one, half of them negative here.
            assert!(mags.iter().zip(&negs).any(|(&m, &n)| m > 0 && n), "{at}");
            assert!(mags.iter().zip(&negs).any(|(&m, &n)| m > 0 && !n), "{at}");
            seen.push(qexp);
        }
        assert_eq!(seen[0], -4);
        assert!(seen.windows(2).all(|w| w[0] <= w[1]), "{seen:?}");
        assert!(seen.iter().any(|&q| q > -4 && q < 30), "{seen:?}");
        // Past 2^70 the exponent stays at 30 and the magnitudes grow past 2^40 instead.
        let (mags, _, qexp) = forward(&bump.map(|&v| v * 1e24), Wavelet::Cdf97, &layout);
        assert_eq!(qexp, 30);
        assert!(mags.iter().any(|&m| m >= 1 << 40));
    }
}
