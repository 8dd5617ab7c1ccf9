//! From the significant coefficients a decode knows back to heights: dequantise each one to
//! the middle of its known interval, undo the band weight, and run the inverse wavelet.
//!
//! One function serves every caller that must agree to the last bit: the decoder, the
//! encoder's per-plane error table, and the max-error cut search (which asks for the heights
//! a decoder would produce at a plane boundary without decoding: there every significant
//! coefficient is known exactly down to that plane, so its magnitude is the true one with
//! the bits below the plane cleared).

use super::quantize;
use super::state::{Known, Plan};
use crate::grid::Grid;
use crate::wavelet::{self, Layout, Wavelet};

/// Integer 5/3 coefficients are kept below this so the inverse lifting cannot overflow i32;
/// a height range under half of it keeps every real coefficient inside.
pub const INT53_LIMIT: f64 = (1u32 << 20) as f64;

/// Per-stream dequantisation constants.
pub struct Dequantiser {
    wavelet: Wavelet,
    /// 9/7: per band, coder units per quantisation step: the step 2^qexp over the band's
    /// weight. 5/3: unused (the plan's shifts weight it).
    scale: Vec<f64>,
}

impl Dequantiser {
    pub fn new(wavelet: Wavelet, layout: &Layout, qexp: i8) -> Self {
        let q = (2f64).powi(i32::from(qexp));
        let scale = match wavelet {
            Wavelet::Cdf97 => quantize::real_weights(Wavelet::Cdf97, layout)
                .iter()
                .map(|w| q / w)
                .collect(),
            Wavelet::LeGall53 => Vec::new(),
        };
        Self { wavelet, scale }
    }

    /// The unweighted coefficients (coder units) of the significant `entries`, the rest zero.
    pub fn coefficients(
        &self,
        plan: &Plan,
        layout: &Layout,
        entries: impl Iterator<Item = Known>,
    ) -> Grid<f64> {
        let mut g = Grid::<f64>::zeros(layout.rows(), layout.cols());
        let data = g.data_mut();
        let signed = |e: &Known, v: f64| if e.neg { -v } else { v };
        match self.wavelet {
            Wavelet::LeGall53 => {
                for e in entries {
                    let s = plan.shifts[usize::from(e.band)];
                    let v = quantize::reconstruct_integer(e.mag, e.known, s);
                    data[e.idx as usize] = signed(&e, v.clamp(-INT53_LIMIT, INT53_LIMIT));
                }
            }
            Wavelet::Cdf97 => {
                for e in entries {
                    let v = quantize::reconstruct(e.mag, e.known) * self.scale[usize::from(e.band)];
                    data[e.idx as usize] = signed(&e, v);
                }
            }
        }
        g
    }

    /// Heights (coder units, offset not added back) from [`Self::coefficients`]' output.
    pub fn heights(&self, coefficients: Grid<f64>, layout: &Layout) -> Grid<f64> {
        match self.wavelet {
            Wavelet::LeGall53 => {
                // Whole numbers within ±2^20: the cast is exact.
                let mut g = coefficients.map(|&v| v as i32);
                wavelet::inverse_int53(&mut g, layout);
                g.map(|&v| f64::from(v))
            }
            Wavelet::Cdf97 => {
                let mut g = coefficients;
                wavelet::inverse(&mut g, Wavelet::Cdf97, layout);
                g
            }
        }
    }
}
