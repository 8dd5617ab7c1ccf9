//! A synthetic mountain range: ridged multifractal noise (Musgrave's construction: each
//! octave is 1 − |noise|, squared, and weighted by the octave above so ridges carry the
//! detail and valleys stay smooth) over a tilted plateau. Deterministic: a hash, not an RNG.

use zerotile_codec::raster::{Crs, Georef, Heightmap};
use zerotile_codec::Grid;

/// Samples per side: 4 × 256 + 1.
pub const SIDE: usize = 1025;

/// Where it sits: a quarter degree square from (7°E, 46.25°N) (sample centres), so the
/// geodetic pyramid has a few dozen tiles at its deepest zoom.
const WEST: f64 = 7.0;
const NORTH: f64 = 46.25;
const EXTENT_DEGREES: f64 = 0.25;

/// A `side × side` heightmap in whole metres (as SRTM stores them), georeferenced in
/// EPSG:4326.
pub fn ridges(side: usize) -> Heightmap {
    let n = side.max(2);
    let data = (0..n * n)
        .map(|k| {
            let (r, c) = (
                (k / n) as f64 / (n - 1) as f64,
                (k % n) as f64 / (n - 1) as f64,
            );
            height(c, r).round()
        })
        .collect();
    let heights = Grid::new(n, n, data).unwrap_or_else(|_| Grid::zeros(n, n));
    let spacing = EXTENT_DEGREES / (n - 1) as f64;
    let georef = Georef::north_up(Crs::Geographic, WEST, NORTH, spacing, spacing);
    Heightmap::new(heights, Some(1.0), Some(georef))
}

/// Height in metres at (`x`, `y`) ∈ [0, 1]²: a valley floor near 400 m, crests near 3,500 m.
fn height(x: f64, y: f64) -> f64 {
    let (mut sum, mut weight, mut freq, mut amp) = (0.0, 1.0, 3.0, 1.0);
    // Warp the domain a little so ridges wander instead of following the noise lattice.
    let wx = x + 0.08 * noise(x * 2.0 + 5.2, y * 2.0 + 1.3, 101);
    let wy = y + 0.08 * noise(x * 2.0 + 9.7, y * 2.0 + 2.8, 202);
    for octave in 0..8 {
        let s = 1.0 - noise(wx * freq, wy * freq, octave).abs();
        let s = s * s * weight;
        weight = (s * 2.0).clamp(0.0, 1.0);
        sum += s * amp;
        freq *= 2.03;
        amp *= 0.5;
    }
    let plateau = 300.0 + 500.0 * x + 200.0 * y;
    plateau + 1700.0 * sum
}

/// Gradient noise in [−1, 1] (Perlin's construction with hashed gradients).
fn noise(x: f64, y: f64, seed: u32) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (ix, iy) = (x0 as i64, y0 as i64);
    let grad = |i: i64, j: i64, dx: f64, dy: f64| {
        let a = f64::from(hash(i, j, seed)) / f64::from(u32::MAX) * std::f64::consts::TAU;
        a.cos() * dx + a.sin() * dy
    };
    let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (u, v) = (fade(fx), fade(fy));
    let n00 = grad(ix, iy, fx, fy);
    let n10 = grad(ix + 1, iy, fx - 1.0, fy);
    let n01 = grad(ix, iy + 1, fx, fy - 1.0);
    let n11 = grad(ix + 1, iy + 1, fx - 1.0, fy - 1.0);
    let top = n00 + u * (n10 - n00);
    let bottom = n01 + u * (n11 - n01);
    // A 2-D gradient noise peaks at √2/2; scale to about [−1, 1].
    (top + v * (bottom - top)) * std::f64::consts::SQRT_2
}

/// A 32-bit integer hash of a lattice point (splitmix64's finaliser).
fn hash(i: i64, j: i64, seed: u32) -> u32 {
    let mut z = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ u64::from(seed).wrapping_mul(0x1656_67B1_9E37_79F9);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn looks_like_mountains_and_is_reproducible() {
        let a = ridges(129);
        let (lo, hi) = a.min_max().unwrap();
        assert!(lo > 200.0 && hi < 5000.0 && hi - lo > 1000.0, "{lo}..{hi}");
        assert_eq!(a, ridges(129));
        // Rough: neighbouring samples differ, so the mesher has work to do.
        let h = &a.heights;
        let rough = (1..129)
            .filter(|&c| h.get(64, c) != h.get(64, c - 1))
            .count();
        assert!(rough > 100);
    }
}
