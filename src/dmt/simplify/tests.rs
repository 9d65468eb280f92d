use super::*;
use crate::dmt::measure;

/// An icosphere of radius 1: 20 * 4^level triangles, wound outwards.
fn sphere(level: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pos: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<DVec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                pos.push(((pos[a as usize] + pos[b as usize]) / 2.0).normalize());
                pos.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut pos),
                midpoint(b, c, &mut pos),
                midpoint(c, a, &mut pos),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    (pos, tris)
}

/// A unit cube with each face cut into n x n squares of two triangles, wound outwards.
fn gridded_cube(n: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut index = std::collections::HashMap::new();
    let mut pos = Vec::new();
    let mut tris = Vec::new();
    let mut vertex = |p: DVec3, pos: &mut Vec<DVec3>| -> u32 {
        let key = (p * n as f64).round().as_ivec3().to_array();
        *index.entry(key).or_insert_with(|| {
            pos.push(p);
            pos.len() as u32 - 1
        })
    };
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: u32, dj: u32| {
                        let mut p = DVec3::ZERO;
                        p[axis] = side;
                        p[u] = (i + di) as f64 / n as f64;
                        p[v] = (j + dj) as f64 / n as f64;
                        p
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]
                        .map(|p| vertex(p, &mut pos));
                    if side == 1.0 {
                        tris.push([q[0], q[1], q[2]]);
                        tris.push([q[0], q[2], q[3]]);
                    } else {
                        tris.push([q[0], q[2], q[1]]);
                        tris.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    (pos, tris)
}

fn never() -> bool {
    false
}

/// The largest distance of an input vertex from the output surface (brute force).
fn farthest(original: &[DVec3], out: &Simplified) -> f64 {
    original
        .iter()
        .map(|&p| {
            out.triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| out.positions[i as usize]);
                    distance_squared_to_triangle(p, a, b, c)
                })
                .fold(f64::INFINITY, f64::min)
                .sqrt()
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_sphere_keeps_within_the_tolerance_and_stays_closed() {
    let (pos, tris) = sphere(4);
    assert!(measure::is_closed_and_oriented(&tris));
    for tolerance in [0.005, 0.02, 0.05] {
        let out = simplify(&pos, &tris, &Limits::new(tolerance), &never).unwrap();
        assert!(measure::is_closed_and_oriented(&out.triangles));
        assert!(
            out.triangles.len() < tris.len() * 9 / 10,
            "{tolerance}: {} of {}",
            out.triangles.len(),
            tris.len()
        );
        let far = farthest(&pos, &out);
        assert!(
            far <= tolerance + out.offset.abs() + 1e-6,
            "{tolerance}: {far} (offset {})",
            out.offset
        );
        // The chords of a convex body lie inside it: the offset is outwards, and small.
        assert!(out.offset > 0.0 && out.offset < tolerance, "{}", out.offset);
        for p in &out.positions {
            let moved_from_an_input_vertex =
                pos.iter().any(|q| p.distance(*q) <= out.offset + 1e-6);
            assert!(moved_from_an_input_vertex, "{p}");
        }
        let (v0, v1) = (
            measure::volume(&pos, &tris),
            measure::volume(&out.positions, &out.triangles),
        );
        assert!(
            (v1 - v0).abs() < 1e-6 * v0,
            "{tolerance}: volume {v0} -> {v1}"
        );
        let q = measure::quality([(out.positions.as_slice(), out.triangles.as_slice())]);
        assert_eq!(q.min_angle_under_10deg, 0.0, "{tolerance}: {q:?}");
    }
}

#[test]
fn a_looser_tolerance_removes_more() {
    let (pos, tris) = sphere(4);
    let counts: Vec<usize> = [0.001, 0.01, 0.05]
        .iter()
        .map(|&t| {
            simplify(&pos, &tris, &Limits::new(t), &never)
                .unwrap()
                .triangles
                .len()
        })
        .collect();
    assert!(counts[0] > counts[1] && counts[1] > counts[2], "{counts:?}");
}

#[test]
fn a_gridded_cube_keeps_its_volume_and_loses_its_flat_grid() {
    let (pos, tris) = gridded_cube(10);
    assert_eq!(tris.len(), 1200);
    let out = simplify(&pos, &tris, &Limits::new(1e-6), &never).unwrap();
    assert!(measure::is_closed_and_oriented(&out.triangles));
    let volume = measure::volume(&out.positions, &out.triangles);
    assert!((volume - 1.0).abs() < 1e-12, "{volume}");
    assert!((measure::area(&out.positions, &out.triangles) - 6.0).abs() < 1e-12);
    assert!(out.triangles.len() < 400, "{}", out.triangles.len());
    for corner in 0..8 {
        let c = DVec3::new(
            (corner & 1) as f64,
            ((corner >> 1) & 1) as f64,
            ((corner >> 2) & 1) as f64,
        );
        assert!(out.positions.contains(&c), "corner {c} kept");
    }
}

#[test]
fn a_tetrahedron_and_an_open_surface_come_back_unchanged() {
    let pos = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
    let tet = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let out = simplify(&pos, &tet, &Limits::new(10.0), &never).unwrap();
    assert_eq!((out.positions, out.triangles), (pos.clone(), tet.clone()));
    assert_eq!(out.offset, 0.0);
    let open = tet[..3].to_vec();
    let out = simplify(&pos, &open, &Limits::new(10.0), &never).unwrap();
    assert_eq!(out.triangles, open);
}

#[test]
fn cancelling_stops_the_simplification() {
    let (pos, tris) = sphere(5);
    assert!(simplify(&pos, &tris, &Limits::new(0.01), &|| true).is_none());
}

#[test]
fn the_distance_to_a_triangle_matches_a_dense_sampling() {
    let (a, b, c) = (
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(2.0, 0.3, 0.1),
        DVec3::new(0.4, 1.5, -0.2),
    );
    let probes = [
        DVec3::new(0.5, 0.5, 1.0),
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(3.0, 0.0, 0.0),
        DVec3::new(1.5, 1.5, 0.3),
        DVec3::new(0.0, 3.0, 0.0),
        DVec3::new(1.0, -1.0, -0.5),
    ];
    let n = 400;
    for p in probes {
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
                best = best.min((a + (b - a) * s + (c - a) * t).distance_squared(p));
            }
        }
        let exact = distance_squared_to_triangle(p, a, b, c);
        assert!(
            exact <= best + 1e-12 && best - exact < 1e-4,
            "{p}: {exact} vs {best}"
        );
    }
}

#[test]
fn a_bumpy_body_with_thin_triangles_keeps_every_bound() {
    // A sphere with a ridged radius and jittered vertices: curved, creased, uneven.
    let (mut pos, tris) = sphere(4);
    let mut seed = 7u64;
    let mut jitter = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for p in &mut pos {
        let r = 1.0 + 0.2 * (5.0 * p.x).sin() * (3.0 * p.y).cos() + 0.01 * jitter();
        *p *= r;
    }
    let before = measure::quality([(pos.as_slice(), tris.as_slice())]);
    let tolerance = 0.02;
    let out = simplify(&pos, &tris, &Limits::new(tolerance), &never).unwrap();
    assert!(measure::is_closed_and_oriented(&out.triangles));
    assert!(
        out.triangles.len() < tris.len() / 2,
        "{}",
        out.triangles.len()
    );
    let far = farthest(&pos, &out);
    assert!(far <= tolerance + out.offset.abs() + 1e-6, "{far}");
    let v0 = measure::volume(&pos, &tris);
    let v1 = measure::volume(&out.positions, &out.triangles);
    assert!((v1 - v0).abs() < 1e-6 * v0, "volume {v0} -> {v1}");
    let after = measure::quality([(out.positions.as_slice(), out.triangles.as_slice())]);
    let slivers = |q: &crate::dmt::Quality| q.min_angle_under_10deg * q.triangles as f64;
    assert!(
        slivers(&after) <= slivers(&before),
        "{before:?} -> {after:?}"
    );
}

#[test]
fn balancing_gives_a_shrunken_sphere_its_volume_back() {
    let (pos, tris) = sphere(3);
    let target = measure::volume(&pos, &tris);
    let mut small: Vec<DVec3> = pos.iter().map(|p| *p * 0.97).collect();
    let offset = balance_volume(&mut small, &tris, target);
    assert!((offset - 0.03).abs() < 1e-4, "{offset}");
    let volume = measure::volume(&small, &tris);
    assert!((volume - target).abs() < 1e-6 * target, "{volume} {target}");
}

#[test]
fn a_large_body_is_simplified_in_parts_alike_on_any_number_of_threads() {
    let (pos, tris) = sphere(6);
    assert!(tris.len() >= PARALLEL_MIN_TRIANGLES);
    let tolerance = 0.002;
    let out = simplify(&pos, &tris, &Limits::new(tolerance), &never).unwrap();
    assert!(measure::is_closed_and_oriented(&out.triangles));
    assert!(
        out.triangles.len() < tris.len() / 3,
        "{}",
        out.triangles.len()
    );
    let v0 = measure::volume(&pos, &tris);
    let v1 = measure::volume(&out.positions, &out.triangles);
    assert!((v1 - v0).abs() < 1e-6 * v0, "volume {v0} -> {v1}");
    // Every input vertex within the distance (plus the offset) of the output: checked on a
    // sample of them near the parts' seams and elsewhere.
    let sample: Vec<DVec3> = pos.iter().step_by(97).copied().collect();
    let far = farthest(&sample, &out);
    assert!(far <= tolerance + out.offset.abs() + 1e-6, "{far}");
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| simplify(&pos, &tris, &Limits::new(tolerance), &never).unwrap());
    assert_eq!(one, out);
}
