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

use std::sync::atomic::AtomicU32;
use std::sync::atomic::Ordering::Relaxed;

use glam::DVec3;
use rayon::prelude::*;

use crate::progress::Progress;
use delaunay::InputMap;

/// Marks a face on the convex hull in [`TetMesh::neighbours`].
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// Vertex positions of the face opposite vertex `i` of a positive tetrahedron, ordered
/// counter-clockwise seen from outside (their normal points away from vertex `i`).
pub const FACE_OUTWARD: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// A conforming tetrahedral mesh.
///
/// Shapes: #T tetrahedra ([`TetMesh::tet_count`]), each with 4 vertex indices into
/// `points` ([`TetMesh::tet`]) and 4 neighbour links ([`TetMesh::neighbours`]):
/// `neighbours(t)[i]` is the tetrahedron across the face opposite `tet(t)[i]`, encoded
/// `t2 * 4 + j` with `j` the index of the same face in `t2` (the vertex of `t2` not on
/// it), or [`NO_NEIGHBOUR`] on the hull. `vertex_of_input` maps each input point to its
/// vertex (duplicates share one); it is empty in a mesh built by
/// [`delaunay_owned_without_map`].
///
/// The tetrahedra are stored as the Delaunay construction builds them, 32 bytes each with
/// vertices and links side by side, so a built mesh is handed over without copying its
/// largest array (see `docs/tet.md`, *Memory*).
#[derive(Default)]
pub struct TetMesh {
    pub points: Vec<DVec3>,
    cells: Vec<Cell>,
    pub vertex_of_input: Vec<u32>,
    /// Input points merged into an earlier identical point.
    pub duplicates_merged: usize,
}

/// One tetrahedron as the construction writes it: vertex ids and neighbour links. Relaxed
/// atomics, so that the construction's workers can share the array without `unsafe` (see
/// `delaunay.rs`); in a finished mesh they are only read, and on x86-64 and AArch64 a
/// relaxed load is an ordinary one.
#[derive(Debug, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub(crate) struct Cell {
    /// Vertex ids (during construction: with mark bits; see `delaunay.rs`).
    pub(crate) v: [AtomicU32; 4],
    /// `t2 * 4 + j` across the face opposite vertex `i`.
    pub(crate) n: [AtomicU32; 4],
}

impl Cell {
    fn new(v: [u32; 4], n: [u32; 4]) -> Cell {
        Cell {
            v: v.map(AtomicU32::new),
            n: n.map(AtomicU32::new),
        }
    }

    /// The neighbour links.
    #[inline(always)]
    fn links(&self) -> [u32; 4] {
        load4(&self.n)
    }

    #[inline]
    fn set_verts(&self, v: [u32; 4]) {
        for (a, x) in self.v.iter().zip(v) {
            a.store(x, Relaxed);
        }
    }

    #[inline]
    fn set_links(&self, n: [u32; 4]) {
        for (a, x) in self.n.iter().zip(n) {
            a.store(x, Relaxed);
        }
    }
}

/// Four relaxed loads, written out: through `array::map` the compiler left the loads of
/// the cavity search's neighbours behind a call.
#[inline(always)]
fn load4(a: &[AtomicU32; 4]) -> [u32; 4] {
    [
        a[0].load(Relaxed),
        a[1].load(Relaxed),
        a[2].load(Relaxed),
        a[3].load(Relaxed),
    ]
}

impl Clone for TetMesh {
    fn clone(&self) -> TetMesh {
        TetMesh {
            points: self.points.clone(),
            cells: (0..self.tet_count())
                .map(|t| Cell::new(self.tet(t), self.neighbours(t)))
                .collect(),
            vertex_of_input: self.vertex_of_input.clone(),
            duplicates_merged: self.duplicates_merged,
        }
    }
}

impl PartialEq for TetMesh {
    fn eq(&self, other: &TetMesh) -> bool {
        self.points == other.points
            && self.tet_count() == other.tet_count()
            && (0..self.tet_count())
                .all(|t| self.tet(t) == other.tet(t) && self.neighbours(t) == other.neighbours(t))
            && self.vertex_of_input == other.vertex_of_input
            && self.duplicates_merged == other.duplicates_merged
    }
}

impl std::fmt::Debug for TetMesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TetMesh")
            .field("points", &self.points.len())
            .field("tets", &self.tet_count())
            .field("vertex_of_input", &self.vertex_of_input.len())
            .field("duplicates_merged", &self.duplicates_merged)
            .finish()
    }
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
    /// No one power-of-two scale brings every nonzero coordinate into the window where
    /// the exact predicates cannot overflow or underflow: `(point, coordinate)` with the
    /// smallest and the largest nonzero magnitude.
    #[error(
        "coordinates too far apart in magnitude for exact arithmetic: point {} has {:e} and point {} has {:e}; nonzero coordinates may differ by a factor of at most 2^297 (about 1e89)",
        small.0, small.1, large.0, large.1
    )]
    MagnitudeRange {
        small: (usize, f64),
        large: (usize, f64),
    },
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
/// an internal translation (and, for magnitudes beyond about `1e-44 .. 1e45`, a scale by a
/// power of two) is used only where it is itself exact. Points with identical
/// coordinates are merged (`duplicates_merged`); the mesh's `points` are the distinct
/// points in spatial (Hilbert curve) order and `vertex_of_input` maps each input point to
/// its vertex. Checks `progress.is_cancelled()`
/// every few thousand insertions.
///
/// Errors: [`TetError::NonFinite`], [`TetError::MagnitudeRange`] (nonzero coordinates
/// more than about 89 orders of magnitude apart), [`TetError::TooFewPoints`] (fewer than
/// 4 distinct), [`TetError::AllCoplanar`], [`TetError::TooManyPoints`],
/// [`TetError::Cancelled`].
pub fn delaunay(points: &[DVec3], progress: &dyn Progress) -> Result<TetMesh, TetError> {
    delaunay::build(points.to_vec(), InputMap::Keep, progress)
}

/// [`delaunay`] taking ownership of the points, which are freed once copied in insertion
/// order (no copy of the input beside the caller's, at large sizes 24 bytes per point).
pub fn delaunay_owned(points: Vec<DVec3>, progress: &dyn Progress) -> Result<TetMesh, TetError> {
    delaunay::build(points, InputMap::Keep, progress)
}

/// [`delaunay_owned`] for a caller that never maps input points to vertices (one that
/// writes the mesh as it is, such as `wellmesh tetrahedralize`): the mesh's
/// `vertex_of_input` is left empty, which saves 4 bytes per input point at the
/// construction's peak (3.8 MiB at 1M points). `duplicates_merged` still counts the
/// merged points; the mesh is the same, tetrahedron for tetrahedron.
pub fn delaunay_owned_without_map(
    points: Vec<DVec3>,
    progress: &dyn Progress,
) -> Result<TetMesh, TetError> {
    delaunay::build(points, InputMap::Drop, progress)
}

impl TetMesh {
    /// A mesh from its arrays: `tets[t]` and `neighbours[t]` as [`TetMesh::tet`] and
    /// [`TetMesh::neighbours`] return them. The arrays are released from their ends as the
    /// mesh fills from its end, so memory stays near 32 bytes per tetrahedron.
    ///
    /// # Panics
    /// If `tets` and `neighbours` differ in length (a caller's bug, not bad input).
    pub fn from_parts(
        points: Vec<DVec3>,
        mut tets: Vec<[u32; 4]>,
        mut neighbours: Vec<[u32; 4]>,
        vertex_of_input: Vec<u32>,
        duplicates_merged: usize,
    ) -> TetMesh {
        assert_eq!(
            tets.len(),
            neighbours.len(),
            "one neighbour row per tetrahedron"
        );
        // Zeroed: not resident until written.
        let cells: Vec<Cell> = bytemuck::zeroed_vec(tets.len());
        const CHUNK: usize = 1 << 14;
        let mut end = tets.len();
        while end > 0 {
            let start = end.saturating_sub(CHUNK);
            cells[start..end]
                .par_iter()
                .zip(&tets[start..end])
                .zip(&neighbours[start..end])
                .for_each(|((c, &v), &n)| {
                    c.set_verts(v);
                    c.set_links(n);
                });
            tets.truncate(start);
            tets.shrink_to_fit();
            neighbours.truncate(start);
            neighbours.shrink_to_fit();
            end = start;
        }
        TetMesh {
            points,
            cells,
            vertex_of_input,
            duplicates_merged,
        }
    }

    /// The mesh of a Delaunay construction: `cells` hold the finite tetrahedra only,
    /// without mark bits.
    pub(crate) fn from_cells(
        points: Vec<DVec3>,
        cells: Vec<Cell>,
        vertex_of_input: Vec<u32>,
        duplicates_merged: usize,
    ) -> TetMesh {
        TetMesh {
            points,
            cells,
            vertex_of_input,
            duplicates_merged,
        }
    }

    /// Number of tetrahedra.
    pub fn tet_count(&self) -> usize {
        self.cells.len()
    }

    /// Vertex ids of tetrahedron `t` (positively oriented).
    #[inline]
    pub fn tet(&self, t: usize) -> [u32; 4] {
        load4(&self.cells[t].v)
    }

    /// Neighbour links of tetrahedron `t` (see [`TetMesh`]).
    #[inline]
    pub fn neighbours(&self, t: usize) -> [u32; 4] {
        self.cells[t].links()
    }

    /// Vertex ids of every tetrahedron, in order.
    pub fn tets(&self) -> impl ExactSizeIterator<Item = [u32; 4]> + Clone + '_ {
        (0..self.tet_count()).map(|t| self.tet(t))
    }

    /// [`TetMesh::tets`] as a parallel iterator.
    pub fn par_tets(&self) -> impl IndexedParallelIterator<Item = [u32; 4]> + '_ {
        (0..self.tet_count()).into_par_iter().map(|t| self.tet(t))
    }

    /// Replaces the vertex ids of tetrahedron `t` (no check: [`TetMesh::validate`] tells).
    pub fn set_tet(&mut self, t: usize, v: [u32; 4]) {
        for (a, x) in self.cells[t].v.iter_mut().zip(v) {
            *a.get_mut() = x;
        }
    }

    /// Replaces the link across the face opposite vertex `i` of tetrahedron `t` (no
    /// check: [`TetMesh::validate`] tells).
    pub fn set_neighbour(&mut self, t: usize, i: usize, link: u32) {
        *self.cells[t].n[i].get_mut() = link;
    }

    /// The four corner positions of tetrahedron `t`.
    pub fn corners(&self, t: usize) -> [DVec3; 4] {
        self.tet(t).map(|v| self.points[v as usize])
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
        self.neighbours(t)[i] == NO_NEIGHBOUR
    }

    /// Vertex ids of the face of `t` opposite its vertex `i`, counter-clockwise seen from
    /// outside `t`.
    pub fn face_vertices(&self, t: usize, i: usize) -> [u32; 3] {
        let tv = self.tet(t);
        FACE_OUTWARD[i].map(|k| tv[k])
    }

    /// All hull faces as `(tet, face)`: the face of `tet` opposite its vertex `face`.
    pub fn hull_faces(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.tet_count()).flat_map(move |t| {
            let n = self.neighbours(t);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mesh_from_parts_reads_back_its_arrays_and_compares_by_content() {
        let points = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
        // More tetrahedra than one chunk of `from_parts`, so its end-first filling shows.
        let tets: Vec<[u32; 4]> = (0..40_000u32).map(|t| [t % 5, 1, 2, 3]).collect();
        let neighbours: Vec<[u32; 4]> = (0..40_000u32)
            .map(|t| [t * 4, NO_NEIGHBOUR, t, 7])
            .collect();
        let mesh = TetMesh::from_parts(points, tets.clone(), neighbours.clone(), vec![0; 5], 2);
        assert_eq!(mesh.tet_count(), tets.len());
        assert_eq!(mesh.tets().collect::<Vec<_>>(), tets);
        assert_eq!(mesh.par_tets().collect::<Vec<_>>(), tets);
        for t in [0, 16_383, 16_384, 23_615, 23_616, 39_999] {
            assert_eq!(mesh.tet(t), tets[t]);
            assert_eq!(mesh.neighbours(t), neighbours[t]);
            assert!(mesh.is_hull_face(t, 1));
            assert!(!mesh.is_hull_face(t, 0));
        }
        let mut copy = mesh.clone();
        assert_eq!(copy, mesh);
        copy.set_tet(9, [1, 0, 2, 3]);
        assert_ne!(copy, mesh);
        let mut copy = mesh.clone();
        copy.set_neighbour(9, 3, NO_NEIGHBOUR);
        assert_ne!(copy, mesh);
        assert_eq!(copy.neighbours(9)[3], NO_NEIGHBOUR);
        assert_eq!(
            format!("{mesh:?}"),
            "TetMesh { points: 5, tets: 40000, vertex_of_input: 5, duplicates_merged: 2 }"
        );
    }
}
