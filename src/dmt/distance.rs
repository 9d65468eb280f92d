//! Signed distance to the other class, for placing surfaces of 0/1 (and yes/no) data.
//!
//! Invariant: `field[v] > 0` exactly for marked vertices and `< 0` for unmarked ones, so the
//! zero level set of the field has the same active tetrahedra as the classification; its
//! magnitude is the Euclidean distance from the vertex to the nearest vertex of the other
//! class found by seed propagation over mesh edges (exact where the nearest point is reached
//! through the mesh along vertices that share the seed, which is the rule on drilling data).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

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
