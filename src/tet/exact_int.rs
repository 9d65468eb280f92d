//! Exact determinants in fixed-width integers, for predicates whose float filter failed.
//!
//! Invariant: an answer is returned only when every intermediate provably fits (the
//! coordinates are integers times one power of two, with differences below 2^49), so it is
//! the exact sign; otherwise `None`, and the caller uses `robust`'s adaptive arithmetic.
//! Lattice and UTM well data (coordinates on a common binary grid) take this path, which
//! is several times faster than general floating-point expansions on exact ties.

use glam::DVec3;
use rayon::prelude::*;

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

    #[inline]
    fn add(self, o: I256) -> I256 {
        let lo = u128::from(self.0[0]) | u128::from(self.0[1]) << 64;
        let hi = u128::from(self.0[2]) | u128::from(self.0[3]) << 64;
        let olo = u128::from(o.0[0]) | u128::from(o.0[1]) << 64;
        let ohi = u128::from(o.0[2]) | u128::from(o.0[3]) << 64;
        let (l, carry) = lo.overflowing_add(olo);
        let h = hi.wrapping_add(ohi).wrapping_add(u128::from(carry));
        I256([l as u64, (l >> 64) as u64, h as u64, (h >> 64) as u64])
    }

    #[inline]
    fn neg(self) -> I256 {
        I256(self.0.map(|l| !l)).add(I256([1, 0, 0, 0]))
    }

    #[inline]
    fn sub(self, o: I256) -> I256 {
        let lo = u128::from(self.0[0]) | u128::from(self.0[1]) << 64;
        let hi = u128::from(self.0[2]) | u128::from(self.0[3]) << 64;
        let olo = u128::from(o.0[0]) | u128::from(o.0[1]) << 64;
        let ohi = u128::from(o.0[2]) | u128::from(o.0[3]) << 64;
        let (l, borrow) = lo.overflowing_sub(olo);
        let h = hi.wrapping_sub(ohi).wrapping_sub(u128::from(borrow));
        I256([l as u64, (l >> 64) as u64, h as u64, (h >> 64) as u64])
    }

    /// `a * b` for `|a| < 2^63`, `|b| < 2^127` (two limb products).
    #[inline]
    fn mul_small(a: i64, b: i128) -> I256 {
        let ma = u128::from(a.unsigned_abs());
        let mb = b.unsigned_abs();
        let lo = ma * u128::from(mb as u64);
        let hi = ma * (mb >> 64);
        let mid = (lo >> 64) + u128::from(hi as u64);
        let r = I256([lo as u64, mid as u64, ((mid >> 64) + (hi >> 64)) as u64, 0]);
        if (a < 0) != (b < 0) { r.neg() } else { r }
    }

    /// `self * l` for `|self| < 2^192`, `l < 2^128`, when the product fits in 255 bits.
    #[inline]
    fn mul_lift(self, l: u128) -> I256 {
        let negative = self.is_negative();
        let a = if negative { self.neg() } else { self };
        let (l0, l1) = (u128::from(l as u64), l >> 64);
        let p0 = u128::from(a.0[0]) * l0;
        let p1 = u128::from(a.0[1]) * l0;
        let p2 = u128::from(a.0[2]) * l0;
        let q0 = u128::from(a.0[0]) * l1;
        let q1 = u128::from(a.0[1]) * l1;
        let q2 = u128::from(a.0[2]) * l1;
        // Column sums of 64-bit digits with carries.
        let c1 = (p0 >> 64) + u128::from(p1 as u64) + u128::from(q0 as u64);
        let c2 =
            (c1 >> 64) + (p1 >> 64) + u128::from(p2 as u64) + (q0 >> 64) + u128::from(q1 as u64);
        let c3 = (c2 >> 64) + (p2 >> 64) + (q1 >> 64) + u128::from(q2 as u64);
        let r = I256([p0 as u64, c1 as u64, c2 as u64, c3 as u64]);
        if negative { r.neg() } else { r }
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

fn max_abs<const N: usize>(v: &[[i128; 3]; N]) -> i128 {
    v.iter().flatten().map(|x| x.abs()).max().unwrap_or(0)
}

/// Exact sign of `(b-a) . ((c-a) x (d-a))` (the `predicates::orient` convention).
pub fn orient_sign(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Option<i32> {
    if coplanar_by_construction([a, b, c, d]) {
        return Some(0);
    }
    let g = to_grid([a, b, c, d])?;
    let v = diffs(&g, 0)?;
    Some(orient_of_diffs([v[1], v[2], v[3]]))
}

/// Sign of `b . (c x d)` for differences below 2^49.
fn orient_of_diffs([b, c, d]: [[i128; 3]; 3]) -> i32 {
    // 2x2 minors < 2^99, so i128 is exact; the 3x3 combination needs 256 bits.
    let m0 = c[1] * d[2] - c[2] * d[1];
    let m1 = c[0] * d[2] - c[2] * d[0];
    let m2 = c[0] * d[1] - c[1] * d[0];
    if max_abs(&[b, c, d]) < 1 << 40 {
        // |det| < 6 * 2^120: plain i128.
        return (b[0] * m0 - b[1] * m1 + b[2] * m2).signum() as i32;
    }
    let det = I256::from_i128(m0)
        .mul_i128(b[0])
        .sub(I256::from_i128(m1).mul_i128(b[1]))
        .add(I256::from_i128(m2).mul_i128(b[2]));
    det.signum()
}

/// Exact sign of the in-sphere determinant (the `predicates::insphere` convention:
/// positive when `e` is inside the circumsphere of the positive tetrahedron `abcd`).
pub fn insphere_sign(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Option<i32> {
    let g = to_grid([a, b, c, d, e])?;
    let v = diffs(&g, 4)?;
    let [ad, bd, cd, dd, _] = v;
    if max_abs(&v) < 1 << 24 {
        return Some(insphere_small([ad, bd, cd, dd]));
    }
    Some(insphere_wide([ad, bd, cd, dd]))
}

/// The in-sphere sign from the differences `p - e`, all below 2^24 (|det| < 2^127).
#[inline]
fn insphere_small([ad, bd, cd, dd]: [[i128; 3]; 4]) -> i32 {
    let ab = ad[0] * bd[1] - bd[0] * ad[1];
    let bc = bd[0] * cd[1] - cd[0] * bd[1];
    let cdm = cd[0] * dd[1] - dd[0] * cd[1];
    let da = dd[0] * ad[1] - ad[0] * dd[1];
    let ac = ad[0] * cd[1] - cd[0] * ad[1];
    let bdm = bd[0] * dd[1] - dd[0] * bd[1];
    let abc = ad[2] * bc - bd[2] * ac + cd[2] * ab;
    let bcd = bd[2] * cdm - cd[2] * bdm + dd[2] * bc;
    let cda = cd[2] * da + dd[2] * ac + ad[2] * cdm;
    let dab = dd[2] * ab + ad[2] * bdm + bd[2] * da;
    let lift = |p: [i128; 3]| p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    let det = (lift(dd) * abc - lift(cd) * dab) + (lift(bd) * cda - lift(ad) * bcd);
    // Shewchuk's sign convention is the opposite of ours (see `predicates`).
    -det.signum() as i32
}

/// The in-sphere sign from the differences `p - e`, all below 2^49 (|det| < 2^252), in
/// straight-line 256-bit arithmetic.
fn insphere_wide([ad, bd, cd, dd]: [[i128; 3]; 4]) -> i32 {
    let ab = ad[0] * bd[1] - bd[0] * ad[1];
    let bc = bd[0] * cd[1] - cd[0] * bd[1];
    let cdm = cd[0] * dd[1] - dd[0] * cd[1];
    let da = dd[0] * ad[1] - ad[0] * dd[1];
    let ac = ad[0] * cd[1] - cd[0] * ad[1];
    let bdm = bd[0] * dd[1] - dd[0] * bd[1];
    // 3x3 minors: |z| < 2^49 times |2x2| < 2^99: below 2^150 each.
    let m = |z: i128, x: i128| I256::mul_small(z as i64, x);
    let abc = m(ad[2], bc).sub(m(bd[2], ac)).add(m(cd[2], ab));
    let bcd = m(bd[2], cdm).sub(m(cd[2], bdm)).add(m(dd[2], bc));
    let cda = m(cd[2], da).add(m(dd[2], ac)).add(m(ad[2], cdm));
    let dab = m(dd[2], ab).add(m(ad[2], bdm)).add(m(bd[2], da));
    // Lifts are non-negative and below 2^100.
    let lift = |p: [i128; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) as u128;
    let det = abc
        .mul_lift(lift(dd))
        .sub(dab.mul_lift(lift(cd)))
        .add(cda.mul_lift(lift(bd)))
        .sub(bcd.mul_lift(lift(ad)));
    -det.signum()
}

/// The common binary grid of a point set (every coordinate is an integer times `2^unit`),
/// found once, so exact predicates on the set convert a coordinate to its integer with one
/// exact multiplication by a power of two instead of taking the float apart.
///
/// Invariant: every coordinate of the set is a multiple of `2^unit` below `2^(unit + 47)` in
/// magnitude, so integers are below 2^47, differences below 2^48, and the determinants fit
/// the widths chosen by `orient_small` / `insphere_small`. Only points of that set may be
/// passed to its methods.
#[derive(Debug)]
pub struct Grid {
    /// `2^-unit`: coordinate times `scale` is its exact integer.
    scale: f64,
    /// Per axis, `2^-lo[k]` for the axis' own lowest set bit: `orient` scales each axis
    /// apart (its determinant only changes by a positive factor).
    orient_scale: [f64; 3],
    /// `orient`'s determinant after the per-axis scaling always fits in i128.
    orient_small: bool,
    /// ... and even in i64: then it costs no more than the float filter.
    orient_tiny: bool,
    /// `insphere`'s determinant always fits in i128.
    insphere_small: bool,
}

/// Largest coordinate magnitude of a [`Grid`], in bits of grid units.
const GRID_BITS: i32 = 47;

/// `x`, an integer of magnitude below 2^51 held in an `f64` (a coordinate of a [`Grid`]
/// in its units: below 2^48), as an `i64`, exactly: `x + 1.5 * 2^52` lies in `[2^52,
/// 2^53)`, where the spacing of doubles is 1, so it is exact, and its bits less those of
/// `1.5 * 2^52` are `x`. An add and a move, where `as i64` also tests for NaN and for
/// overflow to saturate (the grid's predicates convert 6 to 15 coordinates per call;
/// docs/benchmarks-history.md in git history, *nineteenth part*, counts what this saves).
#[inline(always)]
fn grid_int(x: f64) -> i64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    debug_assert!(
        x.fract() == 0.0 && x.abs() < 2f64.powi(51),
        "not a grid integer: {x}"
    );
    (x + MAGIC).to_bits() as i64 - MAGIC.to_bits() as i64
}

/// `2^k` for `-1022 <= k <= 1023`.
fn pow2(k: i32) -> Option<f64> {
    (-1022..=1023)
        .contains(&k)
        .then(|| f64::from_bits(((k + 1023) as u64) << 52))
}

impl Grid {
    /// The grid of `points`, or `None` when their coordinates span more than
    /// [`GRID_BITS`] bits of one binary grid (general floating-point data).
    pub fn new(points: &[DVec3]) -> Option<Grid> {
        // Each axis' lowest and highest set bit, over chunks in parallel (one serial scan
        // until 2026-12-05: with the first tetrahedron 6.7-7.1 ms of a 1M lattice build,
        // 3.2-3.8 ms since); a chunk that leaves the span too
        // wide stops the scan, so general data costs about one chunk per thread.
        type Span = ([i32; 3], [i32; 3]);
        let empty = || ([i32::MAX; 3], [i32::MIN; 3]);
        let narrow = |(lo, hi): Span| {
            let unit = *lo.iter().min().unwrap_or(&0);
            let top = *hi.iter().max().unwrap_or(&0);
            (unit == i32::MAX || top - unit <= GRID_BITS).then_some((lo, hi))
        };
        let merge = |(lo, hi): Span, (lo2, hi2): Span| {
            let m = (
                [0, 1, 2].map(|k| lo[k].min(lo2[k])),
                [0, 1, 2].map(|k| hi[k].max(hi2[k])),
            );
            narrow(m)
        };
        let (lo, hi) = points
            .par_chunks(4096)
            .map(|chunk| {
                let (mut lo, mut hi) = empty();
                for p in chunk {
                    for k in 0..3 {
                        if p[k] != 0.0 {
                            let (l, h) = bit_span(p[k]);
                            lo[k] = lo[k].min(l);
                            hi[k] = hi[k].max(h);
                        }
                    }
                }
                narrow((lo, hi))
            })
            .try_reduce(empty, merge)?;
        let unit = *lo.iter().min().unwrap_or(&0);
        if unit == i32::MAX {
            return None;
        }
        let mut orient_scale = [1.0; 3];
        // Bits of the differences per axis after the per-axis scaling.
        let mut orient_bits = 3;
        let mut diff_bits = 0;
        for k in 0..3 {
            if lo[k] != i32::MAX {
                orient_scale[k] = pow2(-lo[k])?;
                orient_bits += hi[k] - lo[k] + 1;
                diff_bits = diff_bits.max(hi[k] - unit + 1);
            }
        }
        Some(Grid {
            scale: pow2(-unit)?,
            orient_scale,
            orient_small: orient_bits <= 126,
            orient_tiny: orient_bits <= 62,
            insphere_small: 5 * diff_bits + 7 <= 126,
        })
    }

    /// Is the exact `orient` as cheap as its float filter (all in i64)?
    #[inline]
    pub fn orient_is_cheap(&self) -> bool {
        self.orient_tiny
    }

    /// Exact sign of `orient` (module conventions of `predicates`) of four points of the set.
    #[inline(always)]
    pub fn orient(&self, a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> i32 {
        if !self.orient_tiny && coplanar_by_construction([a, b, c, d]) {
            return 0;
        }
        let s = self.orient_scale;
        // Exact: a multiple of 2^lo[k] times 2^-lo[k] is an integer below 2^47.
        let p = |q: DVec3| {
            [
                grid_int(q.x * s[0]),
                grid_int(q.y * s[1]),
                grid_int(q.z * s[2]),
            ]
        };
        let (a, b, c, d) = (p(a), p(b), p(c), p(d));
        if self.orient_tiny {
            let diff = |q: [i64; 3]| [q[0] - a[0], q[1] - a[1], q[2] - a[2]];
            let (b, c, d) = (diff(b), diff(c), diff(d));
            let m0 = c[1] * d[2] - c[2] * d[1];
            let m1 = c[0] * d[2] - c[2] * d[0];
            let m2 = c[0] * d[1] - c[1] * d[0];
            return (b[0] * m0 - b[1] * m1 + b[2] * m2).signum() as i32;
        }
        let diff = |q: [i64; 3]| [0, 1, 2].map(|k| i128::from(q[k] - a[k]));
        let (b, c, d) = (diff(b), diff(c), diff(d));
        if self.orient_small {
            let m0 = c[1] * d[2] - c[2] * d[1];
            let m1 = c[0] * d[2] - c[2] * d[0];
            let m2 = c[0] * d[1] - c[1] * d[0];
            return (b[0] * m0 - b[1] * m1 + b[2] * m2).signum() as i32;
        }
        orient_of_diffs([b, c, d])
    }

    /// Exact sign of `insphere` (module conventions of `predicates`) of five points of the
    /// set. (Ties of vertical wells, the common ones on well data, are cheaper to find
    /// first with [`vertical_wells_tie`] on the coordinates: the construction does.)
    #[inline(always)]
    pub fn insphere(&self, a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> i32 {
        let s = self.scale;
        let g = |q: DVec3| [grid_int(q.x * s), grid_int(q.y * s), grid_int(q.z * s)];
        let ge = g(e);
        let diff = |q: DVec3| {
            let q = g(q);
            [0, 1, 2].map(|k| i128::from(q[k] - ge[k]))
        };
        let v = [diff(a), diff(b), diff(c), diff(d)];
        if self.insphere_small {
            insphere_small(v)
        } else if concyclic_by_construction(&v) {
            0
        } else {
            insphere_wide(v)
        }
    }

    /// The symbolic perturbation's answer (`predicates::in_sphere_perturbed`: is `e`
    /// inside?) for a tie of vertical wells among the points `p` of a positive tetrahedron
    /// and `e`, found by [`vertical_wells_tie`] (`tie.at` = `[j, l, i, m]`). One
    /// orientation in the plane instead of the general tie-break's orientations in space.
    ///
    /// The general tie-break visits the five points from the lexicographically largest
    /// (`x`, then `y`, then `z`) down, answering with the sign of the orientation of `p`
    /// with the visited point replaced by `e` (outside when `e` is reached first), the
    /// first that is not zero:
    /// - Replacing `p[m]` leaves `j`, `l`, `i` and `e` on two vertical lines: coplanar,
    ///   zero, so `m` is passed over whatever its rank.
    /// - Of the others, the largest is on the larger of the two lines (in `x`, then `y`:
    ///   they differ), the deeper or shallower by `z`. If it is `e`: outside.
    /// - Otherwise it is `p[k]`, and `p` with `p[k]` replaced by `e` has two points `u`,
    ///   `w` on one vertical line and two others `a`, `d`; with `w - u = (0, 0, dz)`,
    ///   expanding the determinant along that row gives `orient(u, w, a, d) = dz *
    ///   orient_xy(u, a, d)`. With `A`, `B`, `M` the lines of `j` and `l`, of `i` and `e`,
    ///   and of `m`, and `O = orient_xy(A, B, M)`, the three cases are, as `(u, w, a, d)`
    ///   in `p`'s positions and the sign of their order (a cyclic shift of three keeps
    ///   it, a swap flips it):
    ///   - `k = i`: `(j, l, i, m)`, `(z_l - z_j) O`, times the tie's parity;
    ///   - `k = j`: `(i, j, l, m)` with `e` at `j`, `(z_e - z_i) (-O)`, the same parity;
    ///   - `k = l`: `(i, l, j, m)` with `e` at `l`, `(z_e - z_i) (-O)`, the opposite one.
    ///
    /// `dz` is never zero (distinct points). When `O` is, every later step is zero too
    /// (the same three lines), and the walk ends at `e`: outside.
    ///
    /// The order is read off the coordinates: with no `-0.0` and no NaN among them it is
    /// `f64::total_cmp`'s, the order of the construction's lexicographic ranks.
    ///
    /// Without branches (which case holds is as unpredictable as the tie): with `r_ie`
    /// and `r_jl` the signs of `z_e - z_i` and `z_l - z_j`, `k` is `j` when `A` is the
    /// larger line and `r_jl < 0` (then `-r_ie = r_ie r_jl`), `l` when `r_jl > 0` (`r_ie =
    /// r_ie r_jl`); when `B` is, `e` (outside) if `r_ie > 0`, else `i` (`r_jl`).
    ///
    /// `p(k)` is the point at position `k`, as in [`vertical_wells_tie`].
    #[inline]
    pub fn wells_tie_inside(&self, p: impl Fn(usize) -> DVec3, e: DVec3, tie: WellsTie) -> bool {
        let [j, l, i, m] = tie.at;
        let rise = |below: f64, above: f64| 2 * i32::from(above > below) - 1;
        let a = p(j);
        let a_larger = (a.x > e.x) | ((a.x == e.x) & (a.y > e.y));
        let (r_ie, r_jl) = (rise(p(i).z, e.z), rise(a.z, p(l).z));
        let along = r_jl * if a_larger { r_ie } else { 1 };
        let e_first = !a_larger & (r_ie > 0);
        !e_first & (self.orient_xy(a, e, p(m)) * along * tie.parity > 0)
    }

    /// Exact sign of the orientation of `a`, `b`, `c` seen from above, their `z` ignored:
    /// of `(b - a) x (c - a)` along `z`, positive counter-clockwise. The grid's integers
    /// are below 2^47, so the products of differences fit in i128.
    #[inline]
    pub fn orient_xy(&self, a: DVec3, b: DVec3, c: DVec3) -> i32 {
        let s = self.scale;
        let g = |q: DVec3| [grid_int(q.x * s), grid_int(q.y * s)];
        let (a, b, c) = (g(a), g(b), g(c));
        let d = |q: [i64; 2], k: usize| i128::from(q[k] - a[k]);
        (d(b, 0) * d(c, 1) - d(b, 1) * d(c, 0)).signum() as i32
    }
}

/// The pairs `(j, l)` of four points that [`vertical_wells_tie`] tries on one vertical
/// line, each with the other two `(i1, i2)`, one of which must share `e`'s line.
const WELL_PAIRS: [(usize, usize, usize, usize); 6] = [
    (0, 1, 2, 3),
    (0, 2, 1, 3),
    (0, 3, 1, 2),
    (1, 2, 0, 3),
    (1, 3, 0, 2),
    (2, 3, 0, 1),
];

/// A tie of vertical wells as [`vertical_wells_tie`] finds it: the positions `[j, l, i,
/// m]` and the sign of that sequence as a permutation of `0..4` (-1 when odd).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WellsTie {
    pub at: [usize; 4],
    pub parity: i32,
}

/// The tie at the positions `at` = `[j, l, i, m]`, with the sign of that permutation.
const fn wells_tie(at: [usize; 4]) -> WellsTie {
    let mut inversions = 0;
    let mut x = 0;
    while x < 4 {
        let mut y = x + 1;
        while y < 4 {
            if at[x] > at[y] {
                inversions += 1;
            }
            y += 1;
        }
        x += 1;
    }
    WellsTie {
        at,
        parity: if inversions % 2 == 0 { 1 } else { -1 },
    }
}

/// The ties [`vertical_wells_tie`] tells apart: for each of [`WELL_PAIRS`], `i` first the
/// one, then the other of the two left.
const WELLS_TIES: [WellsTie; 12] = {
    let mut ties = [wells_tie([0, 1, 2, 3]); 12];
    let mut c = 0;
    while c < 12 {
        let (j, l, i1, i2) = WELL_PAIRS[c / 2];
        ties[c] = wells_tie(if c % 2 == 0 {
            [j, l, i1, i2]
        } else {
            [j, l, i2, i1]
        });
        c += 1;
    }
    ties
};

/// For each position `i`, the three others.
const OTHERS: [[usize; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

/// For `i` alone on `e`'s line: the tie `[j, l, i, m]` for each pair of
/// [`OTHERS`]`[i]`, `(o0, o1)`, `(o0, o2)`, `(o1, o2)`.
const ONE_ON_E: [[WellsTie; 3]; 4] = {
    let mut table = [[wells_tie([0, 1, 2, 3]); 3]; 4];
    let mut i = 0;
    while i < 4 {
        let [o0, o1, o2] = OTHERS[i];
        table[i] = [
            wells_tie([o0, o1, i, o2]),
            wells_tie([o0, o2, i, o1]),
            wells_tie([o1, o2, i, o0]),
        ];
        i += 1;
    }
    table
};

/// A co-spherical tie of vertical wells among four points `p` and a fifth `e`, found on
/// the coordinates themselves: two of `p`, at positions `j` and `l`, on one vertical line
/// other than `e`'s, a third, at `i`, on `e`'s line, and equal depth sums `z_j + z_l = z_i
/// + z_e`. Then `j`, `l`, `i` and `e` lie on one circle (as
/// [`concyclic_by_construction`] explains), so the five points lie on one sphere whatever
/// the fourth point, at `m`, is. Returns the first of [`WELLS_TIES`] that holds.
///
/// Exact for points of a [`Grid`] with no `-0.0` (the construction's points): equal
/// coordinates are equal bit patterns then, and the sum of two coordinates is exact (a
/// multiple of the unit below 2^48 units, which a double holds) and never `-0.0`. The
/// cases are tested without branches (which holds is unpredictable) into a bit mask, on
/// the coordinates' bits: a float equality costs twice the instructions (its test for
/// NaN). With one point on `e`'s line (the usual case: a second one there is the fourth
/// point on the query's well) only the three pairs of the other three are tested, else
/// all 12 cases.
///
/// `p(k)` is the point at position `k`. The construction keeps the four points as three
/// arrays of scalars, one per axis: passed as an array of points, they were copied
/// through the stack twice and read back in 16-byte loads from 8-byte stores (a stalled
/// store forwarding each), and the ties took 9.9-11.3% of a one-thread build of the 1M
/// UTM lattice under `perf` instead of 8.3-9.0% (docs/benchmarks-history.md in git
/// history, *nineteenth part*).
#[inline]
pub fn vertical_wells_tie(p: impl Fn(usize) -> DVec3 + Copy, e: DVec3) -> Option<WellsTie> {
    let (ex, ey) = (e.x.to_bits(), e.y.to_bits());
    let line = [0, 1, 2, 3].map(|k| (p(k).x.to_bits(), p(k).y.to_bits()));
    let on_e = line.map(|(x, y)| (x ^ ex) | (y ^ ey) == 0);
    let same_line = |j: usize, l: usize| (line[j].0 ^ line[l].0) | (line[j].1 ^ line[l].1) == 0;
    let with_e = [0, 1, 2, 3].map(|k| (p(k).z + e.z).to_bits());
    let on_e_mask = on_e
        .iter()
        .enumerate()
        .fold(0u32, |mask, (k, &on)| mask | u32::from(on) << k);
    if on_e_mask.count_ones() == 1 {
        // One point on `e`'s line, `i`, and the pair among the three others.
        let i = on_e_mask.trailing_zeros() as usize;
        let [o0, o1, o2] = OTHERS[i];
        let pair =
            |j: usize, l: usize| same_line(j, l) & ((p(j).z + p(l).z).to_bits() == with_e[i]);
        let found =
            u32::from(pair(o0, o1)) | u32::from(pair(o0, o2)) << 1 | u32::from(pair(o1, o2)) << 2;
        return (found != 0).then(|| ONE_ON_E[i][found.trailing_zeros() as usize]);
    }
    let mut found = 0u32;
    for (c, &(j, l, i1, i2)) in WELL_PAIRS.iter().enumerate() {
        let pair = same_line(j, l) & !on_e[j];
        let sum = (p(j).z + p(l).z).to_bits();
        found |= u32::from(pair & on_e[i1] & (sum == with_e[i1])) << (2 * c);
        found |= u32::from(pair & on_e[i2] & (sum == with_e[i2])) << (2 * c + 1);
    }
    (found != 0).then(|| WELLS_TIES[found.trailing_zeros() as usize])
}

/// Are four of the five points concyclic by construction, which makes their insphere
/// determinant exactly zero? `v` holds the differences `p - e` of the four others: true
/// when `e` and one of them lie on a line parallel to a coordinate axis, two others on a
/// second such line, and the two pairs are symmetric about one plane across that axis
/// (equal coordinate sums along it).
///
/// Why zero: the two lines are parallel and distinct, so the four points lie in one plane.
/// There, the perpendicular bisectors of both pairs are the same line (the plane across
/// the axis at half the common sum), and on it lies a point as far from one point of each
/// pair as from the other: the centre of a circle through all four. A circle and a fifth
/// point lie on one sphere (or one plane), so the determinant vanishes.
///
/// Drill holes make this the common tie: vertical wells sampled at common depths give
/// such trapezoids between every two neighbouring wells, and on well data at UTM
/// coordinates every tie the float filter leaves was of this kind, which this test answers
/// with a few comparisons instead of 256-bit products.
fn concyclic_by_construction(v: &[[i128; 3]; 4]) -> bool {
    // The vertical axis first: wells.
    for (k, k1, k2) in [(2, 0, 1), (0, 1, 2), (1, 2, 0)] {
        for i in 0..4 {
            // `v[i]` on the line through `e` (the origin) parallel to axis `k`.
            if v[i][k1] != 0 || v[i][k2] != 0 {
                continue;
            }
            for j in 0..4 {
                for l in j + 1..4 {
                    if j == i || l == i {
                        continue;
                    }
                    let same_line = v[j][k1] == v[l][k1] && v[j][k2] == v[l][k2];
                    let other_line = v[j][k1] != 0 || v[j][k2] != 0;
                    if same_line && other_line && v[j][k] + v[l][k] == v[i][k] {
                        return true;
                    }
                }
            }
        }
    }
    false
}

/// Are the four points coplanar by construction, which makes their orientation exactly
/// zero? True when they share one coordinate (a plane across that axis: a sampling depth),
/// or lie on at most two lines parallel to one coordinate axis (two parallel lines span a
/// plane; one line and any point too).
///
/// Vertical wells make these the orientation ties of well data: counted on the 1M UTM
/// lattice, every orientation the float filter left was an exact zero, 95% of them points
/// on at most two wells and the rest points of one depth. Plain float comparisons, exact
/// for any coordinates, so this answers before any integer arithmetic.
fn coplanar_by_construction(p: [DVec3; 4]) -> bool {
    // Each axis' answer without branches (which of the cases holds is unpredictable); the
    // vertical axis first: wells.
    let across = |k: usize, k1: usize, k2: usize| {
        let plane = (p[1][k] == p[0][k]) & (p[2][k] == p[0][k]) & (p[3][k] == p[0][k]);
        // Points repeating an earlier one's position across axis `k`: at least two
        // repeats leave at most two distinct lines.
        let same = |i: usize, j: usize| (p[i][k1] == p[j][k1]) & (p[i][k2] == p[j][k2]);
        let repeats = u32::from(same(0, 1))
            + u32::from(same(0, 2) | same(1, 2))
            + u32::from(same(0, 3) | same(1, 3) | same(2, 3));
        plane | (repeats >= 2)
    };
    across(2, 0, 1) || across(0, 1, 2) || across(1, 2, 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_integers_convert_exactly_across_their_whole_range() {
        let limit = (1i64 << 51) - 1;
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut values = vec![
            0,
            1,
            -1,
            2,
            -2,
            limit,
            -limit,
            1 << 47,
            -(1 << 47),
            12_345_678_901,
        ];
        for _ in 0..10_000 {
            values.push((xorshift(&mut state) >> 13) as i64 - (1i64 << 50));
        }
        for v in values {
            assert_eq!(grid_int(v as f64), v, "{v}");
        }
        // -0.0 is the integer 0 too.
        assert_eq!(grid_int(-0.0), 0);
    }

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

    fn xorshift(state: &mut u64) -> u64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        *state
    }

    fn robust_orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> i32 {
        crate::tet::predicates::orient_robust(a, b, c, d) as i32 - 1
    }

    fn robust_insphere(p: [DVec3; 5]) -> i32 {
        crate::tet::predicates::insphere_robust(p[0], p[1], p[2], p[3], p[4]) as i32 - 1
    }

    /// Grid predicates against `robust` on the point sets themselves: jittered UTM
    /// lattices (ties, 256-bit insphere, i128 orient), small integer lattices (i64
    /// orient, i128 insphere) and wide random grids (256-bit orient).
    #[test]
    fn grid_predicates_match_robust_on_every_width() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let utm: Vec<DVec3> = (0..400)
            .map(|k| {
                let well = (k / 20) as f64;
                let jitter = (well * 0.618_033_988_749).fract() * 3.1;
                // Jittered collars at UTM magnitude, then the exact local shift.
                let x = 500_000.0 + (well % 5.0) * 50.0 + jitter;
                let y = 6_500_000.0 + (well / 5.0).floor() * 50.0 - jitter;
                DVec3::new(x - 500_100.0, y - 6_500_075.0, (k % 20) as f64 - 9.5)
            })
            .collect();
        let small: Vec<DVec3> = (0..400)
            .map(|k| DVec3::new((k % 7) as f64, ((k / 7) % 7) as f64, (k / 49) as f64 * 0.5))
            .collect();
        let wide: Vec<DVec3> = (0..400)
            .map(|_| {
                let mut c = || (xorshift(&mut state) >> 18) as f64 - (1u64 << 45) as f64;
                DVec3::new(c(), c(), c())
            })
            .collect();
        for (name, pts) in [("utm", utm), ("small", small), ("wide", wide)] {
            let grid = Grid::new(&pts).expect("on a binary grid");
            let mut zeros = 0;
            for _ in 0..20_000 {
                let mut pick = || (xorshift(&mut state) % pts.len() as u64) as u32;
                let ids = [pick(), pick(), pick(), pick(), pick()];
                let p = ids.map(|v| pts[v as usize]);
                let o = grid.orient(p[0], p[1], p[2], p[3]);
                assert_eq!(o, robust_orient(p[0], p[1], p[2], p[3]), "{name} orient");
                let s = grid.insphere(p[0], p[1], p[2], p[3], p[4]);
                assert_eq!(s, robust_insphere(p), "{name} insphere");
                zeros += usize::from(s == 0 && o != 0);
            }
            if name != "wide" {
                assert!(zeros > 50, "{name}: the sample must hit co-spherical ties");
            }
        }
        // Coordinates spanning too many bits have no grid.
        assert!(Grid::new(&[DVec3::new(1e20, 1e-20, 0.0)]).is_none());
    }

    /// Two pairs of points on parallel lines along each axis, symmetric about one plane
    /// across it: detected, and a tie by both the 256-bit path and `robust`. One unit off
    /// the symmetry: not detected, and the 256-bit sign is `robust`'s.
    #[test]
    fn symmetric_pairs_on_parallel_axis_lines_are_ties_and_near_misses_are_not() {
        let mut state = 0x0f1e_2d3c_4b5a_6978u64;
        let as_point = |v: [i128; 3]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
        let with_e = |v: [[i128; 3]; 4]| {
            [
                as_point(v[0]),
                as_point(v[1]),
                as_point(v[2]),
                as_point(v[3]),
                DVec3::ZERO,
            ]
        };
        let mut nonzero_misses = 0;
        for k in 0..3 {
            let line = |x: i128, y: i128, along: i128| {
                let mut p = [0i128; 3];
                p[k] = along;
                p[(k + 1) % 3] = x;
                p[(k + 2) % 3] = y;
                p
            };
            for round in 0..1000 {
                let mut c = || ((xorshift(&mut state) >> 20) as i64 - (1i64 << 43)) as i128;
                let (h, h2, x, y) = (c(), c(), c(), c());
                let other = [c(), c(), c()];
                // `e` is the origin, `on_e` shares its line; `p`, `q` the parallel line.
                let on_e = line(0, 0, h);
                let p = line(x, y, h2);
                let q = line(x, y, h - h2);
                let near = line(x, y, h - h2 + 1);
                // The four in several orders.
                let tie = match round % 3 {
                    0 => [on_e, p, q, other],
                    1 => [p, other, on_e, q],
                    _ => [other, q, p, on_e],
                };
                assert!(concyclic_by_construction(&tie), "axis {k}: {tie:?}");
                assert_eq!(
                    vertical_wells_tie(|k| as_point(tie[k]), DVec3::ZERO).is_some(),
                    k == 2,
                    "axis {k}: {tie:?}"
                );
                assert_eq!(insphere_wide(tie), 0, "axis {k}: {tie:?}");
                assert_eq!(robust_insphere(with_e(tie)), 0, "axis {k}: {tie:?}");
                let miss = [on_e, p, near, other];
                assert!(!concyclic_by_construction(&miss), "axis {k}: {miss:?}");
                assert!(vertical_wells_tie(|k| as_point(miss[k]), DVec3::ZERO).is_none());
                let sign = insphere_wide(miss);
                assert_eq!(sign, robust_insphere(with_e(miss)), "axis {k}: {miss:?}");
                nonzero_misses += usize::from(sign != 0);
            }
        }
        assert!(
            nonzero_misses > 2900,
            "near misses are not ties: {nonzero_misses}"
        );
    }

    /// Ties of vertical wells at UTM magnitudes (jittered collars) and on an exact
    /// lattice (where wells line up, so the orientation in the plane is often zero), in
    /// every order, with the free point on a third well, on one of the two, or in line
    /// with them: found by `vertical_wells_tie`, exact zeros of the integer determinant,
    /// and `wells_tie_inside` gives the general symbolic perturbation's answer.
    #[test]
    fn ties_of_vertical_wells_are_broken_as_the_general_perturbation_breaks_them() {
        let mut state = 0x5eed_0f3e_1150_u64;
        let (mut checked, mut inside, mut flat) = (0, 0, 0);
        for round in 0..40_000 {
            let pick = |state: &mut u64, n: u64| xorshift(state) % n;
            let utm = round % 2 == 0;
            // A well on a 5 x 5 grid of 50 m; jittered by up to 3 m at UTM magnitude.
            let well = |state: &mut u64| {
                let k = xorshift(state) % 25;
                let (gx, gy) = ((k % 5) as f64 * 50.0, (k / 5) as f64 * 50.0);
                if utm {
                    let jitter = |v: u64| (v % 6001) as f64 / 1000.0 - 3.0;
                    let (jx, jy) = (jitter(xorshift(state)), jitter(xorshift(state) >> 7));
                    (
                        500_000.0 + gx + jx - 500_100.0,
                        6_500_000.0 + gy + jy - 6_500_100.0,
                    )
                } else {
                    (gx - 100.0, gy - 100.0)
                }
            };
            let a = well(&mut state);
            let b = well(&mut state);
            if a == b {
                continue;
            }
            let m_line = match pick(&mut state, 4) {
                0 => a,
                1 => b,
                _ => well(&mut state),
            };
            let z = |v: u64| v as f64 - 20.0;
            let (ze, zi, zj) = (
                z(pick(&mut state, 40)),
                z(pick(&mut state, 40)),
                z(pick(&mut state, 40)),
            );
            let zl = zi + ze - zj;
            let zm = z(pick(&mut state, 40));
            let at = |(x, y): (f64, f64), z: f64| DVec3::new(x, y, z);
            let (e, i, j, l, m) = (at(b, ze), at(b, zi), at(a, zj), at(a, zl), at(m_line, zm));
            let distinct = [e, i, j, l, m];
            if (0..5).any(|x| (x + 1..5).any(|y| distinct[x] == distinct[y])) {
                continue;
            }
            // The four in a random order, made positive (or skipped when flat).
            let mut p = [i, j, l, m];
            for k in (1..4).rev() {
                p.swap(k, pick(&mut state, k as u64 + 1) as usize);
            }
            match robust_orient(p[0], p[1], p[2], p[3]) {
                0 => {
                    flat += 1;
                    continue;
                }
                -1 => p.swap(0, 1),
                _ => {}
            }
            let grid = Grid::new(&[p[0], p[1], p[2], p[3], e]).expect("on a binary grid");
            assert_eq!(grid.insphere(p[0], p[1], p[2], p[3], e), 0, "{p:?} {e}");
            let tie = vertical_wells_tie(|k| p[k], e).unwrap_or_else(|| panic!("{p:?} {e}"));
            let answer = grid.wells_tie_inside(|k| p[k], e, tie);
            assert_eq!(
                answer,
                crate::tet::predicates::in_sphere_perturbed(p, e),
                "{p:?} {e} {tie:?}"
            );
            checked += 1;
            inside += usize::from(answer);
        }
        assert!(
            checked > 15_000 && flat > 100,
            "{checked} checked, {flat} flat"
        );
        assert!(
            inside > checked / 5 && inside < checked * 4 / 5,
            "{inside} of {checked}"
        );
    }

    #[test]
    fn points_on_two_axis_lines_or_one_axis_plane_are_coplanar_and_near_misses_are_not() {
        let mut state = 0x0bad_cafe_f00d_1234u64;
        let mut c = move || ((xorshift(&mut state) >> 20) as i64 - (1i64 << 43)) as f64 * 0.125;
        let mut nonzero_misses = 0;
        for round in 0..3000 {
            let k = round % 3;
            // A point with coordinate `h` along axis `k` and `(x, y)` across it.
            let at = |x: f64, y: f64, h: f64| {
                let mut p = DVec3::ZERO;
                p[k] = h;
                p[(k + 1) % 3] = x;
                p[(k + 2) % 3] = y;
                p
            };
            let (x1, y1, x2, y2) = (c(), c(), c(), c());
            let (h1, h2, h3, h4) = (c(), c(), c(), c());
            let two_lines = [
                at(x1, y1, h1),
                at(x2, y2, h2),
                at(x1, y1, h3),
                at(x2, y2, h4),
            ];
            let one_line_and_one = [
                at(x1, y1, h1),
                at(x1, y1, h2),
                at(x2, y2, h3),
                at(x1, y1, h4),
            ];
            let one_plane = [
                at(x1, y1, h1),
                at(x2, y2, h1),
                at(c(), c(), h1),
                at(c(), c(), h1),
            ];
            for set in [two_lines, one_line_and_one, one_plane] {
                assert!(coplanar_by_construction(set), "axis {k}: {set:?}");
                assert_eq!(robust_orient(set[0], set[1], set[2], set[3]), 0, "{set:?}");
            }
            // One point moved off its line (or plane) by one unit of the grid.
            let mut miss = two_lines;
            miss[round % 4][(k + 1) % 3] += 0.125;
            let mut flat_miss = one_plane;
            flat_miss[round % 4][k] += 0.125;
            for set in [miss, flat_miss] {
                assert!(!coplanar_by_construction(set), "axis {k}: {set:?}");
                nonzero_misses += usize::from(robust_orient(set[0], set[1], set[2], set[3]) != 0);
            }
        }
        assert!(
            nonzero_misses > 5900,
            "near misses are not ties: {nonzero_misses}"
        );
    }

    #[test]
    fn wide_insphere_matches_the_generic_256_bit_path_near_its_limit() {
        let mut state = 0x1234_5678_9abc_def1u64;
        for _ in 0..20_000 {
            let mut c = || ((xorshift(&mut state) >> 16) as i64 - (1i64 << 47)) as i128;
            let v = [
                [c(), c(), c()],
                [c(), c(), c()],
                [c(), c(), c()],
                [c(), c(), c()],
            ];
            let p = |k: usize| DVec3::new(v[k][0] as f64, v[k][1] as f64, v[k][2] as f64);
            assert_eq!(
                insphere_wide(v),
                robust_insphere([p(0), p(1), p(2), p(3), DVec3::ZERO])
            );
        }
    }
}
