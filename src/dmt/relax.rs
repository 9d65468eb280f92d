//! Shape relaxation of the balanced grade placements (IbC, CoI): each DMT vertex slides
//! within its tetrahedron's marching-tetrahedra polygon (the convex hull of the
//! linear-interpolation crossings on its active edges, the polygon IbC and CoI already
//! lie in) to where its triangles have the fewest slivers (smallest angle under 10
//! degrees) and then the largest smallest angle.
//!
//! Why: on drilling meshes the tetrahedra are long and flat, and the paper's placements
//! leave a third to a half of the triangles as slivers (docs/dmt.md). A vertex keeps its
//! weights on the crossings, so the volume balance that follows moves it with them and each
//! body still encloses marching tetrahedra's volume.
//!
//! Invariants: every weight stays at least [`MIN_WEIGHT`] (the vertex is strictly inside
//! its polygon, hence inside its tetrahedron); a move never turns an incident triangle
//! over (nor turns it by more than 45 degrees), never makes a dual polygon's cut unsuited
//! (a triangle facing against the polygon's normal, or the polygon's Delaunay edge no longer
//! let through once from back to front: the rules of the triangulation), nor grows the vertex's incident triangles' area by more than
//! [`RING_AREA_GROWTH`] (a move may not buy shape with roughness); sweeps are Gauss-Seidel
//! passes over a colouring in which no two corners of a polygon share a class (each class
//! moves in parallel), so the result does not depend on threads.

use glam::DVec3;
use rayon::prelude::*;

use super::extract::{PolygonKind, Topology, VertexRole};
use super::place::SortedCorners;
use super::{Plan, newell_normal, separates};
use crate::tet::TetMesh;

/// Sweeps over the vertices by default (`wellmesh contour --relax`); 0 keeps the paper's
/// positions.
pub const DEFAULT_SWEEPS: usize = 3;

/// The most sweeps a request may ask for (each costs about one placement of the surface).
pub const MAX_SWEEPS: usize = 50;

/// The most a move may grow the area of the vertex's incident triangles.
pub const RING_AREA_GROWTH: f64 = 1.01;

/// The cosine of the most an incident triangle may turn from its orientation at the paper's
/// positions.
pub const MAX_TURN_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// The smallest weight a crossing keeps.
pub const MIN_WEIGHT: f64 = 1e-3;

/// Candidate moves: this share of the way towards one crossing (negative: away from it).
const STEPS: [f64; 7] = [0.6, 0.4, 0.2, 0.1, -0.1, -0.2, -0.4];

/// The sine of 10 degrees: triangles whose smallest angle has a smaller sine are slivers.
pub const SLIVER_SINE: f64 = 0.173_648_177_666_930_33;

/// The sine of a triangle's smallest angle (0 when degenerate).
pub fn min_angle_sine(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    sine_from_area(a, b, c, (b - a).cross(c - a).length())
}

/// [`min_angle_sine`] given twice the triangle's area.
fn sine_from_area(a: DVec3, b: DVec3, c: DVec3, twice_area: f64) -> f64 {
    let [e0, e1, e2] = [
        (b - a).length_squared(),
        (c - b).length_squared(),
        (a - c).length_squared(),
    ];
    let shortest = e0.min(e1).min(e2);
    let longest = e0.max(e1).max(e2);
    // Twice the area over the two longer edges, which meet at the smallest angle.
    let sine = twice_area / (longest * (e0 + e1 + e2 - longest - shortest)).sqrt();
    if sine.is_finite() { sine.min(1.0) } else { 0.0 }
}

/// The triangles incident to each vertex: `inc[start[v]..start[v + 1]]`.
struct Incidence {
    start: Vec<u32>,
    inc: Vec<u32>,
}

impl Incidence {
    fn new(triangles: &[[u32; 3]], vertices: usize) -> Self {
        let mut start = vec![0u32; vertices + 1];
        for t in triangles {
            for &v in t {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..vertices {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut inc = vec![0u32; triangles.len() * 3];
        for (ti, t) in triangles.iter().enumerate() {
            for &v in t {
                inc[fill[v as usize] as usize] = ti as u32;
                fill[v as usize] += 1;
            }
        }
        Incidence { start, inc }
    }

    fn of(&self, v: usize) -> &[u32] {
        &self.inc[self.start[v] as usize..self.start[v + 1] as usize]
    }
}

/// The corners of DMT vertex `v`'s tetrahedron on `field` (threshold 0).
pub fn corners(topo: &Topology, mesh: &TetMesh, field: &[f64], v: usize) -> SortedCorners {
    let VertexRole::Tet { tet } = topo.roles[v] else {
        unreachable!("DMT vertices come first")
    };
    let tv = mesh.tet(tet as usize);
    SortedCorners::new(
        tv.map(|p| mesh.points[p as usize]),
        tv.map(|p| field[p as usize]),
    )
}

/// A candidate move: its (slivers, smallest sine), its order among the candidates, its
/// weights and its position.
type Candidate = ((usize, f64), usize, [f64; 4], DVec3);

/// What the relaxation works on.
#[derive(Clone, Copy)]
pub struct Surface<'a> {
    pub topo: &'a Topology,
    pub mesh: &'a TetMesh,
    /// The field whose zero level the crossings lie on (one value per mesh vertex).
    pub field: &'a [f64],
    /// The triangles whose shape is judged.
    pub plan: &'a Plan,
    /// Where an added crossing vertex (`Added::Crossing`) sits.
    pub edge_crossing: &'a (dyn Fn(u32, u32) -> DVec3 + Sync),
    /// The end points of a Delaunay edge.
    pub edge_ends: &'a (dyn Fn(u32, u32) -> (DVec3, DVec3) + Sync),
}

/// Relaxes the DMT vertices (`positions[..topo.active_tets]`, with `weights` on their
/// crossings of `field` at threshold 0) for at most `sweeps` sweeps over the triangles of
/// `plan`, or until no vertex moves. Returns the number of moves.
pub fn relax(
    surface: &Surface<'_>,
    weights: &mut [[f64; 4]],
    positions: &mut [DVec3],
    sweeps: usize,
) -> usize {
    let Surface {
        topo,
        plan,
        edge_crossing,
        ..
    } = *surface;
    let mut realized = plan.realize(topo, positions.to_vec(), edge_crossing);
    let rules = MoveRules::new(surface, &realized);
    // Vertices that share a polygon move in different colour classes: a vertex's score
    // reads only the corners of its own polygons, so each class moves in parallel with
    // the result of a sequential pass in class order.
    let classes = colour_classes(plan, &rules.incidence, &rules.movable(&realized));
    let mut moves = 0;
    for sweep in 0..sweeps {
        if sweep > 0 {
            // Added vertices (polygon centroids) follow their corners.
            realized = plan.realize(topo, positions.to_vec(), edge_crossing);
        }
        let mut moved = 0;
        for class in &classes {
            let updates: Vec<(u32, [f64; 4], DVec3)> = class
                .par_iter()
                .filter_map(|&v| {
                    rules
                        .best_move(v as usize, &realized, weights[v as usize])
                        .map(|(w, x)| (v, w, x))
                })
                .collect();
            moved += updates.len();
            for (v, w, x) in updates {
                weights[v as usize] = w;
                positions[v as usize] = x;
                realized[v as usize] = x;
            }
        }
        moves += moved;
        if moved == 0 {
            break;
        }
    }
    moves
}

/// Triangle `t`'s corners with vertex `v` at `x` and every other at `realized`.
fn corners_with(t: [u32; 3], v: usize, x: DVec3, realized: &[DVec3]) -> [DVec3; 3] {
    t.map(|i| {
        if i as usize == v {
            x
        } else {
            realized[i as usize]
        }
    })
}

/// What a vertex's moves are judged against, fixed at the paper's positions for the whole
/// relaxation: its incident triangles and their orientations, and the dual polygons whose
/// cut lets their edge through.
struct MoveRules<'a> {
    surface: Surface<'a>,
    incidence: Incidence,
    /// Each triangle's normal (twice its area) at the paper's positions.
    orientation: Vec<DVec3>,
    /// The triangles of polygon `k` are `ranges[k]..ranges[k + 1]`.
    ranges: Vec<usize>,
    /// Dual polygons whose cut lets their edge through: a move must keep it so.
    guarded: Vec<bool>,
}

impl<'a> MoveRules<'a> {
    fn new(surface: &Surface<'a>, realized: &[DVec3]) -> Self {
        let Surface {
            topo,
            plan,
            edge_ends,
            ..
        } = *surface;
        let triangles = &plan.triangles;
        let incidence = Incidence::new(triangles, realized.len());
        let orientation: Vec<DVec3> = triangles
            .par_iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| realized[i as usize]);
                (b - a).cross(c - a)
            })
            .collect();
        let ranges = plan.polygon_ranges(topo.polygon_count());
        let guarded: Vec<bool> = (0..topo.polygon_count())
            .into_par_iter()
            .map(|k| {
                if topo.kinds[k] != PolygonKind::Dual || topo.dual_open[k] {
                    return false;
                }
                let (a, b) = topo.dual_edges[k];
                let (pa, pb) = edge_ends(a, b);
                separates(
                    pa,
                    pb,
                    triangles[ranges[k]..ranges[k + 1]]
                        .iter()
                        .map(|t| t.map(|i| realized[i as usize])),
                )
            })
            .collect();
        Self {
            surface: *surface,
            incidence,
            orientation,
            ranges,
            guarded,
        }
    }

    /// The DMT vertices that may move: those with a sliver among their triangles at the
    /// paper's positions (on a grid a few percent of them).
    fn movable(&self, realized: &[DVec3]) -> Vec<bool> {
        let triangles = &self.surface.plan.triangles;
        (0..self.surface.topo.active_tets)
            .into_par_iter()
            .map(|v| {
                self.incidence.of(v).iter().any(|&ti| {
                    let [a, b, c] = triangles[ti as usize].map(|i| realized[i as usize]);
                    min_angle_sine(a, b, c) < SLIVER_SINE
                })
            })
            .collect()
    }

    /// (slivers, smallest sine, twice the area) of vertex `v`'s incident triangles with
    /// the vertex at `x`, or None for a move that turns a triangle too far. Only the
    /// triangles holding `v` change, so only they are judged.
    fn ring_shape(&self, v: usize, x: DVec3, realized: &[DVec3]) -> Option<(usize, f64, f64)> {
        let triangles = &self.surface.plan.triangles;
        let mut slivers = 0;
        let mut worst = 1.0f64;
        let mut area = 0.0;
        for &ti in self.incidence.of(v) {
            let [a, b, c] = corners_with(triangles[ti as usize], v, x, realized);
            let normal = (b - a).cross(c - a);
            let length = normal.length();
            let was = self.orientation[ti as usize];
            if normal.dot(was) <= MAX_TURN_COS * length * was.length() {
                return None;
            }
            let sine = sine_from_area(a, b, c, length);
            slivers += usize::from(sine < SLIVER_SINE);
            worst = worst.min(sine);
            area += length;
        }
        Some((slivers, worst, area))
    }

    /// The guarded polygons vertex `v` is a corner of.
    fn guarded_polygons(&self, v: usize) -> Vec<usize> {
        let mut polygons: Vec<usize> = Vec::new();
        for &ti in self.incidence.of(v) {
            let k = self.surface.plan.polygon_of[ti as usize] as usize;
            if self.guarded[k] && !polygons.contains(&k) {
                polygons.push(k);
            }
        }
        polygons
    }

    /// Whether the cut still suits each of `polygons` with vertex `v` at `x`: no triangle
    /// facing against the polygon's normal, and the polygon's edge let through once from
    /// back to front.
    fn keeps_cuts(&self, v: usize, x: DVec3, realized: &[DVec3], polygons: &[usize]) -> bool {
        let Surface {
            topo,
            plan,
            edge_ends,
            ..
        } = self.surface;
        let mut corners_at: Vec<DVec3> = Vec::new();
        polygons.iter().all(|&k| {
            corners_at.clear();
            corners_at.extend(topo.polygon(k).iter().map(|&i| {
                if i as usize == v {
                    x
                } else {
                    realized[i as usize]
                }
            }));
            let normal = newell_normal(&corners_at);
            let tris = &plan.triangles[self.ranges[k]..self.ranges[k + 1]];
            let faces_out = tris.iter().all(|&t| {
                let [a, b, c] = corners_with(t, v, x, realized);
                (b - a).cross(c - a).dot(normal) > 0.0
            });
            let (a, b) = topo.dual_edges[k];
            let (pa, pb) = edge_ends(a, b);
            faces_out
                && separates(
                    pa,
                    pb,
                    tris.iter().map(|&t| corners_with(t, v, x, realized)),
                )
        })
    }

    /// The best move of vertex `v` (weights `w`): the candidate with the fewest slivers
    /// and then the largest smallest angle among those that beat its current position,
    /// keep its ring's area and keep its polygons' cuts; None when no candidate does.
    fn best_move(&self, v: usize, realized: &[DVec3], w: [f64; 4]) -> Option<([f64; 4], DVec3)> {
        let (here, area_limit) = match self.ring_shape(v, realized[v], realized) {
            Some((0, ..)) => return None,
            Some((slivers, worst, area)) => ((slivers, worst), area * RING_AREA_GROWTH),
            None => ((usize::MAX, -1.0), f64::INFINITY),
        };
        let polygons = self.guarded_polygons(v);
        let mut better = self.better_candidates(v, realized, w, here, area_limit);
        // Best first (ties in candidate order); the first whose polygons' cuts still suit
        // it is taken, so the costly cut check runs on as few candidates as possible.
        better.sort_by(|a, b| {
            a.0.0
                .cmp(&b.0.0)
                .then(b.0.1.total_cmp(&a.0.1))
                .then(a.1.cmp(&b.1))
        });
        better
            .into_iter()
            .find(|c| self.keeps_cuts(v, c.3, realized, &polygons))
            .map(|(_, _, w, x)| (w, x))
    }

    /// The candidate moves of vertex `v` (weights `w`, towards or away from each of its
    /// crossings by [`STEPS`]) that keep every weight, do not grow its ring's area past
    /// `area_limit` and beat its current (slivers, smallest sine) `here`; in candidate
    /// order.
    fn better_candidates(
        &self,
        v: usize,
        realized: &[DVec3],
        w: [f64; 4],
        here: (usize, f64),
        area_limit: f64,
    ) -> Vec<Candidate> {
        let Surface {
            topo, mesh, field, ..
        } = self.surface;
        let c = corners(topo, mesh, field, v);
        let crossings: Vec<DVec3> = c.active_edges(0.0).map(|(i, j)| c.v(i, j, 0.0)).collect();
        let mut better: Vec<Candidate> = Vec::new();
        for k in 0..crossings.len() {
            for s in STEPS {
                let mut cand = w.map(|x| x * (1.0 - s));
                cand[k] += s;
                if cand[..crossings.len()].iter().any(|&x| x < MIN_WEIGHT) {
                    continue;
                }
                let x: DVec3 = crossings.iter().zip(&cand).map(|(&q, &wq)| q * wq).sum();
                let Some((slivers, worst, area)) = self.ring_shape(v, x, realized) else {
                    continue;
                };
                if area > area_limit {
                    continue;
                }
                if slivers < here.0 || (slivers == here.0 && worst > here.1) {
                    better.push(((slivers, worst), better.len(), cand, x));
                }
            }
        }
        better
    }
}

/// Greedy colouring of the `movable` DMT vertices such that no two corners of one polygon
/// share a colour; the classes in colour order, each in vertex order.
fn colour_classes(plan: &Plan, incidence: &Incidence, movable: &[bool]) -> Vec<Vec<u32>> {
    let n = movable.len();
    let polygons_total = plan
        .polygon_of
        .iter()
        .map(|&k| k as usize + 1)
        .max()
        .unwrap_or(0);
    let ranges = plan.polygon_ranges(polygons_total);
    let mut colour = vec![u32::MAX; n];
    // stamp[c] == v + 1: colour c is taken by a neighbour of v.
    let mut stamp: Vec<usize> = Vec::new();
    let mut classes: Vec<Vec<u32>> = Vec::new();
    let mut polygons: Vec<usize> = Vec::new();
    for v in (0..n).filter(|&v| movable[v]) {
        polygons.clear();
        for &ti in incidence.of(v) {
            let k = plan.polygon_of[ti as usize] as usize;
            if !polygons.contains(&k) {
                polygons.push(k);
            }
        }
        for &k in &polygons {
            for t in &plan.triangles[ranges[k]..ranges[k + 1]] {
                for &w in t {
                    let w = w as usize;
                    if w < n && colour[w] != u32::MAX {
                        let c = colour[w] as usize;
                        if stamp.len() <= c {
                            stamp.resize(c + 1, 0);
                        }
                        stamp[c] = v + 1;
                    }
                }
            }
        }
        let c = (0..)
            .find(|&c| stamp.get(c).is_none_or(|&s| s != v + 1))
            .unwrap_or(0);
        colour[v] = c as u32;
        if classes.len() <= c {
            classes.resize_with(c + 1, Vec::new);
        }
        classes[c].push(v as u32);
    }
    classes
}
