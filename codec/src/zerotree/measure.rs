//! The true error of a terrain mesh: every grid sample is located in the triangle that covers
//! it and compared with the triangle's linear interpolation (the measure the benchmarks use
//! for Martini and Delatin too), so an error figure can never hide between vertices.

use super::terrain_mesh::TerrainMesh;
use crate::grid::Grid;

/// Mesh against a reference grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshError {
    /// Largest |mesh − reference| over covered samples (height units).
    pub max_abs: f64,
    /// Root mean square over covered samples.
    pub rmse: f64,
    /// Samples no triangle covers: 0 for a mesh without holes.
    pub uncovered: usize,
}

/// Rasterises `mesh` at every sample of `reference` (which must be the mesh's grid; other
/// shapes count every sample as uncovered). Samples on shared edges count once.
pub fn mesh_error(mesh: &TerrainMesh, reference: &Grid<f64>) -> MeshError {
    let (rows, cols) = (reference.rows(), reference.cols());
    if mesh.rows != rows || mesh.cols != cols {
        return MeshError {
            max_abs: f64::NAN,
            rmse: f64::NAN,
            uncovered: reference.len(),
        };
    }
    let mut covered = vec![false; rows * cols];
    let (mut max_abs, mut sum_sq, mut count) = (0f64, 0f64, 0usize);
    for &t in &mesh.triangles {
        let p = t.map(|k| mesh.positions[k as usize]);
        let xy = p.map(|q| (q[0] as i64, q[1] as i64));
        // Twice the signed area in (col, row): the barycentric denominator.
        let area = edge(xy[0], xy[1], xy[2]);
        if area == 0 {
            continue;
        }
        let (x_min, x_max) = span(xy.map(|q| q.0), cols);
        let (y_min, y_max) = span(xy.map(|q| q.1), rows);
        for y in y_min..=y_max {
            for x in x_min..=x_max {
                let q = (x, y);
                let (w0, w1, w2) = (
                    edge(xy[1], xy[2], q),
                    edge(xy[2], xy[0], q),
                    edge(xy[0], xy[1], q),
                );
                // `area >= 0` is equivalent: zero areas were skipped above.
                let inside = if area > 0 {
                    w0 >= 0 && w1 >= 0 && w2 >= 0
                } else {
                    w0 <= 0 && w1 <= 0 && w2 <= 0
                };
                let k = y as usize * cols + x as usize;
                if !inside || covered[k] {
                    continue;
                }
                covered[k] = true;
                let z =
                    (w0 as f64 * p[0][2] + w1 as f64 * p[1][2] + w2 as f64 * p[2][2]) / area as f64;
                let d = (z - reference.data()[k]).abs();
                max_abs = max_abs.max(d);
                sum_sq += d * d;
                count += 1;
            }
        }
    }
    MeshError {
        max_abs,
        rmse: if count > 0 {
            (sum_sq / count as f64).sqrt()
        } else {
            0.0
        },
        uncovered: rows * cols - count,
    }
}

/// Twice the signed area of (a, b, q).
#[inline]
fn edge(a: (i64, i64), b: (i64, i64), q: (i64, i64)) -> i64 {
    (b.0 - a.0) * (q.1 - a.1) - (b.1 - a.1) * (q.0 - a.0)
}

/// Bounding range of three coordinates, clamped to `0..n`.
fn span(v: [i64; 3], n: usize) -> (i64, i64) {
    let lo = v.iter().copied().min().unwrap_or(0).max(0);
    let hi = v.iter().copied().max().unwrap_or(0).min(n as i64 - 1);
    (lo, hi)
}
