//! The ore's plane from a variogram map: the plane along which samples at or above the
//! level keep company with other ore samples in neighbouring holes.
//!
//! For each ore sample and each sample of another hole between [`BAND`] hole spacings
//! away, the pair's indicator semivariogram (0 for ore–ore, 1/2 for ore–waste) is added to
//! the bin of the pair's direction (a hemisphere of [`BIN_DEGREES`] bins). A candidate
//! plane scores the mean of the pairs whose direction lies within [`TOLERANCE_DEGREES`] of
//! it; the best plane is searched on a coarse grid of normals, then refined by degrees.
//!
//! Why: the intercepts' principal axes are the ore's plane when the ore is one lens, but
//! on a field of stacked or staggered lenses they are the drilled area's shape, while the
//! variogram map measures continuity itself (docs/field.md).

use glam::{DVec3, I64Vec3};

use super::estimate::Samples;
use super::kriging::CellMap;

/// Pairs are taken from half a hole spacing to two hole spacings apart.
pub const BAND: (f64, f64) = (0.5, 2.0);
/// A pair counts for a plane when its direction is within this many degrees of it.
pub const TOLERANCE_DEGREES: f64 = 7.5;
/// Width of the direction bins.
pub const BIN_DEGREES: f64 = 2.0;
/// At most this many ore samples are paired (evenly spaced in input order beyond it).
pub const MAX_ORE_SAMPLES: usize = 20_000;
/// Pairs within this many degrees of a plane's normal measure continuity across it.
pub const ACROSS_DEGREES: f64 = 30.0;
/// A plane needs this many pairs to be scored.
const MIN_PAIRS: f64 = 100.0;

/// Direction bins of the upper hemisphere: the semivariogram summed, and the pairs counted.
pub struct DirectionBins {
    sum: Vec<f64>,
    count: Vec<f64>,
    centres: Vec<DVec3>,
}

/// The plane of best continuity and its score, with the score of the plane it was
/// compared with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Continuity {
    pub normal: DVec3,
    /// Mean semivariogram of the pairs in the best plane (0: all ore–ore, 0.5: all
    /// ore–waste).
    pub gamma: f64,
}

const AZIMUTH_BINS: usize = (360.0 / BIN_DEGREES) as usize;
const ELEVATION_BINS: usize = (90.0 / BIN_DEGREES) as usize;

fn bin_of(u: DVec3) -> usize {
    let u = if u.z < 0.0 { -u } else { u };
    let elevation = u.z.clamp(0.0, 1.0).asin().to_degrees();
    let azimuth = u.x.atan2(u.y).to_degrees().rem_euclid(360.0);
    let e = ((elevation / BIN_DEGREES) as usize).min(ELEVATION_BINS - 1);
    let a = ((azimuth / BIN_DEGREES) as usize).min(AZIMUTH_BINS - 1);
    e * AZIMUTH_BINS + a
}

/// The samples hashed for pairing: cells of the band's outer radius.
pub struct PairGrid<'a> {
    samples: &'a Samples,
    level: f64,
    band: (f64, f64),
    grid: CellMap<I64Vec3, Vec<u32>>,
}

impl<'a> PairGrid<'a> {
    /// The grid of `samples` for pairs around the ore (values at or above `level`), holes
    /// `hole_spacing` apart; `None` when the band is empty or not a number.
    pub fn new(samples: &'a Samples, level: f64, hole_spacing: f64) -> Option<PairGrid<'a>> {
        let (lo, hi) = (BAND.0 * hole_spacing, BAND.1 * hole_spacing);
        if hi.is_nan() || hi <= 0.0 {
            return None;
        }
        let mut grid: CellMap<I64Vec3, Vec<u32>> = CellMap::default();
        for (i, p) in samples.points.iter().enumerate() {
            grid.entry((*p / hi).floor().as_i64vec3())
                .or_default()
                .push(i as u32);
        }
        Some(PairGrid {
            samples,
            level,
            band: (lo, hi),
            grid,
        })
    }

    /// The ore samples, in input order.
    pub fn ore(&self) -> Vec<usize> {
        (0..self.samples.values.len())
            .filter(|&i| self.samples.values[i] >= self.level)
            .collect()
    }

    /// The bins of the pairs around the ore samples `ore` (at most [`MAX_ORE_SAMPLES`] of
    /// them, evenly spaced); `None` when fewer than two holes hold them.
    pub fn bins(&self, ore: &[usize]) -> Option<DirectionBins> {
        let samples = self.samples;
        let mut ore_holes: Vec<u32> = ore.iter().map(|&i| samples.holes[i]).collect();
        ore_holes.sort_unstable();
        ore_holes.dedup();
        if ore_holes.len() < 2 {
            return None;
        }
        let (lo, hi) = self.band;
        let mut bins = DirectionBins {
            sum: vec![0.0; AZIMUTH_BINS * ELEVATION_BINS],
            count: vec![0.0; AZIMUTH_BINS * ELEVATION_BINS],
            centres: centres(),
        };
        let stride = ore.len().div_ceil(MAX_ORE_SAMPLES).max(1);
        for &i in ore.iter().step_by(stride) {
            let p = samples.points[i];
            let c = (p / hi).floor().as_i64vec3();
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let Some(list) = self.grid.get(&(c + I64Vec3::new(dx, dy, dz))) else {
                            continue;
                        };
                        for &j in list {
                            let j = j as usize;
                            if samples.holes[j] == samples.holes[i] {
                                continue;
                            }
                            let d = samples.points[j] - p;
                            let length = d.length();
                            if length < lo || length > hi {
                                continue;
                            }
                            let b = bin_of(d / length);
                            let waste = samples.values[j] < self.level;
                            bins.sum[b] += if waste { 0.5 } else { 0.0 };
                            bins.count[b] += 1.0;
                        }
                    }
                }
            }
        }
        Some(bins)
    }
}

impl DirectionBins {
    /// The bins of the pairs around the ore samples (values at or above `level`), holes
    /// `hole_spacing` apart; `None` when fewer than two holes hold ore.
    pub fn new(samples: &Samples, level: f64, hole_spacing: f64) -> Option<DirectionBins> {
        let grid = PairGrid::new(samples, level, hole_spacing)?;
        grid.bins(&grid.ore())
    }

    /// Mean semivariogram of the pairs within the tolerance of the plane normal to
    /// `normal`; `None` with too few pairs.
    pub fn score(&self, normal: DVec3) -> Option<f64> {
        let band = TOLERANCE_DEGREES.to_radians().sin();
        let (mut sum, mut count) = (0.0, 0.0);
        for ((c, s), n) in self.centres.iter().zip(&self.sum).zip(&self.count) {
            if *n > 0.0 && c.dot(normal).abs() < band {
                sum += s;
                count += n;
            }
        }
        (count >= MIN_PAIRS).then(|| sum / count)
    }

    /// Mean semivariogram of the pairs within [`ACROSS_DEGREES`] of `normal`: continuity
    /// across the plane normal to it; `None` with too few pairs.
    pub fn across(&self, normal: DVec3) -> Option<f64> {
        let cone = ACROSS_DEGREES.to_radians().cos();
        let (mut sum, mut count) = (0.0, 0.0);
        for ((c, s), n) in self.centres.iter().zip(&self.sum).zip(&self.count) {
            if *n > 0.0 && c.dot(normal).abs() > cone {
                sum += s;
                count += n;
            }
        }
        (count >= MIN_PAIRS).then(|| sum / count)
    }

    /// Up to `count` planes of low semivariogram, each the least by degrees around a
    /// coarse plane (as in [`DirectionBins::best`]) whose normal is at least `separation`
    /// degrees from those of the planes already taken, the least first: the alternatives
    /// a cross-validation can choose among.
    pub fn minima(&self, count: usize, separation: f64) -> Vec<Continuity> {
        let mut coarse: Vec<(f64, f64, f64)> = coarse_planes()
            .filter_map(|(dd, dip)| self.score(normal(dd, dip)).map(|g| (g, dd, dip)))
            .collect();
        coarse.sort_by(|a, b| a.0.total_cmp(&b.0));
        let cos = separation.to_radians().cos();
        let apart =
            |taken: &[Continuity], n: DVec3| taken.iter().all(|c| c.normal.dot(n).abs() < cos);
        let mut out: Vec<Continuity> = Vec::new();
        for (_, dd0, dip0) in coarse {
            if out.len() == count {
                break;
            }
            if !apart(&out, normal(dd0, dip0)) {
                continue;
            }
            if let Some((gamma, dd, dip)) = self.least(fine_planes(dd0, dip0), None)
                && apart(&out, normal(dd, dip))
            {
                out.push(Continuity {
                    normal: normal(dd, dip),
                    gamma,
                });
            }
        }
        out
    }

    /// The plane of least semivariogram: normals every 5 degrees of dip and 10 of dip
    /// direction, then every degree around the best.
    pub fn best(&self) -> Option<Continuity> {
        let (_, dd0, dip0) = self.least(coarse_planes(), None)?;
        let best = self.least(fine_planes(dd0, dip0), None);
        best.map(|(gamma, dd, dip)| Continuity {
            normal: normal(dd, dip),
            gamma,
        })
    }
}

impl DirectionBins {
    /// The least score over the planes `(dip direction, dip)`, or `best` if lower.
    fn least(
        &self,
        planes: impl Iterator<Item = (f64, f64)>,
        mut best: Option<(f64, f64, f64)>,
    ) -> Option<(f64, f64, f64)> {
        for (dd, dip) in planes {
            if let Some(g) = self.score(normal(dd, dip))
                && best.is_none_or(|(b, _, _)| g < b)
            {
                best = Some((g, dd, dip));
            }
        }
        best
    }
}

/// The upward normal of the plane dipping `dip` degrees toward `dip_direction`.
/// Planes every 10 degrees of dip direction and 5 of dip.
fn coarse_planes() -> impl Iterator<Item = (f64, f64)> {
    (0..=18).flat_map(|d| (0..36).map(move |a| (f64::from(a) * 10.0, f64::from(d) * 5.0)))
}

/// Planes every degree within 12 of dip direction and 6 of dip around `(dd0, dip0)`.
fn fine_planes(dd0: f64, dip0: f64) -> impl Iterator<Item = (f64, f64)> {
    (-6..=6).flat_map(move |d| {
        (-12..=12).map(move |a| (dd0 + f64::from(a), (dip0 + f64::from(d)).clamp(0.0, 90.0)))
    })
}

fn normal(dip_direction: f64, dip: f64) -> DVec3 {
    let (dd, dp) = (dip_direction.to_radians(), dip.to_radians());
    DVec3::new(dd.sin() * dp.sin(), dd.cos() * dp.sin(), dp.cos())
}

fn centres() -> Vec<DVec3> {
    let mut out = Vec::with_capacity(AZIMUTH_BINS * ELEVATION_BINS);
    for e in 0..ELEVATION_BINS {
        let elevation = ((e as f64 + 0.5) * BIN_DEGREES).to_radians();
        for a in 0..AZIMUTH_BINS {
            let azimuth = ((a as f64 + 0.5) * BIN_DEGREES).to_radians();
            out.push(DVec3::new(
                azimuth.sin() * elevation.cos(),
                azimuth.cos() * elevation.cos(),
                elevation.sin(),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vertical holes 20 m apart through a slab 6 m thick dipping 40 degrees toward 120:
    /// the map's plane is the slab's, to within a couple of degrees.
    #[test]
    fn the_map_finds_a_dipping_slab() {
        let n = normal(120.0, 40.0);
        let mut s = Samples::default();
        let mut hole = 0;
        for ix in -6..=6 {
            for iy in -6..=6 {
                let (x, y) = (f64::from(ix) * 20.0, f64::from(iy) * 20.0);
                for k in 0..160 {
                    let p = DVec3::new(x, y, 120.0 - 1.5 * f64::from(k));
                    s.points.push(p);
                    s.values.push(f64::from(u8::from(p.dot(n).abs() < 3.0)));
                    s.holes.push(hole);
                }
                hole += 1;
            }
        }
        let bins = DirectionBins::new(&s, 0.5, 20.0).unwrap();
        let best = bins.best().unwrap();
        let angle = best.normal.dot(n).abs().min(1.0).acos().to_degrees();
        assert!(angle < 2.5, "{best:?} is {angle:.1} degrees off");
        let flat = bins.score(DVec3::Z).unwrap();
        assert!(best.gamma < 0.5 * flat, "{best:?} against flat {flat}");
        // Across a slab 6 m thick, 10-40 m away, an ore sample's partners are all waste.
        assert_eq!(bins.across(n), Some(0.5));

        // The alternatives: the best first, then planes at least 15 degrees apart, each
        // of them scoring what the map says of it.
        let minima = bins.minima(4, 15.0);
        assert_eq!(minima.len(), 4);
        assert_eq!(minima[0], best);
        for (i, a) in minima.iter().enumerate() {
            assert_eq!(bins.score(a.normal), Some(a.gamma));
            for b in &minima[..i] {
                let apart = a.normal.dot(b.normal).abs().min(1.0).acos().to_degrees();
                assert!(
                    apart >= 15.0 - 1e-9,
                    "{a:?} and {b:?} {apart:.1} degrees apart"
                );
            }
        }
    }
}
