use super::*;
use crate::fixtures::{n44w072, n44w072_crop};
use proptest::prelude::*;

fn max_abs_diff(a: &Grid<f64>, b: &Grid<f64>) -> f64 {
    a.data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn rmse(a: &Grid<f64>, b: &Grid<f64>) -> f64 {
    let s: f64 = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x - y).powi(2))
        .sum();
    (s / a.len() as f64).sqrt()
}

#[test]
fn lossless_53_is_bit_exact_on_real_terrain() {
    let g = n44w072_crop(300, 500, 257);
    let enc = encode(&g, &EncodeParams::new(Wavelet::LeGall53, 1.0)).unwrap();
    let dec = decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
    assert_eq!(dec.heights, g);
    assert_eq!(dec.bytes_used, enc.bytes.len());
}

#[test]
fn error_falls_as_more_passes_are_decoded() {
    let g = n44w072_crop(300, 500, 129);
    for wavelet in [Wavelet::LeGall53, Wavelet::Cdf97] {
        let enc = encode(&g, &EncodeParams::new(wavelet, 1.0)).unwrap();
        let mut last = f64::INFINITY;
        for p in enc.passes.iter().filter(|p| p.kind == PassKind::Cleanup) {
            let d = decode(&enc.bytes, DecodeLimit::Bytes(p.end), DEFAULT_MAX_SAMPLES).unwrap();
            let e = rmse(&d.heights, &g);
            assert!(
                e <= last + 1e-9,
                "{wavelet:?}: rmse rose to {e} after plane {}",
                p.plane
            );
            last = e;
        }
        assert!(last < 0.5, "{wavelet:?}: full stream rmse {last}");
    }
}

#[test]
fn decoding_to_a_threshold_reads_exactly_the_passes_above_it() {
    let g = n44w072_crop(0, 0, 65);
    let enc = encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
    let mid = &enc.passes[enc.passes.len() / 2];
    let by_t = decode(
        &enc.bytes,
        DecodeLimit::Threshold(mid.threshold),
        DEFAULT_MAX_SAMPLES,
    )
    .unwrap();
    let last_at_t = enc
        .passes
        .iter()
        .rev()
        .find(|p| p.threshold >= mid.threshold)
        .unwrap();
    let by_bytes = decode(
        &enc.bytes,
        DecodeLimit::Bytes(last_at_t.end),
        DEFAULT_MAX_SAMPLES,
    )
    .unwrap();
    assert_eq!(by_t.heights, by_bytes.heights);
    assert_eq!(by_t.significant, by_bytes.significant);
    assert_eq!(by_t.threshold, mid.threshold);
}

/// The server's heights-only decode must give exactly the heights, bounds and byte counts of
/// the full one: both wavelets, every kind of limit, cuts inside passes and the residual.
/// The pass table's decision counts are the passes' real work: a 9/7 refinement pass codes one
/// bit of every coefficient significant before its plane (the decode up to there says how
/// many),
/// and no pass fits more bits in its bytes than its decisions could carry.
#[test]
fn pass_decision_counts_match_the_coefficients_they_code() {
    let g = n44w072_crop(300, 500, 129);
    let enc = encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
    let mut start = enc.header_len;
    let mut checked = 0;
    for (s, p) in enc.passes.iter().enumerate() {
        // A decision costs at most log2(2048 / 31) < 6.05 bits; termination adds ≤ 4 bytes.
        let bytes = p.end - start;
        assert!(
            (bytes as f64) * 8.0 <= 6.05 * p.decisions as f64 + 32.0,
            "pass {s}: {bytes} bytes from {} decisions",
            p.decisions
        );
        if p.kind == PassKind::Refinement {
            // Those found in this plane's propagation pass are not refined until the next.
            let plane_start = s
                .checked_sub(2)
                .map_or(enc.header_len, |q| enc.passes[q].end);
            let d = decode(
                &enc.bytes,
                DecodeLimit::Bytes(plane_start),
                DEFAULT_MAX_SAMPLES,
            )
            .unwrap();
            let before = d.significant.data().iter().filter(|&&b| b).count() as u64;
            assert_eq!(p.decisions, before, "refinement pass {s}");
            checked += u64::from(before > 0);
        }
        start = p.end;
    }
    assert!(
        checked > 5,
        "only {checked} refinement passes had coefficients to refine"
    );
}

#[test]
fn heights_only_decode_equals_the_full_decode() {
    let g = n44w072_crop(300, 500, 65);
    for (wavelet, max_error) in [(Wavelet::Cdf97, None), (Wavelet::LeGall53, Some(2.0))] {
        let mut params = EncodeParams::new(wavelet, 1.0);
        params.max_error = max_error;
        let enc = encode(&g, &params).unwrap();
        let mut limits = vec![DecodeLimit::All];
        limits.extend([0.5, 2.0, 16.0].map(DecodeLimit::Threshold));
        limits.extend((1..8).map(|i| DecodeLimit::Bytes(enc.bytes.len() * i / 8 + 3)));
        for limit in limits {
            let full = decode(&enc.bytes, limit, DEFAULT_MAX_SAMPLES).unwrap();
            let lean = decode_heights(&enc.bytes, limit, DEFAULT_MAX_SAMPLES).unwrap();
            let label = format!("{} {limit:?}", wavelet.name());
            assert_eq!(full.heights, lean.heights, "{label}");
            assert_eq!(full.bytes_used, lean.bytes_used, "{label}");
            assert_eq!(full.threshold, lean.threshold, "{label}");
            assert_eq!(full.bounded, lean.bounded, "{label}");
            assert_eq!(full.max_error, lean.max_error, "{label}");
        }
    }
}

#[test]
fn every_byte_prefix_decodes_and_significance_only_grows() {
    let g = n44w072_crop(600, 600, 33);
    let enc = encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
    let mut last_sig = 0;
    for cut in enc.header_len..=enc.bytes.len() {
        let d = decode(&enc.bytes, DecodeLimit::Bytes(cut), DEFAULT_MAX_SAMPLES).unwrap();
        let sig = d.significant.data().iter().filter(|&&s| s).count();
        assert!(sig >= last_sig, "cut {cut}: {sig} significant < {last_sig}");
        last_sig = sig;
    }
    for cut in 0..enc.header_len {
        assert!(decode(&enc.bytes, DecodeLimit::Bytes(cut), DEFAULT_MAX_SAMPLES).is_err());
    }
}

#[test]
fn recorded_bounds_hold_after_every_pass() {
    for (g, name) in [
        (n44w072_crop(300, 500, 257), "257² tile"),
        (n44w072_crop(700, 100, 129), "129² tile"),
        (
            n44w072_crop(100, 100, 64).map(|h| h * 0.1 + 0.05),
            "0.1 m steps",
        ),
    ] {
        let step = if name == "0.1 m steps" { 0.1 } else { 1.0 };
        for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
            if wavelet == Wavelet::LeGall53 && step != 1.0 {
                continue;
            }
            let enc = encode(&g, &EncodeParams::new(wavelet, step)).unwrap();
            for (s, p) in enc.passes.iter().enumerate() {
                let at = format!(
                    "{name} {wavelet:?}: pass {s} ({:?} of plane {})",
                    p.kind, p.plane
                );
                // A byte limit at the pass end also decodes the empty passes right after it
                // (they need no bytes): the decode stops after the last of them.
                let last = s + enc.passes[s + 1..]
                    .iter()
                    .take_while(|q| q.end == p.end)
                    .count();
                let bound = enc.passes[last].max_error;
                let d = decode(&enc.bytes, DecodeLimit::Bytes(p.end), DEFAULT_MAX_SAMPLES).unwrap();
                assert_eq!(d.max_error, Some(bound), "{at}");
                let actual = max_abs_diff(&d.heights, &g);
                assert!(
                    actual <= bound && bound <= actual * 1.045,
                    "{at}: bound {bound} for a max error of {actual}"
                );
                if p.kind == PassKind::Cleanup {
                    // Decoding to the plane's threshold stops at the same point.
                    let by_t = decode(
                        &enc.bytes,
                        DecodeLimit::Threshold(p.threshold),
                        DEFAULT_MAX_SAMPLES,
                    )
                    .unwrap();
                    assert_eq!(by_t.max_error, Some(p.max_error), "{at}");
                    assert!(max_abs_diff(&by_t.heights, &g) <= p.max_error, "{at}");
                }
            }
            // The bounds fall as passes are added, to the last plane's few hundredths.
            let first = enc.passes.first().unwrap().max_error;
            let final_bound = enc.passes.last().unwrap().max_error;
            assert!(
                final_bound < first / 100.0,
                "{name} {wavelet:?}: {first} → {final_bound}"
            );
        }
    }
}

#[test]
fn a_pass_decoded_in_part_has_no_bound() {
    let g = n44w072_crop(300, 500, 65);
    let enc = encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
    let cleanup = enc
        .passes
        .iter()
        .rposition(|p| p.kind == PassKind::Cleanup && p.end > enc.passes[0].end + 10)
        .unwrap();
    let d = decode(
        &enc.bytes,
        DecodeLimit::Bytes(enc.passes[cleanup].end - 1),
        DEFAULT_MAX_SAMPLES,
    )
    .unwrap();
    assert_eq!(d.max_error, None);
    let nothing = decode(
        &enc.bytes,
        DecodeLimit::Threshold(1e30),
        DEFAULT_MAX_SAMPLES,
    )
    .unwrap();
    assert_eq!(nothing.max_error, None);
    // A stream physically cut at a pass end has lost the trailer: plane ends (header) keep
    // their bound, the other passes have none.
    let mut planes_seen = 0;
    for p in enc
        .passes
        .iter()
        .filter(|p| p.end < enc.passes[cleanup].end)
    {
        let cut = decode(&enc.bytes[..p.end], DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
        // The decode also runs through the empty passes after p: it stops after the last.
        let last = enc.passes.iter().rfind(|q| q.end == p.end).unwrap();
        if last.kind == PassKind::Cleanup {
            assert_eq!(cut.max_error, Some(last.max_error), "plane {}", p.plane);
            planes_seen += 1;
        } else {
            assert_eq!(cut.max_error, None, "{:?} of plane {}", p.kind, p.plane);
        }
    }
    assert!(planes_seen > 3);
}

#[test]
fn max_error_mode_bounds_every_sample() {
    let g = n44w072_crop(300, 500, 129);
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        let mut last_len = usize::MAX;
        for e in [1.0, 2.0, 4.0, 8.0] {
            let params = EncodeParams {
                max_error: Some(e),
                ..EncodeParams::new(wavelet, 1.0)
            };
            let enc = encode(&g, &params).unwrap();
            let d = decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
            assert!(d.bounded);
            let err = max_abs_diff(&d.heights, &g);
            assert!(err <= e + 1e-9, "{wavelet:?} E={e}: max error {err}");
            let reported = d.max_error.unwrap();
            assert!(
                err <= reported + 1e-9 && reported <= e,
                "{wavelet:?} E={e}: {reported}"
            );
            assert!(
                enc.bytes.len() <= last_len,
                "{wavelet:?}: looser bound cost more bytes"
            );
            last_len = enc.bytes.len();
        }
    }
}

#[test]
fn max_error_mode_holds_on_real_valued_steps() {
    // 0.1 m steps (terrain-RGB-like) and a non-integer bound.
    let g = n44w072_crop(100, 100, 64).map(|h| h * 0.1 + 0.05);
    let params = EncodeParams {
        max_error: Some(0.25),
        ..EncodeParams::new(Wavelet::Cdf97, 0.1)
    };
    let enc = encode(&g, &params).unwrap();
    let d = decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
    assert!(max_abs_diff(&d.heights, &g) <= 0.25 + 1e-9);
}

#[test]
fn flat_and_tiny_grids_round_trip() {
    for (r, c) in [(1, 1), (1, 2), (2, 1), (3, 3), (1, 257), (5, 2)] {
        let flat = Grid::new(r, c, vec![42.0; r * c]).unwrap();
        let ramp = Grid::new(r, c, (0..r * c).map(|i| i as f64 * 3.0 - 7.0).collect()).unwrap();
        for g in [flat, ramp] {
            let enc = encode(&g, &EncodeParams::new(Wavelet::LeGall53, 1.0)).unwrap();
            let d = decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
            assert_eq!(d.heights, g, "{r}x{c}");
        }
    }
}

#[test]
fn bad_parameters_are_errors() {
    let g = Grid::new(2, 2, vec![0.0, f64::NAN, 1.0, 2.0]).unwrap();
    assert!(encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).is_err());
    let g = Grid::new(2, 2, vec![0.0; 4]).unwrap();
    assert!(encode(&g, &EncodeParams::new(Wavelet::Cdf97, 0.0)).is_err());
    let params = EncodeParams {
        max_error: Some(-1.0),
        ..EncodeParams::new(Wavelet::Cdf97, 1.0)
    };
    assert!(encode(&g, &params).is_err());
}

/// A range the coder's 62 bit planes cannot hold (a float no-data sentinel left in the
/// heights, a step far too fine) is refused by the encoder, not written as a stream the
/// decoder refuses; the largest range that fits still round-trips within its bound.
#[test]
fn ranges_past_the_top_bit_plane_are_refused_when_encoding() {
    let name = |r: Result<Encoded, ParamError>| match r {
        Err(ParamError::OutOfRange { name, .. }) => name,
        other => panic!("expected a range error, got {other:?}"),
    };
    let sentinel = Grid::new(2, 2, vec![-f64::from(f32::MAX), 10.0, 12.0, 11.0]).unwrap();
    for w in [Wavelet::Cdf97, Wavelet::LeGall53] {
        assert!(name(encode(&sentinel, &EncodeParams::new(w, 1.0))).starts_with("height range"));
    }
    // The range is quoted short: as 3.4e38, not in 39 digits (1e300 was 301).
    let e = encode(&sentinel, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap_err();
    assert!(e.to_string().contains("got 3.402823"), "{e}");
    assert!(e.to_string().ends_with("e38"), "{e}");
    let fine = Grid::new(2, 2, vec![0.0, 1.0, 2.0, 3.0]).unwrap();
    assert_eq!(
        name(encode(&fine, &EncodeParams::new(Wavelet::Cdf97, 1e-300))),
        "height range / step"
    );
    // 2^40 steps of range is well inside: decoded whole, it is within a step.
    let big = Grid::new(2, 2, vec![0.0, 1e12, 5e11, 2.5e11]).unwrap();
    let enc = encode(&big, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
    let d = decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
    assert!(max_abs_diff(&d.heights, &big) <= 1.0, "{:?}", d.heights);
}

/// A max-error bound below the heights' resolution cannot be kept: refused, where the
/// residual pass once returned 331 m errors for E = 1e-50 and reported success.
#[test]
fn bounds_below_the_float_resolution_are_refused() {
    let g = n44w072_crop(300, 500, 33);
    for e in [1e-20, 1e-50, 1e-300] {
        let params = EncodeParams {
            max_error: Some(e),
            ..EncodeParams::new(Wavelet::Cdf97, 1.0)
        };
        assert!(
            matches!(
                encode(&g, &params),
                Err(ParamError::OutOfRange {
                    name: "max_error",
                    ..
                })
            ),
            "E = {e}"
        );
    }
    // Just above the floor the bound holds.
    let e = 2.0 / (1u64 << 20) as f64;
    let params = EncodeParams {
        max_error: Some(e),
        ..EncodeParams::new(Wavelet::Cdf97, 1.0)
    };
    let enc = encode(&g, &params).unwrap();
    let d = decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
    assert!(max_abs_diff(&d.heights, &g) <= e);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn lossless_53_round_trips_random_grids(rows in 1usize..40, cols in 1usize..40, seed in any::<u64>(), amp in 1i64..5000) {
        let mut s = seed | 1;
        let data: Vec<f64> = (0..rows * cols).map(|_| {
            s ^= s << 13; s ^= s >> 7; s ^= s << 17;
            ((s % (2 * amp as u64 + 1)) as i64 - amp) as f64
        }).collect();
        let g = Grid::new(rows, cols, data).unwrap();
        let enc = encode(&g, &EncodeParams::new(Wavelet::LeGall53, 1.0)).unwrap();
        let d = decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
        prop_assert_eq!(d.heights, g);
    }

    #[test]
    fn corrupt_streams_never_panic(flips in prop::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 1..8), cut in any::<prop::sample::Index>()) {
        let g = n44w072_crop(500, 500, 33);
        let mut bytes = encode(&g, &EncodeParams { max_error: Some(2.0), ..EncodeParams::new(Wavelet::Cdf97, 1.0) }).unwrap().bytes;
        for (at, x) in flips {
            let i = at.index(bytes.len());
            bytes[i] ^= x;
        }
        let cut = cut.index(bytes.len() + 1);
        let _ = decode(&bytes[..cut], DecodeLimit::All, 1 << 20);
    }
}

/// Seeds the decoder fuzzer (`codec/fuzz`, target `ezw_decode`) with real streams: both
/// wavelets, max-error mode, 0.1 m steps, odd shapes, each under every decode limit the
/// target's first byte selects. Run with `cargo test -p zerotile-codec --lib
/// write_fuzz_seeds -- --ignored`; the corpus directory is gitignored.
#[test]
#[ignore]
fn write_fuzz_seeds() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/ezw_decode");
    std::fs::create_dir_all(&dir).unwrap();
    let dem = n44w072();
    let grids = [
        (dem.crop(300, 500, 33, 33).unwrap(), 1.0),
        (dem.crop(600, 600, 17, 17).unwrap(), 1.0),
        (dem.crop(10, 20, 9, 40).unwrap(), 1.0),
        (dem.crop(10, 20, 40, 3).unwrap(), 1.0),
        (dem.crop(0, 0, 1, 7).unwrap(), 1.0),
        (
            dem.crop(100, 100, 24, 24).unwrap().map(|h| h * 0.1 + 0.05),
            0.1,
        ),
        (Grid::new(5, 5, vec![42.0; 25]).unwrap(), 1.0),
    ];
    let mut n = 0;
    for (g, step) in &grids {
        for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
            for max_error in [None, Some(2.0)] {
                let params = EncodeParams {
                    max_error,
                    ..EncodeParams::new(wavelet, *step)
                };
                let Ok(enc) = encode(g, &params) else {
                    continue;
                };
                // A seed must be a valid stream, or the fuzzer starts from noise.
                decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
                // Mode bytes: All, Threshold(mode / 16), Bytes(len · mode / 255).
                for mode in [0u8, 3, 1, 16, 64, 2, 128, 254] {
                    let mut seed = vec![mode];
                    seed.extend_from_slice(&enc.bytes);
                    std::fs::write(dir.join(format!("seed-{n:03}")), seed).unwrap();
                    n += 1;
                }
            }
        }
    }
    assert!(
        n >= 8 * grids.len(),
        "only {n} seeds written to {}",
        dir.display()
    );
}

#[test]
fn a_version_1_stream_is_refused_by_name() {
    let g = n44w072_crop(300, 500, 17);
    let mut bytes = encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0))
        .unwrap()
        .bytes;
    bytes[..4].copy_from_slice(b"ZTW1");
    let err = decode(&bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap_err();
    assert!(
        matches!(&err, DecodeError::Unsupported(m) if m.contains("version 1")),
        "{err}"
    );
}

/// Fuzz find (ezw_decode, 2026-11-24): a segment-length delta near `i64::MAX` overflowed the
/// running length before it was range-checked.
#[test]
fn hostile_segment_length_delta_is_an_error() {
    let stream: &[u8] = &[
        0x5a, 0x54, 0x57, 0x32, 0x00, 0x00, 0x6d, 0x02, 0x02, 0x00, 0x00, 0x00, 0x2b, 0x5d, 0xff,
        0xff, 0xff, 0xff, 0xef, 0xff, 0xff, 0x3b, 0x2a, 0xff, 0xff, 0xff, 0x00, 0x00, 0x00, 0x00,
        0x00, 0x00, 0x00, 0x00, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff,
        0xff, 0xff, 0x00, 0xcc, 0xd9, 0x8e, 0x98, 0x00, 0x00, 0x3f, 0x7f, 0xff, 0xfe, 0xff, 0xff,
        0xff, 0x02, 0x5a, 0x54, 0x57, 0x34, 0x00, 0x00, 0xff, 0xff, 0xff, 0x24, 0x4a, 0x54, 0x1b,
        0x5a, 0x57, 0x32, 0x00, 0x00, 0x00, 0xff, 0xff, 0xff, 0xff, 0xff, 0x0e, 0x00, 0x23, 0xff,
        0x0e, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf6, 0x00, 0x54,
    ];
    assert!(decode(stream, DecodeLimit::Threshold(43.0 / 16.0), 1 << 18).is_err());
}

/// Found by the ezw_decode fuzz target (stop 12): an error-bound delta that sums to
/// i64::MIN made `abs` overflow (a panic with overflow checks, a garbage bound without).
#[test]
fn hostile_error_bound_delta_is_an_error() {
    let stream: &[u8] = &[
        0x5a, 0x54, 0x57, 0x32, 0x00, 0x00, 0x62, 0x22, 0x02, 0x03, 0x00, 0x00, 0x2b, 0x57, 0xff,
        0xff, 0xff, 0xff, 0xff, 0x7e, 0x79, 0x7b, 0xfb, 0x7b, 0x7b, 0x7b, 0x7b, 0x7b, 0x7b, 0x7b,
        0xff, 0xff, 0x7b, 0x27, 0xff, 0x7b, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0xff,
        0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x02, 0xff, 0xff, 0x40, 0x8d, 0xff,
        0x7b, 0x7b, 0x7b, 0xff, 0xff, 0xff, 0x7b, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x25, 0xff,
        0xff, 0xff, 0xff, 0xe2,
    ];
    let limit = DecodeLimit::Threshold(43.0 / 16.0);
    assert!(decode(stream, limit, 1 << 18).is_err());
    assert!(decode_heights(stream, limit, 1 << 18).is_err());
}

/// A whole stream knows its length; every prefix, those ending exactly at a pass end
/// included, is short of it; bytes after it are not counted. With and without the residual
/// section.
#[test]
fn whole_len_tells_a_cut_stream_from_a_whole_one() {
    let g = n44w072_crop(300, 500, 65);
    for max_error in [None, Some(2.0)] {
        let params = EncodeParams {
            max_error,
            ..EncodeParams::new(Wavelet::Cdf97, 1.0)
        };
        let enc = encode(&g, &params).unwrap();
        let n = enc.bytes.len();
        assert_eq!(whole_len(&enc.bytes, DEFAULT_MAX_SAMPLES).unwrap(), Some(n));
        let cuts = enc
            .passes
            .iter()
            .map(|p| p.end)
            .chain([enc.header_len, n / 2, n - 1]);
        for cut in cuts.filter(|&c| c < n) {
            assert_eq!(
                whole_len(&enc.bytes[..cut], DEFAULT_MAX_SAMPLES).unwrap(),
                None,
                "{max_error:?}: cut at {cut} of {n}"
            );
        }
        let mut padded = enc.bytes.clone();
        padded.extend_from_slice(&[0; 100]);
        assert_eq!(whole_len(&padded, DEFAULT_MAX_SAMPLES).unwrap(), Some(n));
    }
}

/// Every coefficient's flag word names which of its eight in-band neighbours are significant
/// and whether the west and north ones are negative. Encoder and decoder update the flags
/// alike, so a neighbour both forget passes every round trip and only costs bits: check the
/// words against the significance map itself, which after a whole plane k is exactly the
/// magnitudes ≥ 2^k.
#[test]
fn neighbour_flags_follow_the_significance_map_after_every_plane() {
    let g = n44w072_crop(300, 500, 65);
    let layout = Layout::full(65, 65);
    let cols = layout.cols();
    let (lo, hi) = g
        .data()
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let centered = g.map(|h| h - ((lo + hi) / 2.0).round());
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        let (mags, negs, _) = quantize::forward(&centered, wavelet, &layout);
        let plan = Plan::new(Tree::new(&layout), Plan::shifts_for(wavelet, &layout));
        let mut state = State::new(&plan);
        let mut truth = Truth {
            mag: &mags,
            neg: &negs,
            parent: plan.tree.parents(),
            sub_new: Vec::new(),
        };
        let top = 63 - mags.iter().max().unwrap().leading_zeros();
        for k in (0..=top).rev() {
            let _ = passes::propagation(EncodeIo::default(), &plan, &mut state, Some(&truth), k);
            let _ = passes::refinement(EncodeIo::default(), &plan, &mut state, Some(&truth), k);
            truth.prepare(&plan, &state, k);
            let _ = passes::cleanup(EncodeIo::default(), &plan, &mut state, Some(&truth), k);
            for b in &plan.tree.bands {
                let (rows, bcols) = (b.rows as isize, b.cols as isize);
                let idx = |i: isize, j: isize| (b.row0 + i as usize) * cols + b.col0 + j as usize;
                let sig = |i: isize, j: isize| {
                    (0..rows).contains(&i)
                        && (0..bcols).contains(&j)
                        && state.is_significant(b, i as usize, j as usize)
                };
                for i in 0..rows {
                    for j in 0..bcols {
                        let at = format!(
                            "{wavelet:?} plane {k}, band at ({}, {}), ({i}, {j})",
                            b.row0, b.col0
                        );
                        assert_eq!(sig(i, j), mags[idx(i, j)] >> k != 0, "{at}");
                        let mut want = 0;
                        for (di, dj, flag) in [
                            (0, -1, context::W),
                            (0, 1, context::E),
                            (-1, 0, context::N),
                            (1, 0, context::S),
                            (-1, -1, context::NW),
                            (-1, 1, context::NE),
                            (1, -1, context::SW),
                            (1, 1, context::SE),
                        ] {
                            if sig(i + di, j + dj) {
                                want |= flag;
                            }
                        }
                        if sig(i, j - 1) && negs[idx(i, j - 1)] {
                            want |= context::W_NEG;
                        }
                        if sig(i - 1, j) && negs[idx(i - 1, j)] {
                            want |= context::N_NEG;
                        }
                        assert_eq!(u32::from(state.flags[idx(i, j)]), want, "{at}");
                    }
                }
            }
        }
    }
}

/// A plane's 5/3 details are all zero (linear interpolation reproduces it), so on 257² only
/// the 2 × 2 LL band and the five level-8 coefficients are ever outside a zerotree; no pass
/// codes more than significance, sign and a zerotree decision for each of those nine. Without
/// zerotrees the first cleanup pass alone would code 257² significance decisions.
#[test]
fn a_plane_codes_only_its_coarsest_coefficients() {
    let n = 257;
    let data = (0..n * n)
        .map(|k| 3.0 * (k / n) as f64 - 2.0 * (k % n) as f64 + 100.0)
        .collect();
    let g = Grid::new(n, n, data).unwrap();
    let enc = encode(&g, &EncodeParams::new(Wavelet::LeGall53, 1.0)).unwrap();
    assert!(enc.passes.len() >= 3);
    for (s, p) in enc.passes.iter().enumerate() {
        assert!(
            p.decisions <= 3 * 9,
            "pass {s} ({:?} of plane {}): {} decisions",
            p.kind,
            p.plane,
            p.decisions
        );
    }
    let d = decode(&enc.bytes, DecodeLimit::All, DEFAULT_MAX_SAMPLES).unwrap();
    assert_eq!(d.heights, g);
}

/// A prefix that ends inside the residual section lacks bytes the max-error bound rests on:
/// its decode is an error or an unbounded one, never a panic and never `bounded`.
#[test]
fn a_prefix_cut_inside_the_residual_section_is_never_bounded() {
    let g = n44w072_crop(300, 500, 65);
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        let params = EncodeParams {
            max_error: Some(2.0),
            ..EncodeParams::new(wavelet, 1.0)
        };
        let enc = encode(&g, &params).unwrap();
        let (header, _) = Header::read(&enc.bytes, DEFAULT_MAX_SAMPLES).unwrap();
        let (_, len) = header.residual.unwrap();
        let start = enc.passes.last().map_or(enc.header_len, |p| p.end);
        assert!(len > 1, "{wavelet:?}: residual section of {len} bytes");
        for cut in start..start + len {
            let decodes = [
                decode(&enc.bytes[..cut], DecodeLimit::All, DEFAULT_MAX_SAMPLES),
                decode(&enc.bytes, DecodeLimit::Bytes(cut), DEFAULT_MAX_SAMPLES),
            ];
            for d in decodes.into_iter().flatten() {
                assert!(
                    !d.bounded,
                    "{wavelet:?}: cut at {cut} of {start}..{}",
                    start + len
                );
            }
        }
        let whole = decode(
            &enc.bytes[..start + len],
            DecodeLimit::All,
            DEFAULT_MAX_SAMPLES,
        );
        assert!(whole.unwrap().bounded, "{wavelet:?}");
    }
}
