//! Tetrahedral meshes: exact 3D Delaunay tetrahedralization of scattered points.
//!
//! Invariant: every tetrahedron of a [`TetMesh`] is positively oriented (its signed volume
//! `(p1-p0) . ((p2-p0) x (p3-p0))` is > 0, decided exactly), `neighbours` is symmetric, and
//! for a Delaunay mesh no vertex lies inside any tetrahedron's circumsphere (ties broken
//! by symbolic perturbation).
//!
//! Design notes (layout, predicates, perturbation, memory) are in `docs/tet.md`.

mod delaunay;
mod exact_int;
pub mod predicates;
mod sort;
mod validate;

use glam::DVec3;

use crate::progress::Progress;

/// Marks a face on the convex hull in [`TetMesh::neighbours`].
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// Vertex positions of the face opposite vertex `i` of a positive tetrahedron, ordered
/// counter-clockwise seen from outside (their normal points away from vertex `i`).
pub const FACE_OUTWARD: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

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

/// Why a tetrahedralization could not be built (or a mesh fails [`TetMesh::validate`]).
#[derive(Debug, thiserror::Error)]
pub enum TetError {
    #[error("need at least 4 distinct points to tetrahedralize, got {distinct}")]
    TooFewPoints { distinct: usize },
    #[error("all points lie in one plane (or on one line): there is no volume to tetrahedralize")]
    AllCoplanar,
    #[error("point {index} has a non-finite coordinate (NaN or infinity)")]
    NonFinite { index: usize },
    #[error("{count} points is more than the {max} a mesh can index")]
    TooManyPoints { count: usize, max: usize },
    #[error("tetrahedralization cancelled")]
    Cancelled,
    #[error("invalid tetrahedral mesh: {0}")]
    Invalid(String),
}

/// The Delaunay tetrahedralization of `points` (exact predicates, co-spherical ties broken
/// by symbolic perturbation, so the result is unique for a given point set).
///
/// `points` may be at any magnitude (UTM coordinates included): predicates are exact, and
/// an internal translation is used only where it is itself exact. Points with identical
/// coordinates are merged (`duplicates_merged`); the mesh's `points` are the distinct
/// points in spatial (Hilbert curve) order and `vertex_of_input` maps each input point to
/// its vertex. Checks `progress.is_cancelled()`
/// every few thousand insertions.
///
/// Errors: [`TetError::NonFinite`], [`TetError::TooFewPoints`] (fewer than 4 distinct),
/// [`TetError::AllCoplanar`], [`TetError::TooManyPoints`], [`TetError::Cancelled`].
pub fn delaunay(points: &[DVec3], progress: &dyn Progress) -> Result<TetMesh, TetError> {
    delaunay::build(points.to_vec(), progress)
}

/// [`delaunay`] taking ownership of the points, so their buffer becomes the mesh's
/// `points` (saves one copy of the input at large sizes).
pub fn delaunay_owned(points: Vec<DVec3>, progress: &dyn Progress) -> Result<TetMesh, TetError> {
    delaunay::build(points, progress)
}

impl TetMesh {
    /// The four corner positions of tetrahedron `t`.
    pub fn corners(&self, t: usize) -> [DVec3; 4] {
        self.tets[t].map(|v| self.points[v as usize])
    }

    /// Signed volume of tetrahedron `t` in cubic units of the points (m^3 for metres):
    /// `(p1-p0) . ((p2-p0) x (p3-p0)) / 6`, positive for every tetrahedron of a valid mesh
    /// (floating point; the sign itself is checked exactly by [`TetMesh::validate`]).
    pub fn signed_volume(&self, t: usize) -> f64 {
        let [p0, p1, p2, p3] = self.corners(t);
        (p1 - p0).dot((p2 - p0).cross(p3 - p0)) / 6.0
    }

    /// Is the face of `t` opposite its vertex `i` on the convex hull?
    pub fn is_hull_face(&self, t: usize, i: usize) -> bool {
        self.neighbours[t][i] == NO_NEIGHBOUR
    }

    /// Vertex ids of the face of `t` opposite its vertex `i`, counter-clockwise seen from
    /// outside `t`.
    pub fn face_vertices(&self, t: usize, i: usize) -> [u32; 3] {
        FACE_OUTWARD[i].map(|k| self.tets[t][k])
    }

    /// All hull faces as `(tet, face)`: the face of `tet` opposite its vertex `face`.
    pub fn hull_faces(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.neighbours.iter().enumerate().flat_map(|(t, n)| {
            (0..4)
                .filter(move |&i| n[i] == NO_NEIGHBOUR)
                .map(move |i| (t, i))
        })
    }

    /// Exact re-check of the mesh, O(T): vertex ids, positive orientation of every
    /// tetrahedron, symmetric neighbour links across identical faces with the two apices
    /// on opposite sides, the local Delaunay property across every interior face and local
    /// convexity across every hull edge (both with the construction's symbolic
    /// perturbation, which together are equivalent to the global empty-sphere property),
    /// a closed consistently oriented hull, and every point used by some tetrahedron.
    pub fn validate(&self) -> Result<(), TetError> {
        validate::validate(self).map_err(TetError::Invalid)
    }
}
