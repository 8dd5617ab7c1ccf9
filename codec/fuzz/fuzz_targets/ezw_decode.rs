//! The EZW decoder must turn any bytes into a decode or an error: never a panic, a hang or
//! an unbounded allocation. The first byte picks the decode limit so prefixes, thresholds
//! and the residual pass are all exercised.
#![no_main]

use libfuzzer_sys::fuzz_target;
use zerotile_codec::ezw::{decode, DecodeLimit};

/// Small enough that a hostile header cannot make the fuzzer allocate gigabytes.
const MAX_SAMPLES: usize = 1 << 18;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else { return };
    let limit = match mode % 3 {
        0 => DecodeLimit::All,
        1 => DecodeLimit::Threshold(f64::from(mode) / 16.0),
        _ => DecodeLimit::Bytes(rest.len() * usize::from(mode) / 255),
    };
    if let Ok(d) = decode(rest, limit, MAX_SAMPLES) {
        assert_eq!(d.heights.len(), d.significant.len());
        assert_eq!(d.heights.len(), d.coefficients.len());
        assert!(d.bytes_used <= rest.len());
        // A recorded bound is a length: finite or infinite, never negative or NaN.
        assert!(d.max_error.is_none_or(|e| e >= 0.0));
    }
});
