//! Delaunay tetrahedralization: validity on random, lattice, UTM, duplicate and degenerate
//! inputs, error cases, and agreement with independent brute-force computations.

use std::collections::BTreeSet;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::DVec3;
use proptest::prelude::*;
use wellmesh::progress::{NoProgress, Progress};
use wellmesh::tet::{TetError, TetMesh, delaunay, delaunay_owned_without_map};

/// Deterministic xorshift64* stream of `f64` in [0, 1).
struct Rng(u64);

impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn point(&mut self) -> DVec3 {
        DVec3::new(self.next_f64(), self.next_f64(), self.next_f64())
    }
}

fn random_points(n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = Rng(seed.max(1));
    (0..n).map(|_| rng.point()).collect()
}

/// `wells x wells` vertical wells on an exact 50 m lattice, `samples` samples 1 m apart.
fn well_lattice(wells: usize, samples: usize, origin: DVec3) -> Vec<DVec3> {
    let mut pts = Vec::new();
    for i in 0..wells {
        for j in 0..wells {
            for k in 0..samples {
                pts.push(origin + DVec3::new(i as f64 * 50.0, j as f64 * 50.0, 300.0 - k as f64));
            }
        }
    }
    pts
}

fn volume_m3(mesh: &TetMesh) -> f64 {
    (0..mesh.tet_count()).map(|t| mesh.signed_volume(t)).sum()
}

fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (b - a).dot((c - a).cross(d - a))
}

/// Convex hull volume by brute force, for points in general position: a triple is a hull
/// facet when every other point lies strictly on one side of its plane.
fn brute_force_hull_volume(pts: &[DVec3]) -> f64 {
    let n = pts.len();
    let centroid = pts.iter().copied().sum::<DVec3>() / n as f64;
    let mut volume = 0.0;
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let sides: Vec<f64> = (0..n)
                    .filter(|&m| m != i && m != j && m != k)
                    .map(|m| orient(pts[i], pts[j], pts[k], pts[m]))
                    .collect();
                if sides.iter().all(|&s| s > 0.0) || sides.iter().all(|&s| s < 0.0) {
                    volume += orient(centroid, pts[i], pts[j], pts[k]).abs() / 6.0;
                }
            }
        }
    }
    volume
}

/// Number of Delaunay tetrahedra by brute force, for points in general position: 4-subsets
/// that are not flat and whose circumsphere holds no other point.
fn brute_force_delaunay_count(pts: &[DVec3]) -> usize {
    use wellmesh::tet::predicates::{Sign, insphere_exact, orient_exact};
    let n = pts.len();
    let mut count = 0;
    for a in 0..n {
        for b in a + 1..n {
            for c in b + 1..n {
                for d in c + 1..n {
                    let (pa, mut pb, mut pc, pd) = (pts[a], pts[b], pts[c], pts[d]);
                    match orient_exact(pa, pb, pc, pd) {
                        Sign::Zero => continue,
                        Sign::Negative => std::mem::swap(&mut pb, &mut pc),
                        Sign::Positive => {}
                    }
                    let empty = (0..n)
                        .filter(|&e| e != a && e != b && e != c && e != d)
                        .all(|e| insphere_exact(pa, pb, pc, pd, pts[e]) == Sign::Negative);
                    count += usize::from(empty);
                }
            }
        }
    }
    count
}

/// The tetrahedra as sets of corner coordinates relative to `origin`, in millimetres
/// (vertex numbering is the construction's own; geometry is what callers rely on).
fn tet_set(mesh: &TetMesh, origin: DVec3) -> BTreeSet<[[i64; 3]; 4]> {
    mesh.tets()
        .map(|t| {
            let mut s = t.map(|v| {
                let p = (mesh.points[v as usize] - origin) * 1000.0;
                [p.x.round() as i64, p.y.round() as i64, p.z.round() as i64]
            });
            s.sort_unstable();
            s
        })
        .collect()
}

#[test]
fn random_points_give_a_valid_delaunay_mesh_filling_the_hull() {
    let pts = random_points(3000, 7);
    let mesh = delaunay(&pts, &NoProgress).unwrap();
    mesh.validate().unwrap();
    assert_eq!(mesh.points.len(), 3000);
    assert_eq!(mesh.duplicates_merged, 0);
    for (i, &v) in mesh.vertex_of_input.iter().enumerate() {
        assert_eq!(mesh.points[v as usize], pts[i]);
    }
    // Uniform random points have about 6.7 tetrahedra per point.
    assert!(mesh.tet_count() > 5 * 3000, "{}", mesh.tet_count());
}

#[test]
fn exact_well_lattice_is_valid_and_fills_its_box() {
    let pts = well_lattice(5, 30, DVec3::ZERO);
    let mesh = delaunay(&pts, &NoProgress).unwrap();
    mesh.validate().unwrap();
    let box_m3 = 200.0 * 200.0 * 29.0;
    assert!((volume_m3(&mesh) - box_m3).abs() < 1e-6 * box_m3);
    for t in 0..mesh.tet_count() {
        assert!(mesh.signed_volume(t) > 0.0, "flat tetrahedron {t}");
    }
}

#[test]
fn lattice_at_utm_coordinates_gives_the_same_tetrahedra_as_at_the_origin() {
    let local = delaunay(&well_lattice(5, 30, DVec3::ZERO), &NoProgress).unwrap();
    let offset = DVec3::new(5e5, 7e6, 0.0);
    let utm_pts = well_lattice(5, 30, offset);
    let utm = delaunay(&utm_pts, &NoProgress).unwrap();
    utm.validate().unwrap();
    assert_eq!(local.tet_count(), utm.tet_count());
    assert_eq!(tet_set(&local, DVec3::ZERO), tet_set(&utm, offset));
    for (i, &v) in utm.vertex_of_input.iter().enumerate() {
        assert_eq!(utm.points[v as usize], utm_pts[i], "caller's coordinates");
    }
}

/// Sets of 50,000 points and more are inserted in parallel zones: the same guarantees.
#[test]
fn large_sets_built_in_parallel_zones_are_exact_and_independent_of_the_origin() {
    let pts = random_points(100_000, 11);
    let mesh = delaunay(&pts, &NoProgress).unwrap();
    mesh.validate().unwrap();
    assert!(mesh.tet_count() > 6 * 100_000, "{}", mesh.tet_count());
    let local = delaunay(&well_lattice(24, 100, DVec3::ZERO), &NoProgress).unwrap();
    local.validate().unwrap();
    let box_m3 = 1150.0 * 1150.0 * 99.0;
    assert!((volume_m3(&local) - box_m3).abs() < 1e-9 * box_m3);
    let offset = DVec3::new(5e5, 7e6, 0.0);
    let utm = delaunay(&well_lattice(24, 100, offset), &NoProgress).unwrap();
    utm.validate().unwrap();
    assert_eq!(tet_set(&local, DVec3::ZERO), tet_set(&utm, offset));
}

/// Wells with jittered collars at UTM coordinates (as `gen_points.py utm-wells` makes
/// them): every co-spherical tie is two samples on one well and two on another, broken by
/// the construction's shortcut for such ties. The mesh is the Delaunay mesh of the
/// general perturbation (`validate` tests each face with it; debug builds also compare
/// each tie's answer), the same on one thread as on several.
#[test]
fn jittered_utm_wells_give_the_delaunay_mesh_of_the_general_tie_break() {
    let mut rng = Rng(0x7e11_5eed);
    let mut pts = Vec::new();
    for i in 0..14 {
        for j in 0..14 {
            let x = 500_000.0 + i as f64 * 50.0 + (rng.next_f64() - 0.5) * 6.0;
            let y = 6_500_000.0 + j as f64 * 50.0 + (rng.next_f64() - 0.5) * 6.0;
            for k in 0..40 {
                pts.push(DVec3::new(x, y, 300.0 - k as f64));
            }
        }
    }
    let mesh = delaunay(&pts, &NoProgress).unwrap();
    mesh.validate().unwrap();
    assert_eq!(mesh.points.len(), pts.len());
    let serial = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| delaunay(&pts, &NoProgress))
        .unwrap();
    assert_eq!(tet_set(&mesh, DVec3::ZERO), tet_set(&serial, DVec3::ZERO));
}

/// The benchmark sizes, validated in full (about a minute):
/// `cargo test --release --test tet_delaunay million -- --ignored`.
#[test]
#[ignore]
fn a_million_uniform_points_and_a_million_sample_utm_lattice_validate() {
    let mesh = delaunay(&random_points(1_000_000, 5), &NoProgress).unwrap();
    mesh.validate().unwrap();
    let offset = DVec3::new(5e5, 7e6, 0.0);
    let mesh = delaunay(&well_lattice(100, 100, offset), &NoProgress).unwrap();
    mesh.validate().unwrap();
    let box_m3 = 4950.0 * 4950.0 * 99.0;
    assert!((volume_m3(&mesh) - box_m3).abs() < 1e-9 * box_m3);
}

#[test]
fn cube_lattice_count_is_defined_by_the_perturbation() {
    // 4 x 4 x 4 unit lattice: every cube is co-spherical. The perturbation makes the
    // result unique; whichever triangulation it picks, it fills the cube exactly.
    let mut pts = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                pts.push(DVec3::new(i as f64, j as f64, k as f64));
            }
        }
    }
    let mesh = delaunay(&pts, &NoProgress).unwrap();
    mesh.validate().unwrap();
    assert!((volume_m3(&mesh) - 27.0).abs() < 1e-9);
    // Insertion order does not matter: reversing the input gives the same tetrahedra.
    let reversed: Vec<DVec3> = pts.iter().rev().copied().collect();
    let back = delaunay(&reversed, &NoProgress).unwrap();
    assert_eq!(tet_set(&back, DVec3::ZERO), tet_set(&mesh, DVec3::ZERO));
}

#[test]
fn duplicate_points_are_merged_and_counted() {
    let mut pts = random_points(200, 3);
    pts.push(pts[5]);
    pts.push(pts[17]);
    pts.push(pts[5]);
    let mesh = delaunay(&pts, &NoProgress).unwrap();
    mesh.validate().unwrap();
    assert_eq!(mesh.duplicates_merged, 3);
    assert_eq!(mesh.points.len(), 200);
    assert_eq!(mesh.vertex_of_input.len(), 203);
    assert_eq!(mesh.vertex_of_input[200], mesh.vertex_of_input[5]);
    assert_eq!(mesh.vertex_of_input[201], mesh.vertex_of_input[17]);
    for (i, &v) in mesh.vertex_of_input.iter().enumerate() {
        assert_eq!(mesh.points[v as usize], pts[i]);
    }
}

/// `wellmesh tetrahedralize` builds without the input map: the same mesh, vertex for
/// vertex and tetrahedron for tetrahedron, the same duplicate count, and no map.
#[test]
fn a_mesh_built_without_the_input_map_is_the_same_mesh() {
    // Large enough for the parallel zones, with duplicates spread through the input.
    let mut pts = random_points(60_000, 21);
    for i in (0..60_000).step_by(997) {
        pts.push(pts[i]);
    }
    let mapped = delaunay(&pts, &NoProgress).unwrap();
    let bare = delaunay_owned_without_map(pts.clone(), &NoProgress).unwrap();
    bare.validate().unwrap();
    assert!(bare.vertex_of_input.is_empty());
    assert_eq!(mapped.vertex_of_input.len(), pts.len());
    assert_eq!(bare.duplicates_merged, 61);
    assert_eq!(bare.duplicates_merged, mapped.duplicates_merged);
    assert_eq!(bare.points, mapped.points);
    assert!(bare.tets().eq(mapped.tets()));
    assert!((0..bare.tet_count()).all(|t| bare.neighbours(t) == mapped.neighbours(t)));
}

#[test]
fn negative_zero_is_the_same_coordinate_as_zero() {
    let mut pts = random_points(50, 9);
    pts.push(DVec3::new(0.0, 0.5, 0.5));
    pts.push(DVec3::new(0.3, 0.1, 0.2));
    pts.push(DVec3::new(-0.0, 0.5, 0.5));
    let mesh = delaunay(&pts, &NoProgress).unwrap();
    mesh.validate().unwrap();
    assert_eq!(mesh.duplicates_merged, 1);
    assert_eq!(mesh.vertex_of_input[50], mesh.vertex_of_input[52]);
}

#[test]
fn coplanar_input_is_rejected() {
    let pts: Vec<DVec3> = (0..50)
        .map(|i| DVec3::new((i % 7) as f64, (i / 7) as f64 * 0.5, 0.0))
        .map(|p| p + DVec3::new(0.0, 0.0, p.x + p.y))
        .collect();
    assert!(matches!(
        delaunay(&pts, &NoProgress),
        Err(TetError::AllCoplanar)
    ));
    let line: Vec<DVec3> = (0..10).map(|i| DVec3::splat(i as f64)).collect();
    assert!(matches!(
        delaunay(&line, &NoProgress),
        Err(TetError::AllCoplanar)
    ));
}

#[test]
fn fewer_than_four_distinct_points_are_rejected() {
    let pts = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::X, DVec3::ZERO];
    assert!(matches!(
        delaunay(&pts, &NoProgress),
        Err(TetError::TooFewPoints { distinct: 3 })
    ));
    assert!(matches!(
        delaunay(&[], &NoProgress),
        Err(TetError::TooFewPoints { distinct: 0 })
    ));
}

#[test]
fn non_finite_coordinates_are_rejected_with_their_index() {
    let mut pts = random_points(10, 1);
    pts[6].y = f64::NAN;
    let err = delaunay(&pts, &NoProgress).unwrap_err();
    assert!(matches!(err, TetError::NonFinite { index: 6 }));
    assert!(err.to_string().contains("point 6"));
}

struct CancelAfter(AtomicUsize);

impl Progress for CancelAfter {
    fn report(&self, _stage: wellmesh::progress::Stage, _fraction: f64) {}
    fn is_cancelled(&self) -> bool {
        self.0.fetch_add(1, Ordering::Relaxed) >= 1
    }
}

#[test]
fn cancellation_stops_the_insertion_loop() {
    let pts = random_points(20_000, 11);
    let result = delaunay(&pts, &CancelAfter(AtomicUsize::new(0)));
    assert!(matches!(result, Err(TetError::Cancelled)));
}

#[test]
fn small_general_position_sets_match_a_brute_force_delaunay() {
    for seed in 1..8 {
        let pts = random_points(18, seed);
        let mesh = delaunay(&pts, &NoProgress).unwrap();
        mesh.validate().unwrap();
        assert_eq!(
            mesh.tet_count(),
            brute_force_delaunay_count(&pts),
            "seed {seed}"
        );
        let hull = brute_force_hull_volume(&pts);
        assert!((volume_m3(&mesh) - hull).abs() < 1e-9 * hull.max(1e-12));
    }
}

#[test]
fn validate_catches_a_flipped_tetrahedron_and_a_broken_link() {
    let mesh = delaunay(&random_points(100, 5), &NoProgress).unwrap();
    let mut flipped = mesh.clone();
    let [a, b, c, d] = mesh.tet(3);
    flipped.set_tet(3, [b, a, c, d]);
    assert!(flipped.validate().is_err());
    let mut unlinked = mesh.clone();
    let t = (0..mesh.tet_count())
        .find(|&t| mesh.neighbours(t)[0] != wellmesh::tet::NO_NEIGHBOUR)
        .unwrap();
    unlinked.set_neighbour(t, 0, wellmesh::tet::NO_NEIGHBOUR);
    assert!(unlinked.validate().is_err());
}

fn shape_strategy() -> impl Strategy<Value = Vec<DVec3>> {
    let coord = || -1000.0f64..1000.0;
    let point = move || (coord(), coord(), coord()).prop_map(|(x, y, z)| DVec3::new(x, y, z));
    let random = prop::collection::vec(point(), 5..120);
    let clustered = (
        prop::collection::vec(point(), 1..4),
        prop::collection::vec(
            (0usize..4, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
            5..120,
        ),
    )
        .prop_map(|(centres, offsets)| {
            offsets
                .into_iter()
                .map(|(c, x, y, z)| centres[c % centres.len()] + DVec3::new(x, y, z) * 1e-3)
                .collect()
        });
    let lattice = (
        2usize..5,
        2usize..5,
        2usize..6,
        prop::collection::vec(0usize..200, 0..20),
    )
        .prop_map(|(nx, ny, nz, drop)| {
            let mut pts = Vec::new();
            for i in 0..nx {
                for j in 0..ny {
                    for k in 0..nz {
                        pts.push(DVec3::new(i as f64 * 50.0, j as f64 * 50.0, k as f64));
                    }
                }
            }
            // Drop a few interior-or-not points to break symmetry (keeps corners).
            for d in drop {
                let idx = d % pts.len();
                if idx != 0 && idx != pts.len() - 1 && pts.len() > 8 {
                    pts.remove(idx);
                }
            }
            pts
        });
    let duplicates = (
        prop::collection::vec(point(), 5..30),
        prop::collection::vec(0usize..30, 0..60),
    )
        .prop_map(|(base, picks)| {
            let mut pts = base.clone();
            pts.extend(picks.into_iter().map(|i| base[i % base.len()]));
            pts
        });
    prop_oneof![random, clustered, lattice, duplicates]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(120))]

    #[test]
    fn every_input_gives_a_valid_mesh_or_a_clear_error(pts in shape_strategy()) {
        match delaunay(&pts, &NoProgress) {
            Ok(mesh) => {
                prop_assert!(mesh.validate().is_ok(), "{:?}", mesh.validate());
                prop_assert_eq!(mesh.vertex_of_input.len(), pts.len());
                for t in 0..mesh.tet_count() {
                    prop_assert!(mesh.signed_volume(t) > 0.0);
                }
            }
            Err(TetError::AllCoplanar | TetError::TooFewPoints { .. }) => {}
            Err(other) => prop_assert!(false, "unexpected error {other}"),
        }
    }

    #[test]
    fn tetrahedra_fill_the_convex_hull_exactly(pts in prop::collection::vec(
        (-10.0f64..10.0, -10.0f64..10.0, -10.0f64..10.0).prop_map(|(x, y, z)| DVec3::new(x, y, z)),
        5..28,
    )) {
        let mesh = delaunay(&pts, &NoProgress).unwrap();
        let hull = brute_force_hull_volume(&pts);
        prop_assert!((volume_m3(&mesh) - hull).abs() <= 1e-9 * hull, "{} vs {}", volume_m3(&mesh), hull);
        prop_assert_eq!(mesh.tet_count(), brute_force_delaunay_count(&pts));
    }
}
