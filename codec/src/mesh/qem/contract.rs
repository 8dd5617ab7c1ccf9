//! The contraction loop: passes over the ranked pairs, the link condition, the normal test,
//! and the contraction itself.

use glam::DVec3;

use super::ranked::{merge, radix_sort};
use super::state::{State, AGGREGATED, ALIVE, BOUNDARY, DEAD};
use super::Stop;

/// A pass stops at this multiple of the error of the pair that would meet the goal if no pair
/// were locked (meshoptimizer's rule: later pairs are worth re-ranking first).
const PASS_ERROR_SLACK: f32 = 1.5;
/// How many pairs ahead of the one being taken the faces are asked for (the records twice as
/// far). On the 1.1M-face bunny 8 and 16 measured the same; either is several misses' worth
/// of work for a pair that is taken.
const PREFETCH_AHEAD: usize = 8;
/// Vertex count above which the pass prefetches and re-ranks in memory order: the records of
/// 16 k vertices (2 MB) outgrow a core's L2. Measured: the Stanford bunny (35 k vertices)
/// → 6,945 faces 40–41 → 34 ms; the fandisk and the UV sphere (5–6 k) stay below it.
const PREFETCH_MIN_VERTICES: usize = 1 << 14;

impl State {
    /// Passes until the face target or the squared error limit stops them: rank all pairs
    /// once; in each pass contract pairs in error order, skipping pairs whose vertices changed
    /// (in this pass or before: their stamps no longer match), so every error used is exact;
    /// then re-rank the moved vertices' pairs and merge them in.
    pub(super) fn run(&mut self, target_faces: usize, limit_sq: f64) -> Stop {
        let (mut fresh, mut scratch) = (Vec::new(), Vec::new());
        let mut moved = Vec::new();
        let mut touched = vec![0u32; self.geo.len()];
        let limit = limit_sq as f32;
        // Only where the records outgrow the caches: below that the asking is pure overhead.
        let large = self.geo.len() > PREFETCH_MIN_VERTICES;
        // Entries in `ranked` whose vertices changed since (an upper estimate).
        let mut stale = 0usize;
        let mut ranked = self.collect();
        radix_sort(&mut ranked, &mut scratch);
        for pass in 1u32.. {
            if self.live_faces <= target_faces {
                return Stop::TargetReached;
            }
            self.report.passes += 1;
            let goal = (self.live_faces - target_faces).div_ceil(2);
            let cap = ranked
                .get(goal + stale)
                .map_or(f32::INFINITY, |e| PASS_ERROR_SLACK * e.error());
            let (mut done, mut over_limit) = (0usize, false);
            // Entries before `end` were looked at this pass: only the refused ones stay valid.
            let mut end = ranked.len();
            moved.clear();
            for (i, e) in ranked.iter().enumerate() {
                // Prefetches only ask the caches: no result depends on them, so their offsets'
                // `+` as `*` and `2 * ` as `2 +` or `2 /` are equivalent (`-` underflows).
                if large {
                    if let Some(ahead) = ranked.get(i + 2 * PREFETCH_AHEAD) {
                        self.prefetch_pair(ahead.a, ahead.b);
                    }
                    if let Some(ahead) = ranked.get(i + PREFETCH_AHEAD) {
                        self.prefetch_faces(ahead.a);
                        self.prefetch_faces(ahead.b);
                    }
                }
                if self.live_faces <= target_faces {
                    return Stop::TargetReached;
                }
                if e.error() > cap && done > goal / 6 {
                    end = i;
                    break;
                }
                let (a, b) = (e.a, e.b);
                // The stamp check alone skips pairs with a dead end (a vertex's stamp is bumped
                // when it dies, and pairs are ranked only between live vertices), so `& ALIVE`
                // as `| ALIVE` (never 0: no check) is equivalent.
                if self.stamps(a, b) != e.stamp || self.flags[b as usize] & ALIVE == 0 {
                    continue;
                }
                if e.error() > limit {
                    over_limit = true;
                    end = i;
                    break;
                }
                // The optimum first: the link condition's walk over both face fans tests it
                // for folds on the way (the link condition almost never refuses).
                let p = self.target(a, b);
                let (link, folds) = self.link_condition(a, b, p);
                let Ok(removed) = link else {
                    self.report.rejected_topology += 1;
                    continue;
                };
                let err = f64::from(e.error());
                let placed = if folds {
                    self.endpoint_placement(a, b, err)
                } else {
                    Some(p)
                };
                let Some(p) = placed else {
                    self.report.rejected_flip += 1;
                    continue;
                };
                stale += (self.count[a as usize] + self.count[b as usize]) as usize;
                self.contract(a, b, p, removed);
                self.report.max_error = self.report.max_error.max(err.sqrt());
                touched[a as usize] = pass;
                touched[b as usize] = pass;
                moved.push(a);
                done += 1;
            }
            if done == 0 {
                return if over_limit {
                    Stop::ErrorLimit
                } else {
                    Stop::NoValidCollapse
                };
            }
            // Re-rank the moved vertices' pairs (once per pair) and merge them in. Stale entries
            // go where this pass already looked (the check is cheap there: those vertices are
            // in cache), and everywhere once they could make up a third of the list.
            fresh.clear();
            if large {
                // In memory order (the vertices follow a Morton curve): neighbours share
                // cache lines. Only large meshes, where it pays.
                moved.sort_unstable();
            }
            for (k, &a) in moved.iter().enumerate() {
                // A prefetch: `+` as `*` is equivalent (see above).
                if let Some(&ahead) = moved.get(k + PREFETCH_AHEAD).filter(|_| large) {
                    self.prefetch_pair(ahead, ahead);
                }
                // `u > a` as `u >= a` is equivalent: a is not its own neighbour.
                self.collect_vertex(a, |u| touched[u as usize] != pass || u > a, &mut fresh);
            }
            radix_sort(&mut fresh, &mut scratch);
            let purge = 3 * stale > ranked.len();
            let (stamp, flags) = (&self.stamp, &self.flags);
            let checked = if purge { ranked.len() } else { end };
            // `&`, not `&&`: no branch (see `merge`). The stamp test alone drops pairs with a
            // dead end (as in the pass above), so either `&` of the first test as `|` (a weaker
            // test, or none) is equivalent.
            let dropped = merge(&mut ranked, &fresh, &mut scratch, checked, |e| {
                (flags[e.a as usize] & flags[e.b as usize] & ALIVE != 0)
                    & (stamp[e.a as usize].wrapping_add(stamp[e.b as usize]) == e.stamp)
            });
            stale = if purge {
                0
            } else {
                stale.saturating_sub(dropped)
            };
            std::mem::swap(&mut ranked, &mut scratch);
            self.maybe_compact();
        }
        Stop::NoValidCollapse
    }

    /// Asks the caches for what taking the pair (a, b) reads first. The pass visits pairs in
    /// error order, so on a mesh larger than the caches (the 1.1M-face bunny: 71 MB of
    /// vertex records) nearly every pair starts with misses on both vertices; the ranked list
    /// says which vertices come next, so their loads can be in flight a few pairs early.
    /// Only a hint: as `()` it changes no result (equivalent).
    #[inline]
    fn prefetch_pair(&self, a: u32, b: u32) {
        for v in [a as usize, b as usize] {
            if let (Some(g), Some(s), Some(c), Some(st)) = (
                self.geo.get(v),
                self.start.get(v),
                self.count.get(v),
                self.stamp.get(v),
            ) {
                mem_prefetch::prefetch_read_data::<_, 3>(&g.q);
                mem_prefetch::prefetch_read_data::<_, 3>(&g.pos);
                mem_prefetch::prefetch_read_data::<_, 3>(s);
                mem_prefetch::prefetch_read_data::<_, 3>(c);
                mem_prefetch::prefetch_read_data::<_, 3>(st);
            }
        }
    }

    /// The second step of [`Self::prefetch_pair`], once `v`'s slice bounds are in cache: its
    /// face list and the faces themselves, which the link condition reads first. Only a hint:
    /// as `()`, or with `s + c` as `s * c` (other faces, or none), it changes no result.
    #[inline]
    fn prefetch_faces(&self, v: u32) {
        let (Some(&s), Some(&c)) = (self.start.get(v as usize), self.count.get(v as usize)) else {
            return;
        };
        let (s, c) = (s as usize, c as usize);
        if let Some(refs) = self.refs.get(s..s + c) {
            for &f in refs {
                if let Some(t) = self.faces.get(f as usize) {
                    mem_prefetch::prefetch_read_data::<_, 3>(t);
                }
            }
        }
    }

    /// The link condition for contracting (a, b): the only common neighbours of a and b are
    /// the far corners of the faces on the edge, an interior edge does not join two boundary
    /// vertices, and no tetrahedron-like cap folds shut. Returns how many faces the
    /// contraction removes (0 for a non-edge pair), and whether moving a and b to `p` turns a
    /// surviving face too far ([`Self::turns_too_far`] for both ends, in the same walk: the
    /// faces are loaded once instead of twice).
    fn link_condition(&mut self, a: u32, b: u32, p: DVec3) -> (Result<usize, ()>, bool) {
        let mut folds = false;
        let (pa, pb) = (self.geo[a as usize].pos, self.geo[b as usize].pos);
        // Faces on the edge, their far corners, and a's neighbours.
        let g = self.next_generation();
        let mut on_edge = 0usize;
        let mut far = [DEAD; 2];
        let (sa, ca) = (
            self.start[a as usize] as usize,
            self.count[a as usize] as usize,
        );
        let (sb, cb) = (
            self.start[b as usize] as usize,
            self.count[b as usize] as usize,
        );
        for &f in &self.refs[sa..sa + ca] {
            let t = self.faces[f as usize];
            if t[0] == DEAD {
                continue;
            }
            if t.contains(&b) {
                if on_edge < 2 {
                    far[on_edge] = t[0] ^ t[1] ^ t[2] ^ a ^ b;
                }
                on_edge += 1;
            } else if !folds {
                folds = self.face_turns_too_far(f, t, a, pa, p);
            }
            for u in t {
                self.mark[u as usize] = g;
            }
        }
        // Common neighbours of a and b (a and b themselves excluded).
        self.mark[a as usize] = 0;
        self.mark[b as usize] = 0;
        let mut common = 0usize;
        let mut b_caps = false;
        // A face of b holding both (distinct) far corners is b-far-far: it cannot hold a.
        // `&&` as `||` is equivalent: `b_caps` is only read when `on_edge == 2`, and equal far
        // corners are refused before it is.
        let caps_possible = on_edge == 2 && far[0] != far[1];
        for &f in &self.refs[sb..sb + cb] {
            let t = self.faces[f as usize];
            if t[0] == DEAD {
                continue;
            }
            b_caps |= caps_possible && t.contains(&far[0]) && t.contains(&far[1]);
            if !folds && !t.contains(&a) {
                folds = self.face_turns_too_far(f, t, b, pb, p);
            }
            // Without a branch: whether a corner is a's neighbour is unpredictable. A hit
            // moves its mark off `g` so it counts once; `+=` as `-=` is equivalent: g − 1 is
            // below every later generation too (marks are zeroed when the counter wraps).
            for u in t {
                let m = &mut self.mark[u as usize];
                let hit = *m == g;
                *m += u32::from(hit);
                common += usize::from(hit);
            }
        }
        if (self.flags[a as usize] | self.flags[b as usize]) & AGGREGATED != 0 {
            // Already non-manifold here: any pair may contract (paper §3).
            return (Ok(on_edge), folds);
        }
        if on_edge == 0 {
            // Aggregation: only parts that do not touch near the pair merge.
            return (if common == 0 { Ok(0) } else { Err(()) }, folds);
        }
        let both_boundary = self.flags[a as usize] & self.flags[b as usize] & BOUNDARY != 0;
        if on_edge > 2 || common != on_edge || (on_edge == 2 && both_boundary) {
            return (Err(()), folds);
        }
        // Faces a-c-d and b-c-d both present would become one face twice.
        if on_edge == 2 && (far[0] == far[1] || (b_caps && self.has_face_with(a, b, far))) {
            return (Err(()), folds);
        }
        (Ok(on_edge), folds)
    }

    /// Whether `v` has a live face without `other` that holds both far corners.
    fn has_face_with(&self, v: u32, other: u32, far: [u32; 2]) -> bool {
        self.ring(v).iter().any(|&f| {
            let t = self.faces[f as usize];
            t[0] != DEAD && !t.contains(&other) && t.contains(&far[0]) && t.contains(&far[1])
        })
    }

    /// Where to put the contracted vertex when the optimum turns a surviving face too far:
    /// whichever endpoint is as good (in flat regions the regularised optimum is the midpoint,
    /// which can fold a thin fan where an endpoint does not); `None` when both fold too.
    fn endpoint_placement(&self, a: u32, b: u32, err: f64) -> Option<DVec3> {
        let fits = |p: DVec3| !self.turns_too_far(a, b, p) && !self.turns_too_far(b, a, p);
        let q = self.geo[a as usize].q + self.geo[b as usize].q;
        let tolerance = err * 1.001 + self.tiny_sq;
        [self.geo[a as usize].pos, self.geo[b as usize].pos]
            .into_iter()
            .find(|&e| q.mean_error(e) <= tolerance && fits(e))
    }

    /// Whether moving `v` to `p` turns a face of `v` that survives (has no `other`) by more
    /// than the allowed angle, collapses it to no area, or leaves it facing away from its
    /// input orientation (small turns add up).
    fn turns_too_far(&self, v: u32, other: u32, p: DVec3) -> bool {
        let pv = self.geo[v as usize].pos;
        self.ring(v).iter().any(|&f| {
            let t = self.faces[f as usize];
            t[0] != DEAD && !t.contains(&other) && self.face_turns_too_far(f, t, v, pv, p)
        })
    }

    /// [`Self::turns_too_far`] for one live face `f` = `t` of `v` (at `pv`). Always inlined:
    /// as a call per face it passed `p` through memory.
    #[inline(always)]
    fn face_turns_too_far(&self, f: u32, t: [u32; 3], v: u32, pv: DVec3, p: DVec3) -> bool {
        // Rotate so v is first: the normal is (b − v) × (c − v) before and after.
        let (b, c) = if t[0] == v {
            (t[1], t[2])
        } else if t[1] == v {
            (t[2], t[0])
        } else {
            (t[0], t[1])
        };
        let (pb, pc) = (self.geo[b as usize].pos, self.geo[c as usize].pos);
        let before = (pb - pv).cross(pc - pv);
        let after = (pb - p).cross(pc - p);
        let (lb, la) = (before.length_squared(), after.length_squared());
        if lb == 0.0 {
            // A face that had no area cannot flip.
            return false;
        }
        // cos(turn) ≤ cos_turn, compared squared to stay clear of square roots.
        let d = before.dot(after);
        let bound = self.cos_turn * self.cos_turn * lb * la;
        let too_far = if self.cos_turn >= 0.0 {
            d <= 0.0 || d * d <= bound
        } else {
            d < 0.0 && d * d >= bound
        };
        // Nor may it end up facing away from what it was in the input.
        too_far || la == 0.0 || after.dot(self.normal_in[f as usize].as_dvec3()) <= 0.0
    }

    /// Contracts b into a at p: faces on the edge die, b's other faces take a, and a's face
    /// slice is rewritten at the end of the reference array.
    fn contract(&mut self, a: u32, b: u32, p: DVec3, removed: usize) {
        let (ai, bi) = (a as usize, b as usize);
        self.geo[ai].pos = p;
        let qb = self.geo[bi].q;
        self.geo[ai].q += qb;
        // `BOUNDARY | AGGREGATED` as `^` is equivalent: the two are different bits.
        self.flags[ai] |= self.flags[bi] & (BOUNDARY | AGGREGATED);
        if removed == 0 {
            self.flags[ai] |= AGGREGATED;
            self.report.aggregations += 1;
        } else {
            self.report.collapses += 1;
        }
        // `&=` as `|=` is equivalent: b stays "alive" but is then also LOCKED, and a locked
        // vertex is never ranked again; its faces are gone and its stamp is bumped.
        self.flags[bi] &= !ALIVE;
        self.stamp[ai] = self.stamp[ai].wrapping_add(1);
        self.stamp[bi] = self.stamp[bi].wrapping_add(1);
        // a's new slice: its live faces without b, then b's live faces renamed. Both slices
        // are copied to the end first and filtered there (one bulk copy each instead of a
        // capacity check and an index per face).
        let new_start = self.refs.len();
        let (sa, ca) = (self.start[ai] as usize, self.count[ai] as usize);
        let (sb, cb) = (self.start[bi] as usize, self.count[bi] as usize);
        self.refs.extend_from_within(sa..sa + ca);
        self.refs.extend_from_within(sb..sb + cb);
        // Without branches: which faces die (a's faces on the edge) and which are already
        // dead is a coin toss per face to the predictor. Renaming b leaves a's other faces
        // and dead faces as they are, and b's faces on the edge died among a's. A face holds
        // b at most once, so `|` as `^` in `dies` is equivalent.
        let (mut keep, from_b) = (new_start, new_start + ca);
        for i in new_start..self.refs.len() {
            let f = self.refs[i];
            let t = self.faces[f as usize];
            let dies = (i < from_b) & ((t[0] == b) | (t[1] == b) | (t[2] == b));
            self.faces[f as usize] = if dies {
                [DEAD; 3]
            } else {
                t.map(|c| if c == b { a } else { c })
            };
            self.live_faces -= usize::from(dies);
            self.refs[keep] = f;
            keep += usize::from(!dies & (t[0] != DEAD));
        }
        self.refs.truncate(keep);
        // `&` as `|` or `^` (always true: a is alive) is equivalent, only slower: without an
        // aggregation the link condition already refused every contraction that would make a
        // face twice, so there is nothing to drop.
        if self.flags[ai] & AGGREGATED != 0 {
            self.drop_duplicates(new_start);
        }
        self.start[ai] = new_start as u32;
        self.count[ai] = (self.refs.len() - new_start) as u32;
        self.count[bi] = 0;
        if !self.partners.is_empty() {
            self.merge_partners(a, b);
        }
    }

    /// Kills faces of the slice `refs[from..]` that repeat an earlier face's vertex set (the
    /// coincident faces of two merged parts) and removes them from the slice.
    fn drop_duplicates(&mut self, from: usize) {
        let key = |t: [u32; 3]| {
            let mut k = t;
            k.sort_unstable();
            k
        };
        let mut keep = from;
        for i in from..self.refs.len() {
            let f = self.refs[i];
            let k = key(self.faces[f as usize]);
            let repeated = self.refs[from..keep]
                .iter()
                .any(|&g| key(self.faces[g as usize]) == k);
            if repeated {
                self.faces[f as usize] = [DEAD; 3];
                self.live_faces -= 1;
            } else {
                self.refs[keep] = f;
                keep += 1;
            }
        }
        self.refs.truncate(keep);
    }

    /// a inherits b's non-edge partners (they are re-ranked with a's other pairs).
    fn merge_partners(&mut self, a: u32, b: u32) {
        let inherited = std::mem::take(&mut self.partners[b as usize]);
        for &x in &inherited {
            if x != a && !self.partners[x as usize].contains(&a) {
                self.partners[x as usize].push(a);
            }
        }
        let mut mine = std::mem::take(&mut self.partners[a as usize]);
        mine.extend(inherited);
        mine.retain(|&x| x != a && x != b && self.flags[x as usize] & ALIVE != 0);
        mine.sort_unstable();
        mine.dedup();
        self.partners[a as usize] = mine;
    }
}
