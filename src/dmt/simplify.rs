//! Shape-keeping simplification of closed bodies.
//!
//! A body contoured on a refined model carries the refinement's finest step all over its
//! surface, flat parts included: Tom Zone's 5 % shell is over a million triangles. This
//! module removes vertices by half-edge collapses (a vertex `u` merged into a neighbour `v`
//! that keeps its position), so every vertex left is one of the surface's own.
//!
//! Invariants (each collapse is refused unless all hold after it):
//! - the surface stays a closed, consistently wound 2-manifold: the link condition of Dey
//!   et al. (the neighbours `u` and `v` share are exactly the two opposite the edge, and no
//!   triangle made by the collapse exists already);
//! - every removed vertex lies within `tolerance` of the simplified surface (each is held
//!   by the nearest triangle among those the collapses around it made, and carried on when
//!   that triangle changes), so the one-sided distance from the original vertices to the
//!   result is at most the tolerance;
//! - no triangle turns by more than `max_turn_deg`, and none comes out with an angle under
//!   `min_angle_deg` unless the triangle it replaces already had a smaller one.
//!
//! The order is the quadric error of Garland and Heckbert (planes of the original triangles
//! around the merged vertices, area-weighted), with short edges first where the surface is
//! flat. Diagonal flips of nearly flat pairs then widen thin triangles. Last, the body is
//! given back its volume by one small offset of every vertex along its normal
//! ([`balance_volume`]; the removed vertices are then within the tolerance plus that
//! offset). Bodies that are not closed are returned as they are.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;

/// How far a simplification may go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Largest distance of a removed vertex from the simplified surface (input units).
    pub tolerance: f64,
    /// Largest turn of a triangle's normal in one collapse, degrees.
    pub max_turn_deg: f64,
    /// Smallest angle a collapse may create, degrees (unless the triangle it replaces
    /// already had a smaller one).
    pub min_angle_deg: f64,
}

impl Limits {
    /// The defaults at a tolerance: a 45-degree turn, no new angle under 10 degrees (the
    /// summary's sliver bound).
    pub fn new(tolerance: f64) -> Self {
        Limits {
            tolerance,
            max_turn_deg: 45.0,
            min_angle_deg: 10.0,
        }
    }
}

/// A simplified body: its vertices (a subset of the input's, each moved by `offset` along
/// its normal so the body keeps its volume) and triangles.
#[derive(Debug, Clone, PartialEq)]
pub struct Simplified {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// The distance every vertex was moved along its normal (outwards when positive) to
    /// give the body back its volume ([`balance_volume`]).
    pub offset: f64,
}

/// Simplifies a closed, oriented body within `limits`, keeping its volume; `None` when
/// cancelled. A body that is not closed, or one that would not stay closed (which the
/// checks rule out), comes back unchanged.
pub fn simplify(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    limits: &Limits,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<Simplified> {
    let unchanged = || Simplified {
        positions: positions.to_vec(),
        triangles: triangles.to_vec(),
        offset: 0.0,
    };
    // A body that is not closed has edges on one triangle, which no collapse takes; the
    // check of the result then returns it as it was.
    if limits.tolerance.is_nan() || limits.tolerance <= 0.0 {
        return Some(unchanged());
    }
    // Vertices and triangles in Morton order: a collapse's neighbourhood then sits close
    // in memory (the DMT's own order follows the tetrahedra).
    let (positions_z, triangles_z) = morton_ordered(positions, triangles);
    let vertices = positions.len();
    let mut work = if triangles.len() >= PARALLEL_MIN_TRIANGLES {
        let first = chunks::simplify_chunks(&positions_z, &triangles_z, limits, cancelled)?;
        let mut work = Work::new(&positions_z, &first.triangles, *limits, Vec::new(), &|v| {
            first.seam[v as usize]
        });
        work.held = first.held;
        work
    } else {
        Work::new(&positions_z, &triangles_z, *limits, Vec::new(), &|_| true)
    };
    work.run(cancelled)?;
    let flips = work.flip_thin_pairs(cancelled)?;
    if work.live_vertices == vertices && flips == 0 {
        return Some(unchanged());
    }
    let mut out = work.compact();
    if !super::measure::is_closed_and_oriented(&out.triangles) {
        return Some(unchanged());
    }
    let volume = super::measure::volume(positions, triangles);
    out.offset = balance_volume(&mut out.positions, &out.triangles, volume);
    if out.offset.is_finite() {
        Some(out)
    } else {
        Some(unchanged())
    }
}

/// Moves every vertex along its normal (the area-weighted mean of its triangles') by one
/// common distance so the closed body `positions`/`triangles` encloses `volume` (to f32
/// positions, as the GLB stores them); returns the distance. A few Newton steps: the
/// volume's derivative along the normals is the sum of the volume gradients' lengths.
/// Half-edge collapses cut chords across curved parts, so a simplified body is a little
/// smaller than the body it came from; this gives it back the volume DMT balanced it to.
pub fn balance_volume(positions: &mut [DVec3], triangles: &[[u32; 3]], volume: f64) -> f64 {
    let mut gradient = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let area_vector = (b - a).cross(c - a) / 6.0;
        for &i in t {
            gradient[i as usize] += area_vector;
        }
    }
    let rate: f64 = gradient.iter().map(|g| g.length()).sum();
    if rate.is_nan() || rate <= 0.0 {
        return 0.0;
    }
    let normals: Vec<DVec3> = gradient.iter().map(|g| g.normalize_or_zero()).collect();
    let start = positions.to_vec();
    let mut offset = 0.0;
    for _ in 0..4 {
        let error = volume - super::measure::volume(positions, triangles);
        if error.is_nan() || error.abs() <= 1e-12 * volume.abs() {
            break;
        }
        offset += error / rate;
        for ((p, s), n) in positions.iter_mut().zip(&start).zip(&normals) {
            *p = (*s + *n * offset).as_vec3().as_dvec3();
        }
    }
    offset
}

/// The vertices sorted by the Morton code of their position in the bounding box (ties by
/// index) and the triangles renumbered, sorted by their smallest corner.
fn morton_ordered(positions: &[DVec3], triangles: &[[u32; 3]]) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let [lo, hi] = super::measure::bbox(positions);
    let scale = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    let code = |p: DVec3| -> u64 {
        let q = ((p - lo) / scale * 2097151.0).clamp(DVec3::ZERO, DVec3::splat(2097151.0));
        let spread = |x: f64| -> u64 {
            let mut v = x as u64 & 0x1f_ffff;
            v = (v | v << 32) & 0x1f00000000ffff;
            v = (v | v << 16) & 0x1f0000ff0000ff;
            v = (v | v << 8) & 0x100f00f00f00f00f;
            v = (v | v << 4) & 0x10c30c30c30c30c3;
            (v | v << 2) & 0x1249249249249249
        };
        spread(q.x) | spread(q.y) << 1 | spread(q.z) << 2
    };
    let mut order: Vec<(u64, u32)> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| (code(*p), i as u32))
        .collect();
    order.sort_unstable();
    let mut rank = vec![0u32; positions.len()];
    for (r, &(_, i)) in order.iter().enumerate() {
        rank[i as usize] = r as u32;
    }
    let sorted_positions = order.iter().map(|&(_, i)| positions[i as usize]).collect();
    let mut sorted_triangles: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|w| rank[w as usize]))
        .collect();
    sorted_triangles.sort_unstable_by_key(|t| (t[0].min(t[1]).min(t[2]), *t));
    (sorted_positions, sorted_triangles)
}

/// A symmetric 4x4 quadric (the upper triangle) with the area it was summed over.
#[derive(Debug, Clone, Copy, Default)]
struct Quadric {
    q: [f64; 10],
    area: f64,
}

impl Quadric {
    fn plane(n: DVec3, d: f64, weight: f64) -> Self {
        let [a, b, c] = n.to_array();
        let w = weight;
        Quadric {
            q: [
                w * a * a,
                w * a * b,
                w * a * c,
                w * a * d,
                w * b * b,
                w * b * c,
                w * b * d,
                w * c * c,
                w * c * d,
                w * d * d,
            ],
            area: weight,
        }
    }

    fn add(&mut self, other: &Quadric) {
        for (a, b) in self.q.iter_mut().zip(&other.q) {
            *a += b;
        }
        self.area += other.area;
    }

    /// Mean squared distance of `p` from the planes summed.
    fn mean_error(&self, p: DVec3) -> f64 {
        let q = &self.q;
        let [x, y, z] = p.to_array();
        let e = q[0] * x * x
            + 2.0 * q[1] * x * y
            + 2.0 * q[2] * x * z
            + 2.0 * q[3] * x
            + q[4] * y * y
            + 2.0 * q[5] * y * z
            + 2.0 * q[6] * y
            + q[7] * z * z
            + 2.0 * q[8] * z
            + q[9];
        e.max(0.0) / self.area.max(f64::MIN_POSITIVE)
    }
}

/// A vertex waiting in the queue: its cheapest collapse's cost when it was pushed.
#[derive(Debug, Clone, Copy)]
struct Entry {
    cost: f64,
    vertex: u32,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    /// Reversed: the heap's top is the cheapest.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .cost
            .total_cmp(&self.cost)
            .then(other.vertex.cmp(&self.vertex))
    }
}

/// Buffers one collapse's checks fill, kept between collapses.
#[derive(Default)]
struct Scratch {
    around_u: Vec<u32>,
    around_v: Vec<u32>,
    /// The triangles that move with `u`, with their corners after the collapse.
    moved: Vec<(u32, [DVec3; 3])>,
    candidates: Vec<(u32, [DVec3; 3])>,
    /// Each removed vertex carried, with the triangle that holds it after the collapse.
    held: Vec<(u32, u32)>,
}

/// Bodies with at least this many triangles are first simplified in [`chunks::CHUNKS`]
/// parts at once.
const PARALLEL_MIN_TRIANGLES: usize = 40_000;

/// Most sweeps of the flips that follow the collapses.
const FLIP_SWEEPS: usize = 4;

/// Cosine of the largest angle between the normals of a pair of triangles whose diagonal
/// may be flipped (30 degrees).
const FLIP_FLATNESS_COS: f64 = 0.866_025_403_784_438_6;

/// Vertices with more neighbours are not collapsed (nor collapsed into): a bound on one
/// collapse's work.
const MAX_VALENCE: usize = 32;

/// Weight of the squared edge length in the cost: it orders collapses where the surface is
/// flat (quadric error zero), shortest first, which keeps triangles even.
const LENGTH_WEIGHT: f64 = 1e-3;

struct Work<'a> {
    pos: &'a [DVec3],
    limits: Limits,
    /// Squared cosine of the largest turn.
    cos_turn_sq: f64,
    /// Cosine of the smallest angle a collapse may create.
    cos_min_angle: f64,
    tris: Vec<[u32; 3]>,
    tri_alive: Vec<bool>,
    vtris: Vec<Vec<u32>>,
    alive: Vec<bool>,
    /// The cost each vertex was last queued at (`INFINITY`: not queued, to be queued again
    /// when a collapse changes its neighbourhood).
    key: Vec<f64>,
    /// Vertices never removed (empty: none).
    locked: Vec<bool>,
    quadric: Vec<Quadric>,
    held: Vec<Vec<u32>>,
    live_vertices: usize,
    heap: BinaryHeap<Entry>,
}

impl<'a> Work<'a> {
    /// The work on `triangles`, with the vertices `locked` never removed (empty: none) and
    /// those `first` says queued at the start (the others wait until a collapse changes
    /// their neighbourhood).
    fn new(
        pos: &'a [DVec3],
        triangles: &[[u32; 3]],
        limits: Limits,
        locked: Vec<bool>,
        first: &dyn Fn(u32) -> bool,
    ) -> Self {
        let n = pos.len();
        let mut valence = vec![0u32; n];
        for &i in triangles.iter().flatten() {
            valence[i as usize] += 1;
        }
        let mut vtris: Vec<Vec<u32>> = valence
            .iter()
            .map(|&k| Vec::with_capacity(k as usize + 4))
            .collect();
        let mut quadric = vec![Quadric::default(); n];
        for (t, tri) in triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|i| pos[i as usize]);
            let cross = (b - a).cross(c - a);
            let len = cross.length();
            let plane = if len > 0.0 {
                let nrm = cross / len;
                Quadric::plane(nrm, -nrm.dot(a), 0.5 * len)
            } else {
                Quadric::default()
            };
            for &i in tri {
                vtris[i as usize].push(t as u32);
                quadric[i as usize].add(&plane);
            }
        }
        let alive: Vec<bool> = vtris.iter().map(|t| !t.is_empty()).collect();
        let live_vertices = alive.iter().filter(|a| **a).count();
        let mut work = Work {
            pos,
            limits,
            cos_turn_sq: limits.max_turn_deg.to_radians().cos().powi(2),
            cos_min_angle: limits.min_angle_deg.to_radians().cos(),
            tris: triangles.to_vec(),
            tri_alive: vec![true; triangles.len()],
            vtris,
            alive,
            key: vec![f64::INFINITY; n],
            locked,
            quadric,
            held: vec![Vec::new(); triangles.len()],
            live_vertices,
            heap: BinaryHeap::with_capacity(n),
        };
        for v in 0..n as u32 {
            if first(v) {
                let best = work.best_cost(v);
                work.queue(v, best);
            }
        }
        work
    }

    fn p(&self, v: u32) -> DVec3 {
        self.pos[v as usize]
    }

    /// The vertices sharing a triangle with `v`, each once, into `out`: on a closed
    /// manifold each follows `v` in exactly one of its triangles.
    fn neighbours_into(&self, v: u32, out: &mut Vec<u32>) {
        out.clear();
        for &t in &self.vtris[v as usize] {
            let tri = self.tris[t as usize];
            let k = tri.iter().position(|&w| w == v).unwrap_or(0);
            out.push(tri[(k + 1) % 3]);
        }
    }

    fn cost(&self, u: u32, v: u32) -> f64 {
        let (pu, pv) = (self.p(u), self.p(v));
        self.quadric[u as usize].mean_error(pv) + LENGTH_WEIGHT * pu.distance_squared(pv)
    }

    /// The cost of `v`'s cheapest collapse. On a closed manifold each neighbour follows `v`
    /// in exactly one of its triangles.
    fn best_cost(&self, v: u32) -> f64 {
        let mut best = f64::INFINITY;
        for &t in &self.vtris[v as usize] {
            let tri = self.tris[t as usize];
            let k = tri.iter().position(|&w| w == v).unwrap_or(0);
            best = best.min(self.cost(v, tri[(k + 1) % 3]));
        }
        best
    }

    /// Queues `v` at `cost` (a lower bound of its collapses' costs: each is checked, and
    /// the cost taken again, when it comes out).
    fn queue(&mut self, v: u32, cost: f64) {
        if self.locked.get(v as usize).copied().unwrap_or(false) {
            return;
        }
        self.key[v as usize] = cost;
        if cost.is_finite() {
            self.heap.push(Entry { cost, vertex: v });
        }
    }

    /// Collapses vertices, cheapest first, until none can go. An entry whose vertex was
    /// queued again since, or whose cost has risen, is passed over (the latter queued at
    /// its new cost); a vertex none of whose collapses holds waits, unqueued, until a
    /// collapse changes its neighbourhood.
    fn run(&mut self, cancelled: &dyn Fn() -> bool) -> Option<()> {
        let mut popped = 0usize;
        let mut scratch = Scratch::default();
        let mut targets: Vec<(f64, u32)> = Vec::with_capacity(16);
        while let Some(entry) = self.heap.pop() {
            popped += 1;
            if popped.is_multiple_of(4096) && cancelled() {
                return None;
            }
            let u = entry.vertex;
            if !self.alive[u as usize] || self.key[u as usize] != entry.cost {
                continue;
            }
            if self.live_vertices <= 4 {
                break;
            }
            self.neighbours_into(u, &mut scratch.around_u);
            targets.clear();
            targets.extend(scratch.around_u.iter().map(|&w| (self.cost(u, w), w)));
            let best = targets.iter().map(|t| t.0).fold(f64::INFINITY, f64::min);
            if best > entry.cost {
                self.queue(u, best);
                continue;
            }
            targets.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            self.key[u as usize] = f64::INFINITY;
            // `scratch.around_u` holds `u`'s neighbours for every plan (no collapse happens
            // between them).
            let chosen = targets
                .iter()
                .find_map(|&(_, v)| self.plan(u, v, &mut scratch).map(|shared| (v, shared)));
            if let Some((v, shared)) = chosen {
                self.apply(u, v, shared, &mut scratch);
            }
        }
        Some(())
    }

    /// Checks the collapse of `u` into `v`; `Some` (the two triangles on the edge, with
    /// where the held vertices go in `scratch.held`) when every invariant holds after it.
    fn plan(&self, u: u32, v: u32, scratch: &mut Scratch) -> Option<[u32; 2]> {
        let shared = self.edge_triangles(u, v)?;
        self.link_holds(u, v, shared, scratch)?;
        self.moved_triangles_keep_shape(u, v, shared, scratch)?;
        self.carry_held(u, v, shared, scratch)?;
        Some(shared)
    }

    /// The two triangles on edge `uv`, when there are exactly two.
    fn edge_triangles(&self, u: u32, v: u32) -> Option<[u32; 2]> {
        let mut found = [u32::MAX; 2];
        let mut count = 0;
        for &t in &self.vtris[u as usize] {
            if self.tris[t as usize].contains(&v) {
                if count == 2 {
                    return None;
                }
                found[count] = t;
                count += 1;
            }
        }
        (count == 2).then_some(found)
    }

    /// The link condition: `u` and `v` share exactly the two vertices opposite their edge,
    /// and no triangle the collapse makes exists already. Vertices of more than
    /// [`MAX_VALENCE`] neighbours are left as they are.
    /// `scratch.around_u` holds `u`'s neighbours.
    fn link_holds(&self, u: u32, v: u32, shared: [u32; 2], scratch: &mut Scratch) -> Option<()> {
        let opposite = shared.map(|t| {
            let tri = self.tris[t as usize];
            tri.into_iter().find(|&w| w != u && w != v).unwrap_or(u)
        });
        if opposite[0] == opposite[1] {
            return None;
        }
        self.neighbours_into(v, &mut scratch.around_v);
        if scratch.around_u.len() + scratch.around_v.len() > 2 * MAX_VALENCE {
            return None;
        }
        for &w in &scratch.around_u {
            if w != v && !opposite.contains(&w) && scratch.around_v.contains(&w) {
                return None;
            }
        }
        // With the shared neighbours exactly the two opposite vertices, a triangle the
        // collapse makes can exist already only as `v` with both of them.
        for &t in &self.vtris[u as usize] {
            if shared.contains(&t) {
                continue;
            }
            let tri = self.tris[t as usize];
            if tri.iter().all(|w| *w == u || opposite.contains(w)) {
                let exists = self.vtris[v as usize].iter().any(|&s| {
                    let other = self.tris[s as usize];
                    opposite.iter().all(|w| other.contains(w))
                });
                if exists {
                    return None;
                }
            }
        }
        Some(())
    }

    /// The triangles around `u` that move with it (`u` replaced by `v`), into
    /// `scratch.moved` with their new corners, when none turns too far or comes out too
    /// thin.
    fn moved_triangles_keep_shape(
        &self,
        u: u32,
        v: u32,
        shared: [u32; 2],
        scratch: &mut Scratch,
    ) -> Option<()> {
        scratch.moved.clear();
        for &t in &self.vtris[u as usize] {
            if shared.contains(&t) {
                continue;
            }
            let tri = self.tris[t as usize];
            let [a, b, c] = tri.map(|w| self.p(w));
            let [na, nb, nc] = tri.map(|w| self.p(if w == u { v } else { w }));
            let old = (b - a).cross(c - a);
            let new = (nb - na).cross(nc - na);
            let (lo2, ln2) = (old.length_squared(), new.length_squared());
            if ln2.is_nan() || ln2 <= 0.0 {
                return None;
            }
            let dot = old.dot(new);
            if lo2 > 0.0 && (dot < 0.0 || dot * dot < self.cos_turn_sq * lo2 * ln2) {
                return None;
            }
            // Smallest angles compared by their cosines (the larger, the thinner).
            // The old triangle's angle matters only when the new one is under the limit.
            let thin = smallest_angle_cos(na, nb, nc);
            if thin > self.cos_min_angle && thin > smallest_angle_cos(a, b, c) {
                return None;
            }
            scratch.moved.push((t, [na, nb, nc]));
        }
        Some(())
    }

    /// Where each removed vertex held around `u` (and `u` itself) goes, into
    /// `scratch.held`, when within the tolerance: the triangle that held it, moved, if
    /// still within; else the nearest of the triangles around `v` after the collapse.
    fn carry_held(&self, u: u32, v: u32, shared: [u32; 2], scratch: &mut Scratch) -> Option<()> {
        let Scratch {
            moved,
            candidates,
            held,
            ..
        } = scratch;
        candidates.clear();
        candidates.extend_from_slice(moved);
        for &t in &self.vtris[v as usize] {
            if !shared.contains(&t) {
                candidates.push((t, self.tris[t as usize].map(|w| self.p(w))));
            }
        }
        let tol2 = self.limits.tolerance * self.limits.tolerance;
        let nearest = |p: DVec3| -> Option<u32> {
            let (best, d2) = candidates
                .iter()
                .map(|(t, [a, b, c])| (*t, distance_squared_to_triangle(p, *a, *b, *c)))
                .min_by(|x, y| x.1.total_cmp(&y.1))?;
            (d2 <= tol2).then_some(best)
        };
        held.clear();
        held.push((u, nearest(self.p(u))?));
        for &(t, [a, b, c]) in moved.iter() {
            for &w in &self.held[t as usize] {
                let p = self.p(w);
                if distance_squared_to_triangle(p, a, b, c) <= tol2 {
                    held.push((w, t));
                } else {
                    held.push((w, nearest(p)?));
                }
            }
        }
        for &t in &shared {
            for &w in &self.held[t as usize] {
                held.push((w, nearest(self.p(w))?));
            }
        }
        Some(())
    }

    fn apply(&mut self, u: u32, v: u32, shared: [u32; 2], scratch: &mut Scratch) {
        let ring = &mut scratch.around_v;
        for &t in &shared {
            self.tri_alive[t as usize] = false;
            self.held[t as usize].clear();
            for w in self.tris[t as usize] {
                if w != u {
                    self.vtris[w as usize].retain(|&s| s != t);
                }
            }
        }
        let around_u = std::mem::take(&mut self.vtris[u as usize]);
        for t in around_u {
            if shared.contains(&t) {
                continue;
            }
            self.held[t as usize].clear();
            for w in &mut self.tris[t as usize] {
                if *w == u {
                    *w = v;
                }
            }
            self.vtris[v as usize].push(t);
        }
        for &(w, t) in &scratch.held {
            self.held[t as usize].push(w);
        }
        self.alive[u as usize] = false;
        self.live_vertices -= 1;
        let q = self.quadric[u as usize];
        self.quadric[v as usize].add(&q);
        // Around `v` every triangle may have changed: a vertex waiting unqueued is queued
        // again, one whose collapse into `v` is now cheaper moves up; `v`'s own costs rose
        // with its quadric (its entry is taken again when it comes out).
        self.neighbours_into(v, ring);
        for &w in ring.iter() {
            let into_v = self.cost(w, v);
            let key = self.key[w as usize];
            if key.is_infinite() {
                let best = self.best_cost(w);
                self.queue(w, best);
            } else if into_v < key {
                self.queue(w, into_v);
            }
        }
        if self.key[v as usize].is_infinite() {
            let best = self.best_cost(v);
            self.queue(v, best);
        }
    }

    /// Flips the diagonal of pairs of triangles where that makes the pair's smallest angle
    /// larger (the Delaunay criterion on the surface), as long as the pair is nearly flat,
    /// no normal turns too far, the flipped diagonal is not an edge already and every
    /// vertex the pair holds stays within the tolerance. Sweeps until none flips (at most
    /// [`FLIP_SWEEPS`]).
    fn flip_thin_pairs(&mut self, cancelled: &dyn Fn() -> bool) -> Option<usize> {
        let mut held = Vec::new();
        let mut total = 0;
        for _ in 0..FLIP_SWEEPS {
            if cancelled() {
                return None;
            }
            let mut flipped = 0usize;
            for t in 0..self.tris.len() as u32 {
                if !self.tri_alive[t as usize] {
                    continue;
                }
                for e in 0..3 {
                    let tri = self.tris[t as usize];
                    let (a, b) = (tri[e], tri[(e + 1) % 3]);
                    if self.try_flip(t, a, b, &mut held) {
                        flipped += 1;
                        break;
                    }
                }
            }
            total += flipped;
            if flipped == 0 {
                break;
            }
        }
        Some(total)
    }

    /// Flips edge `ab` of triangle `t` (`a -> b` in its winding) when every condition of
    /// [`Work::flip_thin_pairs`] holds.
    fn try_flip(&mut self, t: u32, a: u32, b: u32, held: &mut Vec<(u32, u32)>) -> bool {
        let tri = self.tris[t as usize];
        let Some(&c) = tri.iter().find(|&&w| w != a && w != b) else {
            return false;
        };
        let Some(&s) = self.vtris[a as usize]
            .iter()
            .find(|&&s| s != t && self.tris[s as usize].contains(&b))
        else {
            return false;
        };
        let Some(&d) = self.tris[s as usize].iter().find(|&&w| w != a && w != b) else {
            return false;
        };
        if c == d
            || self.vtris[c as usize]
                .iter()
                .any(|&r| self.tris[r as usize].contains(&d))
        {
            return false;
        }
        let [pa, pb, pc, pd] = [a, b, c, d].map(|w| self.p(w));
        let old_worst = smallest_angle_cos(pa, pb, pc).max(smallest_angle_cos(pb, pa, pd));
        let (new_t, new_s) = ([pc, pa, pd], [pd, pb, pc]);
        let new_worst = smallest_angle_cos(pc, pa, pd).max(smallest_angle_cos(pd, pb, pc));
        if new_worst.is_nan() || new_worst >= old_worst - 1e-9 {
            return false;
        }
        let normal = |[x, y, z]: [DVec3; 3]| (y - x).cross(z - x).normalize_or_zero();
        let (n_t, n_s) = (normal([pa, pb, pc]), normal([pb, pa, pd]));
        let (m_t, m_s) = (normal(new_t), normal(new_s));
        let cos_turn = self.cos_turn_sq.sqrt();
        if n_t.dot(n_s) < FLIP_FLATNESS_COS
            || [m_t, m_s]
                .iter()
                .any(|m| m.dot(n_t) < cos_turn || m.dot(n_s) < cos_turn)
        {
            return false;
        }
        let tol2 = self.limits.tolerance * self.limits.tolerance;
        held.clear();
        for &w in self.held[t as usize].iter().chain(&self.held[s as usize]) {
            let p = self.p(w);
            let (dt, ds) = (
                distance_squared_to_triangle(p, new_t[0], new_t[1], new_t[2]),
                distance_squared_to_triangle(p, new_s[0], new_s[1], new_s[2]),
            );
            if dt.min(ds) > tol2 {
                return false;
            }
            held.push((w, if dt <= ds { t } else { s }));
        }
        self.tris[t as usize] = [c, a, d];
        self.tris[s as usize] = [d, b, c];
        self.vtris[a as usize].retain(|&r| r != s);
        self.vtris[b as usize].retain(|&r| r != t);
        self.vtris[c as usize].push(s);
        self.vtris[d as usize].push(t);
        self.held[t as usize].clear();
        self.held[s as usize].clear();
        for &(w, r) in held.iter() {
            self.held[r as usize].push(w);
        }
        true
    }

    /// The live vertices and triangles, renumbered in their original order.
    fn compact(&self) -> Simplified {
        let mut index = vec![u32::MAX; self.pos.len()];
        let mut positions = Vec::with_capacity(self.live_vertices);
        for (i, p) in self.pos.iter().enumerate() {
            if self.alive[i] {
                index[i] = positions.len() as u32;
                positions.push(*p);
            }
        }
        let triangles = self
            .tris
            .iter()
            .zip(&self.tri_alive)
            .filter(|(_, a)| **a)
            .map(|(t, _)| t.map(|w| index[w as usize]))
            .collect();
        Simplified {
            positions,
            triangles,
            offset: 0.0,
        }
    }
}

/// The cosine of a triangle's smallest angle (the one opposite its shortest edge); 1 for a
/// degenerate triangle.
fn smallest_angle_cos(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (x, y) = super::measure::smallest_angle_sides(a, b, c);
    let norms = (x.length_squared() * y.length_squared()).sqrt();
    if norms > 0.0 { x.dot(y) / norms } else { 1.0 }
}

/// Squared distance from `p` to triangle `abc` (Ericson, *Real-Time Collision Detection*,
/// 5.1.5: the closest point by Voronoi regions).
pub fn distance_squared_to_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return (a + ab * t).distance_squared(p);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return (a + ac * t).distance_squared(p);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * t).distance_squared(p);
    }
    let denom = va + vb + vc;
    if denom.is_nan() || denom == 0.0 {
        // Degenerate: the nearest of its edges.
        return [(a, b), (b, c), (c, a)]
            .into_iter()
            .map(|(s, e)| {
                let d = e - s;
                let t = if d.length_squared() > 0.0 {
                    ((p - s).dot(d) / d.length_squared()).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (s + d * t).distance_squared(p)
            })
            .fold(f64::INFINITY, f64::min);
    }
    let (v, w) = (vb / denom, vc / denom);
    (a + ab * v + ac * w).distance_squared(p)
}

mod chunks;

#[cfg(test)]
mod tests;
