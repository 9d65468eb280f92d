//! Vertex placement rules of the DMT paper (IbC, CoI, midpoint), implemented from the
//! definitions in the errata.
//!
//! Invariant: every rule returns a convex combination of the tetrahedron's corners with
//! strictly positive weights on the crossings, so the vertex lies inside the tetrahedron.

use glam::DVec3;

/// Share of an edge kept clear of its endpoints by [`crossing`], so that a sample lying
/// exactly on the threshold does not collapse several DMT vertices onto one point.
pub const CROSSING_CLEARANCE: f64 = 1e-3;

/// The linear-interpolation crossing of `threshold` on the edge `p`-`q`, where `fp` and
/// `fq` lie on opposite sides (one `< threshold`, the other `>= threshold`). The
/// parameter is clamped to `[CROSSING_CLEARANCE, 1 - CROSSING_CLEARANCE]`.
pub fn crossing(p: DVec3, q: DVec3, fp: f64, fq: f64, threshold: f64) -> DVec3 {
    let t = if fq == fp {
        0.5
    } else {
        (threshold - fp) / (fq - fp)
    };
    let t = t.clamp(CROSSING_CLEARANCE, 1.0 - CROSSING_CLEARANCE);
    p + (q - p) * t
}

/// The corners of one tetrahedron with their values, sorted so that `f[0] <= f[1] <= f[2]
/// <= f[3]` (the paper's `a, b, c, d`).
#[derive(Debug, Clone, Copy)]
pub struct SortedCorners {
    pub p: [DVec3; 4],
    pub f: [f64; 4],
}

impl SortedCorners {
    pub fn new(p: [DVec3; 4], f: [f64; 4]) -> Self {
        let mut order = [0usize, 1, 2, 3];
        order.sort_by(|&i, &j| f[i].total_cmp(&f[j]));
        SortedCorners {
            p: order.map(|i| p[i]),
            f: order.map(|i| f[i]),
        }
    }

    /// Number of corners with `value >= threshold`.
    pub fn marked(&self, threshold: f64) -> usize {
        self.f.iter().filter(|&&v| v >= threshold).count()
    }

    /// Crossing on the edge between sorted corners `i` and `j`.
    pub fn v(&self, i: usize, j: usize, threshold: f64) -> DVec3 {
        crossing(self.p[i], self.p[j], self.f[i], self.f[j], threshold)
    }

    /// Pairs `(unmarked, marked)` of sorted-corner indices: the active edges.
    pub fn active_edges(&self, threshold: f64) -> impl Iterator<Item = (usize, usize)> + '_ {
        let unmarked = 4 - self.marked(threshold);
        (0..unmarked).flat_map(move |i| (unmarked..4).map(move |j| (i, j)))
    }
}

/// Intersection between Centroids (paper eq. 1 with the errata's case 1 correction).
/// `c` must be active at `threshold` (1, 2 or 3 marked corners).
pub fn ibc(c: &SortedCorners, threshold: f64) -> DVec3 {
    weighted(c, threshold, &ibc_weights(c, threshold))
}

/// IbC as weights on the crossings of the active edges, in
/// [`SortedCorners::active_edges`] order (summing to 1; unused entries 0).
pub fn ibc_weights(c: &SortedCorners, threshold: f64) -> [f64; 4] {
    let f = c.f;
    let w = match c.marked(threshold) {
        // Case 1: a unmarked; the plane of V_ab, V_ac, V_ad met by the line from P_a to
        // the centroid of face bcd.
        3 => [f[1] - f[0], f[2] - f[0], f[3] - f[0], 0.0],
        // Case 2: a, b unmarked; the plane of the four crossings (V_ac, V_ad, V_bc, V_bd)
        // met by the line joining the midpoints of ab and cd.
        2 => [f[2] - f[0], f[3] - f[0], f[2] - f[1], f[3] - f[1]],
        // Case 3: only d marked; case 1 mirrored.
        1 => [f[3] - f[0], f[3] - f[1], f[3] - f[2], 0.0],
        _ => return coi_weights(c, threshold),
    };
    let sum: f64 = w.iter().sum();
    if sum > 0.0 && sum.is_finite() {
        w.map(|x| x / sum)
    } else {
        coi_weights(c, threshold)
    }
}

/// Centroid of Intersections: the mean of the crossings on the active edges.
pub fn coi(c: &SortedCorners, threshold: f64) -> DVec3 {
    weighted(c, threshold, &coi_weights(c, threshold))
}

/// CoI as weights on the crossings (see [`ibc_weights`]).
pub fn coi_weights(c: &SortedCorners, threshold: f64) -> [f64; 4] {
    let n = c.active_edges(threshold).count();
    let mut w = [0.0; 4];
    for x in w.iter_mut().take(n) {
        *x = 1.0 / n as f64;
    }
    w
}

/// The point with weights `w` on the crossings of the active edges (in
/// [`SortedCorners::active_edges`] order); the centroid of the corners when `c` is not
/// active.
pub fn weighted(c: &SortedCorners, threshold: f64, w: &[f64; 4]) -> DVec3 {
    let (sum, total) = c
        .active_edges(threshold)
        .zip(w)
        .fold((DVec3::ZERO, 0.0), |(s, t), ((i, j), &wi)| {
            (s + c.v(i, j, threshold) * wi, t + wi)
        });
    if total > 0.0 {
        sum / total
    } else {
        (c.p[0] + c.p[1] + c.p[2] + c.p[3]) / 4.0
    }
}

/// The mean of the midpoints of the active edges (for binary data, where values carry no
/// position information beyond the classification).
pub fn midpoint(c: &SortedCorners, threshold: f64) -> DVec3 {
    let (sum, n) = c
        .active_edges(threshold)
        .fold((DVec3::ZERO, 0.0), |(s, n), (i, j)| {
            (s + (c.p[i] + c.p[j]) * 0.5, n + 1.0)
        });
    if n == 0.0 {
        (c.p[0] + c.p[1] + c.p[2] + c.p[3]) / 4.0
    } else {
        sum / n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tet() -> [DVec3; 4] {
        [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(3.0, 0.2, 0.1),
            DVec3::new(0.5, 2.5, -0.3),
            DVec3::new(0.4, 0.7, 2.9),
        ]
    }

    fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
        (b - a).dot((c - a).cross(d - a))
    }

    #[test]
    fn ibc_case_1_lies_on_the_crossing_plane_and_the_line_to_the_face_centroid() {
        let c = SortedCorners::new(tet(), [0.1, 0.9, 1.7, 3.2]);
        let th = 0.6;
        let v = ibc(&c, th);
        let (vab, vac, vad) = (c.v(0, 1, th), c.v(0, 2, th), c.v(0, 3, th));
        let scale = (vab - vac).length() * (vab - vad).length() * (vac - vad).length();
        assert!(
            orient(vab, vac, vad, v).abs() < 1e-12 * scale,
            "off the crossing plane"
        );
        let centroid = (c.p[1] + c.p[2] + c.p[3]) / 3.0;
        let dir = (centroid - c.p[0]).normalize();
        let off = (v - c.p[0]) - dir * (v - c.p[0]).dot(dir);
        assert!(
            off.length() < 1e-12,
            "off the line P_a -> centroid(bcd): {off}"
        );
    }

    #[test]
    fn ibc_case_3_lies_on_the_crossing_plane_and_the_line_to_the_face_centroid() {
        let c = SortedCorners::new(tet(), [0.1, 0.9, 1.7, 3.2]);
        let th = 2.0;
        let v = ibc(&c, th);
        let (vad, vbd, vcd) = (c.v(0, 3, th), c.v(1, 3, th), c.v(2, 3, th));
        let scale = (vad - vbd).length() * (vad - vcd).length() * (vbd - vcd).length();
        assert!(orient(vad, vbd, vcd, v).abs() < 1e-12 * scale);
        let centroid = (c.p[0] + c.p[1] + c.p[2]) / 3.0;
        let dir = (centroid - c.p[3]).normalize();
        let off = (v - c.p[3]) - dir * (v - c.p[3]).dot(dir);
        assert!(off.length() < 1e-12);
    }

    #[test]
    fn ibc_case_2_lies_on_the_line_joining_the_midpoints_of_ab_and_cd() {
        let c = SortedCorners::new(tet(), [0.1, 0.9, 1.7, 3.2]);
        let v = ibc(&c, 1.2);
        let m1 = (c.p[0] + c.p[1]) / 2.0;
        let m2 = (c.p[2] + c.p[3]) / 2.0;
        let dir = (m2 - m1).normalize();
        let off = (v - m1) - dir * (v - m1).dot(dir);
        assert!(off.length() < 1e-12);
        // The weights sum to the denominator: a constant shift of all values is harmless.
        let shifted = SortedCorners::new(tet(), [5.1, 5.9, 6.7, 8.2]);
        assert!((ibc(&shifted, 6.2) - v).length() < 1e-12);
    }

    #[test]
    fn coi_is_the_mean_of_the_crossings() {
        let c = SortedCorners::new(tet(), [0.1, 0.9, 1.7, 3.2]);
        let th = 1.2;
        let expected = (c.v(0, 2, th) + c.v(0, 3, th) + c.v(1, 2, th) + c.v(1, 3, th)) / 4.0;
        assert!((coi(&c, th) - expected).length() < 1e-15);
        // Printed case 2 formula with the errata's P_c coefficient.
        let [fa, fb, fc, fd] = c.f;
        let f = th;
        let [pa, pb, pc, pd] = c.p;
        let printed = (pa * ((fc - f) / (fc - fa) + (fd - f) / (fd - fa))
            + pb * ((fd - f) / (fd - fb) + (fc - f) / (fc - fb))
            + pc * ((f - fa) / (fc - fa) + (f - fb) / (fc - fb))
            + pd * ((f - fa) / (fd - fa) + (f - fb) / (fd - fb)))
            / 4.0;
        assert!((coi(&c, th) - printed).length() < 1e-12);
    }

    #[test]
    fn placements_stay_inside_the_tetrahedron() {
        let p = tet();
        for values in [
            [0.0, 1.0, 1.0, 1.0],
            [0.0, 0.0, 1.0, 1.0],
            [0.0, 0.0, 0.0, 1.0],
        ] {
            let c = SortedCorners::new(p, values);
            for v in [ibc(&c, 0.5), coi(&c, 0.5), midpoint(&c, 0.5)] {
                for (i, j, k, l) in [(0, 1, 2, 3), (1, 0, 3, 2), (2, 3, 0, 1), (3, 2, 1, 0)] {
                    let full = orient(p[i], p[j], p[k], p[l]);
                    let part = orient(p[i], p[j], p[k], v);
                    assert!(part / full > 0.0);
                }
            }
        }
    }

    #[test]
    fn weights_on_the_crossings_give_the_rules_and_stay_inside_the_tetrahedron() {
        let p = tet();
        for (values, th) in [
            ([0.1, 0.9, 1.7, 3.2], 0.6),
            ([0.1, 0.9, 1.7, 3.2], 1.2),
            ([0.1, 0.9, 1.7, 3.2], 2.0),
        ] {
            let c = SortedCorners::new(p, values);
            let w = ibc_weights(&c, th);
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(w.iter().take(c.active_edges(th).count()).all(|&x| x > 0.0));
            assert!((weighted(&c, th, &coi_weights(&c, th)) - coi(&c, th)).length() < 1e-12);
            // Any positive weights (the relaxation's) keep the vertex inside.
            let v = weighted(&c, th, &[0.7, 0.05, 0.2, 0.05]);
            for (i, j, k, l) in [(0, 1, 2, 3), (1, 0, 3, 2), (2, 3, 0, 1), (3, 2, 1, 0)] {
                assert!(orient(p[i], p[j], p[k], v) / orient(p[i], p[j], p[k], p[l]) > 0.0);
            }
        }
    }

    #[test]
    fn crossing_interpolates_and_keeps_clear_of_the_corners() {
        let p = DVec3::ZERO;
        let q = DVec3::new(10.0, 0.0, 0.0);
        assert!((crossing(p, q, 0.0, 4.0, 1.0).x - 2.5).abs() < 1e-12);
        assert!(
            (crossing(p, q, 0.0, 1.0, 1.0).x - 10.0 * (1.0 - CROSSING_CLEARANCE)).abs() < 1e-12
        );
    }
}
