//! Exact integrals of a piecewise-linear field over its superlevel sets on a [`TetMesh`].
//!
//! Invariant: on each tetrahedron the grade `f` and the density `ρ` are the linear
//! interpolation of their corner values, so the piece `{f >= t}` of a tetrahedron is a
//! convex polytope bounded by the plane `f = t`, and the volume, `∫f`, `∫ρ` and `∫ρf` over it
//! are sums over tetrahedra with closed-form integrals (no quadrature, no sampling). Every
//! sum runs over fixed chunks added in order, so the figures do not depend on the thread
//! count.

use glam::DVec3;
use rayon::prelude::*;

use crate::dmt::mt::NO_REGION;
use crate::tet::TetMesh;

/// The integrals over a region of the mesh, in mesh units (lengths of the frame the
/// tetrahedra are built in).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Moments {
    /// `∫ 1`: the volume.
    pub volume: f64,
    /// `∫ f`: the grade integral.
    pub grade: f64,
    /// `∫ ρ`: the mass (density integral; `volume × ρ` for a constant density).
    pub mass: f64,
    /// `∫ ρ f`: the metal integral.
    pub metal: f64,
}

impl Moments {
    fn add(&mut self, other: Moments) {
        self.volume += other.volume;
        self.grade += other.grade;
        self.mass += other.mass;
        self.metal += other.metal;
    }

    fn sub(self, other: Moments) -> Moments {
        Moments {
            volume: self.volume - other.volume,
            grade: self.grade - other.grade,
            mass: self.mass - other.mass,
            metal: self.metal - other.metal,
        }
    }

    /// Every integral multiplied by `factor` (a change of volume unit).
    pub fn scaled(self, factor: f64) -> Moments {
        Moments {
            volume: self.volume * factor,
            grade: self.grade * factor,
            mass: self.mass * factor,
            metal: self.metal * factor,
        }
    }
}

/// The density on the mesh: a constant, or one value per mesh vertex (linearly interpolated
/// like the grade).
#[derive(Debug, Clone, Copy)]
pub enum DensityField<'a> {
    Constant(f64),
    PerVertex(&'a [f64]),
}

impl DensityField<'_> {
    fn at(&self, tet: [u32; 4]) -> [f64; 4] {
        match self {
            DensityField::Constant(r) => [*r; 4],
            DensityField::PerVertex(values) => tet.map(|v| values[v as usize]),
        }
    }
}

/// The integrals over one tetrahedron `p` with corner grades `f` and densities `r`.
///
/// `∫f = V·mean(f)`; `∫ρf = V/20·(Σρ·Σf + Σρᵢfᵢ)` (from `∫λᵢλⱼ = V(1+δᵢⱼ)/20` over the
/// barycentric coordinates λ).
pub fn tet_moments(p: [DVec3; 4], f: [f64; 4], r: [f64; 4]) -> Moments {
    let volume = ((p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) / 6.0).abs();
    let sum_f: f64 = f.iter().sum();
    let sum_r: f64 = r.iter().sum();
    let dot: f64 = f.iter().zip(&r).map(|(a, b)| a * b).sum();
    Moments {
        volume,
        grade: volume * sum_f / 4.0,
        mass: volume * sum_r / 4.0,
        metal: volume * (sum_f * sum_r + dot) / 20.0,
    }
}

/// The integrals over the part `{f >= t}` of one tetrahedron: the whole of it, nothing, or
/// the piece cut off by the plane `f = t` (a corner, the tetrahedron minus a corner, or a
/// wedge split into three tetrahedra), with `f` and `ρ` interpolated at the crossings.
pub fn superlevel_moments(p: [DVec3; 4], f: [f64; 4], r: [f64; 4], t: f64) -> Moments {
    let mut inside = [0usize; 4];
    let mut outside = [0usize; 4];
    let (mut m, mut n) = (0, 0);
    for (i, &value) in f.iter().enumerate() {
        if value >= t {
            inside[m] = i;
            m += 1;
        } else {
            outside[n] = i;
            n += 1;
        }
    }
    // The crossing on edge i -> j (f[i] >= t > f[j]): position, grade (t) and density.
    let cross = |i: usize, j: usize| {
        let s = ((f[i] - t) / (f[i] - f[j])).clamp(0.0, 1.0);
        (p[i] + (p[j] - p[i]) * s, t, r[i] + (r[j] - r[i]) * s)
    };
    let corner = |a: usize| (p[a], f[a], r[a]);
    let piece =
        |c: [(DVec3, f64, f64); 4]| tet_moments(c.map(|x| x.0), c.map(|x| x.1), c.map(|x| x.2));
    match m {
        0 => Moments::default(),
        4 => tet_moments(p, f, r),
        1 => {
            let a = inside[0];
            piece([
                corner(a),
                cross(a, outside[0]),
                cross(a, outside[1]),
                cross(a, outside[2]),
            ])
        }
        3 => {
            let d = outside[0];
            let cut = piece([
                corner(d),
                cross(inside[0], d),
                cross(inside[1], d),
                cross(inside[2], d),
            ]);
            tet_moments(p, f, r).sub(cut)
        }
        _ => {
            let [a, b] = [inside[0], inside[1]];
            let [c, d] = [outside[0], outside[1]];
            let (ac, ad, bc, bd) = (cross(a, c), cross(a, d), cross(b, c), cross(b, d));
            // The wedge with apex a over the faces away from it: the triangle (b, bc, bd)
            // and the planar quad (ac, ad, bd, bc) of the cut, as two triangles.
            let mut sum = piece([corner(a), corner(b), bc, bd]);
            sum.add(piece([corner(a), ac, ad, bd]));
            sum.add(piece([corner(a), ac, bd, bc]));
            sum
        }
    }
}

/// Tetrahedra per chunk of the ordered parallel sums.
const CHUNK: usize = 4096;

/// Sums `each(t)` over every tetrahedron into `len` accumulators, in fixed chunks added in
/// order (the same figures on any thread count).
fn ordered_sum(
    mesh: &TetMesh,
    len: usize,
    each: impl Fn(usize, &mut [Moments]) + Sync,
) -> Vec<Moments> {
    let chunks = mesh.tet_count().div_ceil(CHUNK);
    let partial: Vec<Vec<Moments>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut acc = vec![Moments::default(); len];
            for t in c * CHUNK..((c + 1) * CHUNK).min(mesh.tet_count()) {
                each(t, &mut acc);
            }
            acc
        })
        .collect();
    partial
        .into_iter()
        .fold(vec![Moments::default(); len], |mut total, part| {
            for (x, y) in total.iter_mut().zip(part) {
                x.add(y);
            }
            total
        })
}

/// The integrals over `{f >= threshold}` per marked region (`regions` from
/// [`crate::dmt::mt::marked_regions`] on the same marking): `len` = `region_count`. The
/// marked part of a tetrahedron is convex and belongs to the region of its marked corners,
/// exactly as marching tetrahedra's (and the volume-balanced DMT) bodies do.
pub fn region_moments(
    mesh: &TetMesh,
    values: &[f64],
    density: DensityField,
    threshold: f64,
    regions: &[u32],
    len: usize,
) -> Vec<Moments> {
    ordered_sum(mesh, len, |t, acc| {
        let tet = mesh.tet(t);
        let f = tet.map(|v| values[v as usize]);
        let Some(&marked) = tet.iter().find(|&&v| values[v as usize] >= threshold) else {
            return;
        };
        let region = regions[marked as usize];
        if region == NO_REGION {
            return;
        }
        let p = tet.map(|v| mesh.points[v as usize]);
        acc[region as usize].add(superlevel_moments(p, f, density.at(tet), threshold));
    })
}

/// The integrals over `{f >= c}` of the whole mesh for each cut-off `c` (a grade–tonnage
/// curve), in one pass over the tetrahedra.
pub fn cutoff_moments(
    mesh: &TetMesh,
    values: &[f64],
    density: DensityField,
    cutoffs: &[f64],
) -> Vec<Moments> {
    ordered_sum(mesh, cutoffs.len(), |t, acc| {
        let tet = mesh.tet(t);
        let f = tet.map(|v| values[v as usize]);
        let lo = f.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if cutoffs.iter().all(|&c| c > hi) {
            return;
        }
        let p = tet.map(|v| mesh.points[v as usize]);
        let r = density.at(tet);
        let whole = tet_moments(p, f, r);
        for (sum, &c) in acc.iter_mut().zip(cutoffs) {
            if c <= lo {
                sum.add(whole);
            } else if c <= hi {
                sum.add(superlevel_moments(p, f, r, c));
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dmt::mt::{marked_regions, region_count, region_volumes};
    use crate::progress::NoProgress;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    /// A box [0,a]×[0,b]×[0,c] as the Delaunay of its corners and a lattice inside.
    fn box_mesh(a: f64, b: f64, c: f64, n: usize) -> TetMesh {
        let mut points = Vec::new();
        for i in 0..=n {
            for j in 0..=n {
                for k in 0..=n {
                    // A slight shear of the inner points keeps the lattice off co-sphericity
                    // without leaving the box.
                    let (x, y, z) = (
                        i as f64 / n as f64,
                        j as f64 / n as f64,
                        k as f64 / n as f64,
                    );
                    let inner = i > 0 && i < n && j > 0 && j < n && k > 0 && k < n;
                    let jitter = if inner {
                        0.013 * ((i * 7 + j * 3 + k) % 5) as f64 / n as f64
                    } else {
                        0.0
                    };
                    points.push(DVec3::new((x + jitter) * a, y * b, (z + jitter * 0.5) * c));
                }
            }
        }
        crate::tet::delaunay(&points, &NoProgress).unwrap()
    }

    #[test]
    fn a_linear_field_in_a_box_integrates_exactly() {
        // f = 1 + 2x + 3y - z on [0,4]×[0,3]×[0,2]; ρ = 2.5 + 0.1z.
        let (a, b, c) = (4.0, 3.0, 2.0);
        let mesh = box_mesh(a, b, c, 4);
        let f: Vec<f64> = mesh
            .points
            .iter()
            .map(|p| 1.0 + 2.0 * p.x + 3.0 * p.y - p.z)
            .collect();
        let rho: Vec<f64> = mesh.points.iter().map(|p| 2.5 + 0.1 * p.z).collect();
        // Below the field's minimum (-1): the whole box.
        let got = cutoff_moments(&mesh, &f, DensityField::PerVertex(&rho), &[-10.0]);
        let v = a * b * c;
        // ∫f = V(1 + a + 1.5b - c/2); ∫ρ = V(2.5 + 0.05c);
        // ∫ρf = ∫(1+2x+3y-z)(2.5+0.1z) = 2.5∫f + 0.1∫z f, ∫z f = V(c/2(1 + a + 1.5b) - c²/3).
        let int_f = v * (1.0 + a + 1.5 * b - c / 2.0);
        let int_r = v * (2.5 + 0.05 * c);
        let int_zf = v * (c / 2.0 * (1.0 + a + 1.5 * b) - c * c / 3.0);
        let int_rf = 2.5 * int_f + 0.1 * int_zf;
        let m = got[0];
        assert!(rel(m.volume, v) <= 1e-9, "volume {} vs {v}", m.volume);
        assert!(rel(m.grade, int_f) <= 1e-9, "∫f {} vs {int_f}", m.grade);
        assert!(rel(m.mass, int_r) <= 1e-9, "∫ρ {} vs {int_r}", m.mass);
        assert!(rel(m.metal, int_rf) <= 1e-9, "∫ρf {} vs {int_rf}", m.metal);
    }

    #[test]
    fn a_box_cut_by_a_plane_field_integrates_exactly() {
        // f = x on [0,4]×[0,3]×[0,2]: {f >= t} is the slab [t,4]×[0,3]×[0,2], cut through
        // the inner tetrahedra at arbitrary places.
        let (a, b, c) = (4.0, 3.0, 2.0);
        let mesh = box_mesh(a, b, c, 5);
        let f: Vec<f64> = mesh.points.iter().map(|p| p.x).collect();
        let cutoffs = [0.3, 1.234567, 2.0, 3.999];
        let got = cutoff_moments(&mesh, &f, DensityField::Constant(2.7), &cutoffs);
        for (m, &t) in got.iter().zip(&cutoffs) {
            let v = (a - t) * b * c;
            let int_f = b * c * (a * a - t * t) / 2.0;
            assert!(
                rel(m.volume, v) <= 1e-9,
                "t {t}: volume {} vs {v}",
                m.volume
            );
            assert!(
                rel(m.grade, int_f) <= 1e-9,
                "t {t}: ∫f {} vs {int_f}",
                m.grade
            );
            assert!(rel(m.mass, 2.7 * v) <= 1e-9);
            assert!(rel(m.metal, 2.7 * int_f) <= 1e-9);
        }
    }

    #[test]
    fn a_tetrahedron_cut_by_a_plane_matches_the_closed_form_for_every_corner_count() {
        // The unit corner tetrahedron with f = x + y + z: {f >= t} is the tetrahedron minus
        // the corner simplex of side t: volume (1 - t³)/6; ∫f over the corner simplex of
        // side t is t⁴/8 (the simplex's mean of x+y+z is 3t/4), so ∫f = (1 - t⁴)/8.
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let f = [0.0, 1.0, 1.0, 1.0];
        for t in [0.1, 0.5, 0.9, 1.0] {
            let m = superlevel_moments(p, f, [1.0; 4], t);
            assert!(rel(m.volume, (1.0 - t.powi(3)) / 6.0) <= 1e-9, "t {t}");
            assert!(rel(m.grade, (1.0 - t.powi(4)) / 8.0) <= 1e-9, "t {t}");
        }
        // f = x, cut at t: one marked corner; {x >= t} is the simplex of side 1 - t at
        // (1,0,0): volume (1-t)³/6, mean x = t + (1-t)/4.
        let fx = [0.0, 1.0, 0.0, 0.0];
        for t in [0.2, 0.6] {
            let m = superlevel_moments(p, fx, [2.0; 4], t);
            let v = (1.0 - t).powi(3) / 6.0;
            assert!(rel(m.volume, v) <= 1e-9);
            assert!(rel(m.grade, v * (t + (1.0 - t) / 4.0)) <= 1e-9);
            assert!(rel(m.metal, 2.0 * m.grade) <= 1e-12);
        }
        // f = x + y, cut at 1/2: two marked corners (a wedge). {x + y >= s} in the unit
        // simplex: volume = 1/6 - s³/6 ... for s <= 1 the part x + y < s is the prism-like
        // region of volume s²/2 - s³/3; mean over the whole tet of x+y is 1/2.
        let fxy = [0.0, 1.0, 1.0, 0.0];
        let s: f64 = 0.5;
        let below_volume = s * s / 2.0 - s.powi(3) / 3.0;
        let m = superlevel_moments(p, fxy, [1.0; 4], s);
        assert!(rel(m.volume, 1.0 / 6.0 - below_volume) <= 1e-9);
        // ∫(x+y) over x+y < s: ∫₀ˢ u · u(1-u) du = s³/3 - s⁴/4.
        let below_grade = s.powi(3) / 3.0 - s.powi(4) / 4.0;
        assert!(rel(m.grade, 1.0 / 12.0 - below_grade) <= 1e-9);
    }

    #[test]
    fn a_synthetic_body_agrees_with_monte_carlo_within_its_standard_error() {
        // A paraboloid grade on a jittered lattice: the piecewise-linear field's superlevel
        // set is a lumpy body. Monte-Carlo over the box, evaluating the same piecewise
        // linear field by locating each point.
        let mesh = box_mesh(2.0, 2.0, 2.0, 6);
        let f: Vec<f64> = mesh
            .points
            .iter()
            .map(|p| 3.0 - (*p - DVec3::splat(1.0)).length_squared())
            .collect();
        let t = 2.0;
        let exact = cutoff_moments(&mesh, &f, DensityField::Constant(1.0), &[t])[0];
        let locator = super::super::locate::Locator::new(&mesh);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let n = 200_000;
        let (mut s1, mut s1sq, mut s2, mut s2sq) = (0.0, 0.0, 0.0, 0.0);
        let mut hint = 0;
        for _ in 0..n {
            let q = DVec3::new(next(), next(), next()) * 2.0;
            let (tet, w) = locator.locate(q, hint).expect("inside the box");
            hint = tet;
            let value: f64 = mesh
                .tet(tet)
                .iter()
                .zip(w)
                .map(|(&v, w)| f[v as usize] * w)
                .sum();
            let (x, y) = if value >= t {
                (8.0, 8.0 * value)
            } else {
                (0.0, 0.0)
            };
            s1 += x;
            s1sq += x * x;
            s2 += y;
            s2sq += y * y;
        }
        let nf = n as f64;
        let (mv, mg) = (s1 / nf, s2 / nf);
        let se_v = ((s1sq / nf - mv * mv) / nf).sqrt();
        let se_g = ((s2sq / nf - mg * mg) / nf).sqrt();
        assert!(
            (exact.volume - mv).abs() <= 3.0 * se_v,
            "volume {} vs MC {mv} ± {se_v}",
            exact.volume
        );
        assert!(
            (exact.grade - mg).abs() <= 3.0 * se_g,
            "∫f {} vs MC {mg} ± {se_g}",
            exact.grade
        );
    }

    #[test]
    fn region_volumes_are_marching_tetrahedra_volumes() {
        let mesh = box_mesh(3.0, 2.0, 2.0, 5);
        let f: Vec<f64> = mesh
            .points
            .iter()
            .map(|p| (p.x * 2.1).sin() + (p.y * 1.7).cos() * p.z)
            .collect();
        let t = 0.4;
        let marked: Vec<bool> = f.iter().map(|&v| v >= t).collect();
        let regions = marked_regions(&mesh, &marked);
        let len = region_count(&regions);
        let ours = region_moments(&mesh, &f, DensityField::Constant(1.0), t, &regions, len);
        let mt = region_volumes(&mesh, &f, t, &regions);
        assert_eq!(ours.len(), mt.len());
        for (a, b) in ours.iter().zip(&mt) {
            assert!(rel(a.volume, *b) <= 1e-9, "{} vs {b}", a.volume);
        }
        let total = cutoff_moments(&mesh, &f, DensityField::Constant(1.0), &[t])[0];
        let sum: f64 = ours.iter().map(|m| m.grade).sum();
        assert!(rel(sum, total.grade) <= 1e-9);
    }
}
