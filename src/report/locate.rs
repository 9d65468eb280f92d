//! Point location in a [`TetMesh`]: the tetrahedron holding a point and its barycentric
//! weights, for evaluating the piecewise-linear field anywhere (cross-validation's
//! predictions).
//!
//! Invariant: a point is found in a tetrahedron whose barycentric weights are all at least
//! `-WEIGHT_SLACK` (then clamped to 0 and renormalised, so they sum to 1), or reported
//! outside the hull; never a wrong tetrahedron silently. The walk is the visibility walk
//! (across the face the point is most beyond), which ends on a Delaunay mesh; a point
//! beyond a hull face's plane (by more than the slack) is outside, since the hull is
//! convex. A walk that runs too long falls back to a scan of every tetrahedron.

use glam::DVec3;
use rayon::prelude::*;

use crate::tet::{NO_NEIGHBOUR, TetMesh};

/// Weights this far below zero still count as inside (rounding on faces and edges).
const WEIGHT_SLACK: f64 = 1e-9;

/// Locates points in one mesh, walking from a hint (the last tetrahedron found is a good
/// one for consecutive samples down a hole).
pub struct Locator<'a> {
    mesh: &'a TetMesh,
}

impl<'a> Locator<'a> {
    pub fn new(mesh: &'a TetMesh) -> Self {
        Locator { mesh }
    }

    /// Barycentric weights of `q` in tetrahedron `t` (corner order of `mesh.tet(t)`), and
    /// the index of the most negative one.
    fn weights(&self, t: usize, q: DVec3) -> ([f64; 4], usize) {
        let p = self.mesh.corners(t);
        let det = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| (b - a).dot((c - a).cross(d - a));
        let whole = det(p[0], p[1], p[2], p[3]);
        let mut w = [0.0; 4];
        for (i, wi) in w.iter_mut().enumerate() {
            let mut c = p;
            c[i] = q;
            *wi = det(c[0], c[1], c[2], c[3]) / whole;
        }
        let worst = (0..4).min_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
        (w, worst)
    }

    fn normalised(mut w: [f64; 4]) -> [f64; 4] {
        for x in &mut w {
            *x = x.max(0.0);
        }
        let sum: f64 = w.iter().sum();
        w.map(|x| x / sum)
    }

    /// The tetrahedron holding `q` and its barycentric weights, or `None` when `q` is
    /// outside the mesh's hull. `hint` is where the walk starts (any tetrahedron index).
    pub fn locate(&self, q: DVec3, hint: usize) -> Option<(usize, [f64; 4])> {
        let count = self.mesh.tet_count();
        if count == 0 || !q.is_finite() {
            return None;
        }
        let mut t = hint.min(count - 1);
        // A visibility walk crosses each tetrahedron at most once on a Delaunay mesh.
        for _ in 0..count.min(1 << 20) + 8 {
            let (w, worst) = self.weights(t, q);
            if w[worst] >= -WEIGHT_SLACK {
                return Some((t, Self::normalised(w)));
            }
            let next = self.mesh.neighbours(t)[worst];
            if next == NO_NEIGHBOUR {
                // Beyond a hull face's plane, which bounds the (convex) hull: outside.
                return None;
            }
            t = (next / 4) as usize;
        }
        self.scan(q)
    }

    /// Every tetrahedron tried: the one whose smallest weight is largest, if that weight
    /// counts as inside.
    fn scan(&self, q: DVec3) -> Option<(usize, [f64; 4])> {
        let (t, w, worst) = (0..self.mesh.tet_count())
            .into_par_iter()
            .map(|t| {
                let (w, worst) = self.weights(t, q);
                (t, w, w[worst])
            })
            .reduce_with(|a, b| {
                if b.2 > a.2 || (b.2 == a.2 && b.0 < a.0) {
                    b
                } else {
                    a
                }
            })?;
        (worst >= -WEIGHT_SLACK && worst.is_finite()).then(|| (t, Self::normalised(w)))
    }

    /// The piecewise-linear interpolation of `values` (one per mesh vertex) at `q`, with
    /// the tetrahedron found (a hint for the next call); `None` outside the hull.
    pub fn interpolate(&self, values: &[f64], q: DVec3, hint: usize) -> Option<(f64, usize)> {
        let (t, w) = self.locate(q, hint)?;
        let value = self
            .mesh
            .tet(t)
            .iter()
            .zip(w)
            .map(|(&v, w)| values[v as usize] * w)
            .sum();
        Some((value, t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;

    fn cube_mesh() -> TetMesh {
        let mut points = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..4 {
                    let wobble = ((i * 5 + j * 3 + k * 7) % 11) as f64 * 0.01;
                    points.push(DVec3::new(i as f64 + wobble, j as f64, k as f64 - wobble));
                }
            }
        }
        crate::tet::delaunay(&points, &NoProgress).unwrap()
    }

    #[test]
    fn a_linear_field_is_reproduced_inside_and_nothing_is_found_outside() {
        let mesh = cube_mesh();
        let f: Vec<f64> = mesh
            .points
            .iter()
            .map(|p| 2.0 * p.x - p.y + 0.5 * p.z)
            .collect();
        let locator = Locator::new(&mesh);
        let mut hint = 0;
        for q in [
            DVec3::new(1.5, 1.5, 1.5),
            DVec3::new(0.2, 2.9, 0.3),
            DVec3::new(2.5, 0.1, 2.0),
            // A mesh vertex itself.
            mesh.points[5],
        ] {
            let (value, t) = locator.interpolate(&f, q, hint).expect("inside");
            hint = t;
            let want = 2.0 * q.x - q.y + 0.5 * q.z;
            assert!((value - want).abs() < 1e-9, "{q}: {value} vs {want}");
        }
        assert!(locator.locate(DVec3::new(-1.0, 1.0, 1.0), 0).is_none());
        assert!(locator.locate(DVec3::new(1.0, 1.0, 9.0), 3).is_none());
        assert!(locator.locate(DVec3::NAN, 0).is_none());
    }
}
