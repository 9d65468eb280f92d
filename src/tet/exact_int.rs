//! Exact determinants in fixed-width integers, for predicates whose float filter failed.
//!
//! Invariant: an answer is returned only when every intermediate provably fits (the
//! coordinates are integers times one power of two, with differences below 2^49), so it is
//! the exact sign; otherwise `None`, and the caller uses `robust`'s adaptive arithmetic.
//! Lattice and UTM well data (coordinates on a common binary grid) take this path, which
//! is several times faster than general floating-point expansions on exact ties.

use glam::DVec3;

/// Largest coordinate difference (in grid units) for which the insphere determinant fits
/// in 255 bits: |det| < 2^(5B + 7).
const MAX_DIFF_BITS: u32 = 49;

/// A 256-bit two's complement integer, little-endian 64-bit limbs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct I256([u64; 4]);

impl I256 {
    fn from_i128(v: i128) -> I256 {
        let lo = v as u128;
        let hi = if v < 0 { u64::MAX } else { 0 };
        I256([lo as u64, (lo >> 64) as u64, hi, hi])
    }

    fn is_negative(self) -> bool {
        self.0[3] >> 63 == 1
    }

    fn signum(self) -> i32 {
        if self.is_negative() {
            -1
        } else if self.0 == [0; 4] {
            0
        } else {
            1
        }
    }

    fn add(self, o: I256) -> I256 {
        let mut r = [0u64; 4];
        let mut carry = false;
        for (k, slot) in r.iter_mut().enumerate() {
            let (s1, c1) = self.0[k].overflowing_add(o.0[k]);
            let (s2, c2) = s1.overflowing_add(u64::from(carry));
            *slot = s2;
            carry = c1 || c2;
        }
        I256(r)
    }

    fn neg(self) -> I256 {
        I256(self.0.map(|l| !l)).add(I256([1, 0, 0, 0]))
    }

    fn sub(self, o: I256) -> I256 {
        self.add(o.neg())
    }

    /// `self * b`, exact when the true product fits in 255 bits (callers guarantee it).
    fn mul_i128(self, b: i128) -> I256 {
        let negative = self.is_negative() != (b < 0);
        let a = if self.is_negative() { self.neg() } else { self };
        let mb = b.unsigned_abs();
        let bl = [mb as u64, (mb >> 64) as u64];
        let mut r = [0u64; 4];
        for (j, &bj) in bl.iter().enumerate() {
            if bj == 0 {
                continue;
            }
            let mut carry = 0u128;
            for i in 0..4 - j {
                let cur = u128::from(r[i + j]) + u128::from(a.0[i]) * u128::from(bj) + carry;
                r[i + j] = cur as u64;
                carry = cur >> 64;
            }
        }
        let r = I256(r);
        if negative { r.neg() } else { r }
    }
}

/// Exponent of the lowest set bit of a finite non-zero `x` (x = odd * 2^e), and the odd
/// part's bit length plus that exponent (the highest bit + 1).
fn bit_span(x: f64) -> (i32, i32) {
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    let frac = bits & ((1u64 << 52) - 1);
    let (m, e) = if exp == 0 {
        (frac, -1074)
    } else {
        (frac | (1u64 << 52), exp - 1075)
    };
    let tz = m.trailing_zeros() as i32;
    let len = 64 - m.leading_zeros() as i32;
    (e + tz, e + len)
}

/// The points as integers on their common binary grid (coordinate = integer * 2^k), or
/// `None` if some coordinate would not fit in 62 bits.
fn to_grid<const N: usize>(pts: [DVec3; N]) -> Option<[[i64; 3]; N]> {
    let mut lo = i32::MAX;
    let mut hi = i32::MIN;
    for p in &pts {
        for c in [p.x, p.y, p.z] {
            if c != 0.0 {
                let (l, h) = bit_span(c);
                lo = lo.min(l);
                hi = hi.max(h);
            }
        }
    }
    if lo == i32::MAX {
        return Some([[0; 3]; N]);
    }
    if hi - lo > 62 {
        return None;
    }
    let mut out = [[0i64; 3]; N];
    for (o, p) in out.iter_mut().zip(&pts) {
        for (slot, c) in o.iter_mut().zip([p.x, p.y, p.z]) {
            if c != 0.0 {
                let bits = c.to_bits();
                let exp = ((bits >> 52) & 0x7ff) as i32;
                let frac = bits & ((1u64 << 52) - 1);
                let (m, e) = if exp == 0 {
                    (frac, -1074)
                } else {
                    (frac | (1u64 << 52), exp - 1075)
                };
                // c = m * 2^e, e >= lo - tz(m); shift m to the grid 2^lo.
                let shift = e - lo;
                let v = if shift >= 0 {
                    (m << shift) as i64
                } else {
                    (m >> (-shift)) as i64
                };
                *slot = if c < 0.0 { -v } else { v };
            }
        }
    }
    Some(out)
}

fn fits(d: i64) -> bool {
    d.unsigned_abs() < 1u64 << MAX_DIFF_BITS
}

/// Differences `p - base` on the grid, if all fit in [`MAX_DIFF_BITS`] bits.
fn diffs<const N: usize>(g: &[[i64; 3]; N], base: usize) -> Option<[[i128; 3]; N]> {
    let mut out = [[0i128; 3]; N];
    for (o, p) in out.iter_mut().zip(g) {
        for k in 0..3 {
            let d = p[k] - g[base][k];
            if !fits(d) {
                return None;
            }
            o[k] = i128::from(d);
        }
    }
    Some(out)
}

/// Exact sign of `(b-a) . ((c-a) x (d-a))` (the `predicates::orient` convention).
pub fn orient_sign(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Option<i32> {
    let g = to_grid([a, b, c, d])?;
    let v = diffs(&g, 0)?;
    let (b, c, d) = (v[1], v[2], v[3]);
    // 2x2 minors < 2^99, so i128 is exact; the 3x3 combination needs 256 bits.
    let m0 = c[1] * d[2] - c[2] * d[1];
    let m1 = c[0] * d[2] - c[2] * d[0];
    let m2 = c[0] * d[1] - c[1] * d[0];
    let det = I256::from_i128(m0)
        .mul_i128(b[0])
        .sub(I256::from_i128(m1).mul_i128(b[1]))
        .add(I256::from_i128(m2).mul_i128(b[2]));
    Some(det.signum())
}

/// Exact sign of the in-sphere determinant (the `predicates::insphere` convention:
/// positive when `e` is inside the circumsphere of the positive tetrahedron `abcd`).
pub fn insphere_sign(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Option<i32> {
    let g = to_grid([a, b, c, d, e])?;
    let v = diffs(&g, 4)?;
    let [ad, bd, cd, dd, _] = v;
    let ab = ad[0] * bd[1] - bd[0] * ad[1];
    let bc = bd[0] * cd[1] - cd[0] * bd[1];
    let cdm = cd[0] * dd[1] - dd[0] * cd[1];
    let da = dd[0] * ad[1] - ad[0] * dd[1];
    let ac = ad[0] * cd[1] - cd[0] * ad[1];
    let bdm = bd[0] * dd[1] - dd[0] * bd[1];
    let w = |x: i128| I256::from_i128(x);
    let abc = w(bc)
        .mul_i128(ad[2])
        .sub(w(ac).mul_i128(bd[2]))
        .add(w(ab).mul_i128(cd[2]));
    let bcd = w(cdm)
        .mul_i128(bd[2])
        .sub(w(bdm).mul_i128(cd[2]))
        .add(w(bc).mul_i128(dd[2]));
    let cda = w(da)
        .mul_i128(cd[2])
        .add(w(ac).mul_i128(dd[2]))
        .add(w(cdm).mul_i128(ad[2]));
    let dab = w(ab)
        .mul_i128(dd[2])
        .add(w(bdm).mul_i128(ad[2]))
        .add(w(da).mul_i128(bd[2]));
    let lift = |p: [i128; 3]| p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    let det = dab
        .mul_i128(-lift(cd))
        .add(abc.mul_i128(lift(dd)))
        .add(cda.mul_i128(lift(bd)))
        .sub(bcd.mul_i128(lift(ad)));
    // Shewchuk's sign convention is the opposite of ours (see `predicates`).
    Some(-det.signum())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn i256_arithmetic_matches_i128_where_both_apply() {
        let vals = [
            0i128,
            1,
            -1,
            7,
            -123_456_789,
            i64::MAX as i128,
            i64::MIN as i128,
        ];
        for &x in &vals {
            for &y in &vals {
                let p = I256::from_i128(x).mul_i128(y);
                assert_eq!(p, I256::from_i128(x * y), "{x} * {y}");
                assert_eq!(
                    I256::from_i128(x).add(I256::from_i128(y)),
                    I256::from_i128(x + y)
                );
                assert_eq!(p.signum(), (x * y).signum() as i32);
            }
        }
        // Beyond 128 bits: (2^100)^2 / 2^100 round trip through signs.
        let big = I256::from_i128(1i128 << 100).mul_i128(1i128 << 100);
        assert_eq!(big.0, [0, 0, 0, 1u64 << 8]);
        assert_eq!(big.neg().signum(), -1);
    }

    #[test]
    fn grid_conversion_is_exact() {
        let g = to_grid([DVec3::new(0.5, -3.0, 1024.25), DVec3::ZERO]).unwrap();
        assert_eq!(g[0], [2, -12, 4097]);
        assert!(to_grid([DVec3::new(1e300, 1e-300, 0.0)]).is_none());
    }
}
