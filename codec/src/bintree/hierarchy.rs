//! The right-triangle bintree of a (2^k + 1)² grid, built once per grid size.
//!
//! Evans, Kirkpatrick and Townsend, "Right-triangulated irregular networks" (Algorithmica
//! 30, 2001); Lindstrom et al., "Real-time continuous level of detail rendering of height
//! fields" (SIGGRAPH 1996); V. Agafonkin's Martini (2019) for the flat, level-ordered layout.
//!
//! The square is cut along its diagonal into two right isosceles triangles; a triangle
//! (a, b, c) with hypotenuse a–b and right angle at c splits at the hypotenuse midpoint m into
//! (c, a, m) and (b, c, m), which keep the winding. The midpoints of one quadtree level of the
//! wavelet layout are exactly the split points of two bintree levels: cell centres (the HH
//! positions) split the cells' diagonals, edge midpoints (HL / LH) split the halves that
//! follow. Triangles are stored breadth-first, so the children of the i-th triangle of a
//! level are the (2i)-th and (2i+1)-th of the next.

/// One triangle: sample indices (row-major), hypotenuse `a`–`b`, right angle at `c`, and
/// the hypotenuse midpoint `m` ([`NONE`] on the unsplittable last level), kept so the hot
/// loops never divide to find it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Tri {
    pub a: u32,
    pub b: u32,
    pub c: u32,
    pub m: u32,
}

impl Tri {
    fn new(a: u32, b: u32, c: u32, n: usize) -> Self {
        let m = if splits(a, b, n) {
            midpoint(a, b, n)
        } else {
            NONE
        };
        Self { a, b, c, m }
    }

    /// The two halves of a splittable triangle, in the hierarchy's order: (c, a, m) and
    /// (b, c, m), each with m = (a + b) / 2, which is its hypotenuse's midpoint wherever
    /// it splits again (a hypotenuse to split has even extents, and y·n + x is linear).
    /// The stored last level has [`NONE`] there instead. The extraction walk derives
    /// children with this rather than reading the stored ones: a 16-byte triangle per
    /// visit, spread over 4 MB at 257², was most of its cache misses.
    #[inline]
    pub(crate) fn children(&self) -> [Tri; 2] {
        let Tri { a, b, c, m } = *self;
        let half = |a: u32, b: u32, c: u32| Tri {
            a,
            b,
            c,
            m: (a + b) / 2,
        };
        [half(c, a, m), half(b, c, m)]
    }
}

/// No parent (a root midpoint, or a sample that is never a midpoint).
pub(crate) const NONE: u32 = u32::MAX;

/// The whole triangle hierarchy of an `n × n` grid, `n = 2^k + 1`.
#[derive(Debug)]
pub struct Hierarchy {
    n: usize,
    /// All triangles, level by level from the two roots.
    pub(crate) tris: Vec<Tri>,
    /// `level_start[l]..level_start[l + 1]` are the triangles of level `l`; the last level
    /// holds the unsplittable 1 × 1 halves.
    pub(crate) level_start: Vec<usize>,
    /// For each sample, the midpoints of the (at most two) triangles whose split creates the
    /// triangles this sample splits: a vertex needs both to be vertices first (conformity).
    pub(crate) parents: Vec<[u32; 2]>,
    /// Per level, the small triangles' sample lists (`None` where the error pass scans).
    pub(super) shapes: Vec<Option<super::errors::Shapes>>,
    /// Border samples that forcing a vertex on another edge can pull in
    /// ([`Self::edge_spill`]): only stitching needs them, so they are found on first use.
    spill: std::sync::OnceLock<Vec<u32>>,
}

impl Hierarchy {
    /// Whether [`Self::new`] builds the hierarchy of an `n × n` grid: `n = 2^k + 1` with
    /// `1 ≤ k ≤ 12`. Callers ask before reading a grid of that side.
    pub fn supports(n: usize) -> bool {
        n.checked_sub(1)
            .is_some_and(|m| m.is_power_of_two() && (2..=4096).contains(&m))
    }

    /// The hierarchy of an `n × n` grid; `None` unless [`Self::supports`] `n`.
    pub fn new(n: usize) -> Option<Self> {
        if !Self::supports(n) {
            return None;
        }
        let k = (n - 1).ilog2();
        let idx = |x: usize, y: usize| (y * n + x) as u32;
        let last = n - 1;
        // Roots, counter-clockwise seen from above with north (row 0) up.
        let mut tris = vec![
            Tri::new(idx(last, last), idx(0, 0), idx(0, last), n),
            Tri::new(idx(0, 0), idx(last, last), idx(last, 0), n),
        ];
        let mut level_start = vec![0, 2];
        let mut parents = vec![[NONE; 2]; n * n];
        // 2k splittable levels: the hypotenuse halves every other level.
        for _ in 0..2 * k {
            let (from, to) = (level_start[level_start.len() - 2], tris.len());
            for t in from..to {
                for half in tris[t].children() {
                    let child = Tri::new(half.a, half.b, half.c, n);
                    // The new level's midpoints depend on this level's.
                    if child.m != NONE {
                        add_parent(&mut parents[child.m as usize], tris[t].m);
                    }
                    tris.push(child);
                }
            }
            level_start.push(tris.len());
        }
        let mut hierarchy = Self {
            n,
            tris,
            level_start,
            parents,
            shapes: Vec::new(),
            spill: std::sync::OnceLock::new(),
        };
        hierarchy.shapes = super::errors::level_shapes(&hierarchy);
        Some(hierarchy)
    }

    /// The border samples every stitched tile forces (`extract::edge_spill`).
    pub(crate) fn edge_spill(&self) -> &[u32] {
        self.spill.get_or_init(|| super::extract::edge_spill(self))
    }

    /// Samples per side.
    pub fn side(&self) -> usize {
        self.n
    }

    /// Number of levels, the unsplittable last one included.
    pub(crate) fn levels(&self) -> usize {
        self.level_start.len() - 1
    }

    /// Index of the first child of triangle `t` of level `l` (the second follows it): what
    /// the tests check derived children and level-by-level passes against.
    #[cfg(test)]
    pub(crate) fn first_child(&self, l: usize, t: usize) -> usize {
        self.level_start[l + 1] + 2 * (t - self.level_start[l])
    }
}

/// The sample halfway between samples `a` and `b` (the hypotenuse of every splittable
/// triangle has even extents, so it is a sample).
#[inline]
pub(crate) fn midpoint(a: u32, b: u32, n: usize) -> u32 {
    let n = n as u32;
    let (ax, ay, bx, by) = (a % n, a / n, b % n, b / n);
    ((ay + by) / 2) * n + (ax + bx) / 2
}

/// Whether a hypotenuse from `a` to `b` has a sample at its midpoint (even extents).
#[inline]
pub(crate) fn splits(a: u32, b: u32, n: usize) -> bool {
    let n = n as u32;
    // `a / n` or `b / n` as `* n` changes nothing below 2049²: a splittable hypotenuse has
    // both ends on even rows and columns and n is odd, so |a·n − by| and |ay − b·n| have
    // dy's parity, and are zero only if a = b. From 2049² on the product overflows u32,
    // which overflow checks catch on the 2049² hierarchy the tests build.
    let (dx, dy) = ((a % n).abs_diff(b % n), (a / n).abs_diff(b / n));
    // Called on hypotenuses only, where the first `&&` as `||` and `>` as `>=` change
    // nothing: a hypotenuse is diagonal (dx = dy) or along an axis (one extent zero, the
    // other at least 2), so dx and dy are both even or both odd, and its ends are two
    // corners of a triangle, never the same sample.
    dx % 2 == 0 && dy % 2 == 0 && dx + dy > 0
}

fn add_parent(slot: &mut [u32; 2], m: u32) {
    // Never taken (so `||` as `&&` changes nothing): a sample's parents are the right angles
    // of the triangles whose hypotenuse it halves, one on either side, so never the same
    // (`a_samples_parents_are_the_right_angles_of_the_triangles_it_halves`).
    if slot[0] == m || slot[1] == m {
        return;
    }
    if slot[0] == NONE {
        slot[0] = m;
    } else if slot[1] == NONE {
        slot[1] = m;
    } else {
        debug_assert!(false, "a bintree vertex has at most two parents");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_two_to_the_k_plus_one_sides_have_a_hierarchy() {
        for n in [3, 5, 9, 17, 257] {
            assert!(Hierarchy::new(n).is_some(), "{n}");
        }
        for n in [0, 1, 2, 4, 256, 258, 1000] {
            assert!(Hierarchy::new(n).is_none(), "{n}");
        }
    }

    #[test]
    fn levels_halve_the_area_and_the_last_level_is_unit_halves() {
        let h = Hierarchy::new(17).unwrap();
        assert_eq!(h.levels(), 9);
        for l in 0..h.levels() {
            assert_eq!(h.level_start[l + 1] - h.level_start[l], 2 << l);
        }
        let last = h.level_start[h.levels() - 1];
        assert!(
            h.tris[last..].iter().all(|t| t.m == NONE),
            "1 × 1 halves do not split"
        );
        assert!(h.tris[..last].iter().all(|t| t.m != NONE));
    }

    /// [`Tri::children`]'s midpoint arithmetic against the stored hierarchy's (found by
    /// division), on every splittable triangle of the smallest grid, a mid-size one and the
    /// serving size.
    #[test]
    fn children_are_the_hierarchys() {
        for n in [3, 65, 257] {
            let h = Hierarchy::new(n).unwrap();
            let splittable = h.levels() - 1;
            for l in 0..splittable {
                for t in h.level_start[l]..h.level_start[l + 1] {
                    let first = h.first_child(l, t);
                    for (k, child) in h.tris[t].children().into_iter().enumerate() {
                        let stored = h.tris[first + k];
                        let m = if l + 1 < splittable { child.m } else { NONE };
                        assert_eq!(Tri { m, ..child }, stored, "n {n} level {l} triangle {t}");
                    }
                }
            }
        }
    }

    #[test]
    fn every_non_corner_sample_is_a_midpoint_with_parents_except_the_root_centre() {
        let n = 33;
        let h = Hierarchy::new(n).unwrap();
        let corners = [0, n - 1, n * (n - 1), n * n - 1];
        let centre = (n / 2) * n + n / 2;
        for s in 0..n * n {
            let p = h.parents[s];
            if corners.contains(&s) || s == centre {
                assert_eq!(p, [NONE; 2], "sample {s}");
            } else {
                assert_ne!(p[0], NONE, "sample {s} has no parent");
            }
        }
    }
}
