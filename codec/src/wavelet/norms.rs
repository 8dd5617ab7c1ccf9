//! Synthesis gains of each subband: how much one unit of a coefficient moves the heights.
//!
//! References: I. Daubechies and W. Sweldens, "Factoring wavelet transforms into lifting
//! steps", 1998; ISO/IEC 15444-1 (JPEG 2000 Part 1), Annex F (the filters); D. Taubman and
//! M. Marcellin, "JPEG2000: Image Compression Fundamentals, Standards and Practice", 2002
//! (subband synthesis energy gains as rate–distortion weights).
//!
//! A biorthogonal transform is not orthonormal, so a coefficient's magnitude does not say how
//! much it matters: the coder weights each band by the norm of its synthesis basis function
//! (the inverse transform of a unit impulse in it). The L2 norm orders squared error; the L∞
//! norm bounds the largest height error a coefficient error can cause.
//!
//! The basis function of a coefficient in the Mallat layout is separable: each level's inverse
//! is (columns ⊗ rows) on a rectangle that contains the impulse's whole support from the
//! impulse's own level on, so the 2-D response is the outer product of two 1-D responses,
//! each undoing only the levels from the band's level down to 1. That makes a norm cost two
//! 1-D inverses instead of one 2-D inverse (the test compares both), and the bands of one
//! level share them.

use super::lifting::{inverse_line, Scheme};
use super::{cdf97, legall53, Layout, Orientation, Wavelet};

/// Synthesis gain of one subband: norms of the inverse transform of a unit impulse placed at
/// the band's middle coefficient (`row0 + rows/2`, `col0 + cols/2`). Both are 0 for an empty
/// band (a 1-row grid has no LH/HH).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandNorm {
    /// Root of the sum of squared heights: the squared-error weight is `l2²`.
    pub l2: f64,
    /// Largest |height|: the worst-case error from a unit coefficient error.
    pub linf: f64,
}

impl BandNorm {
    /// An empty band, or an impulse outside the signal: moves nothing.
    const ZERO: BandNorm = BandNorm { l2: 0.0, linf: 0.0 };
}

/// One [`BandNorm`] per band of `layout`, in [`Layout::bands_coarse_to_fine`] order.
///
/// The integer 5/3 shares the real 5/3 norms (its rounding is not linear, but its gains are
/// the real filter's). Cost: two short 1-D inverses per level and axis, tens of microseconds
/// for 257 × 257, so callers need not cache it.
pub fn band_norms(wavelet: Wavelet, layout: &Layout) -> Vec<BandNorm> {
    match wavelet {
        Wavelet::LeGall53 => norms_with(&legall53::Real, layout),
        Wavelet::Cdf97 => norms_with(&cdf97::Real, layout),
    }
}

fn norms_with<S: Scheme<f64>>(scheme: &S, layout: &Layout) -> Vec<BandNorm> {
    // The two 1-D factors per level and axis; a square layout shares one axis table.
    let rows = Axis::new(scheme, layout.levels(), |l| layout.low_rows(l));
    let cols = (layout.cols() != layout.rows())
        .then(|| Axis::new(scheme, layout.levels(), |l| layout.low_cols(l)));
    let cols = cols.as_ref().unwrap_or(&rows);
    layout
        .bands_coarse_to_fine()
        .iter()
        .map(|band| {
            if band.is_empty() {
                return BandNorm::ZERO;
            }
            let m = band.level;
            let (v, h) = match band.orientation {
                None => (rows.low[m], cols.low[m]),
                Some(Orientation::HL) => (rows.low[m], cols.high[m]),
                Some(Orientation::LH) => (rows.high[m], cols.low[m]),
                Some(Orientation::HH) => (rows.high[m], cols.high[m]),
            };
            BandNorm {
                l2: v.l2 * h.l2,
                linf: v.linf * h.linf,
            }
        })
        .collect()
}

/// Norms of the 1-D synthesis responses along one axis, indexed by level: `low[m]` for the
/// middle low-pass sample after `m` levels (`m = 0..=levels`), `high[m]` for the middle
/// high-pass sample of level `m` (`high[0]` unused). The middle matches [`BandNorm`]'s
/// (`row0 + rows/2` of the band), so every band of the layout is a product of two entries.
struct Axis {
    low: Vec<BandNorm>,
    high: Vec<BandNorm>,
}

impl Axis {
    fn new<S: Scheme<f64>>(scheme: &S, levels: usize, low: impl Fn(usize) -> usize) -> Self {
        let len = low(0);
        let mut line = vec![0.0; len];
        let mut scratch = vec![0.0; len];
        let mut response = |pos: usize, level: usize| {
            if pos >= len {
                return BandNorm::ZERO;
            }
            line.fill(0.0);
            line[pos] = 1.0;
            // Undo only the levels from the impulse's own level down to the finest.
            inverse_line(
                &mut line,
                &mut scratch,
                (1..=level).rev().map(|l| low(l - 1)),
                scheme,
            );
            BandNorm {
                l2: line.iter().map(|v| v * v).sum::<f64>().sqrt(),
                linf: line.iter().fold(0.0, |m, v| v.abs().max(m)),
            }
        };
        let low_norms = (0..=levels).map(|m| response(low(m) / 2, m)).collect();
        let high_norms = (0..=levels)
            .map(|m| {
                if m == 0 {
                    BandNorm::ZERO
                } else {
                    response(low(m) + (low(m - 1) - low(m)) / 2, m)
                }
            })
            .collect();
        Self {
            low: low_norms,
            high: high_norms,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::inverse;
    use super::*;
    use crate::Grid;

    /// The definition, evaluated the slow way: a full 2-D inverse per band.
    fn brute_force(wavelet: Wavelet, layout: &Layout) -> Vec<BandNorm> {
        layout
            .bands_coarse_to_fine()
            .iter()
            .map(|b| {
                if b.is_empty() {
                    return BandNorm::ZERO;
                }
                let mut g = Grid::zeros(layout.rows(), layout.cols());
                *g.get_mut(b.row0 + b.rows / 2, b.col0 + b.cols / 2) = 1.0;
                inverse(&mut g, wavelet, layout);
                BandNorm {
                    l2: g.data().iter().map(|v| v * v).sum::<f64>().sqrt(),
                    linf: g.data().iter().fold(0.0, |m: f64, v| m.max(v.abs())),
                }
            })
            .collect()
    }

    #[test]
    fn separable_norms_equal_the_full_2d_impulse_response() {
        let layouts = [
            Layout::full(257, 257),
            Layout::full(300, 17),
            Layout::new(33, 65, 3),
            Layout::full(1, 40),
            Layout::full(2, 3),
            Layout::new(9, 9, 0),
        ];
        for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
            for layout in &layouts {
                let fast = band_norms(wavelet, layout);
                let slow = brute_force(wavelet, layout);
                assert_eq!(fast.len(), slow.len());
                for (k, (f, s)) in fast.iter().zip(&slow).enumerate() {
                    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.max(1.0);
                    assert!(
                        close(f.l2, s.l2) && close(f.linf, s.linf),
                        "{wavelet:?} {layout:?} band {k}: {f:?} vs {s:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn finest_53_bands_match_the_hand_derived_filters() {
        // 1-D synthesis filters of real 5/3 (undo update, then predict):
        //   low  [1/2, 1, 1/2]                      ‖·‖₂² = 3/2,   ‖·‖∞ = 1
        //   high [−1/8, −1/4, 3/4, −1/4, −1/8]      ‖·‖₂² = 46/64, ‖·‖∞ = 3/4
        // so HH1 = high ⊗ high: l2 = 46/64, linf = 9/16; HL1 = LH1 = low ⊗ high.
        let layout = Layout::full(257, 257);
        let norms = band_norms(Wavelet::LeGall53, &layout);
        let hh1 = norms[norms.len() - 1];
        let lh1 = norms[norms.len() - 2];
        let hl1 = norms[norms.len() - 3];
        assert!((hh1.l2 - 46.0 / 64.0).abs() < 1e-12, "{hh1:?}");
        assert!((hh1.linf - 9.0 / 16.0).abs() < 1e-12, "{hh1:?}");
        for b in [hl1, lh1] {
            assert!(
                (b.l2 - (1.5_f64 * 46.0 / 64.0).sqrt()).abs() < 1e-12,
                "{b:?}"
            );
            assert!((b.linf - 0.75).abs() < 1e-12, "{b:?}");
        }
    }

    #[test]
    fn norms_grow_toward_coarser_levels() {
        let layout = Layout::full(257, 257);
        for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
            let norms = band_norms(wavelet, &layout);
            let bands = layout.bands_coarse_to_fine();
            for o in Orientation::ALL {
                let by_level: Vec<f64> = (1..=layout.levels())
                    .map(|l| {
                        norms[bands
                            .iter()
                            .position(|b| b.level == l && b.orientation == Some(o))
                            .unwrap()]
                        .l2
                    })
                    .collect();
                assert!(
                    by_level.windows(2).all(|w| w[1] > w[0]),
                    "{wavelet:?} {o:?}: {by_level:?}"
                );
            }
            assert!(
                norms[0].l2 > norms[1..].iter().map(|n| n.l2).fold(0.0, f64::max),
                "{wavelet:?}: LL is the heaviest"
            );
        }
    }

    /// The table reported for 257 × 257 (`cargo test … print_band_norms -- --nocapture`).
    #[test]
    fn print_band_norms_257() {
        let layout = Layout::full(257, 257);
        let bands = layout.bands_coarse_to_fine();
        for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
            println!("{} 257×257, {} levels", wavelet.name(), layout.levels());
            println!(
                "{:>5} {:>5} {:>9} {:>12} {:>12}",
                "level", "band", "size", "l2", "linf"
            );
            for (b, n) in bands.iter().zip(band_norms(wavelet, &layout)) {
                let name = b.orientation.map_or("LL".to_string(), |o| format!("{o:?}"));
                println!(
                    "{:>5} {:>5} {:>9} {:>12.6} {:>12.6}",
                    b.level,
                    name,
                    format!("{}×{}", b.rows, b.cols),
                    n.l2,
                    n.linf
                );
            }
        }
    }
}
