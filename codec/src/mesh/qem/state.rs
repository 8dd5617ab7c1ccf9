//! The mutable state of one QEM run and its setup: vertices renumbered along a Morton curve,
//! quadrics from face planes, per-vertex face slices, boundary and crease penalty planes,
//! aggregation partners, ranking, and the renumbered output.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

use super::quadric::Quadric;
use super::ranked::{key_of, Entry};
use super::{plane, QemOptions, QemReport, Stop};
use crate::mesh::error::MeshError;
use crate::mesh::indexed::{Aabb, TriMesh};

/// Marks a dead face (its first index) and "no vertex".
pub(super) const DEAD: u32 = u32::MAX;
pub(super) const ALIVE: u8 = 1;
pub(super) const BOUNDARY: u8 = 2;
/// On a non-manifold edge: never moved.
pub(super) const LOCKED: u8 = 4;
/// Took part in an aggregation: its neighbourhood may be non-manifold, so the link condition
/// no longer applies (paper §3.1); duplicate faces are removed instead.
pub(super) const AGGREGATED: u8 = 8;
/// Faces are addressed with u32 and each has three references: stay well inside.
const MAX_FACES: usize = 1 << 30;
/// Non-edge partners kept per vertex when aggregating (the nearest ones).
const MAX_PARTNERS: usize = 8;
/// Vertex count from which the working order follows a Morton curve.
const SPATIAL_ORDER_MIN_VERTICES: usize = 1 << 16;
/// Among equal errors (flat regions have none) shorter edges rank first: the ranking key is
/// error + `TIE_BREAK` · length², far below any error that matters.
const TIE_BREAK: f64 = 1e-8;

/// A vertex's position and quadric in two cache lines.
#[derive(Clone, Copy, Debug, Default)]
#[repr(align(64))]
pub(super) struct Geo {
    pub q: Quadric,
    pub pos: DVec3,
}

pub(super) struct State {
    /// Working id of each input vertex (working ids follow a Morton curve).
    new_of: Vec<u32>,
    /// Position and quadric of each vertex, together: every evaluation reads both.
    pub(super) geo: Vec<Geo>,
    /// Version counters: bumped whenever a vertex moves or dies.
    pub(super) stamp: Vec<u32>,
    pub(super) flags: Vec<u8>,
    pub(super) faces: Vec<[u32; 3]>,
    /// Each face's unit normal in the input (zero for no area): no contraction may turn a
    /// face to face away from it, however small each step.
    pub(super) normal_in: Vec<Vec3>,
    /// Faces of v: `refs[start[v]..start[v] + count[v]]` (dead faces are skipped on reading).
    pub(super) start: Vec<u32>,
    pub(super) count: Vec<u32>,
    pub(super) refs: Vec<u32>,
    /// Length of `refs` after the last compaction.
    refs_compact: usize,
    /// Every manifold edge once, smaller vertex first: the first ranking's input, listed as
    /// entries so the ranking fills in their keys where they are (one list, not two).
    edges: Vec<Entry>,
    /// Scratch marks for neighbour sets, valid where equal to the current generation.
    pub(super) mark: Vec<u32>,
    generation: u32,
    /// Scratch for [`Self::collect_vertex`]: a vertex's neighbours.
    nbrs: Vec<u32>,
    pub(super) live_faces: usize,
    /// Non-edge partners per vertex (empty unless aggregating).
    pub(super) partners: Vec<Vec<u32>>,
    /// cos of the largest normal turn allowed.
    pub(super) cos_turn: f64,
    /// A squared distance far below anything measurable (1e-9 of the diagonal, squared).
    pub(super) tiny_sq: f64,
    pub(super) report: QemReport,
}

impl State {
    pub(super) fn new(
        mesh: &TriMesh,
        options: &QemOptions,
        diagonal: f64,
    ) -> Result<Self, MeshError> {
        let n = mesh.positions.len();
        if mesh.faces.len() > MAX_FACES || n > MAX_FACES {
            return Err(MeshError::Limit {
                what: "faces for simplification",
                got: mesh.faces.len().max(n) as u64,
                limit: MAX_FACES as u64,
            });
        }
        // Large meshes get their vertices in Morton order: neighbours end up close in memory,
        // which is much of the speed of the contraction loop once the data outgrows the caches
        // (small meshes run a little faster without the sort).
        let order = (n > SPATIAL_ORDER_MIN_VERTICES).then(|| spatial_order(&mesh.positions));
        let mut new_of: Vec<u32> = (0..n as u32).collect();
        if let Some(order) = &order {
            for (new, &old) in order.iter().enumerate() {
                new_of[old as usize] = new as u32;
            }
        }
        // Faces that repeat a vertex carry no plane and would confuse the link condition.
        let mut faces: Vec<[u32; 3]> = Vec::with_capacity(mesh.faces.len());
        faces.extend(
            mesh.faces
                .iter()
                .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
                .map(|t| t.map(|i| new_of[i as usize])),
        );
        if n > SPATIAL_ORDER_MIN_VERTICES {
            // Faces follow their first vertex on the curve too (a counting sort).
            faces = sort_by_first_vertex(&faces, n);
        }
        // Positions go straight into their records (no intermediate copy: every page this
        // setup touches is a page fault on a fresh heap, and those add up at 10 k faces).
        let at = |new: usize| order.as_ref().map_or(new, |o| o[new] as usize);
        let mut geo: Vec<Geo> = (0..n)
            .map(|v| Geo {
                q: Quadric::default(),
                pos: mesh.positions[at(v)],
            })
            .collect();
        drop(order);
        // Fundamental quadrics K_p, area-weighted, summed into each corner (paper §5).
        let mut normal_in = Vec::with_capacity(faces.len());
        for t in &faces {
            let [a, b, c] = t.map(|i| geo[i as usize].pos);
            // One normal serves the plane and the orientation record.
            if let Some((normal, d, area)) = plane(a, b, c) {
                normal_in.push(normal.as_vec3());
                let k = Quadric::from_plane(normal, d, area);
                for &i in t {
                    geo[i as usize].q += k;
                }
            } else {
                normal_in.push(Vec3::ZERO);
            }
        }
        // Faces around each vertex, by counting, straight into the growable reference layout
        // (its capacity leaves room for the slices contractions rewrite at the end).
        let mut count = vec![0u32; n];
        for &i in faces.iter().flatten() {
            count[i as usize] += 1;
        }
        // `start` runs as each slice's end while filling, and is its start afterwards.
        let mut start = Vec::with_capacity(n);
        let mut total = 0u32;
        for &c in &count {
            total += c;
            start.push(total);
        }
        let mut refs = Vec::with_capacity(3 * total as usize + 4096);
        refs.resize(total as usize, 0u32);
        for (f, t) in faces.iter().enumerate().rev() {
            for &i in t {
                let s = &mut start[i as usize];
                *s -= 1;
                refs[*s as usize] = f as u32;
            }
        }
        let flags = count
            .iter()
            .map(|&c| if c > 0 { ALIVE } else { 0 })
            .collect();
        let report = QemReport {
            vertices_in: n,
            faces_in: mesh.faces.len(),
            vertices_out: 0,
            faces_out: 0,
            collapses: 0,
            aggregations: 0,
            rejected_topology: 0,
            rejected_flip: 0,
            passes: 0,
            max_error: 0.0,
            stop: Stop::TargetReached,
        };
        Ok(Self {
            new_of,
            geo,
            stamp: vec![0; n],
            flags,
            live_faces: faces.len(),
            faces,
            normal_in,
            start,
            count,
            refs_compact: refs.len().max(4096),
            edges: Vec::with_capacity(refs.len() / 2 + 16),
            refs,
            mark: vec![0; n],
            generation: 0,
            nbrs: Vec::new(),
            partners: Vec::new(),
            cos_turn: options.max_normal_turn_deg.to_radians().cos(),
            tiny_sq: (1e-9 * diagonal).powi(2),
            report,
        })
    }

    pub(super) fn ring(&self, v: u32) -> &[u32] {
        let s = self.start[v as usize] as usize;
        &self.refs[s..s + self.count[v as usize] as usize]
    }

    /// A fresh mark value (and the one after it, which callers may use as a second mark).
    /// Equivalent slips: `>=` as `<` clears the marks on every call (right, only slower), and
    /// `u32::MAX - 2` as `/ 2` clears them at 2³¹ instead.
    pub(super) fn next_generation(&mut self) -> u32 {
        if self.generation >= u32::MAX - 2 {
            self.mark.fill(0);
            self.generation = 0;
        }
        self.generation += 2;
        self.generation
    }

    /// Counts, for each vertex, how many of its faces hold each neighbour: one face is a
    /// boundary edge, three or more a non-manifold one (both ends locked). Boundary edges get
    /// a penalty plane through the edge perpendicular to its face (paper §6); creases (two
    /// faces meeting at more than the crease angle) get one per face, and the two meet in the
    /// crease line, which pins the crease and its corners the way a boundary plane pins a
    /// boundary. Penalties are weighted by squared edge length, to scale like face areas.
    pub(super) fn classify_edges(&mut self, options: &QemOptions) {
        let crease_cos = options.crease_angle_deg.to_radians().cos();
        let n = self.geo.len();
        // Per neighbour u of v: how many faces hold edge (v, u), and the first two of them.
        let mut slot = vec![0u32; n];
        let mut seen: Vec<(u32, u32, [u32; 2])> = Vec::new();
        for v in 0..n as u32 {
            let g = self.next_generation();
            seen.clear();
            let (s, c) = (
                self.start[v as usize] as usize,
                self.count[v as usize] as usize,
            );
            for &f in &self.refs[s..s + c] {
                for u in self.faces[f as usize] {
                    // Each edge once, from its smaller end (which sees all of its faces).
                    if u <= v {
                        continue;
                    }
                    if self.mark[u as usize] == g {
                        let e = &mut seen[slot[u as usize] as usize];
                        if e.1 < 2 {
                            e.2[e.1 as usize] = f;
                        }
                        e.1 += 1;
                    } else {
                        self.mark[u as usize] = g;
                        slot[u as usize] = seen.len() as u32;
                        seen.push((u, 1, [f, DEAD]));
                    }
                }
            }
            for &(u, times, fs) in &seen {
                if times <= 2 {
                    self.edges.push(Entry {
                        a: v,
                        b: u,
                        ..Entry::default()
                    });
                }
                match times {
                    1 => {
                        self.flags[v as usize] |= BOUNDARY;
                        self.flags[u as usize] |= BOUNDARY;
                        // `>` as `>=` is equivalent: a weight of 0 adds planes of all zeros.
                        if options.boundary_weight > 0.0 {
                            self.add_edge_planes(v, u, &fs[..1], options.boundary_weight);
                        }
                    }
                    2 => {
                        if options.crease_weight <= 0.0 {
                            continue;
                        }
                        // Unit normals (zero where a face has no area): sharp means the
                        // faces turn by more than the crease angle.
                        let (n0, n1) = (
                            self.normal_in[fs[0] as usize],
                            self.normal_in[fs[1] as usize],
                        );
                        let sharp = n0 != Vec3::ZERO
                            && n1 != Vec3::ZERO
                            && f64::from(n0.dot(n1)) < crease_cos;
                        if sharp {
                            self.add_edge_planes(v, u, &fs, options.crease_weight);
                        }
                    }
                    _ => {
                        self.flags[v as usize] |= LOCKED;
                        self.flags[u as usize] |= LOCKED;
                    }
                }
            }
        }
    }

    /// Penalty planes through edge (v, u), one perpendicular to each face in `faces`.
    fn add_edge_planes(&mut self, v: u32, u: u32, faces: &[u32], weight: f64) {
        let (p, q) = (self.geo[v as usize].pos, self.geo[u as usize].pos);
        let edge = q - p;
        for &f in faces {
            let Some(normal) = self.normal_in[f as usize].as_dvec3().try_normalize() else {
                continue;
            };
            if let Some(side) = edge.cross(normal).try_normalize() {
                let plane = Quadric::penalty(side, -side.dot(p), weight * edge.length_squared());
                self.geo[v as usize].q += plane;
                self.geo[u as usize].q += plane;
            }
        }
    }

    /// The pair's summed quadric, the point that minimises it and the value there: the
    /// regularised solve inline, the paper's fallback out of line (it keeps the sum out of
    /// memory on the common path).
    #[inline(always)]
    fn optimum(&self, a: u32, b: u32) -> (Quadric, DVec3, f64) {
        let (ga, gb) = (&self.geo[a as usize], &self.geo[b as usize]);
        let q = ga.q + gb.q;
        let (p, e) = q
            .solve(ga.pos, gb.pos)
            .unwrap_or_else(|| Quadric::segment_fallback(&ga.q, &gb.q, ga.pos, gb.pos));
        (q, p, e)
    }

    /// The contraction target alone (the error is already in the ranked entry).
    #[inline]
    pub(super) fn target(&self, a: u32, b: u32) -> DVec3 {
        self.optimum(a, b).1
    }

    /// The pair (a, b) ranked now, unless a vertex is locked. Always inlined into its two
    /// callers (measured: fandisk 978 −2 %, the bunny within noise).
    #[inline(always)]
    fn entry(&self, a: u32, b: u32) -> Option<Entry> {
        if (self.flags[a as usize] | self.flags[b as usize]) & LOCKED != 0 {
            return None;
        }
        let (q, _, e) = self.optimum(a, b);
        let e = if q.w > 0.0 { e / q.w } else { e };
        // Only overflowing coordinates give NaN; rank those last.
        let e = if e.is_nan() { f64::INFINITY } else { e };
        let len_sq = (self.geo[a as usize].pos - self.geo[b as usize].pos).length_squared();
        let key = e + TIE_BREAK * len_sq;
        Some(Entry {
            key: key_of(key as f32),
            a,
            b,
            stamp: self.stamps(a, b),
        })
    }

    /// Both version counters in one number: they only grow, so the sum changes with either.
    pub(super) fn stamps(&self, a: u32, b: u32) -> u32 {
        self.stamp[a as usize].wrapping_add(self.stamp[b as usize])
    }

    /// The pairs of `v` (edges and non-edge partners) with the neighbours `take` accepts,
    /// ranked now.
    pub(super) fn collect_vertex(
        &mut self,
        v: u32,
        take: impl Fn(u32) -> bool,
        out: &mut Vec<Entry>,
    ) {
        // `& ALIVE` as `| ALIVE` (never 0: no check) is equivalent: only vertices that have
        // just kept a contraction are collected, and those are alive.
        if self.flags[v as usize] & ALIVE == 0 {
            return;
        }
        let g = self.next_generation();
        self.mark[v as usize] = g;
        let (s, c) = (
            self.start[v as usize] as usize,
            self.count[v as usize] as usize,
        );
        // The neighbours first, each once, without a branch on whether it was seen (half the
        // corners were, at random); then their pairs.
        let mut nbrs = std::mem::take(&mut self.nbrs);
        nbrs.clear();
        nbrs.resize(3 * c, 0);
        let mut n = 0;
        for i in s..s + c {
            let t = self.faces[self.refs[i] as usize];
            if t[0] == DEAD {
                continue;
            }
            for u in t {
                let m = &mut self.mark[u as usize];
                nbrs[n] = u;
                n += usize::from(*m != g);
                *m = g;
            }
        }
        for &u in &nbrs[..n] {
            if take(u) {
                out.extend(self.entry(v, u));
            }
        }
        self.nbrs = nbrs;
        if let Some(ps) = self.partners.get(v as usize) {
            for &u in ps {
                if self.flags[u as usize] & ALIVE != 0 && self.mark[u as usize] != g && take(u) {
                    self.mark[u as usize] = g;
                    out.extend(self.entry(v, u));
                }
            }
        }
    }

    /// Every edge once (as [`Self::classify_edges`] listed them) and every non-edge partner
    /// pair, ranked (not yet sorted).
    pub(super) fn collect(&mut self) -> Vec<Entry> {
        let mut out = std::mem::take(&mut self.edges);
        let mut kept = 0;
        for i in 0..out.len() {
            if let Some(e) = self.entry(out[i].a, out[i].b) {
                out[kept] = e;
                kept += 1;
            }
        }
        out.truncate(kept);
        for v in 0..self.partners.len() {
            for i in 0..self.partners[v].len() {
                let u = self.partners[v][i];
                // `>` as `>=` is equivalent: a vertex is not its own partner.
                if u > v as u32 {
                    out.extend(self.entry(v as u32, u));
                }
            }
        }
        out
    }

    /// Pairs of vertices closer than `t` that share no face (paper §3.1 aggregation), found
    /// through a uniform grid of cell size `t`; each vertex keeps its nearest few.
    pub(super) fn add_virtual_pairs(&mut self, t: f64) {
        if !(t > 0.0 && t.is_finite()) {
            return;
        }
        let cell = |p: DVec3| (p / t).floor().as_i64vec3().to_array();
        // `ALIVE | LOCKED` as `^` is equivalent: different bits.
        let free = |flags: u8| flags & (ALIVE | LOCKED) == ALIVE;
        let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for v in 0..self.geo.len() as u32 {
            if free(self.flags[v as usize]) {
                grid.entry(cell(self.geo[v as usize].pos))
                    .or_default()
                    .push(v);
            }
        }
        self.partners = vec![Vec::new(); self.geo.len()];
        let mut near = Vec::new();
        for v in 0..self.geo.len() as u32 {
            if !free(self.flags[v as usize]) {
                continue;
            }
            // v's neighbours are marked: they are edges already.
            let g = self.next_generation();
            for i in 0..self.count[v as usize] as usize {
                let t = self.faces[self.refs[self.start[v as usize] as usize + i] as usize];
                for u in t {
                    self.mark[u as usize] = g;
                }
            }
            let p = self.geo[v as usize].pos;
            let [x, y, z] = cell(p);
            near.clear();
            // p's cell and those around it. `x + dx` as `x - dx` visits the same cells in
            // another order, which reorders only candidates exactly as far from p (not tested).
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(bucket) = grid.get(&[x + dx, y + dy, z + dz]) else {
                            continue;
                        };
                        for &u in bucket {
                            let d = (self.geo[u as usize].pos - p).length_squared();
                            // `u > v` as `>=` is equivalent: v marked itself with its faces.
                            if u > v && self.mark[u as usize] != g && d < t * t {
                                near.push((d, u));
                            }
                        }
                    }
                }
            }
            near.sort_by(|a, b| a.0.total_cmp(&b.0));
            for &(_, u) in near.iter().take(MAX_PARTNERS) {
                self.partners[v as usize].push(u);
                self.partners[u as usize].push(v);
            }
        }
    }

    /// Rewrites the reference array once dead slices make up half of it, keeping memory and
    /// cache footprint proportional to the live mesh.
    pub(super) fn maybe_compact(&mut self) {
        // Compacting changes no result, only memory: `2 *` as `2 +` or `2 /` compacts more
        // often (equivalent: only slower). `<=` as `>` compacts after every pass that leaves
        // the array within twice its last compacted length, and never again after one that
        // does not (memory only; not tested).
        if self.refs.len() <= 2 * self.refs_compact {
            return;
        }
        let mut refs = Vec::with_capacity(9 * self.live_faces + 4096);
        for v in 0..self.geo.len() {
            let (s, c) = (self.start[v] as usize, self.count[v] as usize);
            let new_start = refs.len();
            refs.extend(
                self.refs[s..s + c]
                    .iter()
                    .filter(|&&f| self.faces[f as usize][0] != DEAD),
            );
            self.start[v] = new_start as u32;
            self.count[v] = (refs.len() - new_start) as u32;
        }
        self.refs = refs;
        self.refs_compact = self.refs.len().max(4096);
    }

    /// The surviving faces over the surviving vertices, renumbered in input order.
    pub(super) fn finish(mut self) -> (TriMesh, QemReport) {
        let mut remap = vec![DEAD; self.geo.len()];
        for t in &self.faces {
            if t[0] != DEAD {
                for &i in t {
                    remap[i as usize] = 0;
                }
            }
        }
        let mut positions = Vec::new();
        for &v in &self.new_of {
            let r = &mut remap[v as usize];
            if *r == 0 {
                *r = positions.len() as u32;
                positions.push(self.geo[v as usize].pos);
            }
        }
        let faces: Vec<[u32; 3]> = self
            .faces
            .iter()
            .filter(|t| t[0] != DEAD)
            .map(|t| t.map(|i| remap[i as usize]))
            .collect();
        self.report.vertices_out = positions.len();
        self.report.faces_out = faces.len();
        (TriMesh::new(positions, faces), self.report)
    }
}

/// Vertex ids sorted along a Morton (Z-order) curve of their positions, 10 bits an axis (ties
/// keep input order).
fn spatial_order(positions: &[DVec3]) -> Vec<u32> {
    let bounds = Aabb::from_points(positions);
    let extent = (bounds.max - bounds.min).max_element();
    // Equivalent: `&&` as `||` and `>` as `>=` (an infinite extent gives a scale of 0 either
    // way, and a zero one an infinite scale times 0, NaN, which is 0 as an integer).
    let scale = if extent > 0.0 && extent.is_finite() {
        1023.0 / extent
    } else {
        0.0
    };
    let spread = |x: u64| {
        // Two zero bits between each of the 10 low bits of x. Each `|` below joins disjoint
        // bits, so as `^` it is equivalent (4, and 2 in the key).
        let mut x = x & 0x3ff;
        x = (x | x << 16) & 0x0300_00ff;
        x = (x | x << 8) & 0x0300_f00f;
        x = (x | x << 4) & 0x030c_30c3;
        (x | x << 2) & 0x0924_9249
    };
    let keys: Vec<u32> = positions
        .iter()
        .map(|p| {
            let q = ((*p - bounds.min) * scale).max(DVec3::ZERO);
            let [x, y, z] = q.to_array().map(|c| c as u64);
            (spread(x) | spread(y) << 1 | spread(z) << 2) as u32
        })
        .collect();
    // LSD radix sort of the ids by 30-bit key, 10 bits a pass (stable: ties keep input order).
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    let mut scratch = vec![0u32; order.len()];
    let mut counts = vec![0usize; 1025];
    for shift in [0, 10, 20] {
        counts.fill(0);
        for &i in &order {
            counts[(keys[i as usize] >> shift) as usize % 1024 + 1] += 1;
        }
        for d in 0..1024 {
            counts[d + 1] += counts[d];
        }
        for &i in &order {
            let d = (keys[i as usize] >> shift) as usize % 1024;
            scratch[counts[d]] = i;
            counts[d] += 1;
        }
        std::mem::swap(&mut order, &mut scratch);
    }
    order
}

/// Faces stably sorted by their smallest vertex id, by counting.
fn sort_by_first_vertex(faces: &[[u32; 3]], vertex_count: usize) -> Vec<[u32; 3]> {
    let first = |t: &[u32; 3]| t[0].min(t[1]).min(t[2]) as usize;
    let mut at = vec![0usize; vertex_count + 1];
    for t in faces {
        at[first(t) + 1] += 1;
    }
    for v in 0..vertex_count {
        at[v + 1] += at[v];
    }
    let mut out = vec![[0u32; 3]; faces.len()];
    for t in faces {
        let slot = &mut at[first(t)];
        out[*slot] = *t;
        *slot += 1;
    }
    out
}

#[cfg(test)]
#[path = "state_tests.rs"]
mod tests;
