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
use crate::tet::TetMesh;

/// Vertex -> incident tetrahedra (compressed rows).
struct Incidence {
    start: Vec<u32>,
    tets: Vec<u32>,
}

fn incidence(mesh: &TetMesh) -> Incidence {
    let n = mesh.points.len();
    let mut start = vec![0u32; n + 1];
    for tv in &mesh.tets {
        for &v in tv {
            start[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut tets = vec![0u32; start[n] as usize];
    for (t, tv) in mesh.tets.iter().enumerate() {
        for &v in tv {
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
    for tv in &mesh.tets {
        let m = tv.iter().filter(|&&v| marked[v as usize]).count();
        if m == 0 || m == 4 {
            continue;
        }
        for &a in tv {
            if !needed[a as usize] {
                needed[a as usize] = true;
                remaining += 1;
            }
            for &b in tv {
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
            for &w in &mesh.tets[t as usize] {
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
    /// The placement rule applied to the balanced field (threshold 0).
    pub rule: fn(&SortedCorners, f64) -> DVec3,
    /// Bisection steps (precision `2^-steps` of the balance's range).
    pub steps: usize,
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
) -> Vec<[f64; 4]> {
    let n_regions = regions
        .iter()
        .zip(marked)
        .filter(|&(_, &m)| m)
        .map(|(&r, _)| r as usize + 1)
        .max()
        .unwrap_or(0);
    // The region of each surface vertex and of each polygon.
    let tet_region = |t: u32| -> u32 {
        let tv = mesh.tets[t as usize];
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
    // A fan of every polygon, for the volumes the balance is solved on.
    let mut fan: Vec<([u32; 3], u32)> = Vec::new();
    for k in 0..topo.polygon_count() {
        let poly = topo.polygon(k);
        let r = vertex_region[poly[0] as usize];
        for i in 1..poly.len() - 1 {
            fan.push(([poly[0], poly[i], poly[i + 1]], r));
        }
    }
    let volumes = |positions: &[DVec3]| -> Vec<f64> {
        let mut v = vec![0.0; n_regions];
        for &(t, r) in &fan {
            let [a, b, c] = t.map(|i| positions[i as usize]);
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
            .for_each(|((p, role), &r)| {
                let VertexRole::Tet { tet } = *role else {
                    unreachable!("the first vertices are DMT vertices")
                };
                let tv = mesh.tets[tet as usize];
                let corners = SortedCorners::new(
                    tv.map(|v| mesh.points[v as usize]),
                    tv.map(|v| value(v, r)),
                );
                *p = (balance.rule)(&corners, 0.0);
            });
        let crossing = |a: u32, b: u32| {
            let (pa, pb) = (mesh.points[a as usize], mesh.points[b as usize]);
            let r = regions[a as usize];
            place::crossing(pb, pa, value(b, r), value(a, r), 0.0)
        };
        place_hull_vertices(topo, mesh, marked, &crossing, positions);
    };
    let target: Vec<f64> = (0..n_regions)
        .map(|r| balance.target.get(r).copied().unwrap_or(0.0))
        .collect();
    let zero = vec![0.0; n_regions];
    let mut lo = vec![-BALANCE_LIMIT; n_regions];
    let mut hi = vec![BALANCE_LIMIT; n_regions];
    let mut alpha = zero;
    for _ in 0..balance.steps {
        for r in 0..n_regions {
            alpha[r] = 0.5 * (lo[r] + hi[r]);
        }
        place(&alpha, positions);
        // Volume grows with the balance: a larger marked side pushes crossings outwards.
        for (r, v) in volumes(positions).into_iter().enumerate() {
            if v < target[r] {
                lo[r] = alpha[r];
            } else {
                hi[r] = alpha[r];
            }
        }
    }
    for r in 0..n_regions {
        alpha[r] = 0.5 * (lo[r] + hi[r]);
    }
    place(&alpha, positions);
    // The balanced field at the corners of every active tetrahedron.
    topo.roles[..topo.active_tets]
        .par_iter()
        .zip(&vertex_region[..topo.active_tets])
        .map(|(role, &r)| {
            let VertexRole::Tet { tet } = *role else {
                unreachable!("the first vertices are DMT vertices")
            };
            mesh.tets[tet as usize].map(|v| balanced(field[v as usize], alpha[r as usize]))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::progress::NoProgress;

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
