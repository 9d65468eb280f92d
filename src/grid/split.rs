//! Cube splits: every grid cell cut into 5 or 6 tetrahedra, conforming across cells.
//!
//! Invariant: the returned mesh has only positively oriented tetrahedra (orientation decided
//! exactly; zero-volume ones are left out and counted) and symmetric `neighbours` built by
//! pairing equal sorted face triples.

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::{CubeSplit, GridError, GridVolume};
use crate::tet::{NO_NEIGHBOUR, TetMesh};

/// Corner `b` of a cell is point `(i + (b & 1), j + (b >> 1 & 1), k + (b >> 2 & 1))`.
///
/// 6-split (CFK): the paths `0 -> e_a -> e_a + e_b -> 7` over the orderings of the axes.
/// Every cube face is cut along the diagonal through corner 0 or corner 7, which the
/// neighbouring cell cuts the same way.
/// Corner orders are positively oriented in a right-handed cell.
const SIX: [[u8; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 7, 5],
    [0, 2, 7, 3],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 7, 6],
];

/// 5-split of an even cell (`(i + j + k) % 2 == 0`): central tetrahedron on the corners of
/// even bit parity, then the four odd corners cut off. The odd cell is the mirror image.
const FIVE_EVEN: [[u8; 4]; 5] = [
    [0, 3, 6, 5],
    [1, 0, 5, 3],
    [2, 0, 3, 6],
    [4, 0, 6, 5],
    [7, 3, 5, 6],
];
const FIVE_ODD: [[u8; 4]; 5] = [
    [1, 2, 4, 7],
    [0, 1, 2, 4],
    [3, 1, 7, 2],
    [5, 1, 4, 7],
    [6, 2, 7, 4],
];

/// What the split did, for reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct SplitReport {
    pub cells: usize,
    pub tets: usize,
    /// Tetrahedra with negative volume in their cell's corner order (left-handed axes or
    /// folded curvilinear cells), reordered to be positive.
    pub flipped_tets: usize,
    /// Tetrahedra of exactly zero volume (collapsed cells), left out.
    pub degenerate_tets: usize,
    /// Cells with at least one degenerate tetrahedron.
    pub degenerate_cells: usize,
    /// Tetrahedra touching a blanked point, left out.
    pub blanked_tets: usize,
    /// Faces on the mesh boundary.
    pub boundary_faces: usize,
}

/// Splits every cell of `grid` into tetrahedra. See [`tetrahedralize_with_report`].
pub fn tetrahedralize(grid: &GridVolume, split: CubeSplit) -> Result<TetMesh, GridError> {
    tetrahedralize_with_report(grid, split).map(|(mesh, _)| mesh)
}

/// Splits every cell of `grid` into 5 or 6 tetrahedra.
///
/// The mesh's `points` are the grid's (all of them, `vertex_of_input` the identity), so
/// `grid.values` are its per-vertex values. Tetrahedra touching a blanked point or of zero
/// volume are left out; their faces become boundary faces. Fails only when no tetrahedron
/// is left.
pub fn tetrahedralize_with_report(
    grid: &GridVolume,
    split: CubeSplit,
) -> Result<(TetMesh, SplitReport), GridError> {
    let [nx, ny, nz] = grid.dims;
    if nx < 2 || ny < 2 || nz < 2 || grid.points.len() != nx * ny * nz {
        return Err(GridError::shape(
            &grid.source,
            format!(
                "dims {nx}x{ny}x{nz} do not match {} points",
                grid.points.len()
            ),
        ));
    }
    let cells_per_slab = (nx - 1) * (ny - 1);

    // Each slab of cells (fixed k) is independent: split them in parallel.
    let slabs: Vec<(Vec<[u32; 4]>, SplitReport)> = (0..nz - 1)
        .into_par_iter()
        .map(|k| {
            let mut tets = Vec::with_capacity(cells_per_slab * split.tets_per_cell());
            let mut report = SplitReport::default();
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    split_cell(grid, split, [i, j, k], &mut tets, &mut report);
                }
            }
            (tets, report)
        })
        .collect();

    let mut report = SplitReport {
        cells: cells_per_slab * (nz - 1),
        ..SplitReport::default()
    };
    let mut tets = Vec::with_capacity(slabs.iter().map(|(t, _)| t.len()).sum());
    for (slab, r) in slabs {
        tets.extend_from_slice(&slab);
        report.flipped_tets += r.flipped_tets;
        report.degenerate_tets += r.degenerate_tets;
        report.degenerate_cells += r.degenerate_cells;
        report.blanked_tets += r.blanked_tets;
    }
    report.tets = tets.len();
    if tets.is_empty() {
        return Err(GridError::shape(
            &grid.source,
            format!(
                "no cell left to contour ({} tetrahedra blanked, {} of zero volume)",
                report.blanked_tets, report.degenerate_tets
            ),
        ));
    }

    let neighbours = face_adjacency(&tets);
    report.boundary_faces = neighbours
        .iter()
        .flatten()
        .filter(|n| **n == NO_NEIGHBOUR)
        .count();
    let mesh = TetMesh {
        points: grid.points.clone(),
        vertex_of_input: (0..grid.points.len() as u32).collect(),
        tets,
        neighbours,
        duplicates_merged: 0,
    };
    Ok((mesh, report))
}

fn split_cell(
    grid: &GridVolume,
    split: CubeSplit,
    [i, j, k]: [usize; 3],
    tets: &mut Vec<[u32; 4]>,
    report: &mut SplitReport,
) {
    let corner = |b: u8| -> u32 {
        let b = b as usize;
        grid.index(i + (b & 1), j + (b >> 1 & 1), k + (b >> 2 & 1)) as u32
    };
    let templates: &[[u8; 4]] = match split {
        CubeSplit::Six => &SIX,
        CubeSplit::Five if (i + j + k) % 2 == 0 => &FIVE_EVEN,
        CubeSplit::Five => &FIVE_ODD,
    };
    let mut degenerate = false;
    for template in templates {
        let mut tet = template.map(corner);
        if tet.iter().any(|v| grid.is_blanked(*v as usize)) {
            report.blanked_tets += 1;
            continue;
        }
        let [a, b, c, d] = tet.map(|v| grid.points[v as usize]);
        let volume6 = signed_volume6(a, b, c, d);
        if volume6 == 0.0 {
            report.degenerate_tets += 1;
            degenerate = true;
            continue;
        }
        if volume6 < 0.0 {
            tet.swap(2, 3);
            report.flipped_tets += 1;
        }
        tets.push(tet);
    }
    if degenerate {
        report.degenerate_cells += 1;
    }
}

/// Six times the signed volume `(b-a) . ((c-a) x (d-a))`, with an exact sign (Shewchuk's
/// adaptive predicate; `robust::orient3d` is positive for the opposite orientation).
pub(crate) fn signed_volume6(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    let p = |v: DVec3| robust::Coord3D {
        x: v.x,
        y: v.y,
        z: v.z,
    };
    -robust::orient3d(p(a), p(b), p(c), p(d))
}

/// `neighbours[t][j]` = `t2 * 4 + j2` for the tetrahedron sharing the face opposite corner
/// `j` of `t`, [`NO_NEIGHBOUR`] when no other tetrahedron has that face.
///
/// # Panics
/// If a face is in three or more tetrahedra: the splits are conforming, so that is a bug.
pub(crate) fn face_adjacency(tets: &[[u32; 4]]) -> Vec<[u32; 4]> {
    let mut faces: Vec<([u32; 3], u32)> = Vec::with_capacity(tets.len() * 4);
    for (t, tet) in tets.iter().enumerate() {
        for j in 0..4 {
            let mut key = [tet[(j + 1) % 4], tet[(j + 2) % 4], tet[(j + 3) % 4]];
            key.sort_unstable();
            faces.push((key, (t * 4 + j) as u32));
        }
    }
    faces.par_sort_unstable();
    let mut neighbours = vec![[NO_NEIGHBOUR; 4]; tets.len()];
    let mut n = 0;
    while n < faces.len() {
        let mut m = n + 1;
        while m < faces.len() && faces[m].0 == faces[n].0 {
            m += 1;
        }
        assert!(
            m - n <= 2,
            "face {:?} is in {} tetrahedra: the cube split is not conforming",
            faces[n].0,
            m - n
        );
        if m - n == 2 {
            let (x, y) = (faces[n].1, faces[n + 1].1);
            neighbours[(x / 4) as usize][(x % 4) as usize] = y;
            neighbours[(y / 4) as usize][(y % 4) as usize] = x;
        }
        n = m;
    }
    neighbours
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_volume_matches_the_tet_convention() {
        let v = signed_volume6(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z);
        assert_eq!(v, 1.0);
        assert_eq!(
            signed_volume6(DVec3::ZERO, DVec3::Y, DVec3::X, DVec3::Z),
            -1.0
        );
    }

    #[test]
    fn templates_are_positive_and_fill_the_unit_cube() {
        let corner = |b: u8| DVec3::new((b & 1) as f64, (b >> 1 & 1) as f64, (b >> 2 & 1) as f64);
        for templates in [&SIX[..], &FIVE_EVEN[..], &FIVE_ODD[..]] {
            let total: f64 = templates
                .iter()
                .map(|t| {
                    let [a, b, c, d] = t.map(corner);
                    let v = signed_volume6(a, b, c, d);
                    assert!(v > 0.0, "{t:?}");
                    v / 6.0
                })
                .sum();
            assert!((total - 1.0).abs() < 1e-12, "{templates:?}: {total}");
        }
    }
}
