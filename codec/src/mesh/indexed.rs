//! The indexed triangle mesh every object-mesh algorithm reads and writes: positions in f64
//! (simplifiers accumulate quadrics and distances there), faces as three `u32` indices
//! (the width glTF and GPU index buffers use).

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::error::{InvalidMesh, MeshError};

/// An indexed triangle mesh. Faces wind counter-clockwise seen from outside.
///
/// Nothing is assumed about the contents: indices may be out of range and coordinates may be
/// NaN until [`TriMesh::check`] or [`crate::mesh::validate::repair`] has run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TriMesh {
    pub positions: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
}

/// An axis-aligned box; `min > max` (the [`Default`]) is the empty box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self {
            min: DVec3::splat(f64::INFINITY),
            max: DVec3::splat(f64::NEG_INFINITY),
        }
    }
}

impl Aabb {
    /// The smallest box holding every point (empty for no points).
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> Self {
        points.into_iter().fold(Self::default(), |b, &p| b.grow(p))
    }

    #[must_use]
    pub fn grow(self, p: DVec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Length of the diagonal: the unit mesh errors are reported in (0 for an empty box).
    /// Past ~1e150 a side's square overflows (and below ~1e-150 it underflows), so such a
    /// box is measured in units of its longest side; inside, the plain length, bit for bit.
    pub fn diagonal(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.max - self.min;
        let m = d.abs().max_element();
        if m == 0.0 || (1e-150..=1e150).contains(&m) {
            d.length()
        } else {
            m * (d / m).length()
        }
    }
}

impl TriMesh {
    pub fn new(positions: Vec<DVec3>, faces: Vec<[u32; 3]>) -> Self {
        Self { positions, faces }
    }

    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    pub fn face_count(&self) -> usize {
        self.faces.len()
    }

    /// Errors if any coordinate is not finite or any index points past the vertices: the two
    /// faults no repair can fix, and the contract every algorithm here relies on.
    pub fn check(&self) -> Result<(), MeshError> {
        let mut bad = self
            .positions
            .iter()
            .enumerate()
            .filter(|(_, p)| !p.is_finite());
        if let Some((first, _)) = bad.next() {
            return Err(InvalidMesh::NonFiniteCoordinates {
                count: 1 + bad.count(),
                first,
            }
            .into());
        }
        let n = self.positions.len();
        let mut out = self
            .faces
            .iter()
            .enumerate()
            .flat_map(|(f, t)| t.iter().map(move |&i| (f, i)))
            .filter(|&(_, i)| i as usize >= n);
        if let Some((face, index)) = out.next() {
            return Err(InvalidMesh::IndexOutOfRange {
                count: 1 + out.count(),
                face,
                index: u64::from(index),
                vertices: n,
            }
            .into());
        }
        Ok(())
    }

    /// Box of the referenced vertices only, so stray unused vertices do not inflate it.
    pub fn bounding_box(&self) -> Aabb {
        let n = self.positions.len();
        let mut used = vec![false; n];
        for &i in self.faces.iter().flatten() {
            if let Some(u) = used.get_mut(i as usize) {
                *u = true;
            }
        }
        let referenced = self.positions.iter().zip(&used).filter(|(_, &u)| u);
        Aabb::from_points(referenced.map(|(p, _)| p))
    }

    /// Diagonal of [`Self::bounding_box`]: distances are reported as a fraction of it.
    pub fn diagonal(&self) -> f64 {
        self.bounding_box().diagonal()
    }

    /// The three corners of face `f`, or `None` if an index is out of range.
    pub fn corners(&self, f: usize) -> Option<[DVec3; 3]> {
        let t = self.faces.get(f)?;
        Some([
            *self.positions.get(t[0] as usize)?,
            *self.positions.get(t[1] as usize)?,
            *self.positions.get(t[2] as usize)?,
        ])
    }

    /// Unit normal of every face (zero for a zero-area or out-of-range face).
    pub fn face_normals(&self) -> Vec<DVec3> {
        (0..self.faces.len())
            .map(|f| {
                self.corners(f).map_or(DVec3::ZERO, |[a, b, c]| {
                    (b - a).cross(c - a).normalize_or_zero()
                })
            })
            .collect()
    }

    /// Area of every face (zero for an out-of-range face).
    pub fn face_areas(&self) -> Vec<f64> {
        (0..self.faces.len())
            .map(|f| {
                self.corners(f)
                    .map_or(0.0, |[a, b, c]| 0.5 * (b - a).cross(c - a).length())
            })
            .collect()
    }

    pub fn surface_area(&self) -> f64 {
        self.face_areas().iter().sum()
    }

    /// Area-weighted vertex normals (unit, or +Z where the faces around cancel): what renderers
    /// and the GLB writer need.
    pub fn vertex_normals(&self) -> Vec<DVec3> {
        let mut acc = vec![DVec3::ZERO; self.positions.len()];
        for (f, t) in self.faces.iter().enumerate() {
            if let Some([a, b, c]) = self.corners(f) {
                // The cross product's length is twice the area: area weighting for free.
                let n = (b - a).cross(c - a);
                for &i in t {
                    if let Some(s) = acc.get_mut(i as usize) {
                        *s += n;
                    }
                }
            }
        }
        acc.iter()
            .map(|n| n.try_normalize().unwrap_or(DVec3::Z))
            .collect()
    }

    /// Drops vertices no face references and renumbers faces in first-kept order; returns the
    /// old→new map (`u32::MAX` for dropped) so callers can carry attributes along.
    /// Out-of-range indices are left as they are (run [`Self::check`] first).
    pub fn drop_unreferenced(&mut self) -> Vec<u32> {
        let n = self.positions.len();
        let mut remap = vec![u32::MAX; n];
        for &i in self.faces.iter().flatten() {
            if let Some(r) = remap.get_mut(i as usize) {
                *r = 0;
            }
        }
        let mut kept = Vec::with_capacity(n);
        for (old, r) in remap.iter_mut().enumerate() {
            if *r == 0 {
                *r = kept.len() as u32;
                kept.push(self.positions[old]);
            }
        }
        for i in self.faces.iter_mut().flatten() {
            if let Some(&r) = remap.get(*i as usize) {
                *i = r;
            }
        }
        self.positions = kept;
        remap
    }

    /// Merges vertices with bit-identical positions (as unwelded exports like the teapot's
    /// patches have) and drops the ones left unreferenced; returns the number merged.
    /// `-0.0` and `0.0` are the same position here.
    pub fn weld(&mut self) -> usize {
        let key = |p: DVec3| p.to_array().map(|c| (c + 0.0).to_bits());
        // Sort indices by position: equal positions become neighbours, no hash map needed.
        let mut order: Vec<u32> = (0..self.positions.len() as u32).collect();
        order.sort_unstable_by_key(|&i| key(self.positions[i as usize]));
        let mut canon: Vec<u32> = (0..self.positions.len() as u32).collect();
        let mut merged = 0;
        for w in order.windows(2) {
            let (a, b) = (w[0] as usize, w[1] as usize);
            if key(self.positions[a]) == key(self.positions[b]) {
                canon[b] = canon[a];
                merged += 1;
            }
        }
        for i in self.faces.iter_mut().flatten() {
            if let Some(&c) = canon.get(*i as usize) {
                *i = c;
            }
        }
        self.drop_unreferenced();
        merged
    }

    /// Number of distinct undirected edges.
    pub fn edge_count(&self) -> usize {
        let mut edges: Vec<(u32, u32)> = self
            .faces
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        edges.len()
    }

    /// χ = V − E + F over the referenced vertices: 2 for a closed sphere-like surface, 2 − 2g
    /// for genus g, lower by one per boundary loop.
    pub fn euler_characteristic(&self) -> i64 {
        let mut used = vec![false; self.positions.len()];
        for &i in self.faces.iter().flatten() {
            if let Some(u) = used.get_mut(i as usize) {
                *u = true;
            }
        }
        let v = used.iter().filter(|&&u| u).count() as i64;
        v - self.edge_count() as i64 + self.faces.len() as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> TriMesh {
        TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
        )
    }

    #[test]
    fn tetrahedron_is_a_sphere() {
        let m = tetra();
        assert_eq!(m.euler_characteristic(), 2);
        assert_eq!(m.edge_count(), 6);
        assert!((m.diagonal() - 3f64.sqrt()).abs() < 1e-12);
        let n = m.face_normals();
        assert_eq!(n[0], -DVec3::Z);
        assert!((m.surface_area() - (1.5 + 0.5 * 3f64.sqrt())).abs() < 1e-12);
    }

    #[test]
    fn check_reports_nan_and_out_of_range() {
        let mut m = tetra();
        m.positions[2].y = f64::NAN;
        assert!(matches!(
            m.check(),
            Err(MeshError::Invalid(InvalidMesh::NonFiniteCoordinates {
                count: 1,
                first: 2
            }))
        ));
        let mut m = tetra();
        m.faces[3][1] = 9;
        assert!(matches!(
            m.check(),
            Err(MeshError::Invalid(InvalidMesh::IndexOutOfRange {
                face: 3,
                index: 9,
                ..
            }))
        ));
    }

    #[test]
    fn weld_merges_exact_duplicates_and_drops_unused() {
        // Two triangles sharing an edge, stored unwelded, plus an unused vertex.
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE];
        let mut m = TriMesh::new(
            vec![p[0], p[1], p[2], p[1], p[3], p[2], DVec3::splat(7.0)],
            vec![[0, 1, 2], [3, 4, 5]],
        );
        assert_eq!(m.weld(), 2);
        assert_eq!(m.vertex_count(), 4);
        assert_eq!(m.edge_count(), 5);
        assert_eq!(m.faces[0][1], m.faces[1][0]);
    }

    #[test]
    fn drop_unreferenced_returns_the_map() {
        let mut m = TriMesh::new(
            vec![DVec3::ONE, DVec3::ZERO, DVec3::X, DVec3::Y],
            vec![[1, 2, 3]],
        );
        let map = m.drop_unreferenced();
        assert_eq!(map, vec![u32::MAX, 0, 1, 2]);
        assert_eq!(m.faces, vec![[0, 1, 2]]);
        assert_eq!(m.positions.len(), 3);
    }
}
