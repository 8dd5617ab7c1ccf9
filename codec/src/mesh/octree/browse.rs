//! Region-of-interest browsing (the paper's §III, Fig. 9): from a base level, the boxes whose
//! screen projection meets the region and whose average normal faces the viewer are refined one
//! depth at a time, each child again only if it meets the region, down to the leaves; the rest
//! of the model stays at the base level.

use glam::DVec3;

use super::tree::{Node, Octree};
use crate::error::ParamError;

/// A perspective camera. Only the direction of projection matters for browsing, so there are no
/// near and far planes: a box is on screen if any corner is in front of the eye.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub eye: DVec3,
    pub target: DVec3,
    /// World direction that is up on screen (need not be orthogonal to the view direction).
    pub up: DVec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y_deg: f64,
    /// Width / height of the viewport, > 0.
    pub aspect: f64,
}

impl View {
    /// A view with +Z up unless looking along Z, then +Y up.
    pub fn looking_at(eye: DVec3, target: DVec3, fov_y_deg: f64, aspect: f64) -> Self {
        let dir = (target - eye).normalize_or_zero();
        // A tolerance, not a boundary: at sin² = 1e-6 neither axis is parallel to the view, so
        // `<=` picks an up as usable as `<` does.
        let up = if dir.cross(DVec3::Z).length_squared() < 1e-6 {
            DVec3::Y
        } else {
            DVec3::Z
        };
        Self {
            eye,
            target,
            up,
            fov_y_deg,
            aspect,
        }
    }

    /// The camera basis and focal scales, or why the view is unusable.
    pub(crate) fn camera(&self) -> Result<Camera, ParamError> {
        let bad = |name, expected, got: String| ParamError::OutOfRange {
            name,
            expected,
            got,
        };
        let finite = [self.eye, self.target, self.up]
            .iter()
            .all(|v| v.is_finite());
        if !finite {
            return Err(bad(
                "view",
                "finite eye, target and up",
                format!(
                    "eye {}, target {}, up {}",
                    xyz(self.eye),
                    xyz(self.target),
                    xyz(self.up)
                ),
            ));
        }
        let forward = (self.target - self.eye).normalize_or_zero();
        if forward == DVec3::ZERO {
            return Err(bad(
                "view target",
                "distinct from the eye",
                xyz(self.target),
            ));
        }
        let right = forward.cross(self.up).normalize_or_zero();
        if right == DVec3::ZERO {
            return Err(bad(
                "view up",
                "not parallel to the view direction",
                xyz(self.up),
            ));
        }
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 180.0) {
            return Err(bad(
                "fov",
                "in (0, 180) degrees",
                self.fov_y_deg.to_string(),
            ));
        }
        if !(self.aspect > 0.0 && self.aspect.is_finite()) {
            return Err(bad("aspect", "finite and > 0", self.aspect.to_string()));
        }
        let focal_y = 1.0 / (self.fov_y_deg.to_radians() * 0.5).tan();
        Ok(Camera {
            eye: self.eye,
            forward,
            right,
            up: right.cross(forward),
            focal_x: focal_y / self.aspect,
            focal_y,
        })
    }
}

/// A screen rectangle in normalised device coordinates: x from −1 (left) to 1 (right), y from
/// −1 (bottom) to 1 (top), as OpenGL's NDC and the paper's "window mapped to NDC".
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roi {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Roi {
    /// The whole screen.
    pub const FULL: Self = Self {
        x0: -1.0,
        y0: -1.0,
        x1: 1.0,
        y1: 1.0,
    };

    /// From a pixel rectangle (`x` right, `y` down from the top-left corner, as windows count)
    /// on a `width`×`height` viewport.
    pub fn from_pixels(px0: f64, py0: f64, px1: f64, py1: f64, width: f64, height: f64) -> Self {
        let x = |p: f64| 2.0 * p / width - 1.0;
        let y = |p: f64| 1.0 - 2.0 * p / height;
        Self {
            x0: x(px0.min(px1)),
            x1: x(px0.max(px1)),
            y0: y(py0.max(py1)),
            y1: y(py0.min(py1)),
        }
    }

    pub(crate) fn check(&self) -> Result<(), ParamError> {
        let ok = [self.x0, self.y0, self.x1, self.y1]
            .iter()
            .all(|c| c.is_finite())
            && self.x0 < self.x1
            && self.y0 < self.y1;
        if ok {
            Ok(())
        } else {
            Err(ParamError::OutOfRange {
                name: "roi",
                expected: "finite NDC corners with x0 < x1 and y0 < y1",
                got: self.to_string(),
            })
        }
    }
}

/// As the `roi` query parameter spells it, `x0,y0,x1,y1`: error messages quote it back to the
/// people who typed it.
impl std::fmt::Display for Roi {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}

/// A point as `x,y,z`, the way `eye` and `target` are typed, for error messages (glam's
/// `Debug` would print `DVec3(0.0, 0.0, 5.0)`).
fn xyz(v: DVec3) -> String {
    format!("{},{},{}", v.x, v.y, v.z)
}

/// An orthonormal camera frame with the projection's focal scales.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Camera {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    focal_x: f64,
    focal_y: f64,
}

impl Camera {
    /// Normalised device x, y of a point, or `None` behind (or on) the eye plane.
    pub fn project(&self, p: DVec3) -> Option<(f64, f64)> {
        let d = p - self.eye;
        let w = d.dot(self.forward);
        (w > 0.0).then(|| {
            (
                self.focal_x * d.dot(self.right) / w,
                self.focal_y * d.dot(self.up) / w,
            )
        })
    }

    /// Whether the box's projection meets the region ("속하거나 걸치는": inside or straddling).
    /// A box straddling the eye plane is taken as meeting it (its projection is unbounded, and
    /// the eye is in or near it); a box wholly behind the eye is not on screen at all: taking
    /// it as meeting refined everything behind a camera that looked away from the model.
    pub fn box_meets(&self, node: &Node, roi: &Roi) -> bool {
        let (lo, hi) = (node.min(), node.max());
        let mut x = (f64::INFINITY, f64::NEG_INFINITY);
        let mut y = (f64::INFINITY, f64::NEG_INFINITY);
        let mut behind = 0;
        for corner in 0..8 {
            // `== 0` for `!= 0` takes each corner's opposite: the same eight corners, in
            // another order, and the bounds below do not depend on the order.
            let pick = |bit: usize, a: f64, b: f64| if corner & bit != 0 { b } else { a };
            let p = DVec3::new(
                pick(1, lo.x, hi.x),
                pick(2, lo.y, hi.y),
                pick(4, lo.z, hi.z),
            );
            match self.project(p) {
                Some((px, py)) => {
                    x = (x.0.min(px), x.1.max(px));
                    y = (y.0.min(py), y.1.max(py));
                }
                None => behind += 1,
            }
        }
        if behind > 0 {
            return behind < 8;
        }
        x.0 <= roi.x1 && x.1 >= roi.x0 && y.0 <= roi.y1 && y.1 >= roi.y0
    }

    /// The paper's eq. 3: front-facing when the view vector u (eye → box) and the average
    /// normal a satisfy u·a ≤ 0. A box whose normals cancel (a thin plate seen edge-on, both
    /// sides in one box) counts as front-facing: one of its sides is.
    pub fn faces_viewer(&self, node: &Node, normal_sum: DVec3) -> bool {
        let a = normal_sum.normalize_or_zero();
        a == DVec3::ZERO || (node.centre - self.eye).dot(a) <= 0.0
    }
}

/// Which boxes a browse opened, and the cut it leaves.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Refinement {
    /// Boxes collapsed in the result: the base level's, and the region's partly refined ones.
    pub collapsed: Vec<u32>,
    /// Base-level boxes selected for refinement (in the region and front-facing).
    pub selected: usize,
    /// Boxes opened below the base level.
    pub opened: usize,
}

/// The paper's Fig. 9 with two queues merged into one breadth-first queue: a box in the region
/// is opened (its children replace it); a child outside the region stays collapsed.
pub(crate) fn refine(
    tree: &Octree,
    normal_sum: &[DVec3],
    base: u32,
    camera: &Camera,
    roi: &Roi,
) -> Refinement {
    let mut out = Refinement::default();
    let mut queue = std::collections::VecDeque::new();
    // The base level: boxes at depth `base`, and leaves above it (already full detail).
    for (i, node) in tree.nodes.iter().enumerate() {
        if node.depth != base || node.is_leaf() {
            continue;
        }
        // Steps 1–2: in the region and facing the viewer.
        if camera.box_meets(node, roi) && camera.faces_viewer(node, normal_sum[i]) {
            out.selected += 1;
            queue.push_back(i);
        } else {
            out.collapsed.push(i as u32);
        }
    }
    // Step 5: open level by level, so every step joins like two adjacent levels do.
    while let Some(t) = queue.pop_front() {
        out.opened += 1;
        for c in tree.nodes[t].child_range() {
            let child = &tree.nodes[c];
            if child.is_leaf() {
                continue;
            }
            if camera.box_meets(child, roi) {
                queue.push_back(c);
            } else {
                out.collapsed.push(c as u32);
            }
        }
    }
    out
}
