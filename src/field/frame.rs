//! The anisotropy ellipsoid of the model: an orientation (dip direction, dip, pitch) and
//! three ranges, and the map into "range units" where the covariance is isotropic.
//!
//! Conventions (those of Leapfrog and most resource packages): the dip direction is the
//! azimuth (degrees clockwise from north, +y) the plane dips toward; the dip is its angle
//! below the horizontal; the pitch is the angle, in the plane, from the strike (dip
//! direction − 90°) to the major axis, toward the down-dip direction. The semi-major axis
//! lies in the plane across the major one; the minor axis is the plane's normal.

use glam::{DMat3, DVec3};
use serde::Serialize;

/// An orientation of the ore's plane and its major axis, in degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Orientation {
    pub dip_direction: f64,
    pub dip: f64,
    pub pitch: f64,
}

impl Orientation {
    pub const FLAT: Orientation = Orientation {
        dip_direction: 0.0,
        dip: 0.0,
        pitch: 0.0,
    };

    /// The major, semi-major and minor unit axes (right-handed).
    pub fn axes(&self) -> [DVec3; 3] {
        let (dd, dip, pitch) = (
            self.dip_direction.to_radians(),
            self.dip.to_radians(),
            self.pitch.to_radians(),
        );
        let strike_az = dd - std::f64::consts::FRAC_PI_2;
        let strike = DVec3::new(strike_az.sin(), strike_az.cos(), 0.0);
        let down_dip = DVec3::new(dd.sin() * dip.cos(), dd.cos() * dip.cos(), -dip.sin());
        let major = strike * pitch.cos() + down_dip * pitch.sin();
        let semi = -strike * pitch.sin() + down_dip * pitch.cos();
        [major, semi, major.cross(semi)]
    }

    /// The orientation whose plane is normal to `normal` and whose major axis is `major`
    /// projected into that plane.
    pub fn from_axes(major: DVec3, normal: DVec3) -> Orientation {
        let mut n = normal.normalize();
        if n.z < 0.0 {
            n = -n;
        }
        let dip = n.z.clamp(-1.0, 1.0).acos();
        let horizontal = (n.x * n.x + n.y * n.y).sqrt();
        let dd = if horizontal < 1e-9 {
            0.0
        } else {
            n.x.atan2(n.y)
        };
        let strike_az = dd - std::f64::consts::FRAC_PI_2;
        let strike = DVec3::new(strike_az.sin(), strike_az.cos(), 0.0);
        let down_dip = DVec3::new(dd.sin() * dip.cos(), dd.cos() * dip.cos(), -dip.sin());
        let m = major - n * major.dot(n);
        let mut pitch = m.dot(down_dip).atan2(m.dot(strike)).to_degrees();
        if pitch < 0.0 {
            pitch += 180.0;
        }
        if pitch >= 180.0 {
            pitch -= 180.0;
        }
        Orientation {
            dip_direction: dd.to_degrees().rem_euclid(360.0),
            dip: dip.to_degrees(),
            pitch,
        }
    }
}

/// The ellipsoid: axes and ranges (major, semi-major, minor), in input units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    pub orientation: Orientation,
    pub ranges: [f64; 3],
    to_unit: DMat3,
    from_unit: DMat3,
}

impl Ellipsoid {
    pub fn new(orientation: Orientation, ranges: [f64; 3]) -> Self {
        let axes = orientation.axes();
        let rotation = DMat3::from_cols(axes[0], axes[1], axes[2]).transpose();
        let scale = DVec3::new(1.0 / ranges[0], 1.0 / ranges[1], 1.0 / ranges[2]);
        let to_unit = DMat3::from_diagonal(scale) * rotation;
        Ellipsoid {
            orientation,
            ranges,
            to_unit,
            from_unit: to_unit.inverse(),
        }
    }

    /// A point (or offset) in range units along the ellipsoid's axes.
    #[inline]
    pub fn to_unit(&self, p: DVec3) -> DVec3 {
        self.to_unit * p
    }

    /// The inverse of [`Ellipsoid::to_unit`].
    #[inline]
    pub fn from_unit(&self, u: DVec3) -> DVec3 {
        self.from_unit * u
    }

    /// The matrix of [`Ellipsoid::to_unit`].
    pub fn to_unit_matrix(&self) -> DMat3 {
        self.to_unit
    }

    /// The matrix of [`Ellipsoid::from_unit`].
    pub fn from_unit_matrix(&self) -> DMat3 {
        self.from_unit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_are_right_handed_and_round_trip() {
        for &(dd, dip, pitch) in &[
            (0.0, 0.0, 0.0),
            (90.0, 30.0, 20.0),
            (236.0, 33.0, 33.0),
            (315.0, 80.0, 120.0),
        ] {
            let o = Orientation {
                dip_direction: dd,
                dip,
                pitch,
            };
            let [a, b, c] = o.axes();
            assert!((a.cross(b) - c).length() < 1e-12);
            assert!(a.dot(b).abs() < 1e-12 && (a.length() - 1.0).abs() < 1e-12);
            let back = Orientation::from_axes(a, c);
            if dip > 0.0 {
                assert!((back.dip_direction - dd).abs() < 1e-9, "{back:?}");
                assert!((back.pitch - pitch).abs() < 1e-9, "{back:?}");
            }
            assert!((back.dip - dip).abs() < 1e-9);
        }
        // A plane dipping 30 degrees east: its normal leans east, the down-dip axis goes
        // east and down.
        let o = Orientation {
            dip_direction: 90.0,
            dip: 30.0,
            pitch: 90.0,
        };
        let [major, _, _] = o.axes();
        assert!(major.x > 0.8 && major.z < -0.4);
    }

    #[test]
    fn unit_space_divides_by_the_ranges() {
        let e = Ellipsoid::new(
            Orientation {
                dip_direction: 90.0,
                dip: 30.0,
                pitch: 90.0,
            },
            [200.0, 100.0, 10.0],
        );
        let [major, semi, minor] = e.orientation.axes();
        assert!((e.to_unit(major * 200.0) - DVec3::X).length() < 1e-12);
        assert!((e.to_unit(semi * 100.0) - DVec3::Y).length() < 1e-12);
        assert!((e.to_unit(minor * 10.0) - DVec3::Z).length() < 1e-12);
        let p = DVec3::new(3.0, -4.0, 5.0);
        assert!((e.from_unit(e.to_unit(p)) - p).length() < 1e-12);
    }
}
