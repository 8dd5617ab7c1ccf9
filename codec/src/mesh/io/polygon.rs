//! Polygons cut into triangles: OBJ `f` statements and PLY faces of more than three corners.
//!
//! A polygon is laid flat along its Newell normal (Tampieri, "Newell's method for computing the
//! plane equation of a polygon", Graphics Gems III, 1992) by dropping the axis the normal leans
//! on most, turned so that the polygon runs counter-clockwise. A convex polygon is then fanned
//! from its first corner, the triangles every reader gave before (convexity as in Schorn and
//! Fisher, "Testing the convexity of a polygon", Graphics Gems IV, 1994); any other is
//! ear-clipped (Meisters, "Polygons have ears", 1975) by the `earcut` crate, Mapbox's earcut
//! with its z-order index and its passes for self-touching rings. A fan of a concave polygon
//! covers ground outside it, twice over, with triangles wound against it.
//!
//! Every triangle is wound as its polygon: its normal points the way the polygon's does. What
//! polygons that are not simple give, none of them a panic:
//! - non-planar: cut as they lie in the plane of the normal, each corner keeping its position;
//! - repeated corners: a convex polygon's fan repeats the vertex in a triangle, which
//!   [`crate::mesh::repair`] drops; earcut leaves the repeat out;
//! - collinear corners: in a convex polygon, fan triangles of zero area, which repair drops;
//!   earcut leaves the corner out;
//! - self-intersecting: what earcut can cut of it, wound as the polygon's net area;
//! - no net area (every corner on one line or point, a figure eight whose loops cancel) or
//!   coordinates too large to measure: no side to wind by, so fanned as listed; repair drops
//!   the triangles without area ([`crate::mesh::io::read_bytes`] refuses coordinates that are
//!   not finite).

use earcut::Earcut;
use glam::DVec3;

use super::MeshLimits;
use crate::mesh::error::MeshError;

/// Cuts polygons, keeping its buffers from one to the next.
pub(super) struct Triangulator {
    earcut: Earcut<f64>,
    /// The polygon's corners in its plane, scaled into [-1, 1].
    plane: Vec<[f64; 2]>,
    /// Earcut's triangles, as positions in `plane`.
    ears: Vec<u32>,
}

impl Triangulator {
    pub(super) fn new() -> Self {
        Self {
            earcut: Earcut::new(),
            plane: Vec::new(),
            ears: Vec::new(),
        }
    }

    /// Pushes the triangles of `polygon` (indices into `positions`, all in range) onto
    /// `faces`. A polygon that is not convex may have [`MeshLimits::max_polygon_corners`].
    pub(super) fn push(
        &mut self,
        positions: &[DVec3],
        polygon: &[u32],
        faces: &mut Vec<[u32; 3]>,
        limits: &MeshLimits,
    ) -> Result<(), MeshError> {
        match *polygon {
            // A triangle as it is: most faces, and nothing to choose.
            [a, b, c] => {
                faces.push([a, b, c]);
                return Ok(());
            }
            [_, _, _, _, ..] => {}
            // Points and lines are no surface (the readers pass none).
            _ => return Ok(()),
        }
        // Flat and counter-clockwise; with no plane there is nothing better than the fan.
        if !self.project(positions, polygon) || is_convex(&self.plane) {
            push_fan(faces, polygon);
            return Ok(());
        }
        // Ear clipping takes time growing with the square of the corners.
        limits.polygon_corners(polygon.len() as u64)?;
        self.earcut
            .earcut(self.plane.iter().copied(), &[] as &[u32], &mut self.ears);
        for t in self.ears.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|k| k as usize);
            // Counter-clockwise in the plane is the polygon's way round, whatever earcut's own
            // convention.
            let t = if turn(self.plane[a], self.plane[b], self.plane[c]) < 0.0 {
                [a, c, b]
            } else {
                [a, b, c]
            };
            faces.push(t.map(|k| polygon[k]));
        }
        Ok(())
    }

    /// Fills `plane` with the corners laid along the Newell normal, counter-clockwise; false
    /// when the normal is zero or not finite.
    fn project(&mut self, positions: &[DVec3], polygon: &[u32]) -> bool {
        let corner = |i: u32| positions[i as usize];
        let origin = corner(polygon[0]);
        // About the first corner and scaled into [-1, 1], so neither the normal's products nor
        // earcut's can overflow however far out or large the polygon is.
        let scale = polygon
            .iter()
            .map(|&i| (corner(i) - origin).abs().max_element())
            .fold(0.0, f64::max);
        if !(scale.is_finite() && scale > 0.0) {
            return false;
        }
        let at = |i: u32| (corner(i) - origin) / scale;
        // Newell's normal: twice the polygon's vector area, its sides summed.
        let mut normal = DVec3::ZERO;
        let mut prev = at(polygon[polygon.len() - 1]);
        for &i in polygon {
            let p = at(i);
            normal += prev.cross(p);
            prev = p;
        }
        let k = normal.abs().max_position();
        if !normal.is_finite() || normal[k] == 0.0 {
            return false;
        }
        // The two other axes in cyclic order see the polygon counter-clockwise when the
        // normal's k-th component is positive, swapped when it is negative.
        let (mut u, mut v) = ((k + 1) % 3, (k + 2) % 3);
        if normal[k] < 0.0 {
            std::mem::swap(&mut u, &mut v);
        }
        self.plane.clear();
        self.plane.extend(polygon.iter().map(|&i| {
            let p = at(i);
            [p[u], p[v]]
        }));
        true
    }
}

/// Fans a polygon (`n ≥ 3` corners) into `n − 2` triangles from its first corner.
fn push_fan(faces: &mut Vec<[u32; 3]>, polygon: &[u32]) {
    if let Some((&first, rest)) = polygon.split_first() {
        for w in rest.windows(2) {
            faces.push([first, w[0], w[1]]);
        }
    }
}

/// Twice the signed area of the triangle `a b c`: positive counter-clockwise.
fn turn(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether a counter-clockwise polygon is convex: it never turns right or back on itself,
/// and its sides' directions change sign at most twice along each axis, which a polygon
/// winding round more than once (a pentagram turns left at every corner) cannot do.
/// Repeated corners make sides of no length, which are passed over.
fn is_convex(plane: &[[f64; 2]]) -> bool {
    let n = plane.len();
    let side = |i: usize| {
        let (a, b) = (plane[i % n], plane[(i + 1) % n]);
        [b[0] - a[0], b[1] - a[1]]
    };
    let Some(last) = (0..n).rev().map(side).find(|s| *s != [0.0, 0.0]) else {
        return false;
    };
    let sign = |x: f64| (x > 0.0) as i8 - (x < 0.0) as i8;
    // Each axis's direction where the polygon closes, to count its changes once round.
    let mut heading = [0, 1].map(|axis| {
        (0..n)
            .rev()
            .map(|i| sign(side(i)[axis]))
            .find(|&d| d != 0)
            .unwrap_or(0)
    });
    let (mut prev, mut flips) = (last, [0; 2]);
    for s in (0..n).map(side).filter(|s| *s != [0.0, 0.0]) {
        let cross = prev[0] * s[1] - prev[1] * s[0];
        let dot = prev[0] * s[0] + prev[1] * s[1];
        if cross < 0.0 || (cross == 0.0 && dot < 0.0) {
            return false;
        }
        for axis in 0..2 {
            let d = sign(s[axis]);
            if d != 0 && d != heading[axis] {
                flips[axis] += 1;
                heading[axis] = d;
            }
        }
        prev = s;
    }
    flips[0] <= 2 && flips[1] <= 2
}

#[cfg(test)]
mod tests {
    use super::is_convex;

    #[test]
    fn convexity_is_told_by_turns_and_windings() {
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let with_a_corner_on_a_side = [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let with_a_corner_twice = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        for convex in [&square[..], &with_a_corner_on_a_side, &with_a_corner_twice] {
            assert!(is_convex(convex), "{convex:?}");
        }
        // Left at every corner, but round twice.
        let pentagram: Vec<[f64; 2]> = (0..5)
            .map(|k| {
                let a = f64::from(2 * k) * std::f64::consts::TAU / 5.0;
                [a.cos(), a.sin()]
            })
            .collect();
        let clockwise = [[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]];
        let notched = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.5], [0.0, 2.0]];
        let back_on_itself = [[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        for not in [&pentagram[..], &clockwise, &notched, &back_on_itself] {
            assert!(!is_convex(not), "{not:?}");
        }
    }
}
