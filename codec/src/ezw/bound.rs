//! Upper bounds of the decoding error, as the stream records them: one per plane end (the
//! points `DecodeLimit::Threshold` stops at), measured by the encoder when it decodes
//! itself there, so a server can promise a maximum height error for any decode depth.
//!
//! A bound is stored on a logarithmic scale relative to its plane's threshold T_k:
//! `bound = T_k · 2^(q/16)` with an integer q (1/16 octave, ≤ 4.4 % above the measured error),
//! rounded up so it is never below the measurement, and q = [`ZERO`] for an exact decode.
//! Powers of two and a table of 16 mantissas make the decoder's arithmetic exact (two IEEE
//! multiplications), so encoder and decoder agree on every bit of a bound on any platform.

/// Steps per octave.
const STEPS: i32 = 16;
/// q stays within ±2^14 (2^±1024 · T_k spans all of f64); beyond that a stream is malformed.
pub const Q_LIMIT: i32 = 1 << 14;
/// The code of an exact decode.
pub const ZERO: i32 = i32::MIN;
/// No bound recorded (a stream cut before its trailer).
pub const UNKNOWN: i32 = i32::MAX;

/// 2^(i/16), i = 0..16, as f64 literals (any increasing table in [1, 2) would do: the encoder
/// checks its choice with this same table).
const MANTISSA: [f64; 16] = [
    1.0,
    1.044_273_782_427_413_8,
    1.090_507_732_665_257_7,
    1.138_788_634_756_691_6,
    1.189_207_115_002_721,
    1.241_857_812_073_484,
    1.296_839_554_651_009_6,
    1.354_255_546_936_892_7,
    std::f64::consts::SQRT_2,
    1.476_826_145_939_499_3,
    1.542_210_825_407_940_7,
    1.610_490_331_949_254_3,
    1.681_792_830_507_429,
    1.756_252_160_373_299_5,
    1.834_008_086_409_342_4,
    1.915_206_561_397_147_4,
];

/// The bound code q stands for on a plane with threshold `t` (height units).
pub fn value(q: i32, t: f64) -> f64 {
    if q == ZERO {
        return 0.0;
    }
    let (octave, step) = (q.div_euclid(STEPS), q.rem_euclid(STEPS));
    // Split the power of two so neither factor leaves f64's normal range.
    let half = octave / 2;
    t * MANTISSA[step as usize] * (2f64).powi(half) * (2f64).powi(octave - half)
}

/// The smallest code whose bound is at least `err` (≥ 0, height units) on a plane with
/// threshold `t` > 0.
pub fn quantise_up(err: f64, t: f64) -> i32 {
    if err <= 0.0 {
        return ZERO;
    }
    // Only where the search starts: the loops below settle on the smallest code whatever
    // the guess (mutants of this line and of the clamp's `-Q_LIMIT` are equivalent, slower).
    let guess = ((err / t).log2() * f64::from(STEPS)).ceil();
    let mut q = if guess.is_finite() {
        (guess as i32).clamp(-Q_LIMIT, Q_LIMIT)
    } else {
        Q_LIMIT
    };
    // The logarithm is approximate: settle on the exact table. (`value(q, t) <= err` here
    // is equivalent: at equality it steps up once and the next loop steps back.)
    while q < Q_LIMIT && value(q, t) < err {
        q += 1;
    }
    while q > -Q_LIMIT && value(q - 1, t) >= err {
        q -= 1;
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mantissas_are_powers_of_two_to_the_sixteenth() {
        for (i, &m) in MANTISSA.iter().enumerate() {
            assert!((m - (2f64).powf(i as f64 / 16.0)).abs() < 1e-15);
        }
    }

    #[test]
    fn quantised_bounds_hold_and_are_tight() {
        for t in [1e-3, 0.0625, 1.0, 3.2, 4096.0] {
            for err in [1e-13, 4.55e-13, 0.01, 0.3, 1.0, 1.5, 7.0, 99.5, 12345.678] {
                let q = quantise_up(err, t);
                let b = value(q, t);
                assert!(b >= err, "t {t} err {err}: bound {b}");
                assert!(b <= err * 1.0443, "t {t} err {err}: bound {b} is loose");
            }
        }
        assert_eq!(quantise_up(0.0, 1.0), ZERO);
        assert_eq!(value(ZERO, 1.0), 0.0);
    }

    /// An error one ulp above a table value needs the next code. There the logarithm is
    /// blind to the ulp (log2 of 2^n·(1 + 2^-52) rounds to n), so the first guess is a code
    /// too low and only the upward search finds the bound that holds.
    #[test]
    fn one_ulp_above_a_table_value_is_the_next_code() {
        let up = |v: f64| f64::from_bits(v.to_bits() + 1);
        for t in [1.0, 0.0625, 4096.0, 1e-3, 3.2] {
            for q in -300..300 {
                let err = up(value(q, t));
                let got = quantise_up(err, t);
                assert_eq!(got, q + 1, "t {t} q {q}");
                assert!(value(got, t) >= err);
            }
        }
    }

    /// 2^±1024 · T_k is outside f64 for T_k = 1 but not for every threshold: the power of
    /// two is applied in two halves, so a code far up the scale on a tiny threshold (or far
    /// down on a huge one) still gives its exact value, not ∞, 0 or NaN.
    #[test]
    fn extreme_octaves_stay_exact() {
        let (tiny, huge) = ((2f64).powi(-1000), (2f64).powi(1000));
        assert_eq!(value(16 * 1030, tiny), (2f64).powi(30));
        assert_eq!(value(-16 * 1030, huge), (2f64).powi(-30));
        assert_eq!(value(Q_LIMIT, tiny), (2f64).powi(24));
        assert_eq!(value(-Q_LIMIT, huge), (2f64).powi(-24));
        assert_eq!(
            value(16 * 1030 + 8, tiny),
            (2f64).powi(30) * std::f64::consts::SQRT_2
        );
    }

    /// Codes stay within ±Q_LIMIT, the range the stream reader accepts, even where the
    /// table would want more: past the top the bound is clamped (an error over 2^1024
    /// thresholds, which a readable stream's planes cannot reach), past the bottom it is
    /// looser than it could be, never below the error.
    #[test]
    fn codes_stay_within_the_limit() {
        let (tiny, huge) = ((2f64).powi(-1000), (2f64).powi(1000));
        assert_eq!(quantise_up((2f64).powi(25), tiny), Q_LIMIT);
        assert_eq!(quantise_up(f64::MAX, tiny), Q_LIMIT);
        assert_eq!(quantise_up((2f64).powi(-40), huge), -Q_LIMIT);
        assert!(value(-Q_LIMIT, huge) >= (2f64).powi(-40));
        // err / t below f64's range: the logarithm is -∞, the search starts at the top and
        // comes all the way down.
        assert_eq!(quantise_up((2f64).powi(-80), huge), -Q_LIMIT);
        // At the limits themselves, the exact codes.
        assert_eq!(quantise_up((2f64).powi(24), tiny), Q_LIMIT);
        assert_eq!(quantise_up((2f64).powi(-24), huge), -Q_LIMIT);
    }

    /// A bound that is exactly a table value codes as that value's own code: `value` is
    /// strictly increasing in q, so q is the smallest code at or above it, whatever the
    /// logarithm's rounding says.
    #[test]
    fn a_table_value_quantises_to_its_own_code() {
        for t in [1e-3, 0.0625, 1.0, 3.2, 4096.0] {
            for q in -300..300 {
                assert_eq!(quantise_up(value(q, t), t), q, "t {t} q {q}");
            }
        }
    }
}
