//! Orientations that vary in space: the variogram map drawn around anchors spread over
//! the ore, and (with `--orientation-field varying`) each kriging block's anisotropy
//! turned to the planes of the anchors near it.
//!
//! A field of lenses does not share one plane: on Tom Zone the map's plane over all the
//! ore (dip 68 toward 246) is the best plane of the south-western half, while around the
//! north-eastern holes it scores half as well again as their own (docs/field.md,
//! *Orientations that vary in space*). Each anchor pairs only the ore samples within
//! [`RADIUS_SEMI`] semi-major ranges of it; its own best plane is used where it beats the
//! global plane on those pairs by more than [`LOCAL_MARGIN`] and lies more than
//! [`MIN_TURN_DEGREES`] from it, and the global plane otherwise. A block's plane is the
//! principal plane of the anchors' normals weighted by a Gaussian of their distance
//! (sign-free: the average of `n n^T`), with the global plane as a weak prior, so the
//! frame turns smoothly from anchor to anchor and returns to the global one away from
//! them. The infill lattice and the model's extent keep the global frame (why the option
//! is partial: docs/field.md).
//!
//! Invariant: where every anchor keeps the global plane, or a block's plane is within
//! [`SAME_DEGREES`] of it, the block uses the global frame exactly, so a single lens's
//! model is the global model to the byte.

use glam::{DMat3, DVec3};
use rayon::prelude::*;
use serde::Serialize;

use super::continuity::PairGrid;
use super::estimate::{Samples, principal_axes};
use super::frame::{Ellipsoid, Orientation};

/// An anchor's own plane is used when it scores this share below the global plane's on
/// the anchor's pairs. The global rule's margin is 4 %; an anchor has fewer pairs, so its
/// best plane beats any other by chance more easily: on the single lenses of
/// `bench/geology` anchors beat the lens's plane by at most 12.7 % (one at a lens's edge,
/// 82 ore samples), where the turned lenses of `two_dips` beat it by 27-60 % and the two
/// slabs of `tests/field_model.rs` their compromise plane by 19-21 % (docs/field.md).
pub const LOCAL_MARGIN: f64 = 0.15;
/// Anchors lie on a lattice of this many semi-major ranges.
pub const SPACING_SEMI: f64 = 1.0;
/// An anchor pairs the ore samples within this many semi-major ranges.
pub const RADIUS_SEMI: f64 = 1.0;
/// An anchor's plane within this many degrees of the global one is the global one: the
/// map's bins are 2 degrees and its tolerance 7.5, so its best plane wanders a few degrees
/// around a plane the pairs fit as well.
pub const MIN_TURN_DEGREES: f64 = 15.0;
/// An anchor needs this many ore samples, in this many holes.
pub const MIN_ORE_SAMPLES: usize = 50;
pub const MIN_ORE_HOLES: usize = 5;
/// The global plane's weight: that of an anchor this many spacings away.
pub const PRIOR_SPACINGS: f64 = 2.0;
/// A block plane within this many degrees of the global one is the global one.
pub const SAME_DEGREES: f64 = 1.0;

/// One anchor: where it is, what its pairs say.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LocalPlane {
    /// Local coordinates (the input's, less the run's origin).
    pub centre: [f64; 3],
    pub ore_samples: usize,
    pub ore_holes: usize,
    /// The anchor's best plane (its major axis the global one's, projected).
    pub orientation: Orientation,
    /// Mean semivariogram of the anchor's pairs in its best plane and in the global one.
    pub gamma: f64,
    pub global_gamma: f64,
    /// Whether the anchor's plane is used (`gamma` below `global_gamma` by the margin).
    pub used: bool,
}

/// The anchors of a model, as its summary records them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LocalPlanes {
    pub spacing: f64,
    pub radius: f64,
    pub margin: f64,
    pub anchors: Vec<LocalPlane>,
}

impl LocalPlanes {
    /// The anchors of the ore (samples of `t` at or above `level`) around the `global`
    /// model; `None` when the map cannot be drawn or no anchor has enough ore.
    pub fn estimate(
        t: &Samples,
        level: f64,
        hole_spacing: f64,
        global: &Ellipsoid,
    ) -> Option<LocalPlanes> {
        let grid = PairGrid::new(t, level, hole_spacing)?;
        let ore = grid.ore();
        if ore.len() < MIN_ORE_SAMPLES {
            return None;
        }
        let spacing = SPACING_SEMI * global.ranges[1];
        let radius = RADIUS_SEMI * global.ranges[1];
        if !(spacing > 0.0 && radius > 0.0) {
            return None;
        }
        let mut nodes: Vec<[i64; 3]> = ore
            .iter()
            .map(|&i| (t.points[i] / spacing).round().as_i64vec3().to_array())
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        let global_normal = global.orientation.axes()[2];
        let global_major = global.orientation.axes()[0];
        let r2 = radius * radius;
        let anchors: Vec<LocalPlane> = nodes
            .par_iter()
            .filter_map(|node| {
                let centre = DVec3::new(node[0] as f64, node[1] as f64, node[2] as f64) * spacing;
                let near: Vec<usize> = ore
                    .iter()
                    .copied()
                    .filter(|&i| t.points[i].distance_squared(centre) <= r2)
                    .collect();
                let mut holes: Vec<u32> = near.iter().map(|&i| t.holes[i]).collect();
                holes.sort_unstable();
                holes.dedup();
                if near.len() < MIN_ORE_SAMPLES || holes.len() < MIN_ORE_HOLES {
                    return None;
                }
                let bins = grid.bins(&near)?;
                let best = bins.best()?;
                let global_gamma = bins.score(global_normal)?;
                Some(LocalPlane {
                    centre: centre.to_array(),
                    ore_samples: near.len(),
                    ore_holes: holes.len(),
                    orientation: Orientation::from_axes(global_major, best.normal),
                    gamma: best.gamma,
                    global_gamma,
                    used: best.gamma < global_gamma * (1.0 - LOCAL_MARGIN)
                        && best.normal.dot(global_normal).abs()
                            < MIN_TURN_DEGREES.to_radians().cos(),
                })
            })
            .collect();
        (!anchors.is_empty()).then_some(LocalPlanes {
            spacing,
            radius,
            margin: LOCAL_MARGIN,
            anchors,
        })
    }

    /// Whether any anchor turns the plane.
    pub fn any_used(&self) -> bool {
        self.anchors.iter().any(|a| a.used)
    }
}

/// Each block's frame: the map from the global model's range units to those of the
/// block's own ellipsoid (the global ranges along the turned axes).
#[derive(Debug, Clone)]
pub struct LocalFrames {
    global: Ellipsoid,
    /// Anchor centres (local coordinates) and normals (the global one where unused).
    anchors: Vec<(DVec3, DVec3)>,
    spacing: f64,
}

impl LocalFrames {
    /// `None` when no anchor turns the plane: the global frame holds everywhere.
    pub fn new(planes: &LocalPlanes, global: Ellipsoid) -> Option<LocalFrames> {
        if !planes.any_used() {
            return None;
        }
        let global_normal = global.orientation.axes()[2];
        let anchors = planes
            .anchors
            .iter()
            .map(|a| {
                let n = if a.used {
                    a.orientation.axes()[2]
                } else {
                    global_normal
                };
                (DVec3::from_array(a.centre), n)
            })
            .collect();
        Some(LocalFrames {
            global,
            anchors,
            spacing: planes.spacing,
        })
    }

    /// The map from global range units to the block's at `unit` (global range units);
    /// `None` where the block's plane is the global one.
    pub fn map_at(&self, unit: DVec3) -> Option<DMat3> {
        let p = self.global.from_unit(unit);
        let axes = self.global.orientation.axes();
        let outer = |n: DVec3| DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        let prior = (-PRIOR_SPACINGS * PRIOR_SPACINGS).exp();
        let mut tensor = outer(axes[2]) * prior;
        let mut weight = prior;
        for &(c, n) in &self.anchors {
            let d = c.distance(p) / self.spacing;
            if d > 3.0 {
                continue;
            }
            let w = (-d * d).exp();
            tensor += outer(n) * w;
            weight += w;
        }
        let (_, vectors) = principal_axes(tensor * (1.0 / weight));
        let normal = vectors[0];
        if normal.dot(axes[2]).abs() >= SAME_DEGREES.to_radians().cos() {
            return None;
        }
        let local = Ellipsoid::new(Orientation::from_axes(axes[0], normal), self.global.ranges);
        Some(local.to_unit_matrix() * self.global.from_unit_matrix())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples_of(points: Vec<DVec3>, values: Vec<f64>, holes: Vec<u32>) -> Samples {
        Samples {
            points,
            values,
            holes,
        }
    }

    /// Vertical holes on a 20 m grid through two slabs 10 m thick: in x < 0 one dipping 45
    /// degrees toward east, in x >= 0 one dipping 45 toward north.
    fn two_domains() -> Samples {
        let (mut points, mut values, mut holes) = (Vec::new(), Vec::new(), Vec::new());
        let mut hole = 0;
        for i in -15..15 {
            for j in -8..8 {
                let (x, y) = (f64::from(i) * 20.0 + 10.0, f64::from(j) * 20.0 + 10.0);
                for k in 0..200 {
                    let z = 150.0 - f64::from(k) * 1.5;
                    // Distance to the slab's mid-plane z = -x (east dip) or z = -y (north).
                    let w = if x < 0.0 { z + x + 150.0 } else { z + y } / 2f64.sqrt();
                    points.push(DVec3::new(x, y, z));
                    values.push(if w.abs() <= 5.0 { 10.0 } else { 1.0 });
                    holes.push(hole);
                }
                hole += 1;
            }
        }
        samples_of(points, values, holes)
    }

    #[test]
    fn anchors_find_each_domains_plane() {
        let t = two_domains();
        let global = Ellipsoid::new(
            Orientation {
                dip_direction: 90.0,
                dip: 45.0,
                pitch: 0.0,
            },
            [200.0, 120.0, 15.0],
        );
        let planes = LocalPlanes::estimate(&t, 5.0, 20.0, &global).expect("anchors");
        let east = planes
            .anchors
            .iter()
            .filter(|a| a.centre[0] < -130.0)
            .collect::<Vec<_>>();
        let north = planes
            .anchors
            .iter()
            .filter(|a| a.centre[0] > 130.0)
            .collect::<Vec<_>>();
        assert!(!east.is_empty() && !north.is_empty(), "{planes:?}");
        for a in &east {
            assert!(!a.used, "east keeps the global plane: {a:?}");
        }
        for a in &north {
            assert!(a.used, "north turns: {a:?}");
            let o = a.orientation;
            assert!((o.dip - 45.0).abs() < 5.0, "{o:?}");
            let dd = (o.dip_direction + 180.0).rem_euclid(360.0) - 180.0;
            assert!(dd.abs() < 8.0, "{o:?}");
        }
        let frames = LocalFrames::new(&planes, global).expect("turned");
        // Deep in the east domain the frame is the global one; deep in the north one a
        // point on the north-dipping plane is near the block's plane (small minor
        // coordinate) though far from the global plane.
        assert!(
            frames
                .map_at(global.to_unit(DVec3::new(-250.0, 0.0, 100.0)))
                .is_none()
        );
        let centre = DVec3::new(250.0, 0.0, 0.0);
        let m = frames.map_at(global.to_unit(centre)).expect("north frame");
        let along = DVec3::new(0.0, 50.0, -50.0);
        let local = m * global.to_unit(along);
        assert!(local.z.abs() < 0.6, "{local:?}");
        assert!(global.to_unit(along).z.abs() > 2.0);
    }
}
