//! The spheroidal covariance: a finite-range family used by implicit modellers (Leapfrog's
//! "spheroidal" interpolant, `ferreus_rbf`'s spheroidal kernels).
//!
//! With `r` the distance in range units (1 at the range) and `r_s = kappa * r`:
//! `rho(r) = 1 - lambda * r_s` for `r_s <= x*`, else `c * (1 + r_s^2)^(-order/2)`. The two
//! pieces meet with the same value and slope at `x*`; at the range the covariance has
//! fallen to about 4 % of the sill (order 3), so the range reads as a variogram's practical
//! range. The constants per order are the published calibration of the family.
//!
//! Invariant: `rho(0) = 1`, `rho` decreases monotonically and is positive for every `r`.

/// The orders of the spheroidal family this crate evaluates.
pub const ORDERS: [u8; 3] = [3, 5, 7];

/// The default order: on the geology benchmark's lenses it keeps more of a thin lens than
/// order 3 (median IoU 0.859 against 0.834, docs/field.md, *Choices measured*).
pub const DEFAULT_ORDER: u8 = 7;

#[derive(Debug, Clone, Copy, PartialEq)]
struct Constants {
    inflexion: f64,
    slope: f64,
    kappa: f64,
    tail: f64,
}

/// A spheroidal correlation function of one order, on distances in range units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spheroidal {
    order: u8,
    c: Constants,
}

impl Spheroidal {
    /// `None` for an order outside [`ORDERS`].
    pub fn new(order: u8) -> Option<Self> {
        let c = match order {
            3 => Constants {
                inflexion: 0.5,
                slope: 0.75,
                kappa: 2.679_834_058_6,
                tail: 0.873_464_053_7,
            },
            5 => Constants {
                inflexion: 0.408_248_290_5,
                slope: 1.020_620_726_2,
                kappa: 1.582_279_575_0,
                tail: 0.857_598_016_8,
            },
            7 => Constants {
                inflexion: 0.353_553_390_6,
                slope: 1.237_436_867_1,
                kappa: 1.200_867_664_4,
                tail: 0.849_486_253_3,
            },
            _ => return None,
        };
        Some(Spheroidal { order, c })
    }

    pub fn order(&self) -> u8 {
        self.order
    }

    /// The correlation at distance `r` (range units): 1 at 0, about 0.04 at the range.
    #[inline]
    pub fn rho(&self, r: f64) -> f64 {
        let rs = self.c.kappa * r;
        if rs <= self.c.inflexion {
            1.0 - self.c.slope * rs
        } else {
            let q = 1.0 + rs * rs;
            let m = f64::from(self.order);
            self.c.tail * q.powf(-0.5 * m)
        }
    }

    /// [`Spheroidal::rho`] of a squared distance, without a square root for order 3 beyond
    /// the inflexion (the hot path of kriging).
    #[inline]
    pub fn rho_sq(&self, r2: f64) -> f64 {
        let k2 = self.c.kappa * self.c.kappa;
        let rs2 = k2 * r2;
        if rs2 <= self.c.inflexion * self.c.inflexion {
            1.0 - self.c.slope * rs2.sqrt()
        } else {
            let q = 1.0 + rs2;
            match self.order {
                3 => self.c.tail / (q * q.sqrt()),
                5 => self.c.tail / (q * q * q.sqrt()),
                _ => self.c.tail / (q * q * q * q.sqrt()),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_meet_and_fall_to_a_few_percent_at_the_range() {
        for order in ORDERS {
            let k = Spheroidal::new(order).unwrap();
            assert_eq!(k.rho(0.0), 1.0);
            let x = k.c.inflexion / k.c.kappa;
            let (below, above) = (k.rho(x * (1.0 - 1e-9)), k.rho(x * (1.0 + 1e-9)));
            assert!(
                (below - above).abs() < 1e-6,
                "order {order}: {below} vs {above}"
            );
            let at_range = k.rho(1.0);
            assert!(
                at_range > 0.0 && at_range < 0.06,
                "order {order}: {at_range}"
            );
            let mut last = 1.0;
            for i in 1..400 {
                let r = f64::from(i) * 0.01;
                let v = k.rho(r);
                assert!(v < last && v > 0.0);
                assert!((k.rho_sq(r * r) - v).abs() < 1e-12);
                last = v;
            }
        }
        assert!(Spheroidal::new(4).is_none());
    }
}
