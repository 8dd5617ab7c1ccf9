//! The decimation state: vertices removed one at a time, holes refilled, curvature kept
//! against the original's (paper §4, fig. 3).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;
use smallvec::SmallVec;

use super::measure::{discrete_curvature, measure_with, FaceGeom, Measure, Weights};
use super::refill::refill;
use crate::mesh::indexed::TriMesh;

/// A vertex removal worked out but not applied.
struct Removal {
    faces: Vec<[u32; 3]>,
    /// The refill's face geometry, parallel to `faces`: applying the removal reuses it.
    geoms: Vec<Option<FaceGeom>>,
    /// The ring's measures after the removal: the ring's new W once it is applied. They
    /// are what [`Decimator::measure_now`] would compute then, bit for bit (the same faces
    /// in the same order), and the trig behind them is most of decimation's time.
    measures: SmallVec<[(u32, Measure); 8]>,
    /// Per ring vertex, W_now − W_original = a·x + b with x = 1 / the area scale: the area
    /// scale follows N_now, so ε moves with every removal anywhere, not only with the ring.
    drift: SmallVec<[(f64, f64); 8]>,
}

/// ε (paper eq. 9) of a removal with ring drift `drift` at inverse area scale `x`.
fn epsilon(drift: &[(f64, f64)], x: f64) -> f64 {
    drift
        .iter()
        .fold(0.0, |e, &(a, b)| e.max((a * x + b).abs()))
}

/// The largest inverse area scale at which ε ≤ `bound`, if any: x only falls as vertices
/// go, so a removal refused above it passes once x has fallen that far.
fn passes_below(drift: &[(f64, f64)], bound: f64) -> Option<f64> {
    let (mut lo, mut hi) = (0.0_f64, f64::INFINITY);
    for &(a, b) in drift {
        if a > 0.0 {
            lo = lo.max((-bound - b) / a);
            hi = hi.min((bound - b) / a);
        } else if b.abs() > bound {
            return None;
        }
    }
    (lo <= hi).then_some(hi)
}

/// Parks refused removal `v` (at `ver`) until the inverse area scale, `x` now, has fallen to
/// where ε ≤ `bound`, if it ever does.
fn park(
    parked: &mut BinaryHeap<Entry>,
    drift: &[(f64, f64)],
    bound: f64,
    x: f64,
    v: u32,
    ver: u32,
) {
    // `at < x` as `at <= x` differs only when rounding puts a refused removal's pass point
    // on x itself (ε(x) > bound but (bound − b) / a = x): an equivalent mutant in practice.
    if let Some(at) = passes_below(drift, bound).filter(|&at| at < x) {
        parked.push(Entry(-at, v, ver));
    }
}

/// A removal that did not go, remembered until its neighbourhood changes: evaluating one
/// is most of decimation's time, and each level (and each step of a face target) tries
/// again every vertex the last one refused, mostly unchanged.
struct Refusal {
    /// [`Decimator::stamp`] of the vertex when it was evaluated.
    stamp: u32,
    /// The drift of [`Removal`], or `None` when the removal would break the surface.
    drift: Option<Box<[(f64, f64)]>>,
}

/// Min-heap entry: key, vertex, the vertex's version when pushed.
#[derive(PartialEq)]
struct Entry(f64, u32, u32);

impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap.
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

/// A mesh being decimated.
pub struct Decimator {
    pos: Vec<DVec3>,
    faces: Vec<[u32; 3]>,
    /// Each face's geometry; `None` for a degenerate face, which then adds nothing.
    geom: Vec<Option<FaceGeom>>,
    alive: Vec<bool>,
    /// Alive faces of each vertex.
    vf: Vec<Vec<u32>>,
    removed: Vec<bool>,
    /// Corners and non-manifold vertices of the input: never removed.
    locked: Vec<bool>,
    version: Vec<u32>,
    /// Each live vertex's measure on the current mesh.
    measure: Vec<Measure>,
    /// Moves on whenever a vertex's removal could evaluate differently: when its faces or
    /// any neighbour's faces change (a removal reads its ring's fans).
    stamp: Vec<u32>,
    refused: Vec<Option<Refusal>>,
    /// W of every vertex on the input mesh, and the input's scales.
    w_orig: Vec<f64>,
    area_max: f64,
    weighted_max: f64,
    /// Vertices of the input: the area scale follows the mean vertex area, which grows as
    /// N_input / N_now.
    input_vertices: usize,
    weights: Weights,
    lambda_c: f64,
    live_faces: usize,
    live_vertices: usize,
    /// Largest error of any removal applied so far.
    worst: f64,
}

impl Decimator {
    pub fn new(mesh: &TriMesh, weights: Weights, lambda_c: f64) -> Self {
        let n = mesh.positions.len();
        let mut vf = vec![Vec::new(); n];
        for (k, f) in mesh.faces.iter().enumerate() {
            for &v in f {
                vf[v as usize].push(k as u32);
            }
        }
        let mut d = Self {
            pos: mesh.positions.clone(),
            faces: mesh.faces.clone(),
            geom: mesh
                .faces
                .iter()
                .map(|f| FaceGeom::new(f.map(|v| mesh.positions[v as usize])))
                .collect(),
            alive: vec![true; mesh.faces.len()],
            vf,
            removed: vec![false; n],
            locked: vec![false; n],
            version: vec![0; n],
            measure: Vec::new(),
            stamp: vec![0; n],
            refused: std::iter::repeat_with(|| None).take(n).collect(),
            w_orig: vec![0.0; n],
            area_max: 0.0,
            weighted_max: 0.0,
            input_vertices: 0,
            weights,
            lambda_c,
            live_faces: mesh.faces.len(),
            live_vertices: 0,
            worst: 0.0,
        };
        let measures: Vec<Measure> = (0..n as u32).map(|v| d.measure_now(v)).collect();
        let q = d.weights.scale_quantile;
        d.area_max = quantile(measures.iter().map(|m| m.area).collect(), q);
        d.weighted_max = quantile(measures.iter().map(|m| m.weighted).collect(), q);
        for (v, m) in measures.iter().enumerate() {
            d.w_orig[v] = discrete_curvature(m, d.area_max, d.weighted_max, &d.weights);
            d.locked[v] = m.is_corner() || m.non_manifold;
            if d.vf[v].is_empty() {
                d.removed[v] = true;
            } else {
                d.live_vertices += 1;
            }
        }
        d.input_vertices = d.live_vertices;
        d.measure = measures;
        d
    }

    /// The area scale of eq. 8 when `live` vertices remain: the input's, grown with the mean
    /// vertex area (the paper's "average area of each step"), so coarsening evenly costs
    /// nothing and only uneven areas count.
    fn area_scale(&self, live: usize) -> f64 {
        self.area_max * self.input_vertices as f64 / live.max(1) as f64
    }

    /// 1 / [`Self::area_scale`] (0 when there is no area scale, as W then has no area part).
    fn inverse_scale(&self, live: usize) -> f64 {
        let s = self.area_scale(live);
        if s > 0.0 {
            1.0 / s
        } else {
            0.0
        }
    }

    pub fn faces(&self) -> usize {
        self.live_faces
    }

    pub fn vertices(&self) -> usize {
        self.live_vertices
    }

    /// Largest ε of the removals so far.
    pub fn worst_error(&self) -> f64 {
        self.worst
    }

    /// W of each input vertex (paper eq. 8), for inspection.
    pub fn original_curvature(&self) -> &[f64] {
        &self.w_orig
    }

    /// Removes vertices in order of W while each removal's ε stays ≤ `max_error` (paper §4).
    pub fn run_to_error(&mut self, max_error: f64) {
        self.run_to_error_until(max_error, 0);
    }

    /// Climbs the fixed ladder of bounds up to `max_error` ([`super::ladder`]), so a larger
    /// bound never keeps more faces; a bound below its first rung is one run to it.
    pub fn climb_to_error(&mut self, max_error: f64) {
        match super::ladder::top_rung(max_error) {
            Some(top) => super::ladder::climb(self, top, 0),
            None => {
                self.run_to_error(max_error);
            }
        }
    }

    /// [`Self::run_to_error`], stopping early once at most `floor` faces remain.
    ///
    /// A removal's ε changes when its ring changes (it is then re-queued) and also as the
    /// area scale grows with every removal anywhere. A removal refused for its ring's area
    /// drift is parked until the scale has grown enough for it to pass, then re-queued by
    /// W; without that a level kept every vertex refused early on, which the scale had
    /// freed by the end (the vase kept 78 % at ε = 0.15, now 68 %).
    ///
    /// Returns the least ε of the removals refused for it, for a caller that found nothing
    /// removed: the bound at which something goes next.
    pub fn run_to_error_until(&mut self, max_error: f64, floor: usize) -> Option<f64> {
        let mut least: Option<f64> = None;
        let mut refuse = |e: f64| least = Some(least.map_or(e, |l| l.min(e)));
        let mut heap: BinaryHeap<Entry> = (0..self.pos.len() as u32)
            .filter_map(|v| self.entry(v))
            .collect::<Vec<_>>()
            .into();
        // Parked removals keyed by −x: the largest inverse scale at which each passes.
        let mut parked = BinaryHeap::new();
        while let Some(Entry(_, v, ver)) = heap.pop() {
            if self.live_faces <= floor {
                break;
            }
            if ver != self.version[v as usize] || self.removed[v as usize] {
                continue;
            }
            let x = self.inverse_scale(self.live_vertices - 1);
            let refused = self.refused[v as usize]
                .as_ref()
                .filter(|r| r.stamp == self.stamp[v as usize])
                .map(|r| r.drift.as_deref());
            // Debug builds (the tests) check each remembered refusal against a fresh look.
            debug_assert!(
                refused.is_none_or(
                    |d| self.evaluate(v).map(|r| r.drift.to_vec()) == d.map(<[_]>::to_vec)
                )
            );
            // Only a shortcut: without the `Some(None)` arm, or with the guard `false`, a
            // remembered refusal is evaluated again and refused the same way (same stamp,
            // same drift; the debug assertion above checks it). Equivalent mutants.
            match refused {
                Some(None) => continue,
                Some(Some(drift)) if epsilon(drift, x) > max_error => {
                    refuse(epsilon(drift, x));
                    park(&mut parked, drift, max_error, x, v, ver);
                    continue;
                }
                _ => {}
            }
            let stamp = self.stamp[v as usize];
            let Some(r) = self.evaluate(v) else {
                self.refused[v as usize] = Some(Refusal { stamp, drift: None });
                continue;
            };
            let error = epsilon(&r.drift, x);
            if error > max_error {
                refuse(error);
                park(&mut parked, &r.drift, max_error, x, v, ver);
                let drift = Some(r.drift.into_vec().into_boxed_slice());
                self.refused[v as usize] = Some(Refusal { stamp, drift });
                continue;
            }
            let Removal {
                faces,
                geoms,
                measures,
                ..
            } = r;
            let ring = self.apply(v, faces, geoms, &measures, error);
            // Only the ring's W changed (the paper recomputes the 1-ring). Removals next to
            // the ring that were refused are not tried again this level, although their ε
            // moved too: re-trying that 2-ring tripled the fandisk's time.
            heap.extend(ring.into_iter().filter_map(|u| self.entry(u)));
            let x = self.inverse_scale(self.live_vertices.saturating_sub(1));
            while parked.peek().is_some_and(|e: &Entry| -e.0 >= x) {
                if let Some(Entry(_, u, ver)) = parked.pop() {
                    if ver == self.version[u as usize] {
                        heap.extend(self.entry(u));
                    }
                }
            }
        }
        least
    }

    /// Reaches at most `target` faces the paper's way: levels of growing ε, each removing in
    /// order of W, the last one stopped at the target. Ends early if nothing more can go.
    pub fn run_to_faces(&mut self, target: usize) {
        let mut bound = 0.02;
        // Equivalent: `>` as `>=` (a level run at the target stops at its first pop, its
        // floor reached), `<` as `<=` (no product of 0.02 by 1.15s and 2s is 64.0 exactly).
        while self.live_faces > target && bound < 64.0 {
            let before = self.live_faces;
            self.run_to_error_until(bound, target);
            bound *= if self.live_faces == before { 2.0 } else { 1.15 };
        }
    }

    /// The current mesh, unreferenced vertices dropped.
    pub fn mesh(&self) -> TriMesh {
        alive_mesh(&self.pos, &self.faces, &self.alive)
    }

    /// `v`'s place in the removal order (by its W now), if it may go.
    fn entry(&self, v: u32) -> Option<Entry> {
        // This guard and `evaluate`'s back each other up: either one as `&&` is an
        // equivalent mutant (a removed or locked vertex popped is refused by the other, or
        // skipped as removed at the pop).
        if self.removed[v as usize] || self.locked[v as usize] {
            return None;
        }
        let scale = self.area_scale(self.live_vertices);
        let w = discrete_curvature(
            &self.measure[v as usize],
            scale,
            self.weighted_max,
            &self.weights,
        );
        Some(Entry(w, v, self.version[v as usize]))
    }

    /// The alive faces of `v` with their geometry.
    fn with_geom(&self, v: u32) -> impl Iterator<Item = ([u32; 3], FaceGeom)> + '_ {
        self.vf[v as usize]
            .iter()
            .filter_map(|&f| self.geom[f as usize].map(|g| (self.faces[f as usize], g)))
    }

    fn measure_now(&self, v: u32) -> Measure {
        measure_with(
            v,
            self.with_geom(v),
            |i| self.pos[i as usize],
            &self.weights,
        )
    }

    /// Works out removing `v`: the refill and its ε, or `None` if the removal would break
    /// the surface (non-manifold ring, no valid refill, an edge or face that would double).
    fn evaluate(&self, v: u32) -> Option<Removal> {
        if self.removed[v as usize] || self.locked[v as usize] {
            return None;
        }
        let (r, faces) = refill(
            v,
            &self.vf,
            &self.faces,
            |i| self.pos[i as usize],
            self.lambda_c,
            Some(self.weights.feature_angle),
        )?;

        // ε: the largest change of W on the ring against the input (eq. 9), kept as a
        // function of the area scale.
        let mut drift = SmallVec::new();
        let mut measures = SmallVec::new();
        let geoms: Vec<Option<FaceGeom>> = faces
            .iter()
            .map(|&f| FaceGeom::new(f.map(|i| self.pos[i as usize])))
            .collect();
        let fresh: Vec<([u32; 3], FaceGeom)> = faces
            .iter()
            .zip(&geoms)
            .filter_map(|(&f, g)| g.map(|g| (f, g)))
            .collect();
        for &u in &r.vertices {
            let around = self
                .with_geom(u)
                .filter(|(f, _)| !f.contains(&v))
                .chain(fresh.iter().copied().filter(|(f, _)| f.contains(&u)));
            if self.vf[u as usize]
                .iter()
                .all(|&f| self.faces[f as usize].contains(&v))
                && !faces.iter().any(|f| f.contains(&u))
            {
                // u would be left without faces: that is a hole, not a decimation.
                return None;
            }
            let m = measure_with(u, around, |i| self.pos[i as usize], &self.weights);
            if m.non_manifold {
                return None;
            }
            // W = λ_a A x + (bending part): the bending part is W with no area scale.
            let bending = discrete_curvature(&m, f64::INFINITY, self.weighted_max, &self.weights);
            drift.push((
                self.weights.area * m.area,
                bending - self.w_orig[u as usize],
            ));
            measures.push((u, m));
        }
        Some(Removal {
            faces,
            geoms,
            measures,
            drift,
        })
    }

    /// Applies a removal; returns the ring, whose W changed (and whose versions move on).
    /// `measures` are the ring's measures after it ([`Removal::measures`]).
    fn apply(
        &mut self,
        v: u32,
        new_faces: Vec<[u32; 3]>,
        geoms: Vec<Option<FaceGeom>>,
        measures: &[(u32, Measure)],
        error: f64,
    ) -> Vec<u32> {
        // Every vertex whose removal reads a fan that changes: the ring's neighbours (v
        // and the ring among them). New edges join ring vertices only, so no vertex
        // becomes a ring vertex's neighbour without being stamped here.
        let touched = self.vf[v as usize]
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .flat_map(|u| &self.vf[u as usize])
            .flat_map(|&g| self.faces[g as usize]);
        for x in touched {
            self.stamp[x as usize] = self.stamp[x as usize].wrapping_add(1);
        }
        let dead: Vec<u32> = std::mem::take(&mut self.vf[v as usize]);
        let mut ring: Vec<u32> = Vec::new();
        for &f in &dead {
            self.alive[f as usize] = false;
            self.live_faces -= 1;
            for u in self.faces[f as usize] {
                if u != v {
                    self.vf[u as usize].retain(|&g| g != f);
                    if !ring.contains(&u) {
                        ring.push(u);
                    }
                }
            }
        }
        for (f, g) in new_faces.into_iter().zip(geoms) {
            let id = self.faces.len() as u32;
            self.faces.push(f);
            self.geom.push(g);
            self.alive.push(true);
            self.live_faces += 1;
            for u in f {
                self.vf[u as usize].push(id);
            }
        }
        self.removed[v as usize] = true;
        self.live_vertices -= 1;
        self.worst = self.worst.max(error);
        // A guard only: `evaluate` refuses a removal that would leave a ring vertex without
        // faces, so this never fires. Its `!` deleted and `-= 1` as `+=` or `/=` are
        // equivalent mutants (`&&` as `||` removes every ring vertex and is caught).
        for &u in &ring {
            if self.vf[u as usize].is_empty() && !self.removed[u as usize] {
                self.removed[u as usize] = true;
                self.live_vertices -= 1;
            }
        }
        for &u in &ring {
            self.version[u as usize] = self.version[u as usize].wrapping_add(1);
            self.measure[u as usize] = match measures.iter().find(|e| e.0 == u) {
                Some(&(_, m)) => m,
                None => self.measure_now(u),
            };
            debug_assert!(
                self.removed[u as usize] || self.measure[u as usize] == self.measure_now(u)
            );
        }
        ring
    }
}

/// The `q`-quantile of `v` (0 for an empty list).
fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let k = ((v.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
    v[k]
}

/// The faces marked alive over `positions`, unreferenced vertices dropped: what a
/// decimation that removes faces in place leaves behind.
pub(crate) fn alive_mesh(positions: &[DVec3], faces: &[[u32; 3]], alive: &[bool]) -> TriMesh {
    let mut mesh = TriMesh {
        positions: positions.to_vec(),
        faces: faces
            .iter()
            .zip(alive)
            .filter(|(_, &a)| a)
            .map(|(f, _)| *f)
            .collect(),
    };
    mesh.drop_unreferenced();
    mesh
}

#[cfg(test)]
mod tests {
    use super::super::tests::{flat_grid, uv_sphere};
    use super::super::DEFAULT_LAMBDA_C;
    use super::*;

    #[test]
    fn epsilon_is_the_largest_ring_drift_at_the_scale() {
        // |2·3 − 1| = 5 against |0.5·3 + 0.25| = 1.75.
        assert_eq!(epsilon(&[(2.0, -1.0), (0.5, 0.25)], 3.0), 5.0);
        assert_eq!(epsilon(&[(0.5, 0.25), (2.0, -1.0)], 0.25), 0.5);
        assert_eq!(epsilon(&[], 3.0), 0.0);
    }

    #[test]
    fn passes_below_is_the_largest_scale_that_keeps_every_drift_in_bound() {
        // |2x − 1| ≤ 3 up to x = 2.
        assert_eq!(passes_below(&[(2.0, -1.0)], 3.0), Some(2.0));
        // |2x − 10| ≤ 2 on [4, 6], |2x − 9| ≤ 2 on [3.5, 5.5]: both on [4, 5.5].
        assert_eq!(passes_below(&[(2.0, -10.0)], 2.0), Some(6.0));
        assert_eq!(passes_below(&[(2.0, -10.0), (2.0, -9.0)], 2.0), Some(5.5));
        // [4, 6] and [0, 2] do not meet: no scale passes.
        assert_eq!(passes_below(&[(2.0, -10.0), (2.0, -2.0)], 2.0), None);
        // No area part: in bound at every scale (|b| = bound included), or at none.
        assert_eq!(passes_below(&[(0.0, 0.5)], 1.0), Some(f64::INFINITY));
        assert_eq!(passes_below(&[(0.0, 1.0)], 1.0), Some(f64::INFINITY));
        assert_eq!(passes_below(&[(0.0, -3.0)], 1.0), None);
        assert_eq!(passes_below(&[(2.0, -1.0), (0.0, 3.0)], 1.0), None);
    }

    #[test]
    fn quantile_is_the_nearest_rank_in_sorted_order() {
        // 0 … 100 reversed: the q-quantile is the value at rank round(100 q) of the sorted
        // list, here the value q·100 itself.
        let v: Vec<f64> = (0..=100).rev().map(f64::from).collect();
        assert_eq!(quantile(v.clone(), 0.97), 97.0);
        assert_eq!(quantile(v.clone(), 0.5), 50.0);
        assert_eq!(quantile(v.clone(), 0.004), 0.0);
        assert_eq!(quantile(v.clone(), 0.006), 1.0);
        assert_eq!(quantile(v.clone(), 1.0), 100.0);
        // q is clamped to [0, 1]; an empty list has quantile 0.
        assert_eq!(quantile(v.clone(), 2.0), 100.0);
        assert_eq!(quantile(v, -1.0), 0.0);
        assert_eq!(quantile(vec![-3.0, -7.0], 0.97), -3.0);
        assert_eq!(quantile(Vec::new(), 0.5), 0.0);
    }

    #[test]
    fn one_run_removes_in_order_of_w_as_one_run_per_removal_does() {
        // With no area part (λ_a = 0) W does not move with the scale, and at an unbounded ε
        // nothing is parked: one run taking k removals must take the same ones as k runs
        // of one removal, each of which starts from a fresh queue of every vertex's W now.
        // A queue entry left from before a removal changed its vertex's W must be skipped:
        // taken at its old W, it removes out of order.
        let sphere = uv_sphere(10, 20, 1.0);
        let n = sphere.faces.len();
        let w = Weights {
            area: 0.0,
            ..Weights::default()
        };
        let k = 10;
        let mut one = Decimator::new(&sphere, w, DEFAULT_LAMBDA_C);
        one.run_to_error_until(f64::INFINITY, n - 2 * k);
        // Nothing refused: the one run had nothing it would not try again.
        assert!(one.refused.iter().all(Option::is_none));
        let mut each = Decimator::new(&sphere, w, DEFAULT_LAMBDA_C);
        for i in 1..=k {
            each.run_to_error_until(f64::INFINITY, n - 2 * i);
            assert_eq!(each.faces(), n - 2 * i);
        }
        assert_eq!(one.faces(), n - 2 * k);
        assert_eq!(one.mesh(), each.mesh());
    }

    #[test]
    fn a_removals_epsilon_is_its_rings_w_change_at_the_scale_after_it() {
        // Eq. 9 on the mesh the removal leaves: the ring's W there, its area part scaled by
        // the input's area scale × N_input / N_now with N_now the vertices left, against W
        // on the input.
        let sphere = uv_sphere(10, 20, 1.0);
        let n = sphere.faces.len();
        let mut d = Decimator::new(&sphere, Weights::default(), DEFAULT_LAMBDA_C);
        d.run_to_error_until(f64::INFINITY, n - 2);
        assert_eq!(d.vertices(), sphere.positions.len() - 1);
        let gone = d.removed.iter().position(|&r| r).unwrap() as u32;
        let mut ring: Vec<u32> = sphere
            .faces
            .iter()
            .filter(|f| f.contains(&gone))
            .flatten()
            .copied()
            .filter(|&u| u != gone)
            .collect();
        ring.sort_unstable();
        ring.dedup();
        assert!(ring.len() >= 3, "{ring:?}");
        let scale = d.area_max * sphere.positions.len() as f64 / d.vertices() as f64;
        let eps = ring
            .iter()
            .map(|&u| {
                let w = discrete_curvature(&d.measure_now(u), scale, d.weighted_max, &d.weights);
                (w - d.w_orig[u as usize]).abs()
            })
            .fold(0.0, f64::max);
        assert!(eps > 0.0);
        assert!(
            (d.worst_error() - eps).abs() <= 1e-12 * eps,
            "ε {} against {eps}",
            d.worst_error()
        );
    }

    #[test]
    fn a_removal_may_leave_no_ring_vertex_without_faces() {
        // The centre of a flat 3 × 3 grid: two of its ring's corners have no face but the
        // centre's, and keep faces of the refill, so the centre may go.
        let grid = flat_grid(3);
        let d = Decimator::new(&grid, Weights::default(), DEFAULT_LAMBDA_C);
        assert!(d.vf[0].iter().all(|&f| d.faces[f as usize].contains(&4)));
        let r = d.evaluate(4).expect("the centre may go");
        assert!(r.faces.iter().any(|f| f.contains(&0)), "{:?}", r.faces);
        // A lone triangle's corner: the refill has no face and lets it go, but the other
        // two corners would be left with none.
        let lone = TriMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            faces: vec![[0, 1, 2]],
        };
        let d = Decimator::new(&lone, Weights::default(), DEFAULT_LAMBDA_C);
        assert!(!d.locked[0]);
        let fill = refill(0, &d.vf, &d.faces, |i| d.pos[i as usize], 0.5, None);
        assert_eq!(fill.map(|(_, new)| new.len()), Some(0));
        assert!(d.evaluate(0).is_none());
    }
}
