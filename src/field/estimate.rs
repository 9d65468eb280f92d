//! Parameters found from the data: spacings, sill and nugget, the orientation of the ore
//! and the ranges. Each is a documented rule a geologist can check and override
//! (docs/field.md, *Parameters from the data*).

use glam::{DMat3, DVec3};
use serde::Serialize;

use super::frame::Orientation;

/// Runs of ore in a hole may bridge at most this many waste samples (internal dilution).
pub const MAX_DILUTION: usize = 2;

/// Fewer holes with an intercept than this and the ore's orientation and in-plane ranges
/// are not taken from the intercepts (too few to span a plane).
pub const MIN_INTERCEPT_HOLES: usize = 5;

/// The in-plane ranges are the intercepts' spread (this many standard deviations along
/// each in-plane principal axis) ...
pub const SPREAD_SIGMAS: f64 = 3.0;
/// ... kept between these multiples of the hole spacing: one lens's spread is its extent,
/// but the spread of a field of many lenses is the field's, and a range that long would
/// join them (measured on Tom Zone, docs/field.md).
pub const RANGE_HOLE_SPACINGS: (f64, f64) = (1.5, 6.0);

/// Intercepts farther than this many median distances from the median centre are left out
/// of the orientation and spread.
pub const TRIM_MEDIANS: f64 = 3.0;

/// The shortest minor range, in sample spacings.
pub const MIN_MINOR_SAMPLES: f64 = 3.0;

/// A hole crossing the ore's plane at less than this angle (degrees) runs along the ore:
/// its intercept measures the ore's extent in the plane, not its thickness across it.
pub const MIN_CROSSING_DEGREES: f64 = 20.0;

/// When ore continues across the ore's plane at least this share as often as along it
/// (pairs of an ore sample with samples of other holes 0.5-2 hole spacings away, the
/// variogram map's), the ore is not a lens at the scale of the drilling: the minor range is
/// that share of the semi-major range instead of the intercepts' thickness (docs/field.md).
pub const MASSIVE_ACROSS_SHARE: f64 = 0.5;

/// At or below this share the ore is a lens and the intercepts' thickness is the minor
/// range; between it and [`MASSIVE_ACROSS_SHARE`] the minor range moves linearly from the
/// thickness to the massive ore's, so a share near the cut does not flip the model.
pub const LENS_ACROSS_SHARE: f64 = 0.25;

/// The minor range from the intercepts' `thickness` and the variogram map's `share` of ore
/// across the plane: the thickness for a lens, `share * semi` for massive ore, a linear
/// blend between [`LENS_ACROSS_SHARE`] and [`MASSIVE_ACROSS_SHARE`]. `None` when the
/// thickness stands (a lens, or massive ore no thicker than the thickness).
pub fn massive_minor(thickness: f64, share: f64, semi: f64) -> Option<f64> {
    let w = ((share - LENS_ACROSS_SHARE) / (MASSIVE_ACROSS_SHARE - LENS_ACROSS_SHARE)).min(1.0);
    let massive = share * semi;
    (w > 0.0 && massive > thickness).then_some(thickness + w * (massive - thickness))
}

/// The nugget is at most this share of the sill.
pub const MAX_NUGGET_SHARE: f64 = 0.5;

/// The samples the model is fitted on, in local coordinates, grouped by hole.
#[derive(Debug, Clone, Default)]
pub struct Samples {
    pub points: Vec<DVec3>,
    pub values: Vec<f64>,
    pub holes: Vec<u32>,
}

impl Samples {
    /// Sample indices per hole, each hole's in down-hole order (sorted along the line from
    /// its first sample to its last as read).
    pub fn by_hole(&self) -> Vec<Vec<u32>> {
        let count = self
            .holes
            .iter()
            .map(|&h| h as usize + 1)
            .max()
            .unwrap_or(0);
        let mut out = vec![Vec::new(); count];
        for (i, &h) in self.holes.iter().enumerate() {
            out[h as usize].push(i as u32);
        }
        out.retain(|v| !v.is_empty());
        for hole in &mut out {
            let first = self.points[hole[0] as usize];
            let last = self.points[*hole.last().unwrap_or(&hole[0]) as usize];
            let dir = last - first;
            hole.sort_by(|&a, &b| {
                let ta = (self.points[a as usize] - first).dot(dir);
                let tb = (self.points[b as usize] - first).dot(dir);
                ta.total_cmp(&tb).then(a.cmp(&b))
            });
        }
        out
    }
}

/// A run of ore down one hole.
#[derive(Debug, Clone, Copy)]
pub struct Intercept {
    pub hole: u32,
    pub centre: DVec3,
    /// From the first ore sample to the last, plus one sample spacing.
    pub length: f64,
    /// The hole's direction along the run.
    pub direction: DVec3,
}

/// Spacings of the data: down the holes and between them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spacing {
    /// Median distance between consecutive samples of a hole.
    pub sample: f64,
    /// Median distance from a hole's centroid to the nearest other hole's centroid.
    pub hole: f64,
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Sample and hole spacings (each at least a millionth of the data's extent).
pub fn spacing(samples: &Samples, holes: &[Vec<u32>]) -> Spacing {
    let p = &samples.points;
    let steps: Vec<f64> = holes
        .iter()
        .flat_map(|h| {
            h.windows(2)
                .map(|w| p[w[0] as usize].distance(p[w[1] as usize]))
        })
        .filter(|d| *d > 0.0)
        .collect();
    let centroids: Vec<DVec3> = holes
        .iter()
        .map(|h| h.iter().map(|&i| p[i as usize]).sum::<DVec3>() / h.len() as f64)
        .collect();
    let nearest: Vec<f64> = centroids
        .iter()
        .enumerate()
        .filter_map(|(i, c)| {
            centroids
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, d)| c.distance(*d))
                .filter(|d| *d > 0.0)
                .min_by(f64::total_cmp)
        })
        .collect();
    let (lo, hi) = p.iter().fold((DVec3::MAX, DVec3::MIN), |(lo, hi), q| {
        (lo.min(*q), hi.max(*q))
    });
    let floor = ((hi - lo).length() * 1e-6).max(1e-9);
    let sample = median(steps).unwrap_or(floor).max(floor);
    let hole = median(nearest).unwrap_or(sample * 10.0).max(floor);
    Spacing { sample, hole }
}

/// Sill (variance of the values) and nugget (the down-hole variogram extrapolated to lag
/// zero from its first two lags, at most [`MAX_NUGGET_SHARE`] of the sill).
pub fn sill_and_nugget(samples: &Samples, holes: &[Vec<u32>]) -> (f64, f64) {
    let v = &samples.values;
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sill = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    if sill <= 0.0 {
        return (0.0, 0.0);
    }
    let gamma = |lag: usize| -> Option<f64> {
        let (mut sum, mut count) = (0.0, 0usize);
        for h in holes {
            for w in h.windows(lag + 1) {
                let d = v[w[0] as usize] - v[w[lag] as usize];
                sum += 0.5 * d * d;
                count += 1;
            }
        }
        (count > 0).then(|| sum / count as f64)
    };
    let nugget = match (gamma(1), gamma(2)) {
        (Some(g1), Some(g2)) => (2.0 * g1 - g2).clamp(0.0, g1),
        (Some(g1), None) => g1,
        _ => 0.0,
    };
    (sill, nugget.min(MAX_NUGGET_SHARE * sill))
}

/// The runs of ore down one hole, given each sample's flag in down-hole order: the
/// positions of each run's first and last ore sample, where at most [`MAX_DILUTION`]
/// waste samples between two ore samples are bridged (internal dilution). The one rule
/// the intercepts and the contacts of a flag (`contacts.rs`) share.
pub fn ore_runs(ore: impl IntoIterator<Item = bool>) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (k, is_ore) in ore.into_iter().enumerate() {
        if !is_ore {
            continue;
        }
        match runs.last_mut() {
            Some(run) if k - run.1 <= MAX_DILUTION + 1 => run.1 = k,
            _ => runs.push((k, k)),
        }
    }
    runs
}

/// The runs of samples at or above `level` down each hole ([`ore_runs`]).
pub fn intercepts(
    samples: &Samples,
    holes: &[Vec<u32>],
    level: f64,
    spacing: f64,
) -> Vec<Intercept> {
    let p = &samples.points;
    let is_ore = |i: u32| samples.values[i as usize] >= level;
    let mut out = Vec::new();
    for hole in holes {
        for (first, last) in ore_runs(hole.iter().map(|&i| is_ore(i))) {
            let (a, b) = (p[hole[first] as usize], p[hole[last] as usize]);
            let direction = if a.distance(b) > 0.0 {
                (b - a).normalize()
            } else {
                DVec3::Z
            };
            let ore_points: Vec<DVec3> = hole[first..=last]
                .iter()
                .filter(|&&i| is_ore(i))
                .map(|&i| p[i as usize])
                .collect();
            out.push(Intercept {
                hole: samples.holes[hole[first] as usize],
                centre: ore_points.iter().sum::<DVec3>() / ore_points.len() as f64,
                length: a.distance(b) + spacing,
                direction,
            });
        }
    }
    out
}

/// Eigenvalues (descending) and unit eigenvectors of a symmetric matrix, by Jacobi sweeps.
pub fn principal_axes(m: DMat3) -> ([f64; 3], [DVec3; 3]) {
    let mut a = m.to_cols_array_2d();
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..50 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off < 1e-15 * (a[0][0].abs() + a[1][1].abs() + a[2][2].abs() + 1e-300) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| a[j][j].total_cmp(&a[i][i]));
    let vals = order.map(|i| a[i][i].max(0.0));
    let vecs = order.map(|i| DVec3::new(v[0][i], v[1][i], v[2][i]).normalize());
    (vals, vecs)
}

/// What the intercepts say of the ore: its orientation, in-plane spread and thickness.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InterceptGeometry {
    pub orientation: Orientation,
    /// [`SPREAD_SIGMAS`] standard deviations of the intercept centres along the major and
    /// semi-major axes (before the hole-spacing bounds).
    pub spread: [f64; 2],
    /// Median over the holes that cross the plane at [`MIN_CROSSING_DEGREES`] or more of
    /// the true thickness of each one's longest intercept; when fewer than
    /// [`MIN_INTERCEPT_HOLES`] holes cross it so, the centres' spread across the plane
    /// ([`SPREAD_SIGMAS`] standard deviations).
    pub thickness: f64,
    /// The holes whose intercepts measured the thickness (0: from the centres' spread).
    pub thickness_holes: usize,
    pub holes: usize,
    pub intercepts: usize,
    /// What the variogram map said, when it could be drawn (`continuity.rs`).
    pub map: Option<MapScores>,
}

/// The variogram map's verdict on the ore's plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MapScores {
    /// The plane of best continuity (its pitch is that of the orientation used).
    pub plane: Orientation,
    /// Mean indicator semivariogram of the ore's pairs in that plane...
    pub gamma: f64,
    /// ... and in the plane of the intercepts' principal axes.
    pub intercepts_gamma: f64,
    /// Whether the map's plane was used: its semivariogram is below the intercepts' by
    /// more than [`MAP_MARGIN`] of it.
    pub used: bool,
    /// Mean semivariogram of the ore's pairs across the plane used (within
    /// [`super::continuity::ACROSS_DEGREES`] of its normal).
    pub across_gamma: Option<f64>,
    /// How often ore continues across the plane used, as a share of how often it does
    /// along it: `(1 - 2 across_gamma) / (1 - 2 gamma)`, with the gamma of the plane used
    /// (see [`massive_minor`]).
    pub across_share: Option<f64>,
}

/// The variogram map's plane replaces the intercepts' when its semivariogram is lower by
/// more than this share (docs/field.md).
pub const MAP_MARGIN: f64 = 0.04;

/// The frame the intercepts' extent and thickness are measured in.
#[derive(Debug, Clone, Copy)]
enum Axes {
    /// The centres' principal axes; in the plane normal to the vector when there is one,
    /// its major axis the centres' greatest spread in that plane.
    Principal(Option<DVec3>),
    /// These axes as they are (an orientation given by hand).
    Given(Orientation),
}

/// The orientation and extent of the ore from the intercepts at `level`, when at least
/// [`MIN_INTERCEPT_HOLES`] holes cut it: in the plane normal to `plane` when given (the
/// centres' spread projected into it), else in the plane of their principal axes.
pub fn intercept_geometry(
    intercepts: &[Intercept],
    plane: Option<DVec3>,
) -> Option<InterceptGeometry> {
    geometry(intercepts, Axes::Principal(plane))
}

/// The extent and thickness of the ore measured along the axes of `orientation` (one
/// given by hand): the centres' spread along its major and semi-major axes, the thickness
/// across its plane.
pub fn intercept_geometry_in(
    intercepts: &[Intercept],
    orientation: Orientation,
) -> Option<InterceptGeometry> {
    geometry(intercepts, Axes::Given(orientation))
}

fn geometry(intercepts: &[Intercept], axes: Axes) -> Option<InterceptGeometry> {
    let mut holes: Vec<u32> = intercepts.iter().map(|i| i.hole).collect();
    holes.sort_unstable();
    holes.dedup();
    if holes.len() < MIN_INTERCEPT_HOLES {
        return None;
    }
    // Intercepts far from the others (an exploration hole's patch) would swing the axes:
    // keep those within TRIM_MEDIANS median distances of the coordinate-wise median.
    let median_centre = DVec3::new(
        median(intercepts.iter().map(|i| i.centre.x).collect())?,
        median(intercepts.iter().map(|i| i.centre.y).collect())?,
        median(intercepts.iter().map(|i| i.centre.z).collect())?,
    );
    let typical = median(
        intercepts
            .iter()
            .map(|i| i.centre.distance(median_centre))
            .collect(),
    )?;
    let kept: Vec<&Intercept> = intercepts
        .iter()
        .filter(|i| i.centre.distance(median_centre) <= TRIM_MEDIANS * typical.max(1e-9))
        .collect();
    let intercepts = kept;
    // Centres weighted by length: a long intercept is more of the ore than a short one.
    let total: f64 = intercepts.iter().map(|i| i.length).sum();
    let mean = intercepts
        .iter()
        .map(|i| i.centre * i.length)
        .sum::<DVec3>()
        / total;
    let mut cov = DMat3::ZERO;
    for i in &intercepts {
        let d = i.centre - mean;
        cov += DMat3::from_cols(d * d.x, d * d.y, d * d.z) * i.length;
    }
    cov *= 1.0 / total;
    let (orientation, spread, normal) = match axes {
        Axes::Given(o) => {
            let [major, semi, normal] = o.axes();
            let sd = |a: DVec3| a.dot(cov * a).max(0.0).sqrt();
            (o, [sd(major), sd(semi)], normal)
        }
        Axes::Principal(plane) => {
            let plane = plane.map(DVec3::normalize);
            let projected = match plane {
                Some(n) => {
                    let project = DMat3::IDENTITY - DMat3::from_cols(n * n.x, n * n.y, n * n.z);
                    project * cov * project
                }
                None => cov,
            };
            let (vals, vecs) = principal_axes(projected);
            if vals[1] <= 0.0 {
                return None;
            }
            let normal = plane.unwrap_or(vecs[2]);
            (
                Orientation::from_axes(vecs[0], normal),
                [vals[0].sqrt(), vals[1].sqrt()],
                normal,
            )
        }
    };
    let mut longest: std::collections::HashMap<u32, &Intercept> = std::collections::HashMap::new();
    for &i in &intercepts {
        let e = longest.entry(i.hole).or_insert(i);
        if i.length > e.length {
            *e = i;
        }
    }
    let crossing = MIN_CROSSING_DEGREES.to_radians().sin();
    let across: Vec<f64> = longest
        .values()
        .map(|i| (i.length, i.direction.dot(normal).abs()))
        .filter(|&(_, cos)| cos >= crossing)
        .map(|(length, cos)| length * cos)
        .collect();
    let thickness_holes = across.len();
    let thickness = if thickness_holes >= MIN_INTERCEPT_HOLES {
        median(across)?
    } else {
        SPREAD_SIGMAS * normal.dot(cov * normal).max(0.0).sqrt()
    };
    Some(InterceptGeometry {
        orientation,
        spread: [SPREAD_SIGMAS * spread[0], SPREAD_SIGMAS * spread[1]],
        thickness,
        thickness_holes,
        holes: holes.len(),
        intercepts: intercepts.len(),
        map: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Up to MAX_DILUTION waste samples inside a run are bridged, one more ends it; waste
    /// at either end of a run is not part of it.
    #[test]
    fn ore_runs_bridge_internal_dilution_only() {
        let flags = |s: &str| s.chars().map(|c| c == '1').collect::<Vec<_>>();
        assert_eq!(ore_runs(flags("0100100011000")), vec![(1, 4), (8, 9)]);
        assert_eq!(ore_runs(flags("1")), vec![(0, 0)]);
        assert_eq!(ore_runs(flags("0000")), vec![]);
        assert_eq!(ore_runs(flags("10011")), vec![(0, 4)]);
    }

    /// A lens keeps its thickness, massive ore gets its share of the semi-major range, and
    /// between the two shares the minor range moves without a jump.
    #[test]
    fn the_minor_range_moves_from_the_lens_to_massive_ore_without_a_jump() {
        let (thickness, semi) = (10.0, 160.0);
        assert_eq!(massive_minor(thickness, 0.0, semi), None);
        assert_eq!(massive_minor(thickness, LENS_ACROSS_SHARE, semi), None);
        let full = massive_minor(thickness, MASSIVE_ACROSS_SHARE, semi).unwrap();
        assert!((full - MASSIVE_ACROSS_SHARE * semi).abs() < 1e-9);
        assert_eq!(massive_minor(thickness, 0.8, semi), Some(0.8 * semi));
        let mid = (LENS_ACROSS_SHARE + MASSIVE_ACROSS_SHARE) / 2.0;
        let half = massive_minor(thickness, mid, semi).unwrap();
        assert!((half - (thickness + (mid * semi - thickness) / 2.0)).abs() < 1e-9);
        let below = massive_minor(thickness, MASSIVE_ACROSS_SHARE - 1e-6, semi).unwrap();
        assert!((full - below).abs() < 1e-3, "{below} against {full}");
        // Massive ore no thicker than the runs down the holes: the thickness stands.
        assert_eq!(massive_minor(100.0, 0.6, semi), None);
    }

    #[test]
    fn principal_axes_of_a_rotated_diagonal() {
        let r = DMat3::from_rotation_z(0.4) * DMat3::from_rotation_x(0.3);
        let m = r * DMat3::from_diagonal(DVec3::new(9.0, 4.0, 1.0)) * r.transpose();
        let (vals, vecs) = principal_axes(m);
        assert!((vals[0] - 9.0).abs() < 1e-9 && (vals[2] - 1.0).abs() < 1e-9);
        assert!((m * vecs[0] - vecs[0] * 9.0).length() < 1e-9);
    }

    /// Vertical holes on a 20 m grid through a flat slab 6 m thick at z in [0, 6):
    /// intercepts give a flat orientation, 6 m thickness and the grid's spread.
    #[test]
    fn intercepts_of_a_flat_slab() {
        let mut s = Samples::default();
        let mut hole = 0;
        for ix in 0..6 {
            for iy in 0..6 {
                for k in 0..20 {
                    let z = -10.0 + f64::from(k) * 1.5;
                    s.points
                        .push(DVec3::new(f64::from(ix) * 20.0, f64::from(iy) * 20.0, z));
                    s.values
                        .push(if (0.0..6.0).contains(&z) { 1.0 } else { 0.0 });
                    s.holes.push(hole);
                }
                hole += 1;
            }
        }
        let holes = s.by_hole();
        let sp = spacing(&s, &holes);
        assert!((sp.sample - 1.5).abs() < 1e-9 && (sp.hole - 20.0).abs() < 1e-9);
        let cuts = intercepts(&s, &holes, 0.5, sp.sample);
        assert_eq!(cuts.len(), 36);
        let g = intercept_geometry(&cuts, None).unwrap();
        assert!(g.orientation.dip < 1e-6, "{:?}", g.orientation);
        assert!((g.thickness - 6.0).abs() < 1e-9, "{}", g.thickness);
        // A uniform 6 x 6 grid 100 m wide has a standard deviation of 34.2 m per axis.
        assert!((g.spread[0] - 3.0 * 34.156).abs() < 0.1, "{:?}", g.spread);
        let (sill, nugget) = sill_and_nugget(&s, &holes);
        assert!(sill > 0.0 && nugget <= MAX_NUGGET_SHARE * sill);
    }

    /// Vertical holes on a 20 m grid through a block of ore 90 m deep. In a flat plane each
    /// hole's intercept is the thickness; in a vertical plane
    /// the holes run along the ore and their 90 m intercepts say nothing of its thickness
    /// across: that is the centres' spread across the plane, not a tenth of an intercept.
    #[test]
    fn holes_along_the_plane_do_not_measure_its_thickness() {
        let mut s = Samples::default();
        for (hole, (ix, iy)) in (0..6).flat_map(|x| (0..6).map(move |y| (x, y))).enumerate() {
            // The block's top steps down 3 m a row to the north, so its centres span a plane.
            let top = 3.0 * f64::from(iy);
            for k in 0..90 {
                let z = -15.0 + f64::from(k) * 1.5;
                s.points
                    .push(DVec3::new(f64::from(ix) * 20.0, f64::from(iy) * 20.0, z));
                s.values.push(if (top..top + 90.0).contains(&z) {
                    1.0
                } else {
                    0.0
                });
                s.holes.push(hole as u32);
            }
        }
        let holes = s.by_hole();
        let sp = spacing(&s, &holes);
        let cuts = intercepts(&s, &holes, 0.5, sp.sample);
        let flat = intercept_geometry(&cuts, Some(DVec3::Z)).unwrap();
        assert_eq!(flat.thickness_holes, 36);
        assert!((flat.thickness - 90.0).abs() < 1e-9, "{}", flat.thickness);
        let vertical = intercept_geometry(&cuts, Some(DVec3::X)).unwrap();
        assert_eq!(vertical.thickness_holes, 0);
        assert!(
            (vertical.thickness - 3.0 * 34.156).abs() < 0.1,
            "{}",
            vertical.thickness
        );
        // Ten degrees off the vertical plane: still along it.
        let tilted = DVec3::new(1.0, 0.0, 10f64.to_radians().tan()).normalize();
        assert_eq!(
            intercept_geometry(&cuts, Some(tilted))
                .unwrap()
                .thickness_holes,
            0
        );
    }
}
