//! Coefficients ↔ the integer magnitudes the bit planes code, with per-subband weights.
//!
//! Bit-plane coding spends bits in order of magnitude, so a coefficient's magnitude must
//! reflect what it does to the heights. Subbands differ by up to ~60× (5/3) and ~130× (9/7)
//! in synthesis L2 energy, so each band is weighted by its synthesis norm (relative to the
//! smallest): then the threshold order is the order of squared-error reduction.
//! The integer 5/3 path weights by a power-of-two shift instead, which keeps it reversible.

use crate::wavelet::{band_norms, Layout, Wavelet};

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

/// Reconstruction point inside the known interval [mag, mag + 2^known): its midpoint, except
/// on integer bands (`shift` ≥ 0) where bits below the shift are known zeros.
#[inline]
pub fn reconstruct(mag: u64, known: u8, shift: Option<u8>) -> f64 {
    let width = (1u64 << known) as f64;
    match shift {
        Some(s) if known <= s => mag as f64,
        Some(s) => mag as f64 + (width - (1u64 << s) as f64) / 2.0,
        None => mag as f64 + width / 2.0,
    }
}
