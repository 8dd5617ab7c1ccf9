//! The EZW decoder must turn any bytes into a decode or an error: never a panic, a hang or
//! an unbounded allocation. The first byte picks the decode limit so prefixes, thresholds
//! and the residual pass are all exercised. The server's heights-only decode must agree with
//! the full one on every input: the same heights, bounds and bytes, or an error for both.
//! `whole_len` (what `zerotile info --verify` asks) never claims more bytes than it got.
#![no_main]

use libfuzzer_sys::fuzz_target;
use zerotile_codec::ezw::{decode, decode_heights, whole_len, DecodeLimit};

/// Small enough that a hostile header cannot make the fuzzer allocate gigabytes.
const MAX_SAMPLES: usize = 1 << 18;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let limit = match mode % 3 {
        0 => DecodeLimit::All,
        1 => DecodeLimit::Threshold(f64::from(mode) / 16.0),
        _ => DecodeLimit::Bytes(rest.len() * usize::from(mode) / 255),
    };
    if let Ok(Some(n)) = whole_len(rest, MAX_SAMPLES) {
        assert!(n <= rest.len(), "whole_len {n} past the {} bytes given", rest.len());
    }
    let lean = decode_heights(rest, limit, MAX_SAMPLES);
    match decode(rest, limit, MAX_SAMPLES) {
        Ok(d) => {
            assert_eq!(d.heights.len(), d.significant.len());
            assert_eq!(d.heights.len(), d.coefficients.len());
            assert!(d.bytes_used <= rest.len());
            // A recorded bound is a length: finite or infinite, never negative or NaN.
            assert!(d.max_error.is_none_or(|e| e >= 0.0));
            let Ok(lean) = lean else {
                panic!("decode succeeded, decode_heights failed")
            };
            // Bit patterns: NaN heights must agree too.
            let bits = |g: &zerotile_codec::Grid<f64>| {
                g.data().iter().map(|h| h.to_bits()).collect::<Vec<_>>()
            };
            assert_eq!(bits(&d.heights), bits(&lean.heights));
            assert_eq!((d.bytes_used, d.bounded), (lean.bytes_used, lean.bounded));
            assert_eq!(
                d.max_error.map(f64::to_bits),
                lean.max_error.map(f64::to_bits)
            );
        }
        Err(_) => assert!(lean.is_err(), "decode failed, decode_heights succeeded"),
    }
});
