//! The hierarchical view sphere (paper §3.2): the Gaussian sphere cut into 8 octant cells,
//! each split into four per level, as a quadtree. A unit normal maps to the octahedron by
//! n / (|x| + |y| + |z|), so inside its octant it has barycentric coordinates
//! (|x|, |y|, |z|) / Σ, and each level picks one of four sub-triangles: three corner ones and
//! the inverted middle one.

use glam::DVec3;

/// Deepest level kept: 8 · 4⁷ = 131,072 cells, finer than any test mesh's normals need.
pub const MAX_LEVEL: u8 = 7;

/// A cell: its octant and the path of child indices (2 bits each) down to `level`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Cell {
    pub level: u8,
    pub octant: u8,
    pub path: u16,
}

impl Cell {
    /// The ancestor at `level` (≤ this one's).
    pub fn ancestor(self, level: u8) -> Cell {
        let level = level.min(self.level);
        Cell {
            level,
            octant: self.octant,
            path: self.path >> (2 * (self.level - level)),
        }
    }

    /// A key unique across levels.
    pub fn key(self) -> u32 {
        // The three fields' bits do not overlap (path < 2¹⁴, octant < 8), so `|` and `^` agree.
        (u32::from(self.level) << 24) | (u32::from(self.octant) << 16) | u32::from(self.path)
    }

    /// The cell's corners on the first octant's face of the octahedron (x + y + z = 1).
    fn octahedron_corners(self) -> [DVec3; 3] {
        let mut corners = [DVec3::X, DVec3::Y, DVec3::Z];
        for k in (0..self.level).rev() {
            let child = (self.path >> (2 * k)) & 3;
            let mid = |i: usize, j: usize| (corners[i] + corners[j]) / 2.0;
            let (ab, bc, ca) = (mid(0, 1), mid(1, 2), mid(2, 0));
            corners = match child {
                0 => [corners[0], ab, ca],
                1 => [ab, corners[1], bc],
                2 => [ca, bc, corners[2]],
                _ => [bc, ca, ab],
            };
        }
        corners
    }

    /// Moves a first-octant direction into the cell's octant.
    fn signed(self, c: DVec3) -> DVec3 {
        let sign = |bit: u8| if self.octant & bit != 0 { -1.0 } else { 1.0 };
        // The signs are ±1, so `/` for each `*` below would give the same vector.
        DVec3::new(c.x * sign(1), c.y * sign(2), c.z * sign(4))
    }

    /// The unit direction at the cell's centre.
    pub fn centre(self) -> DVec3 {
        let [a, b, c] = self.octahedron_corners();
        // Only the direction counts (normalised below), and the corners' sum stays under 3 in
        // every component, so `* 3.0` or `% 3.0` would give the same centre.
        self.signed((a + b + c) / 3.0).normalize_or_zero()
    }

    /// The cell's three corners as unit directions. The cell is the cone they span: a
    /// straight edge on the octahedron is a great-circle arc on the sphere.
    pub fn corners(self) -> [DVec3; 3] {
        self.octahedron_corners()
            .map(|c| self.signed(c).normalize())
    }

    /// The least |cos| between `d` (a unit vector) and a direction in the cell: 0 when the
    /// great circle ⟂ `d` crosses the cell, else the least at a corner (on a cone whose
    /// corners all lie on one side of that circle, the cosine is smallest at a corner: a
    /// direction is Σ wᵢ cᵢ / |Σ wᵢ cᵢ| with wᵢ ≥ 0 and |Σ wᵢ cᵢ| ≤ Σ wᵢ).
    pub fn min_abs_cos(self, d: DVec3) -> f64 {
        let cos = self.corners().map(|c| c.dot(d));
        // A corner at exactly 0 gives 0 either way, so `>=` and `<=` would do the same.
        let one_side = cos.iter().all(|&c| c > 0.0) || cos.iter().all(|&c| c < 0.0);
        if one_side {
            cos.iter().fold(f64::INFINITY, |m, c| m.min(c.abs()))
        } else {
            0.0
        }
    }
}

/// The cell of direction `n` at `level` (≤ [`MAX_LEVEL`]); `None` for a zero or non-finite
/// vector. A direction on a cell's edge goes to the positive octant (a zero component, +0 or
/// −0, counts as positive) and to the middle sub-triangle, which treats the axes alike.
pub fn cell_of(n: DVec3, level: u8) -> Option<Cell> {
    let sum = n.x.abs() + n.y.abs() + n.z.abs();
    if !(sum > 0.0 && sum.is_finite()) {
        return None;
    }
    // The three bits do not overlap, so `|` and `^` agree.
    let octant = u8::from(n.x < 0.0) | (u8::from(n.y < 0.0) << 1) | (u8::from(n.z < 0.0) << 2);
    let mut b = [n.x.abs() / sum, n.y.abs() / sum, n.z.abs() / sum];
    let mut path = 0u16;
    for _ in 0..level.min(MAX_LEVEL) {
        let child = if b[0] > 0.5 {
            b = [2.0 * b[0] - 1.0, 2.0 * b[1], 2.0 * b[2]];
            0
        } else if b[1] > 0.5 {
            b = [2.0 * b[0], 2.0 * b[1] - 1.0, 2.0 * b[2]];
            1
        } else if b[2] > 0.5 {
            b = [2.0 * b[0], 2.0 * b[1], 2.0 * b[2] - 1.0];
            2
        } else {
            // The middle triangle has corners at the edge midpoints: (0,½,½), (½,0,½), (½,½,0)
            // in that order, matching `Cell::centre`'s [bc, ca, ab].
            b = [1.0 - 2.0 * b[0], 1.0 - 2.0 * b[1], 1.0 - 2.0 * b[2]];
            3
        };
        // `path << 2` has its low two bits clear and `child` < 4, so `|` and `^` agree.
        path = (path << 2) | child;
    }
    Some(Cell {
        level: level.min(MAX_LEVEL),
        octant,
        path,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_nest_and_hold_their_own_centres() {
        let dirs = [
            DVec3::new(0.3, -0.5, 0.8),
            DVec3::new(-1.0, 0.01, 0.02),
            DVec3::new(0.2, 0.2, -0.9),
            DVec3::new(0.33, 0.34, 0.33),
        ];
        for d in dirs {
            let fine = cell_of(d, MAX_LEVEL).unwrap();
            for level in 0..=MAX_LEVEL {
                let c = cell_of(d, level).unwrap();
                assert_eq!(fine.ancestor(level), c, "{d} at {level}");
                // The centre of a cell maps back into the same cell.
                assert_eq!(cell_of(c.centre(), level), Some(c), "{d} at {level}");
            }
        }
        assert_eq!(cell_of(DVec3::ZERO, 3), None);
    }

    #[test]
    fn level_zero_is_the_eight_octants_and_cells_shrink() {
        let mut octants = std::collections::HashSet::new();
        for sx in [-1.0, 1.0] {
            for sy in [-1.0, 1.0] {
                for sz in [-1.0, 1.0] {
                    octants.insert(cell_of(DVec3::new(sx, sy, sz), 0).unwrap().key());
                }
            }
        }
        assert_eq!(octants.len(), 8);
        // Nearby normals share coarse cells and part at fine ones.
        let (a, b) = (DVec3::new(0.5, 0.5, 0.7), DVec3::new(0.52, 0.5, 0.7));
        assert_eq!(cell_of(a, 1), cell_of(b, 1));
        assert_ne!(cell_of(a, MAX_LEVEL), cell_of(b, MAX_LEVEL));
    }

    #[test]
    fn keys_tell_every_cell_of_every_level_apart() {
        // Regions of a view mix levels: a cell and its middle descendants share octant and
        // path bits (path 0 at level 0, 1, 2…) and only the level tells them apart.
        let mut keys = std::collections::HashSet::new();
        let mut cells = 0;
        for level in 0..=MAX_LEVEL {
            for octant in 0..8 {
                // Every path at the coarse levels, the first and last few at the finer ones.
                let paths = 1u32 << (2 * level);
                for path in (0..paths.min(64)).chain(paths.saturating_sub(64).max(64)..paths) {
                    let cell = Cell {
                        level,
                        octant,
                        path: path as u16,
                    };
                    assert!(keys.insert(cell.key()), "{cell:?}");
                    cells += 1;
                }
            }
        }
        assert_eq!(keys.len(), cells);
        let c = Cell {
            level: 7,
            octant: 5,
            path: 0x3fff,
        };
        assert_eq!(c.key(), 7 << 24 | 5 << 16 | 0x3fff);
    }
}
