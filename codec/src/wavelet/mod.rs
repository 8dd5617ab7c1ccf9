//! Separable 2-D biorthogonal wavelet transforms by lifting, on grids of any size, laid out in
//! the Mallat layout of [`subbands`].
//!
//! References: I. Daubechies and W. Sweldens, "Factoring wavelet transforms into lifting
//! steps", J. Fourier Anal. Appl. 4(3), 1998; ISO/IEC 15444-1 (JPEG 2000 Part 1), Annex F.
//!
//! - [`forward_int53`] / [`inverse_int53`]: reversible integer LeGall 5/3, the lossless mode.
//! - [`forward`] / [`inverse`]: real 5/3 or CDF 9/7, for lossy coding.
//! - [`band_norms`]: each band's synthesis gain, so the coder can weight bands.
//!
//! Per level the rows of the current low-pass rectangle are transformed, then its columns;
//! even samples become low-pass, odd samples high-pass, low part first, so a (2^n + 1) side
//! keeps both end samples in the low-pass at every level. Boundaries use whole-sample
//! symmetric extension; a side of length 1 is left alone. Both wavelets are normalised alike:
//! low-pass DC gain 1 (a constant grid's LL is the constant) and high-pass Nyquist gain 2.
//! Each transform takes the [`Layout`] of its grid's shape; a mismatch is a broken contract
//! (a debug assertion; release builds leave the grid untouched).
//!
//! ```
//! use zerotile_codec::wavelet::{self, Layout, Wavelet};
//! use zerotile_codec::Grid;
//!
//! let heights = Grid::new(3, 3, vec![10, 12, 14, 11, 13, 15, 12, 14, 16]).unwrap();
//! let layout = Layout::full(3, 3);
//! let mut coefficients = heights.clone();
//! wavelet::forward_int53(&mut coefficients, &layout);
//! assert_eq!(coefficients.data(), &[10, 14, 0, 12, 16, 0, 0, 0, 0]); // a plane: corners only
//! wavelet::inverse_int53(&mut coefficients, &layout);
//! assert_eq!(coefficients, heights);
//! assert_eq!("9/7".parse::<Wavelet>(), Ok(Wavelet::Cdf97));
//! ```

pub mod subbands;

mod cdf97;
mod legall53;
mod lifting;
mod norms;

use std::fmt;
use std::str::FromStr;

pub use norms::{band_norms, BandNorm};
pub use subbands::{Band, Layout, Orientation};

use crate::error::ParamError;
use crate::Grid;

/// Which biorthogonal wavelet a stream or a transform uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Wavelet {
    /// LeGall 5/3: short, reversible in integers (lossless mode), predict = linear interpolation.
    LeGall53,
    /// CDF 9/7: smoother basis, better lossy rate–distortion.
    Cdf97,
}

impl Wavelet {
    /// Stable lowercase name (also the serde form).
    pub fn name(self) -> &'static str {
        match self {
            Wavelet::LeGall53 => "legall53",
            Wavelet::Cdf97 => "cdf97",
        }
    }

    /// Stream id. Numbered as JPEG 2000's COD marker numbers its transforms
    /// (0 = 9-7 irreversible, 1 = 5-3 reversible); never renumber, streams store it.
    pub fn id(self) -> u8 {
        match self {
            Wavelet::Cdf97 => 0,
            Wavelet::LeGall53 => 1,
        }
    }

    /// Inverse of [`Wavelet::id`]; `None` for an id no version has written.
    pub fn from_id(id: u8) -> Option<Self> {
        match id {
            0 => Some(Wavelet::Cdf97),
            1 => Some(Wavelet::LeGall53),
            _ => None,
        }
    }
}

impl fmt::Display for Wavelet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Wavelet {
    type Err = ParamError;

    /// Accepts `53`, `5/3`, `legall53`, `97`, `9/7`, `cdf97` (ASCII case-insensitive).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "53" | "5/3" | "legall53" => Ok(Wavelet::LeGall53),
            "97" | "9/7" | "cdf97" => Ok(Wavelet::Cdf97),
            _ => Err(ParamError::OutOfRange {
                name: "wavelet",
                expected: "one of 53, 5/3, legall53, 97, 9/7, cdf97",
                got: s.to_string(),
            }),
        }
    }
}

/// Reversible integer LeGall 5/3 (JPEG 2000 reversible filter with floor rounding), in place
/// over `layout.levels()` levels. Exact round trip with [`inverse_int53`] for every input: the
/// arithmetic wraps rather than overflows, so the coefficients are JPEG 2000's as long as the
/// intermediate sums fit in i32 (see `legall53` for the headroom).
pub fn forward_int53(grid: &mut Grid<i32>, layout: &Layout) {
    lifting::forward_2d(grid, layout, &legall53::Integer);
}

/// Exact inverse of [`forward_int53`].
pub fn inverse_int53(grid: &mut Grid<i32>, layout: &Layout) {
    lifting::inverse_2d(grid, layout, &legall53::Integer);
}

/// Real-valued transform in place: 5/3 without rounding, or CDF 9/7.
pub fn forward(grid: &mut Grid<f64>, wavelet: Wavelet, layout: &Layout) {
    match wavelet {
        Wavelet::LeGall53 => lifting::forward_2d(grid, layout, &legall53::Real),
        Wavelet::Cdf97 => lifting::forward_2d(grid, layout, &cdf97::Real),
    }
}

/// Inverse of [`forward`] (exact up to floating-point rounding).
pub fn inverse(grid: &mut Grid<f64>, wavelet: Wavelet, layout: &Layout) {
    match wavelet {
        Wavelet::LeGall53 => lifting::inverse_2d(grid, layout, &legall53::Real),
        Wavelet::Cdf97 => lifting::inverse_2d(grid, layout, &cdf97::Real),
    }
}

/// One level of the real 5/3 analysis of one line in place, exactly as [`forward`]'s row
/// pass runs it: the line becomes `[low | high]`. `scratch` is at least as long as `line`; a
/// line under 2 samples is left alone (as [`forward`] leaves it).
///
/// With [`analyze_53_split`], what lets `pyramid` keep only a level's low-pass without a
/// padded copy of the whole level or a scratch as large.
pub(crate) fn analyze_53_line(line: &mut [f64], scratch: &mut [f64]) {
    let n = line.len();
    if n >= 2 && scratch.len() >= n {
        lifting::analyze_row(line, &mut scratch[..n], &legall53::Real);
    }
}

/// One level of the real 5/3 analysis of `w` columns at once, exactly as [`forward`]'s column
/// pass runs it: `s` holds the even rows and `d` the odd ones, `w` values each (`s.len() ==
/// ns·w`, `d.len() == nd·w`, `nd ≥ 1`, `ns ∈ {nd, nd + 1}`); afterwards `s` is the low-pass.
/// Columns never mix, so any subset of a grid's columns lifts to the same values.
pub(crate) fn analyze_53_split(s: &mut [f64], d: &mut [f64], w: usize) {
    use lifting::Scheme as _;
    legall53::Real.analyze(s, d, w);
}

/// Deterministic test data without a `rand` dependency.
#[cfg(test)]
pub(crate) mod testutil {
    use crate::Grid;

    /// SplitMix64.
    pub struct Rng(pub u64);

    impl Rng {
        pub fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }

        /// Uniform in [−amp, amp].
        pub fn int(&mut self, amp: i32) -> i32 {
            let span = 2 * i64::from(amp) + 1;
            ((self.next() % span as u64) as i64 - i64::from(amp)) as i32
        }

        /// Uniform in [−amp, amp).
        pub fn real(&mut self, amp: f64) -> f64 {
            ((self.next() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * amp
        }
    }

    pub fn grid_i32(rows: usize, cols: usize, amp: i32, seed: u64) -> Grid<i32> {
        let mut rng = Rng(seed);
        Grid::new(rows, cols, (0..rows * cols).map(|_| rng.int(amp)).collect()).unwrap()
    }

    pub fn grid_f64(rows: usize, cols: usize, amp: f64, seed: u64) -> Grid<f64> {
        let mut rng = Rng(seed);
        Grid::new(
            rows,
            cols,
            (0..rows * cols).map(|_| rng.real(amp)).collect(),
        )
        .unwrap()
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::testutil::{grid_f64, grid_i32};
    use super::*;

    const MAX_SIDE: usize = 300;
    const INT_AMP: i32 = 1 << 20;
    const REAL_AMP: f64 = 5000.0;
    const REAL_TOLERANCE: f64 = 1e-3;

    /// Every side 1..=300 as a square, a single row and a single column: every 1-D length
    /// meets both passes at every level it reaches.
    fn sweep_shapes() -> impl Iterator<Item = (usize, usize)> {
        (1..=MAX_SIDE).flat_map(|n| [(n, n), (1, n), (n, 1)])
    }

    fn int_round_trip(rows: usize, cols: usize, levels: usize, seed: u64) {
        let original = grid_i32(rows, cols, INT_AMP, seed);
        let layout = Layout::new(rows, cols, levels);
        let mut g = original.clone();
        forward_int53(&mut g, &layout);
        inverse_int53(&mut g, &layout);
        assert!(
            g == original,
            "int 5/3 {rows}×{cols}, {} levels: round trip not exact",
            layout.levels()
        );
    }

    fn real_round_trip_error(
        rows: usize,
        cols: usize,
        levels: usize,
        wavelet: Wavelet,
        seed: u64,
    ) -> f64 {
        let original = grid_f64(rows, cols, REAL_AMP, seed);
        let layout = Layout::new(rows, cols, levels);
        let mut g = original.clone();
        forward(&mut g, wavelet, &layout);
        inverse(&mut g, wavelet, &layout);
        g.data()
            .iter()
            .zip(original.data())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn int53_round_trip_is_exact_on_every_side_up_to_300() {
        for (k, (rows, cols)) in sweep_shapes().enumerate() {
            int_round_trip(rows, cols, subbands::MAX_LEVELS, k as u64);
        }
    }

    #[test]
    fn int53_round_trip_is_exact_with_partial_levels() {
        for (rows, cols) in [(257, 257), (300, 299), (2, 300), (129, 7), (5, 1)] {
            for levels in 0..=4 {
                int_round_trip(rows, cols, levels, (rows * 1000 + levels) as u64);
            }
        }
    }

    #[test]
    fn int53_round_trip_is_exact_on_a_real_tile() {
        let original = crate::fixtures::n44w072_crop(300, 500, 257).map(|&h| h as i32);
        let layout = Layout::full(257, 257);
        let mut g = original.clone();
        forward_int53(&mut g, &layout);
        // A real tile compacts its energy: outside the 2×2 LL the coefficients are a small
        // fraction of the heights (the identity would leave them all there).
        let ll = layout.ll();
        let detail: f64 = (0..257 * 257)
            .filter(|k| !(k / 257 < ll.rows && k % 257 < ll.cols))
            .map(|k| f64::from(g.data()[k]).abs())
            .sum();
        let heights: f64 = original.data().iter().map(|&h| f64::from(h).abs()).sum();
        assert!(
            detail < 0.05 * heights,
            "details hold {detail} of {heights}"
        );
        inverse_int53(&mut g, &layout);
        assert_eq!(g, original);
    }

    #[test]
    fn real_round_trips_stay_within_tolerance_on_every_side_up_to_300() {
        for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
            let mut worst: f64 = 0.0;
            for (k, (rows, cols)) in sweep_shapes().enumerate() {
                let err =
                    real_round_trip_error(rows, cols, subbands::MAX_LEVELS, wavelet, k as u64);
                assert!(
                    err < REAL_TOLERANCE,
                    "{wavelet:?} {rows}×{cols}: max error {err}"
                );
                worst = worst.max(err);
            }
            println!("{wavelet:?}: worst round-trip error over the sweep {worst:e}");
        }
    }

    #[test]
    fn real_round_trips_with_partial_levels() {
        for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
            for (rows, cols) in [(257, 257), (300, 299), (2, 300), (129, 7)] {
                for levels in 0..=4 {
                    let err = real_round_trip_error(rows, cols, levels, wavelet, levels as u64);
                    assert!(
                        err < REAL_TOLERANCE,
                        "{wavelet:?} {rows}×{cols} {levels} levels: {err}"
                    );
                }
            }
        }
    }

    #[test]
    fn constant_grid_has_zero_details_and_ll_equal_to_the_constant() {
        for (rows, cols) in [(257, 257), (256, 300), (1, 77), (13, 1), (2, 2), (1, 1)] {
            let layout = Layout::full(rows, cols);
            let ll = layout.ll();
            let in_ll = |r: usize, c: usize| r < ll.rows && c < ll.cols;

            let mut g = Grid::new(rows, cols, vec![-1234; rows * cols]).unwrap();
            forward_int53(&mut g, &layout);
            for r in 0..rows {
                for c in 0..cols {
                    assert_eq!(
                        *g.get(r, c),
                        if in_ll(r, c) { -1234 } else { 0 },
                        "int 5/3 {rows}×{cols} ({r}, {c})"
                    );
                }
            }

            for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
                let mut g = Grid::new(rows, cols, vec![812.625; rows * cols]).unwrap();
                forward(&mut g, wavelet, &layout);
                for r in 0..rows {
                    for c in 0..cols {
                        let want = if in_ll(r, c) { 812.625 } else { 0.0 };
                        assert!(
                            (g.get(r, c) - want).abs() < 1e-9,
                            "{wavelet:?} {rows}×{cols} ({r}, {c}): {}",
                            g.get(r, c)
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn empty_grids_are_left_alone() {
        for (rows, cols) in [(0, 0), (0, 5), (5, 0)] {
            let layout = Layout::full(rows, cols);
            let mut g = Grid::<i32>::zeros(rows, cols);
            forward_int53(&mut g, &layout);
            inverse_int53(&mut g, &layout);
            let mut g = Grid::<f64>::zeros(rows, cols);
            forward(&mut g, Wavelet::Cdf97, &layout);
            inverse(&mut g, Wavelet::LeGall53, &layout);
            assert!(g.is_empty());
            assert!(band_norms(Wavelet::Cdf97, &layout)
                .iter()
                .all(|n| n.l2 == 0.0));
        }
    }

    #[test]
    fn zero_levels_is_the_identity() {
        let original = grid_f64(17, 9, REAL_AMP, 3);
        let mut g = original.clone();
        forward(&mut g, Wavelet::Cdf97, &Layout::new(17, 9, 0));
        assert_eq!(g, original);
    }

    #[test]
    fn wavelet_names_ids_and_parsing_agree() {
        for w in [Wavelet::LeGall53, Wavelet::Cdf97] {
            assert_eq!(Wavelet::from_id(w.id()), Some(w));
            assert_eq!(w.name().parse::<Wavelet>(), Ok(w));
            assert_eq!(w.to_string(), w.name());
            assert_eq!(
                serde_json::to_string(&w).unwrap(),
                format!("\"{}\"", w.name())
            );
        }
        for (s, w) in [
            ("53", Wavelet::LeGall53),
            ("5/3", Wavelet::LeGall53),
            ("LeGall53", Wavelet::LeGall53),
            ("97", Wavelet::Cdf97),
            (" 9/7", Wavelet::Cdf97),
            ("CDF97", Wavelet::Cdf97),
        ] {
            assert_eq!(s.parse::<Wavelet>(), Ok(w), "{s:?}");
        }
        assert!(matches!(
            "haar".parse::<Wavelet>(),
            Err(ParamError::OutOfRange {
                name: "wavelet",
                ..
            })
        ));
        assert_eq!(Wavelet::from_id(2), None);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn int53_round_trip_is_exact_on_random_shapes(
            rows in 1..=MAX_SIDE,
            cols in 1..=MAX_SIDE,
            levels in 0..=subbands::MAX_LEVELS,
            seed: u64,
        ) {
            let original = grid_i32(rows, cols, INT_AMP, seed);
            let layout = Layout::new(rows, cols, levels);
            let mut g = original.clone();
            forward_int53(&mut g, &layout);
            inverse_int53(&mut g, &layout);
            prop_assert_eq!(g, original);
        }

        #[test]
        fn real_round_trips_on_random_shapes(
            rows in 1..=MAX_SIDE,
            cols in 1..=MAX_SIDE,
            levels in 0..=subbands::MAX_LEVELS,
            seed: u64,
        ) {
            for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
                let err = real_round_trip_error(rows, cols, levels, wavelet, seed);
                prop_assert!(
                    err < REAL_TOLERANCE,
                    "{:?} {}×{} {} levels: {}", wavelet, rows, cols, levels, err
                );
            }
        }
    }
}
