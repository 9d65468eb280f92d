//! Exact verification of a [`TetMesh`]: what `TetMesh::validate` checks.
//!
//! Invariant: uses only the exact predicates (and the same symbolic perturbation as the
//! construction), so a mesh that passes is a Delaunay tetrahedralization of its points'
//! convex hull under that perturbation.

use std::collections::HashMap;

use super::predicates::{self, Sign};
use super::{FACE_OUTWARD, NO_NEIGHBOUR, TetMesh};

/// The first defect found, described for a human. An empty `vertex_of_input` (a mesh
/// built without the map) is not checked.
pub fn validate(mesh: &TetMesh) -> Result<(), String> {
    let n_points = mesh.points.len();
    let mapped = !mesh.vertex_of_input.is_empty();
    if let Some(i) = mesh
        .vertex_of_input
        .iter()
        .position(|&v| v as usize >= n_points)
    {
        return Err(format!("input point {i} maps to a vertex out of range"));
    }
    if mapped && mesh.vertex_of_input.len() != n_points + mesh.duplicates_merged {
        return Err(format!(
            "{} input points but {} vertices and {} merged duplicates",
            mesh.vertex_of_input.len(),
            n_points,
            mesh.duplicates_merged
        ));
    }
    let mut used = vec![false; n_points];
    for (t, tv) in mesh.tets().enumerate() {
        for (i, &v) in tv.iter().enumerate() {
            if v as usize >= n_points {
                return Err(format!("tetrahedron {t} has vertex {v} out of range"));
            }
            if tv[..i].contains(&v) {
                return Err(format!("tetrahedron {t} repeats vertex {v}"));
            }
            used[v as usize] = true;
        }
        let [a, b, c, d] = mesh.corners(t);
        if predicates::orient_exact(a, b, c, d) != Sign::Positive {
            return Err(format!("tetrahedron {t} {tv:?} is not positively oriented"));
        }
    }
    if let Some(v) = used.iter().position(|&u| !u) {
        return Err(format!("vertex {v} is in no tetrahedron"));
    }
    for t in 0..mesh.tet_count() {
        for i in 0..4 {
            let link = mesh.neighbours(t)[i];
            if link == NO_NEIGHBOUR {
                continue;
            }
            let (t2, j) = ((link >> 2) as usize, (link & 3) as usize);
            if t2 >= mesh.tet_count() || t2 == t {
                return Err(format!("tetrahedron {t} face {i} links to {link}"));
            }
            if mesh.neighbours(t2)[j] != (t * 4 + i) as u32 {
                return Err(format!(
                    "tetrahedron {t} face {i} -> {t2} face {j} is not linked back"
                ));
            }
            let mut face = mesh.face_vertices(t, i);
            let mut other = mesh.face_vertices(t2, j);
            face.sort_unstable();
            other.sort_unstable();
            if face != other {
                return Err(format!(
                    "tetrahedra {t} and {t2} are linked across different faces"
                ));
            }
            let apex = mesh.points[mesh.tet(t2)[j] as usize];
            let mut r = mesh.corners(t);
            r[i] = apex;
            if predicates::orient_exact(r[0], r[1], r[2], r[3]) != Sign::Negative {
                return Err(format!(
                    "tetrahedra {t} and {t2} are on the same side of their shared face"
                ));
            }
            if predicates::in_sphere_perturbed(mesh.corners(t), apex) {
                return Err(format!(
                    "vertex {} is inside the circumsphere of tetrahedron {t} (not Delaunay)",
                    mesh.tet(t2)[j]
                ));
            }
        }
    }
    validate_hull(mesh)
}

/// The hull faces form a closed, consistently oriented surface that is locally convex
/// (across every hull edge, the other face's far vertex is not beyond this face, nor on
/// its plane inside its circumcircle under the perturbation).
fn validate_hull(mesh: &TetMesh) -> Result<(), String> {
    let faces: Vec<[u32; 3]> = mesh
        .hull_faces()
        .map(|(t, i)| FACE_OUTWARD[i].map(|k| mesh.tet(t)[k]))
        .collect();
    if faces.is_empty() {
        return if mesh.tet_count() == 0 {
            Ok(())
        } else {
            Err("the mesh has no hull faces".to_string())
        };
    }
    // Directed edge (a, b) -> (face, vertex opposite the edge in that face).
    let mut edges: HashMap<(u32, u32), (usize, u32)> = HashMap::with_capacity(faces.len() * 3);
    for (f, tri) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            if edges.insert((a, b), (f, c)).is_some() {
                return Err(format!("hull edge {a}-{b} is used twice in one direction"));
            }
        }
    }
    let p = |v: u32| mesh.points[v as usize];
    for (&(a, b), &(f, _)) in &edges {
        let Some(&(_, d)) = edges.get(&(b, a)) else {
            return Err(format!("hull edge {a}-{b} borders only one hull face"));
        };
        let [x, y, z] = faces[f];
        match predicates::orient_exact(p(x), p(y), p(z), p(d)) {
            Sign::Negative => {}
            Sign::Positive => {
                return Err(format!("the hull is not convex at edge {a}-{b}"));
            }
            Sign::Zero => {
                if predicates::in_circle_coplanar_perturbed(p(x), p(y), p(z), p(d)) {
                    return Err(format!(
                        "coplanar hull faces at edge {a}-{b} are not Delaunay"
                    ));
                }
            }
        }
    }
    Ok(())
}
