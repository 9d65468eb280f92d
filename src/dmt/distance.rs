//! Signed distance to the other class, for placing surfaces of 0/1 (and yes/no) data.
//!
//! Invariant: `field[v] > 0` exactly for marked vertices and `< 0` for unmarked ones, so the
//! zero level set of the field has the same active tetrahedra as the classification; its
//! magnitude is the Euclidean distance from the vertex to the nearest vertex of the other
//! class found by seed propagation over mesh edges (exact where the nearest point is reached
//! through the mesh along vertices that share the seed, which is the rule on drilling data).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;
use rayon::prelude::*;

use super::extract::{Topology, VertexRole, place_hull_vertices};
use super::place::{self, SortedCorners};
use super::{Plan, polygon_marked_point};
use crate::tet::TetMesh;

/// Vertex -> incident tetrahedra (compressed rows).
struct Incidence {
    start: Vec<u32>,
    tets: Vec<u32>,
}

fn incidence(mesh: &TetMesh) -> Incidence {
    let n = mesh.points.len();
    let mut start = vec![0u32; n + 1];
    for tv in mesh.tets() {
        for v in tv {
            start[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut tets = vec![0u32; start[n] as usize];
    for (t, tv) in mesh.tets().enumerate() {
        for v in tv {
            tets[fill[v as usize] as usize] = t as u32;
            fill[v as usize] += 1;
        }
    }
    Incidence { start, tets }
}

/// The signed distance field of the classification `marked` (see the module invariant),
/// settled on every vertex of a tetrahedron with both classes (the only values a placement
/// reads); vertices the search did not settle get `+-scale`, a bound larger than any
/// distance in the mesh.
pub fn signed_class_distance(mesh: &TetMesh, marked: &[bool]) -> Vec<f64> {
    let n = mesh.points.len();
    let (lo, hi) = mesh.points.iter().fold(
        (
            glam::DVec3::splat(f64::INFINITY),
            glam::DVec3::splat(f64::NEG_INFINITY),
        ),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let scale = ((hi - lo).length() * 2.0).max(1.0);
    let mut dist = vec![f64::INFINITY; n];
    let mut seed = vec![u32::MAX; n];
    // Vertices of active tetrahedra still to settle; the search stops when none is left.
    let mut needed = vec![false; n];
    let mut heap: BinaryHeap<Reverse<(u64, u32)>> = BinaryHeap::new();
    let key = |d: f64| d.to_bits();
    let offer = |v: u32, s: u32, dist: &mut [f64], seed: &mut [u32], heap: &mut BinaryHeap<_>| {
        let d = mesh.points[v as usize].distance(mesh.points[s as usize]);
        if d < dist[v as usize] {
            dist[v as usize] = d;
            seed[v as usize] = s;
            heap.push(Reverse((key(d), v)));
        }
    };
    let mut remaining = 0usize;
    for tv in mesh.tets() {
        let m = tv.iter().filter(|&&v| marked[v as usize]).count();
        if m == 0 || m == 4 {
            continue;
        }
        for a in tv {
            if !needed[a as usize] {
                needed[a as usize] = true;
                remaining += 1;
            }
            for b in tv {
                if marked[a as usize] != marked[b as usize] {
                    offer(a, b, &mut dist, &mut seed, &mut heap);
                }
            }
        }
    }
    let inc = incidence(mesh);
    let mut settled = vec![false; n];
    while let Some(Reverse((_, v))) = heap.pop() {
        if settled[v as usize] {
            continue;
        }
        settled[v as usize] = true;
        if needed[v as usize] {
            remaining -= 1;
            if remaining == 0 {
                break;
            }
        }
        let s = seed[v as usize];
        for &t in &inc.tets[inc.start[v as usize] as usize..inc.start[v as usize + 1] as usize] {
            for &w in &mesh.tet(t as usize) {
                if w != v && !settled[w as usize] && marked[w as usize] == marked[v as usize] {
                    offer(w, s, &mut dist, &mut seed, &mut heap);
                }
            }
        }
    }
    (0..n)
        .map(|v| {
            let d = if settled[v] { dist[v] } else { scale };
            if marked[v] { d } else { -d }
        })
        .collect()
}

/// The balance stays inside (-BALANCE_LIMIT, BALANCE_LIMIT), so signs never flip.
const BALANCE_LIMIT: f64 = 0.95;

/// The field value seen by a body with balance `alpha`: the marked side scaled by
/// `1 + alpha`, the unmarked side by `1 - alpha` (signs unchanged for |alpha| < 1).
#[inline]
fn balanced(g: f64, alpha: f64) -> f64 {
    if g > 0.0 {
        g * (1.0 + alpha)
    } else {
        g * (1.0 - alpha)
    }
}

/// What each body's volume is balanced to, and the placement rule used on the field.
#[derive(Clone, Copy)]
pub struct Balance<'a> {
    /// Per marked region (`mt::marked_regions` id): the volume to match.
    pub target: &'a [f64],
    /// The placement rule applied to the balanced field (threshold 0), given the DMT
    /// vertex's index and its tetrahedron's corners.
    pub rule: &'a (dyn Fn(usize, &SortedCorners) -> DVec3 + Sync),
    /// At most this many placements.
    pub steps: usize,
    /// The triangulation whose volumes are balanced.
    pub plan: &'a Plan,
}

/// A body's volume is balanced to this share of its target.
const BALANCE_TOLERANCE: f64 = 1e-5;

/// The root of an increasing function `g` on `(-limit, limit)`, searched from 0: a step
/// outwards until the root is bracketed, then false position with the Illinois rule
/// (superlinear, and never worse than a few bisections).
struct RootSearch {
    lo: (f64, Option<f64>),
    hi: (f64, Option<f64>),
    /// The end kept by the last step: -1 lower, 1 upper.
    kept: i8,
    best: (f64, f64),
    tolerance: f64,
    evaluated: bool,
    /// The next outward step while only one end is known.
    step: f64,
}

impl RootSearch {
    fn new(limit: f64, tolerance: f64) -> Self {
        Self {
            lo: (-limit, None),
            hi: (limit, None),
            kept: 0,
            best: (0.0, f64::INFINITY),
            tolerance,
            evaluated: false,
            step: 0.1,
        }
    }

    fn done(&self) -> bool {
        self.best.1.abs() <= self.tolerance || self.hi.0 - self.lo.0 < 1e-9
    }

    fn best(&self) -> f64 {
        self.best.0
    }

    /// `g` at [`RootSearch::best`].
    fn miss(&self) -> f64 {
        self.best.1
    }

    /// The next balance to evaluate.
    fn next(&self) -> f64 {
        if self.done() {
            return self.best.0;
        }
        let (lo, hi) = (self.lo.0, self.hi.0);
        match (self.lo.1, self.hi.1) {
            _ if !self.evaluated => 0.0,
            (Some(glo), Some(ghi)) => {
                let x = lo - glo * (hi - lo) / (ghi - glo);
                // Keep strictly inside the bracket.
                let margin = 1e-3 * (hi - lo);
                x.clamp(lo + margin, hi - margin)
            }
            // One end known: step outwards, twice as far each time, at most halfway to
            // the limit.
            (Some(_), None) => lo + self.step.min(0.5 * (hi - lo)),
            (None, Some(_)) => hi - self.step.min(0.5 * (hi - lo)),
            (None, None) => 0.5 * (lo + hi),
        }
    }

    fn record(&mut self, x: f64, g: f64) {
        if !g.is_finite() {
            return;
        }
        if self.evaluated && (self.lo.1.is_none() || self.hi.1.is_none()) {
            self.step *= 2.0;
        }
        self.evaluated = true;
        if g.abs() < self.best.1.abs() {
            self.best = (x, g);
        }
        if g < 0.0 {
            if x >= self.lo.0 {
                // Illinois: the upper end was kept twice, so its weight halves.
                if self.kept == 1
                    && let Some(ghi) = &mut self.hi.1
                {
                    *ghi *= 0.5;
                }
                self.lo = (x, Some(g));
                self.kept = 1;
            }
        } else if x <= self.hi.0 {
            if self.kept == -1
                && let Some(glo) = &mut self.lo.1
            {
                *glo *= 0.5;
            }
            self.hi = (x, Some(g));
            self.kept = -1;
        }
    }
}

/// What [`place_balanced`] found: the balanced field at the corners (in `mesh.tets` order)
/// of each active tetrahedron, and the balance of each marked region.
pub struct Balanced {
    pub corner_field: Vec<[f64; 4]>,
    pub alpha: Vec<f64>,
    /// Per region: how far the balanced volume misses its target, as a share of it
    /// (0 when met to the tolerance; larger when no balance in range reaches it).
    pub missed: Vec<f64>,
    /// The region of each surface vertex (`topo.roles` order).
    pub vertex_region: Vec<u32>,
}

/// The balanced crossing on the active edge from marked `a` to unmarked `b`.
pub fn balanced_crossing(
    mesh: &TetMesh,
    field: &[f64],
    regions: &[u32],
    alpha: &[f64],
    a: u32,
    b: u32,
) -> DVec3 {
    let (pa, pb) = (mesh.points[a as usize], mesh.points[b as usize]);
    let al = alpha
        .get(regions[a as usize] as usize)
        .copied()
        .unwrap_or(0.0);
    place::crossing(
        pb,
        pa,
        balanced(field[b as usize], al),
        balanced(field[a as usize], al),
        0.0,
    )
}

/// Places every surface vertex by `balance.rule` on the signed `field` (positive exactly
/// at marked vertices), with one balance per marked region (body) chosen so that the
/// body's volume equals `balance.target` for its region.
///
/// Why: the distance field of 0/1 data gives smooth surfaces (no staircase between
/// samples), but at convex edges it leans towards the inside samples, whose nearest outside
/// sample is the next one down the hole, while the outside samples' nearest inside one is a
/// whole well spacing away; bodies come out several percent small. On grade data DMT's
/// polygons are chords across convex surfaces. The target the callers give is the volume
/// of the linear interpolation's superlevel set (what marching tetrahedra encloses), so
/// each body keeps its placement's shape and that volume.
/// `regions[v]` is the body of marked vertex `v` (see `mt::marked_regions`). Returns the
/// balanced field at the corners (in `mesh.tets` order) of each active tetrahedron.
pub fn place_balanced(
    topo: &Topology,
    mesh: &TetMesh,
    marked: &[bool],
    field: &[f64],
    regions: &[u32],
    positions: &mut [DVec3],
    balance: Balance<'_>,
) -> Balanced {
    let n_regions = regions
        .iter()
        .zip(marked)
        .filter(|&(_, &m)| m)
        .map(|(&r, _)| r as usize + 1)
        .max()
        .unwrap_or(0);
    // The region of each surface vertex and of each polygon.
    let tet_region = |t: u32| -> u32 {
        let tv = mesh.tet(t as usize);
        let v = tv
            .iter()
            .copied()
            .find(|&v| marked[v as usize])
            .expect("active tet");
        regions[v as usize]
    };
    let vertex_region: Vec<u32> = topo
        .roles
        .iter()
        .map(|role| match *role {
            VertexRole::Tet { tet } => tet_region(tet),
            VertexRole::HullFace { face } => tet_region(face / 4),
            VertexRole::HullEdge { a, .. } => regions[a as usize],
            VertexRole::HullPoint { point } => regions[point as usize],
        })
        .collect();
    // The triangles the balance is solved on, with their region.
    let polygon_region: Vec<u32> = (0..topo.polygon_count())
        .map(|k| regions[polygon_marked_point(topo, k) as usize])
        .collect();
    let plan = balance.plan;
    let triangle_region: Vec<u32> = plan
        .polygon_of
        .iter()
        .map(|&k| polygon_region[k as usize])
        .collect();
    let base = positions.len();
    let volumes = |positions: &[DVec3], alpha: &[f64]| -> Vec<f64> {
        let crossing = |a: u32, b: u32| balanced_crossing(mesh, field, regions, alpha, a, b);
        let extra: Vec<DVec3> = plan
            .added
            .iter()
            .map(|&a| Plan::added_position(topo, positions, a, &crossing))
            .collect();
        let at = |i: u32| {
            let i = i as usize;
            if i < base {
                positions[i]
            } else {
                extra[i - base]
            }
        };
        let mut v = vec![0.0; n_regions];
        for (t, &r) in plan.triangles.iter().zip(&triangle_region) {
            let [a, b, c] = t.map(at);
            v[r as usize] += a.dot(b.cross(c)) / 6.0;
        }
        v
    };
    let place = |alpha: &[f64], positions: &mut [DVec3]| {
        let value = |v: u32, r: u32| balanced(field[v as usize], alpha[r as usize]);
        positions[..topo.active_tets]
            .par_iter_mut()
            .zip(&topo.roles[..topo.active_tets])
            .zip(&vertex_region[..topo.active_tets])
            .enumerate()
            .for_each(|(i, ((p, role), &r))| {
                let VertexRole::Tet { tet } = *role else {
                    unreachable!("the first vertices are DMT vertices")
                };
                let tv = mesh.tet(tet as usize);
                let corners = SortedCorners::new(
                    tv.map(|v| mesh.points[v as usize]),
                    tv.map(|v| value(v, r)),
                );
                *p = (balance.rule)(i, &corners);
            });
        let crossing = |a: u32, b: u32| balanced_crossing(mesh, field, regions, alpha, a, b);
        place_hull_vertices(topo, mesh, marked, &crossing, positions);
    };
    let target: Vec<f64> = (0..n_regions)
        .map(|r| balance.target.get(r).copied().unwrap_or(0.0))
        .collect();
    // Volume grows with the balance (a larger marked side pushes crossings outwards): one
    // bracketed root search per body, all bodies placed together at each step.
    let mut search: Vec<RootSearch> = target
        .iter()
        .map(|&t| RootSearch::new(BALANCE_LIMIT, BALANCE_TOLERANCE * t.abs()))
        .collect();
    let mut alpha = vec![0.0; n_regions];
    for _ in 0..balance.steps {
        if search.iter().all(RootSearch::done) {
            break;
        }
        for (a, s) in alpha.iter_mut().zip(&search) {
            *a = s.next();
        }
        place(&alpha, positions);
        for (r, v) in volumes(positions, &alpha).into_iter().enumerate() {
            search[r].record(alpha[r], v - target[r]);
        }
    }
    let best: Vec<f64> = search.iter().map(RootSearch::best).collect();
    let missed: Vec<f64> = search
        .iter()
        .zip(&target)
        .map(|(s, &t)| if s.done() { 0.0 } else { (s.miss() / t).abs() })
        .collect();
    if best != alpha {
        alpha = best;
        place(&alpha, positions);
    }
    // The balanced field at the corners of every active tetrahedron.
    let corner_field = topo.roles[..topo.active_tets]
        .par_iter()
        .zip(&vertex_region[..topo.active_tets])
        .map(|(role, &r)| {
            let VertexRole::Tet { tet } = *role else {
                unreachable!("the first vertices are DMT vertices")
            };
            mesh.tet(tet as usize)
                .map(|v| balanced(field[v as usize], alpha[r as usize]))
        })
        .collect();
    Balanced {
        corner_field,
        alpha,
        missed,
        vertex_region,
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::progress::NoProgress;

    fn solve(g: impl Fn(f64) -> f64, tolerance: f64) -> (f64, usize) {
        let mut search = RootSearch::new(BALANCE_LIMIT, tolerance);
        let mut steps = 0;
        while !search.done() && steps < 12 {
            let x = search.next();
            assert!(x.abs() < BALANCE_LIMIT, "{x} outside the limits");
            search.record(x, g(x));
            steps += 1;
        }
        (search.best(), steps)
    }

    #[test]
    fn the_balance_search_finds_roots_near_zero_far_out_and_at_kinks_in_few_steps() {
        // Smooth and near 0 (the usual body), far out, and a kinked increasing function.
        for (root, kink) in [(0.03, false), (-0.2, false), (0.8, false), (0.1, true)] {
            let g = |x: f64| {
                let d = x - root;
                if kink && d > 0.0 {
                    5.0 * d
                } else {
                    d + 0.4 * d.powi(3)
                }
            };
            let (x, steps) = solve(g, 1e-7);
            assert!(
                (x - root).abs() < 1e-6,
                "root {root}: found {x} in {steps} steps"
            );
            assert!(steps <= 10, "root {root}: {steps} steps");
        }
        // No root inside the limits: the search ends at the best end it reached.
        let (x, _) = solve(|x| x + 2.0, 1e-7);
        assert!(x < -0.9, "{x}");
    }

    #[test]
    fn the_field_is_the_distance_to_the_other_class_along_the_wells() {
        // 3 x 3 vertical wells 10 m apart, samples every metre; marked below z = 4.5.
        let mut points = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..10 {
                    let jitter = 0.01 * f64::from(i * 3 + j);
                    points.push(DVec3::new(
                        10.0 * f64::from(i) + jitter,
                        10.0 * f64::from(j) - jitter,
                        f64::from(k),
                    ));
                }
            }
        }
        let mesh = crate::tet::delaunay(&points, &NoProgress).unwrap();
        let marked: Vec<bool> = mesh.points.iter().map(|p| p.z < 4.5).collect();
        let field = signed_class_distance(&mesh, &marked);
        let mut checked = 0;
        for (v, p) in mesh.points.iter().enumerate() {
            assert_eq!(field[v] > 0.0, marked[v], "the sign is the class");
            // The nearest sample of the other class is on the same well, 4.5 +- 0.5 away.
            let expected = if marked[v] { 5.0 - p.z } else { 4.0 - p.z };
            // Vertices of tetrahedra with both classes are settled; others may keep the
            // bound (larger than any distance here).
            if (p.z - 4.5).abs() < 1.0 || field[v].abs() < 50.0 {
                assert!(
                    (field[v] - expected).abs() < 1e-12,
                    "{p}: {} vs {expected}",
                    field[v]
                );
                checked += 1;
            } else {
                assert!(field[v].abs() > 50.0);
            }
        }
        assert!(checked >= 9 * 2);
    }
}
