//! Tetrahedral meshes: exact 3D Delaunay tetrahedralization of scattered points.
//!
//! Invariant: every tetrahedron of a [`TetMesh`] is positively oriented (its signed volume
//! `(p1-p0) . ((p2-p0) x (p3-p0))` is > 0, decided exactly), `neighbours` is symmetric, and
//! for a Delaunay mesh no vertex lies inside any tetrahedron's circumsphere (ties broken
//! by symbolic perturbation).

use glam::DVec3;

/// Marks a face on the convex hull in [`TetMesh::neighbours`].
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// A conforming tetrahedral mesh.
///
/// Shapes: `tets` #T by 4 vertex indices into `points`; `neighbours` #T by 4, where
/// `neighbours[t][i]` is the tetrahedron across the face opposite `tets[t][i]`, encoded
/// `t2 * 4 + j` with `j` the index of the same face in `t2` (the vertex of `t2` not on
/// it), or [`NO_NEIGHBOUR`] on the hull. `vertex_of_input` maps each input point to its
/// vertex (duplicates share one).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TetMesh {
    pub points: Vec<DVec3>,
    pub tets: Vec<[u32; 4]>,
    pub neighbours: Vec<[u32; 4]>,
    pub vertex_of_input: Vec<u32>,
    /// Input points merged into an earlier identical point.
    pub duplicates_merged: usize,
}
mod placeholder;
pub use placeholder::{TetError, delaunay};
