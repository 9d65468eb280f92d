//! Cube splits: conforming, positively oriented tetrahedra that fill the grid exactly.

use std::collections::HashMap;

use glam::DVec3;
use wellmesh::grid::{CubeSplit, GridVolume, tetrahedralize, tetrahedralize_with_report};
use wellmesh::tet::{NO_NEIGHBOUR, TetMesh};

fn signed_volume(mesh: &TetMesh, t: usize) -> f64 {
    let [a, b, c, d] = mesh.tet(t).map(|v| mesh.points[v as usize]);
    (b - a).dot((c - a).cross(d - a)) / 6.0
}

fn sorted_face(tet: &[u32; 4], j: usize) -> [u32; 3] {
    let mut f = [tet[(j + 1) % 4], tet[(j + 2) % 4], tet[(j + 3) % 4]];
    f.sort_unstable();
    f
}

/// Checks the `TetMesh` contract independently of how the mesh was built; returns the
/// number of boundary faces.
fn assert_valid_mesh(mesh: &TetMesh) -> usize {
    assert_eq!(
        mesh.vertex_of_input,
        (0..mesh.points.len() as u32).collect::<Vec<_>>()
    );
    let mut uses: HashMap<[u32; 3], usize> = HashMap::new();
    for (t, tet) in mesh.tets().enumerate() {
        assert!(signed_volume(mesh, t) > 0.0, "tet {t} {tet:?} not positive");
        for j in 0..4 {
            *uses.entry(sorted_face(&tet, j)).or_default() += 1;
            let n = mesh.neighbours(t)[j];
            if n == NO_NEIGHBOUR {
                continue;
            }
            let (t2, j2) = ((n / 4) as usize, (n % 4) as usize);
            assert_ne!(t2, t);
            assert_eq!(mesh.neighbours(t2)[j2], (t * 4 + j) as u32, "not symmetric");
            assert_eq!(sorted_face(&mesh.tet(t2), j2), sorted_face(&tet, j));
        }
    }
    assert!(
        uses.values().all(|n| *n == 1 || *n == 2),
        "a face in 3+ tets"
    );
    let boundary = uses.values().filter(|n| **n == 1).count();
    let marked_boundary = (0..mesh.tet_count())
        .flat_map(|t| mesh.neighbours(t))
        .filter(|&n| n == NO_NEIGHBOUR)
        .count();
    assert_eq!(
        boundary, marked_boundary,
        "every unshared face is NO_NEIGHBOUR"
    );
    boundary
}

fn total_volume(mesh: &TetMesh) -> f64 {
    (0..mesh.tet_count()).map(|t| signed_volume(mesh, t)).sum()
}

fn ramp(dims: [usize; 3]) -> Vec<f64> {
    (0..dims.iter().product::<usize>())
        .map(|n| n as f64)
        .collect()
}

#[test]
fn both_splits_conform_and_fill_the_box() {
    let dims = [4, 3, 5];
    let spacing = DVec3::new(2.0, 0.5, 3.0);
    let grid = GridVolume::regular("box", dims, spacing, ramp(dims)).unwrap();
    let box_volume = 3.0 * 2.0 * 2.0 * 0.5 * 4.0 * 3.0;
    let cells = 3 * 2 * 4;
    let quads = 2 * (3 * 2 + 2 * 4 + 3 * 4);
    for split in [CubeSplit::Five, CubeSplit::Six] {
        let (mesh, report) = tetrahedralize_with_report(&grid, split).unwrap();
        assert_eq!(mesh.tet_count(), cells * split.tets_per_cell(), "{split}");
        assert_eq!(report.degenerate_tets + report.blanked_tets, 0);
        let boundary = assert_valid_mesh(&mesh);
        assert_eq!(boundary, 2 * quads, "{split}: boundary quads split in two");
        assert_eq!(report.boundary_faces, boundary);
        assert!((total_volume(&mesh) - box_volume).abs() < 1e-9, "{split}");

        // Boundary faces are exactly the faces on the box's six planes.
        let lo = grid.points[0];
        let hi = grid.points[grid.len() - 1];
        for (t, tet) in mesh.tets().enumerate() {
            for j in 0..4 {
                let face = sorted_face(&tet, j).map(|v| mesh.points[v as usize]);
                let on_plane = (0..3).any(|axis| {
                    face.iter().all(|p| p[axis] == lo[axis])
                        || face.iter().all(|p| p[axis] == hi[axis])
                });
                assert_eq!(on_plane, mesh.neighbours(t)[j] == NO_NEIGHBOUR);
            }
        }
    }
}

#[test]
fn five_split_alternates_so_cells_share_face_diagonals() {
    // A single 2x2x2-cell block: without alternation neighbouring cells would cut their
    // shared faces along crossing diagonals and faces would be unmatched (more boundary).
    let dims = [3, 3, 3];
    let grid = GridVolume::regular("g", dims, DVec3::ONE, ramp(dims)).unwrap();
    let mesh = tetrahedralize(&grid, CubeSplit::Five).unwrap();
    assert_eq!(assert_valid_mesh(&mesh), 2 * 6 * 4);
}

#[test]
fn warped_curvilinear_grid_stays_conforming_and_exact_in_volume() {
    // Interior points moved by less than a quarter cell: cells stay convex-ish, boundary
    // fixed, so the tetrahedra still tile the box.
    let dims = [6, 5, 4];
    let mut points = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let interior = |n: usize, d: usize| n > 0 && n + 1 < d;
                let wobble = |s: f64| 0.2 * (s * 12.9898).sin();
                let mut p = DVec3::new(i as f64, j as f64, k as f64);
                if interior(i, dims[0]) && interior(j, dims[1]) && interior(k, dims[2]) {
                    let seed = (i * 31 + j * 17 + k * 7) as f64;
                    p += DVec3::new(wobble(seed), wobble(seed + 1.0), wobble(seed + 2.0));
                }
                points.push(p + DVec3::new(500_000.0, 7_000_000.0, 300.0));
            }
        }
    }
    let n = points.len();
    let grid = GridVolume::curvilinear("warped", dims, points, vec![0.0; n], Vec::new()).unwrap();
    assert_eq!(grid.origin, DVec3::new(500_002.5, 7_000_002.0, 301.5));
    for split in [CubeSplit::Five, CubeSplit::Six] {
        let (mesh, report) = tetrahedralize_with_report(&grid, split).unwrap();
        assert_eq!(report.flipped_tets, 0);
        assert_valid_mesh(&mesh);
        assert!((total_volume(&mesh) - 5.0 * 4.0 * 3.0).abs() < 1e-9);
    }
}

#[test]
fn left_handed_grid_is_reoriented() {
    let dims = [3, 3, 3];
    let axes = [DVec3::X, DVec3::Y, DVec3::NEG_Z * 2.0];
    let grid = GridVolume::lattice("lh", dims, DVec3::ZERO, axes, ramp(dims)).unwrap();
    for split in [CubeSplit::Five, CubeSplit::Six] {
        let (mesh, report) = tetrahedralize_with_report(&grid, split).unwrap();
        assert_eq!(report.flipped_tets, mesh.tet_count());
        assert_valid_mesh(&mesh);
        assert!((total_volume(&mesh) - 2.0 * 2.0 * 4.0).abs() < 1e-9);
    }
}

#[test]
fn collapsed_cells_and_blanked_points_are_left_out_and_reported() {
    // Squash the k = 0 layer onto k = 1 along one row: the cells there lose volume.
    let dims = [3, 3, 3];
    let mut points = Vec::new();
    for k in 0..3 {
        for j in 0..3 {
            for i in 0..3 {
                let z = if k == 0 && j == 0 { 1.0 } else { k as f64 };
                points.push(DVec3::new(i as f64, j as f64, z));
            }
        }
    }
    let mut blanked = vec![false; 27];
    blanked[26] = true; // corner (2, 2, 2)
    let grid = GridVolume::curvilinear("c", dims, points, ramp(dims), blanked).unwrap();
    let (mesh, report) = tetrahedralize_with_report(&grid, CubeSplit::Six).unwrap();
    assert!(
        report.degenerate_tets > 0 && report.degenerate_cells == 2,
        "{report:?}"
    );
    assert!(report.blanked_tets > 0);
    assert_eq!(
        mesh.tet_count() + report.degenerate_tets + report.blanked_tets,
        8 * 6
    );
    assert!(mesh.tets().all(|t| !t.contains(&26)));
    assert_valid_mesh(&mesh);
}

#[test]
fn all_blanked_is_an_error_naming_the_grid() {
    let grid = GridVolume::regular("empty", [2, 2, 2], DVec3::ONE, vec![f64::NAN; 8]).unwrap();
    let err = tetrahedralize(&grid, CubeSplit::Six)
        .unwrap_err()
        .to_string();
    assert!(err.contains("empty") && err.contains("blanked"), "{err}");
}
