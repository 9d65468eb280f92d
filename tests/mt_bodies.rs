//! Marching tetrahedra on grid-split meshes: closed, outward bodies with honest volumes,
//! capped where the data ends, and the counts of the uncapped surface.

use std::collections::{HashMap, HashSet};

use glam::DVec3;
use proptest::prelude::*;
use wellmesh::dmt::Body;
use wellmesh::dmt::mt::{MtFace, marching_tetrahedra};
use wellmesh::grid::{CubeSplit, GridVolume, tetrahedralize};
use wellmesh::tet::TetMesh;

const SPLITS: [CubeSplit; 2] = [CubeSplit::Five, CubeSplit::Six];

/// A grid over `[lo, hi]^3` with `n` samples per axis and values `f(point)`; returns the
/// grid and the local coordinates' shift.
fn sampled(n: usize, lo: f64, hi: f64, f: impl Fn(DVec3) -> f64) -> GridVolume {
    let step = (hi - lo) / (n - 1) as f64;
    let mut values = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                values.push(f(
                    DVec3::new(i as f64, j as f64, k as f64) * step + DVec3::splat(lo)
                ));
            }
        }
    }
    let mut grid = GridVolume::regular("sampled", [n; 3], DVec3::splat(step), values).unwrap();
    // Put the lattice where it was sampled: input coordinates start at `lo`.
    grid.origin += DVec3::splat(lo);
    grid
}

/// Every edge in exactly two triangles, in opposite directions (checked independently of
/// the library's own `closed` flag).
fn assert_closed_and_oriented(body: &Body) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &body.triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            *directed.entry((a, b)).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "edge {a}-{b} used twice in one direction");
        assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
    }
    assert!(body.closed);
    assert!(
        body.volume > 0.0,
        "outward triangles give a positive volume"
    );
}

fn brute_force_counts(mesh: &TetMesh, values: &[f64], threshold: f64) -> (usize, usize) {
    let mut edges = HashSet::new();
    let mut active = 0;
    for tet in mesh.tets() {
        let marked = tet.map(|v| values[v as usize] >= threshold);
        if marked.iter().any(|m| *m) && !marked.iter().all(|m| *m) {
            active += 1;
        }
        for a in 0..4 {
            for b in a + 1..4 {
                if marked[a] != marked[b] {
                    edges.insert((tet[a].min(tet[b]), tet[a].max(tet[b])));
                }
            }
        }
    }
    (edges.len(), active)
}

#[test]
fn sphere_inside_the_grid_is_one_closed_body_with_the_right_volume() {
    let r = 1.0;
    // The distance, not its square: the interpolant of |p|^2 on a lattice is the same for
    // every cube split (|c|^2 is linear on {0,1}^3), the distance's is not.
    let grid = sampled(31, -1.5, 1.5, |p| -p.length());
    let exact = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    for split in SPLITS {
        let mesh = tetrahedralize(&grid, split).unwrap();
        let mt = marching_tetrahedra(&mesh, &grid.values, -r);
        assert_eq!(mt.bodies.len(), 1, "{split}");
        let body = &mt.bodies[0];
        assert_closed_and_oriented(body);
        assert!(!body.truncated);
        let error = (body.volume - exact).abs() / exact;
        eprintln!(
            "sphere r=1, 31^3 grid, split {split}: volume {:+.6}%, area {:+.6}%, {} triangles",
            (body.volume / exact - 1.0) * 100.0,
            (body.area / (4.0 * std::f64::consts::PI) - 1.0) * 100.0,
            body.triangles.len()
        );
        assert!(error < 0.02, "{split}: volume {} vs {exact}", body.volume);
        let area_error =
            (body.area - 4.0 * std::f64::consts::PI).abs() / (4.0 * std::f64::consts::PI);
        assert!(area_error < 0.05, "{split}: area {}", body.area);
        // The sphere is centred on the grid's origin (bbox centre).
        assert!(
            body.bbox[0].abs_diff_eq(DVec3::splat(-1.0), 0.06),
            "{:?}",
            body.bbox
        );
        assert!(
            body.bbox[1].abs_diff_eq(DVec3::splat(1.0), 0.06),
            "{:?}",
            body.bbox
        );
    }
}

#[test]
fn outside_of_a_sphere_is_capped_at_the_grid_boundary() {
    let grid = sampled(25, -1.5, 1.5, |p| p.length_squared());
    let ball = 4.0 / 3.0 * std::f64::consts::PI;
    for split in SPLITS {
        let mesh = tetrahedralize(&grid, split).unwrap();
        let mt = marching_tetrahedra(&mesh, &grid.values, 1.0);
        // One body with two shells: the capped box (outward) and the cavity (inward).
        assert_eq!(mt.bodies.len(), 1);
        let body = &mt.bodies[0];
        assert_closed_and_oriented(body);
        assert!(body.truncated);
        let exact = 27.0 - ball;
        assert!(
            (body.volume - exact).abs() / exact < 0.01,
            "{}",
            body.volume
        );
    }
}

#[test]
fn sphere_cut_by_the_grid_boundary_is_capped_and_truncated() {
    // Ball of radius 1 centred on the face z = 0 of the grid [-1.5, 1.5]^2 x [0, 1.5].
    let n = 31;
    let step = 3.0 / (n - 1) as f64;
    let nz = 16;
    let mut values = Vec::new();
    for k in 0..nz {
        for j in 0..n {
            for i in 0..n {
                let p = DVec3::new(
                    i as f64 * step - 1.5,
                    j as f64 * step - 1.5,
                    k as f64 * step,
                );
                values.push(1.0 - p.length_squared());
            }
        }
    }
    let grid = GridVolume::regular("half", [n, n, nz], DVec3::splat(step), values).unwrap();
    let half_ball = 2.0 / 3.0 * std::f64::consts::PI;
    for split in SPLITS {
        let mesh = tetrahedralize(&grid, split).unwrap();
        let mt = marching_tetrahedra(&mesh, &grid.values, 0.0);
        assert_eq!(mt.bodies.len(), 1);
        let body = &mt.bodies[0];
        assert_closed_and_oriented(body);
        assert!(body.truncated);
        assert!(
            (body.volume - half_ball).abs() / half_ball < 0.02,
            "{}",
            body.volume
        );
        // The cap is the disc of radius 1 on the grid's bottom face.
        let bottom = grid.points[0].z;
        assert!((body.bbox[0].z - bottom).abs() < 1e-12);
    }
}

#[test]
fn two_separate_spheres_are_two_bodies() {
    let centres = [DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.2, 0.0, 0.0)];
    let grid = sampled(33, -2.0, 2.0, |p| {
        centres
            .iter()
            .map(|c| 0.36 - (p - *c).length_squared())
            .fold(f64::NEG_INFINITY, f64::max)
    });
    let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.6f64.powi(3);
    let mesh = tetrahedralize(&grid, CubeSplit::Six).unwrap();
    let mt = marching_tetrahedra(&mesh, &grid.values, 0.0);
    assert_eq!(mt.bodies.len(), 2);
    for body in &mt.bodies {
        assert_closed_and_oriented(body);
        assert!(
            (body.volume - exact).abs() / exact < 0.05,
            "{}",
            body.volume
        );
    }
}

#[test]
fn counts_are_the_active_edges_and_tets() {
    let grid = sampled(12, -1.0, 1.0, |p| (3.0 * p.x).sin() + p.y * p.z);
    for split in SPLITS {
        let mesh = tetrahedralize(&grid, split).unwrap();
        for threshold in [-0.5, 0.0, 0.3] {
            let mt = marching_tetrahedra(&mesh, &grid.values, threshold);
            let (edges, tets) = brute_force_counts(&mesh, &grid.values, threshold);
            assert_eq!(mt.counts.active_edges, edges);
            assert_eq!(mt.counts.surface_vertices, edges);
            assert_eq!(mt.vertices.len(), edges);
            assert_eq!(mt.counts.active_tets, tets);
            assert_eq!(mt.counts.surface_faces, tets);
            assert_eq!(mt.faces.len(), tets);
            let marked = grid.values.iter().filter(|v| **v >= threshold).count();
            assert_eq!(mt.counts.marked_points, marked);
            // Every vertex lies on its edge, between the two ends.
            for (v, [a, b]) in mt.vertices.iter().zip(&mt.vertex_edges) {
                assert!(grid.values[*a as usize] >= threshold);
                assert!(grid.values[*b as usize] < threshold);
                let (pa, pb) = (mesh.points[*a as usize], mesh.points[*b as usize]);
                let along = (*v - pa).length() + (pb - *v).length();
                assert!((along - (pb - pa).length()).abs() < 1e-12);
            }
            let quads = mt
                .faces
                .iter()
                .filter(|f| matches!(f, MtFace::Quad(_)))
                .count();
            assert_eq!(mt.triangles().len(), tets + quads);
        }
    }
}

/// A grid with spacing (1, 0.7, 1.3), interior points moved by up to `warp` of a cell (so
/// cells stay valid for `warp` < 0.25), and values cycling through `seeds`.
fn random_grid(dims: [usize; 3], seeds: &[f64], warp: f64) -> GridVolume {
    let n = dims.iter().product::<usize>();
    let values = (0..n)
        .map(|i| seeds[i % seeds.len()] + i as f64 * 1e-9)
        .collect();
    let spacing = DVec3::new(1.0, 0.7, 1.3);
    let points = (0..n)
        .map(|p| {
            let ijk = [
                p % dims[0],
                (p / dims[0]) % dims[1],
                p / (dims[0] * dims[1]),
            ];
            let interior = (0..3).all(|a| ijk[a] > 0 && ijk[a] + 1 < dims[a]);
            let wobble = |s: usize| warp * (seeds[(p + s) % seeds.len()]);
            let offset = if interior {
                DVec3::new(wobble(1), wobble(2), wobble(3))
            } else {
                DVec3::ZERO
            };
            (DVec3::new(ijk[0] as f64, ijk[1] as f64, ijk[2] as f64) + offset) * spacing
        })
        .collect();
    GridVolume::curvilinear("random", dims, points, values, Vec::new()).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Whatever the values, every body is closed and outward, and the marked and unmarked
    /// regions add up to the whole grid.
    #[test]
    fn marked_and_unmarked_bodies_tile_the_grid(
        nx in 2usize..6, ny in 2usize..6, nz in 2usize..6,
        seeds in prop::collection::vec(-1.0f64..1.0, 1..40),
        threshold in -0.8f64..0.8,
        five in any::<bool>(),
        warp in prop::sample::select(vec![0.0, 0.2]),
    ) {
        let grid = random_grid([nx, ny, nz], &seeds, warp);
        let split = if five { CubeSplit::Five } else { CubeSplit::Six };
        let mesh = tetrahedralize(&grid, split).unwrap();
        let inside = marching_tetrahedra(&mesh, &grid.values, threshold);
        let negated: Vec<f64> = grid.values.iter().map(|v| -v).collect();
        // Values are distinct from the threshold almost surely; `> t` is `-v >= -t` then.
        prop_assume!(grid.values.iter().all(|v| *v != threshold));
        let outside = marching_tetrahedra(&mesh, &negated, -threshold);
        let mut total = 0.0;
        for body in inside.bodies.iter().chain(&outside.bodies) {
            assert_closed_and_oriented(body);
            total += body.volume;
        }
        let box_volume = (nx - 1) as f64 * (ny - 1) as f64 * 0.7 * (nz - 1) as f64 * 1.3;
        prop_assert!((total - box_volume).abs() < 1e-9 * box_volume.max(1.0), "{total} vs {box_volume}");
        // The two surfaces are the same faces, seen from either side.
        prop_assert_eq!(inside.counts.active_tets, outside.counts.active_tets);
        prop_assert_eq!(inside.counts.active_edges, outside.counts.active_edges);
    }
}

#[test]
fn blanked_points_leave_a_hole_that_is_capped_like_the_hull() {
    // A 2x2x2 block of "don't know" points inside a marked slab: the tetrahedra touching
    // them are left out, and the body gains a capped cavity around the hole.
    let dims = [9, 9, 9];
    let n = 9 * 9 * 9;
    let values: Vec<f64> = (0..n).map(|p| if p / 81 < 6 { 1.0 } else { 0.0 }).collect();
    let mut blanked = vec![false; n];
    for k in 3..5 {
        for j in 3..5 {
            for i in 3..5 {
                blanked[i + 9 * (j + 9 * k)] = true;
            }
        }
    }
    let points = (0..n)
        .map(|p| DVec3::new((p % 9) as f64, ((p / 9) % 9) as f64, (p / 81) as f64))
        .collect();
    let grid = GridVolume::curvilinear("holed", dims, points, values, blanked).unwrap();
    for split in SPLITS {
        let mesh = tetrahedralize(&grid, split).unwrap();
        let kept_volume: f64 = mesh
            .tets()
            .map(|t| {
                let [a, b, c, d] = t.map(|v| mesh.points[v as usize]);
                (b - a).dot((c - a).cross(d - a)) / 6.0
            })
            .sum();
        assert!(
            kept_volume < 512.0 - 1.0,
            "{split}: the hole removed volume"
        );
        let inside = marching_tetrahedra(&mesh, &grid.values, 0.5);
        let outside = marching_tetrahedra(
            &mesh,
            &grid.values.iter().map(|v| -v).collect::<Vec<_>>(),
            -0.5,
        );
        assert_eq!(inside.bodies.len(), 1, "{split}");
        let body = &inside.bodies[0];
        assert_closed_and_oriented(body);
        assert!(body.truncated);
        let total: f64 = inside
            .bodies
            .iter()
            .chain(&outside.bodies)
            .map(|b| b.volume)
            .sum();
        assert!(
            (total - kept_volume).abs() < 1e-9,
            "{split}: {total} vs {kept_volume}"
        );
    }
}
