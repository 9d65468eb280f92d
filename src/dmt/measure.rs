//! Measures of triangle meshes: volume, area, closedness, connected components, triangle
//! quality.
//!
//! Invariant: every measure is computed from exactly the triangles it is given, in the
//! frame they are given in (local coordinates keep the sums accurate at UTM magnitudes).

use glam::DVec3;
use rayon::prelude::*;

use super::Quality;

/// Enclosed volume by the divergence theorem: positive for outward-facing triangles.
pub fn volume(positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            a.dot(b.cross(c))
        })
        .sum::<f64>()
        / 6.0
}

/// Total surface area.
pub fn area(positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            (b - a).cross(c - a).length() * 0.5
        })
        .sum()
}

/// `true` when every directed edge occurs exactly once and its reverse exactly once: a
/// closed, consistently oriented surface (every edge in exactly two triangles).
pub fn is_closed_and_oriented(triangles: &[[u32; 3]]) -> bool {
    // Outgoing directed edges grouped by source vertex (counting sort), then every edge
    // a -> b must be unique among a's and have exactly one reverse among b's.
    let vertex_count = triangles
        .iter()
        .flatten()
        .max()
        .map_or(0, |&m| m as usize + 1);
    let mut start = vec![0u32; vertex_count + 1];
    for t in triangles {
        for &v in t {
            start[v as usize + 1] += 1;
        }
    }
    for i in 0..vertex_count {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut targets = vec![0u32; triangles.len() * 3];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if a == b {
                return false;
            }
            targets[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
        }
    }
    let out = |v: u32| &targets[start[v as usize] as usize..start[v as usize + 1] as usize];
    (0..vertex_count as u32).into_par_iter().all(|a| {
        let mine = out(a);
        mine.iter().enumerate().all(|(i, &b)| {
            !mine[..i].contains(&b) && out(b).iter().filter(|&&x| x == a).count() == 1
        })
    })
}

/// Axis-aligned bounds `[min, max]` of the points.
pub fn bbox(positions: &[DVec3]) -> [DVec3; 2] {
    positions.iter().fold(
        [DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)],
        |[lo, hi], &p| [lo.min(p), hi.max(p)],
    )
}

/// Smallest interior angle of a triangle, in degrees (0 for a degenerate one).
pub fn min_angle_deg(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (u, v) = smallest_angle_sides(a, b, c);
    u.cross(v).length().atan2(u.dot(v)).to_degrees()
}

/// The two sides from the corner of a triangle's smallest angle: the one opposite its
/// shortest edge.
pub fn smallest_angle_sides(a: DVec3, b: DVec3, c: DVec3) -> (DVec3, DVec3) {
    let (ab, bc, ca) = (
        (b - a).length_squared(),
        (c - b).length_squared(),
        (a - c).length_squared(),
    );
    let (apex, p, q) = if bc <= ab && bc <= ca {
        (a, b, c)
    } else if ca <= ab {
        (b, c, a)
    } else {
        (c, a, b)
    };
    (p - apex, q - apex)
}

/// Triangle quality over several meshes.
pub fn quality<'a>(meshes: impl IntoIterator<Item = (&'a [DVec3], &'a [[u32; 3]])>) -> Quality {
    let mut q = Quality {
        min_angle_deg: 180.0,
        ..Quality::default()
    };
    let mut sum = 0.0;
    let mut slivers = 0usize;
    for (positions, triangles) in meshes {
        q.vertices += positions.len();
        q.triangles += triangles.len();
        for t in triangles {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let m = min_angle_deg(a, b, c);
            sum += m;
            q.min_angle_deg = q.min_angle_deg.min(m);
            if m < 10.0 {
                slivers += 1;
            }
        }
    }
    if q.triangles > 0 {
        q.mean_min_angle_deg = sum / q.triangles as f64;
        q.min_angle_under_10deg = slivers as f64 / q.triangles as f64;
    } else {
        q.min_angle_deg = 0.0;
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let p: Vec<DVec3> = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64) * 2.0)
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (p, t)
    }

    #[test]
    fn a_cube_has_its_volume_and_area_and_is_closed() {
        let (p, t) = cube();
        assert!((volume(&p, &t) - 8.0).abs() < 1e-12);
        assert!((area(&p, &t) - 24.0).abs() < 1e-12);
        assert!(is_closed_and_oriented(&t));
        let shifted: Vec<DVec3> = p.iter().map(|&q| q + DVec3::new(5e5, 7e6, 300.0)).collect();
        assert!(
            (volume(&shifted, &t) - 8.0).abs() < 1e-3,
            "volume is translation invariant"
        );
    }

    #[test]
    fn a_flipped_triangle_breaks_orientation_and_a_missing_one_breaks_closure() {
        let (_, mut t) = cube();
        t[3].swap(1, 2);
        assert!(!is_closed_and_oriented(&t));
        let (_, mut t) = cube();
        t.pop();
        assert!(!is_closed_and_oriented(&t));
    }

    #[test]
    fn the_smallest_angle_is_found_whatever_the_corner_order() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::new(0.0, 3f64.sqrt(), 0.0));
        for (p, q, r) in [(a, b, c), (b, c, a), (c, a, b), (a, c, b)] {
            assert!((min_angle_deg(p, q, r) - 30.0).abs() < 1e-9);
        }
    }
}
