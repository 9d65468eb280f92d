//! Desurveying: positions along a drill hole from its survey stations, by the minimum
//! curvature method.
//!
//! Invariant: between two stations the path is the circular arc (or straight line) that
//! minimum curvature assumes, so a hole that truly follows an arc or a line is reproduced
//! exactly at every depth; above the first station the path follows the first station's
//! direction, below the last station the last one's. Coordinates are x east, y north,
//! z up; positions are relative to the collar.

use glam::DVec3;

/// One survey station, already in the down-positive convention.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Station {
    /// Measured depth along the hole, input units.
    pub depth: f64,
    /// Degrees clockwise from north.
    pub azimuth_deg: f64,
    /// Degrees below horizontal (90 = straight down; negative = up-hole).
    pub dip_down_deg: f64,
}

/// Unit direction of a station: x east, y north, z up.
pub fn direction(azimuth_deg: f64, dip_down_deg: f64) -> DVec3 {
    let (az, dip) = (azimuth_deg.to_radians(), dip_down_deg.to_radians());
    DVec3::new(az.sin() * dip.cos(), az.cos() * dip.cos(), -dip.sin())
}

/// A desurveyed hole: station depths, unit directions and positions relative to the collar.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    depths: Vec<f64>,
    directions: Vec<DVec3>,
    positions: Vec<DVec3>,
    /// Segments whose end directions are opposite, where minimum curvature is undefined
    /// and balanced tangential was used instead.
    pub reversed_segments: usize,
}

/// Dogleg angle (radians) between two unit vectors, accurate for small angles.
fn dogleg(t1: DVec3, t2: DVec3) -> f64 {
    2.0 * ((t2 - t1).length() * 0.5).clamp(0.0, 1.0).asin()
}

const TINY_ANGLE: f64 = 1e-9;
const NEAR_PI: f64 = std::f64::consts::PI - 1e-6;

/// Displacement after `length` along an arc that starts in direction `t1` and turns by
/// `beta` towards `t2`'s plane, ending in direction `tf`.
fn arc_step(t1: DVec3, tf: DVec3, beta: f64, length: f64) -> DVec3 {
    let ratio = if beta < TINY_ANGLE {
        1.0
    } else {
        (beta * 0.5).tan() / (beta * 0.5)
    };
    (t1 + tf) * (length * 0.5 * ratio)
}

impl Trajectory {
    /// Desurveys `stations` (depth-sorted, distinct depths, finite). No station: vertical
    /// (straight down); one station: a straight line in its direction.
    pub fn new(stations: &[Station]) -> Self {
        if stations.is_empty() {
            return Self {
                depths: vec![0.0],
                directions: vec![DVec3::NEG_Z],
                positions: vec![DVec3::ZERO],
                reversed_segments: 0,
            };
        }
        let mut depths = Vec::with_capacity(stations.len() + 1);
        let mut directions = Vec::with_capacity(stations.len() + 1);
        let first = direction(stations[0].azimuth_deg, stations[0].dip_down_deg);
        if stations[0].depth > 0.0 {
            // Above the first station the hole is taken as straight in its direction.
            depths.push(0.0);
            directions.push(first);
        }
        for s in stations {
            depths.push(s.depth);
            directions.push(direction(s.azimuth_deg, s.dip_down_deg));
        }
        let mut positions = Vec::with_capacity(depths.len());
        let mut reversed = 0;
        // A first station above the collar (negative depth) is placed by extrapolation.
        positions.push(if depths[0] < 0.0 {
            directions[0] * depths[0]
        } else {
            DVec3::ZERO
        });
        for i in 1..depths.len() {
            let (t1, t2) = (directions[i - 1], directions[i]);
            let length = depths[i] - depths[i - 1];
            let beta = dogleg(t1, t2);
            let step = if beta > NEAR_PI {
                reversed += 1;
                (t1 + t2) * (length * 0.5)
            } else {
                arc_step(t1, t2, beta, length)
            };
            positions.push(positions[i - 1] + step);
        }
        Self {
            depths,
            directions,
            positions,
            reversed_segments: reversed,
        }
    }

    /// Position at measured depth `depth`, relative to the collar.
    pub fn position(&self, depth: f64) -> DVec3 {
        let n = self.depths.len();
        if depth <= self.depths[0] {
            return self.positions[0] + self.directions[0] * (depth - self.depths[0]);
        }
        if depth >= self.depths[n - 1] {
            return self.positions[n - 1] + self.directions[n - 1] * (depth - self.depths[n - 1]);
        }
        // depths[i] <= depth < depths[i + 1]
        let i = self.depths.partition_point(|&d| d <= depth) - 1;
        let (t1, t2) = (self.directions[i], self.directions[i + 1]);
        let length = depth - self.depths[i];
        let total = self.depths[i + 1] - self.depths[i];
        let beta = dogleg(t1, t2);
        let step = if beta < TINY_ANGLE {
            (t1 + t2) * (length * 0.5)
        } else if beta > NEAR_PI {
            // Balanced tangential: half the segment along t1, half along t2.
            let half = total * 0.5;
            t1 * length.min(half) + t2 * (length - half).max(0.0)
        } else {
            let f = length / total;
            let tf = ((t1 * ((1.0 - f) * beta).sin() + t2 * (f * beta).sin()) / beta.sin())
                .normalize_or(t1);
            arc_step(t1, tf, f * beta, length)
        };
        self.positions[i] + step
    }

    /// Station depths (including an added depth-0 station when the first survey is deeper).
    pub fn station_depths(&self) -> &[f64] {
        &self.depths
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_follow_east_north_up() {
        assert!((direction(0.0, 90.0) - DVec3::NEG_Z).length() < 1e-12);
        assert!((direction(90.0, 0.0) - DVec3::X).length() < 1e-12);
        assert!((direction(0.0, 0.0) - DVec3::Y).length() < 1e-12);
        assert!((direction(180.0, -30.0).z - 0.5).abs() < 1e-12);
    }

    #[test]
    fn no_station_is_vertical() {
        let t = Trajectory::new(&[]);
        assert_eq!(t.position(12.5), DVec3::new(0.0, 0.0, -12.5));
    }

    #[test]
    fn opposite_stations_fall_back_to_balanced_tangential() {
        let s = [
            Station {
                depth: 0.0,
                azimuth_deg: 0.0,
                dip_down_deg: 90.0,
            },
            Station {
                depth: 10.0,
                azimuth_deg: 0.0,
                dip_down_deg: -90.0,
            },
        ];
        let t = Trajectory::new(&s);
        assert_eq!(t.reversed_segments, 1);
        assert!(t.position(5.0).is_finite());
        assert!((t.position(5.0).z + 5.0).abs() < 1e-9);
    }
}
