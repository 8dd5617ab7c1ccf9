//! Oct encoding of unit vectors into two bytes, as quantized-mesh's extension 1 stores
//! per-vertex normals.
//!
//! References:
//! - Z. H. Cigolle, S. Donow, D. Evangelakos, M. Mara, M. McGuire, Q. Meyer, "A Survey of
//!   Efficient Representations for Independent Unit Vectors", JCGT 3(2), 2014, §3.3 (the
//!   octahedral projection and its fold of the lower hemisphere).
//! - CesiumJS `AttributeCompression.octEncode` / `octDecode`: the byte convention clients
//!   decode, SNORM in 0..=255 with `round((clamp(t, −1, 1) · 0.5 + 0.5) · 255)`.

use glam::{DVec2, DVec3};

/// The SNORM range of one byte.
const RANGE_MAX: f64 = 255.0;

/// Two bytes for the unit vector `n` (ECEF normals for quantized-mesh). A zero or non-finite
/// vector encodes as straight up the z axis.
pub fn oct_encode(n: DVec3) -> [u8; 2] {
    // Project onto the octahedron |x| + |y| + |z| = 1, then onto its xy plane.
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if !(l1.is_finite() && l1 > 0.0) {
        return oct_encode(DVec3::Z);
    }
    let mut p = DVec2::new(n.x / l1, n.y / l1);

    // Fold the lower hemisphere over the diagonals so the square is covered once. On the
    // equator (z = 0, |x| + |y| = 1) the fold is the identity: `<` or `<=` alike.
    if n.z < 0.0 {
        p = DVec2::new(
            (1.0 - p.y.abs()) * sign_not_zero(p.x),
            (1.0 - p.x.abs()) * sign_not_zero(p.y),
        );
    }
    [to_snorm(p.x), to_snorm(p.y)]
}

/// The unit vector two oct-encoded bytes stand for.
pub fn oct_decode([x, y]: [u8; 2]) -> DVec3 {
    // Back to the square, then unfold the lower hemisphere.
    let mut p = DVec2::new(from_snorm(x), from_snorm(y));
    let z = 1.0 - p.x.abs() - p.y.abs();
    // The same fold, again the identity on the equator.
    if z < 0.0 {
        p = DVec2::new(
            (1.0 - p.y.abs()) * sign_not_zero(p.x),
            (1.0 - p.x.abs()) * sign_not_zero(p.y),
        );
    }
    DVec3::new(p.x, p.y, z).normalize()
}

/// ±1, never 0: a lower-hemisphere point with x = 0 folds to x = 1 − |y|, not to 0. By ±1
/// multiplying and dividing are the same, so the mutants that turn the folds' `*` into `/`
/// survive as equivalent.
fn sign_not_zero(v: f64) -> f64 {
    if v < 0.0 {
        -1.0
    } else {
        1.0
    }
}

fn to_snorm(t: f64) -> u8 {
    // In 0..=255 after the clamp, so the cast cannot truncate.
    ((t.clamp(-1.0, 1.0) * 0.5 + 0.5) * RANGE_MAX).round() as u8
}

fn from_snorm(b: u8) -> f64 {
    f64::from(b) / RANGE_MAX * 2.0 - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_encode_as_cesium_does() {
        // 127.5 rounds up, as JavaScript's Math.round does.
        assert_eq!(oct_encode(DVec3::Z), [128, 128]);
        assert_eq!(oct_encode(DVec3::X), [255, 128]);
        assert_eq!(oct_encode(DVec3::NEG_X), [0, 128]);
        assert_eq!(oct_encode(DVec3::Y), [128, 255]);
        // The south pole folds to a corner of the square.
        assert_eq!(oct_encode(DVec3::NEG_Z), [255, 255]);
        assert_eq!(oct_encode(DVec3::ZERO), oct_encode(DVec3::Z));
        assert_eq!(oct_encode(DVec3::NAN), oct_encode(DVec3::Z));
    }

    #[test]
    fn round_trip_is_within_a_degree_everywhere() {
        // A Fibonacci sphere: unit vectors spread evenly over every octant.
        let n = 2000;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let mut worst: f64 = 0.0;
        for i in 0..n {
            let z = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
            let r = (1.0 - z * z).sqrt();
            let a = golden * f64::from(i);
            let v = DVec3::new(r * a.cos(), r * a.sin(), z);
            let back = oct_decode(oct_encode(v));
            assert!((back.length() - 1.0).abs() < 1e-12);
            worst = worst.max(v.angle_between(back).to_degrees());
        }
        // 8 bits per axis: the worst case is ~0.8° (Cigolle et al., table 1, oct 16-bit).
        assert!(worst < 1.0, "worst round-trip error {worst}°");
    }

    #[test]
    fn every_byte_pair_decodes_to_a_unit_vector() {
        for x in 0..=255u8 {
            for y in 0..=255u8 {
                let v = oct_decode([x, y]);
                assert!((v.length() - 1.0).abs() < 1e-12, "({x}, {y}) → {v}");
            }
        }
    }
}
