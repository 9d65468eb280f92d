//! Exact geometric predicates for the tetrahedralization: the only caller of `robust`.
//!
//! Invariant: every answer is the sign of the exact determinant of the given `f64`
//! coordinates (a float filter answers only when its error bound proves the sign), and
//! ties are broken by one symbolic perturbation, so the same inputs always give the same
//! answer whatever the caller.
//!
//! Conventions (written once, used everywhere in `tet`):
//! - `orient(a, b, c, d)` is the sign of `(b-a) . ((c-a) x (d-a))`: positive when `d` is on
//!   the side of the plane `abc` towards which `(b-a) x (c-a)` points. A tetrahedron
//!   `[a, b, c, d]` is *positive* when `orient(a, b, c, d) > 0`. This is the opposite sign
//!   of `robust::orient3d`, which is positive when `d` lies *below* a counter-clockwise `abc`.
//! - `insphere(a, b, c, d, e)` is positive when `e` is strictly inside the circumsphere of
//!   the positive tetrahedron `abcd`. `robust::insphere` is positive inside for tetrahedra
//!   that *it* calls positive (ours are negative for it), so we negate it.
//! - Symbolic perturbation (Edelsbrunner–Mücke; the scheme CGAL's `Delaunay_triangulation_3`
//!   uses): each point `p` is lifted to `|p|^2 + eps^(rank p)` where the rank is the
//!   lexicographic order of `(x, y, z)`, the largest point getting the largest
//!   perturbation. A zero `insphere` is then decided by the orientation of the minor of the
//!   most perturbed point, so no five points are ever co-spherical and the Delaunay
//!   tetrahedralization is unique.

use std::cmp::Ordering;

use glam::DVec3;
use robust::Coord3D;

use super::exact_int;

/// Sign of an exact determinant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sign {
    Negative,
    Zero,
    Positive,
}

impl Sign {
    pub(super) fn of(value: f64) -> Sign {
        if value > 0.0 {
            Sign::Positive
        } else if value < 0.0 {
            Sign::Negative
        } else {
            Sign::Zero
        }
    }
}

fn c3(p: DVec3) -> Coord3D<f64> {
    Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// Coordinates whose magnitudes keep the filter's error bound a normal float.
#[inline]
fn filter_usable(lo: f64, hi: f64) -> bool {
    lo > 1e-50 && hi < 1e50
}

/// Exact sign of `(b-a) . ((c-a) x (d-a))` (see the module conventions).
#[inline]
pub fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
    match orient_filter(a, b, c, d) {
        Some(s) => s,
        None => orient_exact(a, b, c, d),
    }
}

/// The float filter of [`orient`]: the exact sign when the `f64` determinant's error bound
/// proves it, else `None`.
#[inline]
pub fn orient_filter(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Option<Sign> {
    let det = orient_det(a, b, c, d);
    let (bx, by, bz) = (b.x - a.x, b.y - a.y, b.z - a.z);
    let (cx, cy, cz) = (c.x - a.x, c.y - a.y, c.z - a.z);
    let (dx, dy, dz) = (d.x - a.x, d.y - a.y, d.z - a.z);
    // Static filter: |error| <= 1e-14 * max|dx| * max|dy| * max|dz| (Shewchuk's o3derrboundA
    // on the permanent <= 6 mx my mz gives 4.7e-15; doubled for margin).
    let mx = bx.abs().max(cx.abs()).max(dx.abs());
    let my = by.abs().max(cy.abs()).max(dy.abs());
    let mz = bz.abs().max(cz.abs()).max(dz.abs());
    let lo = mx.min(my).min(mz);
    let hi = mx.max(my).max(mz);
    if filter_usable(lo, hi) {
        let eps = 1e-14 * mx * my * mz;
        if det > eps {
            return Some(Sign::Positive);
        }
        if det < -eps {
            return Some(Sign::Negative);
        }
    }
    None
}

/// A cheaper bound than [`orient_filter`]'s on its determinant `det` ([`orient_det`],
/// computed by the caller): every |difference| is at most `r = sqrt(len)`, `len` the
/// largest squared edge from `a`, so `1e-14 r^3` is at least the per-axis bound. The sign,
/// or `None`. For points on an integer grid, where the exact test follows at once (what
/// this leaves is nearly always an exact zero).
#[inline]
pub(super) fn orient_len_bound(det: f64, a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Option<Sign> {
    let len = max_of_numbers(
        max_of_numbers((b - a).length_squared(), (c - a).length_squared()),
        (d - a).length_squared(),
    );
    (len > 1e-100 && len < 1e100)
        .then(|| sign_beyond(det, 1e-14 * len * len.sqrt()))
        .flatten()
}

/// The larger of `a` and `b`, neither of them NaN (lifts and squared lengths of finite
/// points), as one `maxsd`. `f64::max` also handles NaN, which costs a compare and a
/// blend more per step, on the chain the grid kernel's bounds and their jumps wait on:
/// the insphere bound's lift with `f64::max` made a one-thread 1M UTM lattice build
/// about 4% slower (docs/benchmarks-history.md in git history, *twenty-third part*).
#[inline(always)]
fn max_of_numbers(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// The sign of `det` when `|det|` exceeds the error bound `eps`.
#[inline(always)]
pub(super) fn sign_beyond(det: f64, eps: f64) -> Option<Sign> {
    (det.abs() > eps).then_some(if det > 0.0 {
        Sign::Positive
    } else {
        Sign::Negative
    })
}

/// The `f64` determinant [`orient_filter`] decides on, without its error bound.
#[inline]
pub fn orient_det(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    let (bx, by, bz) = (b.x - a.x, b.y - a.y, b.z - a.z);
    let (cx, cy, cz) = (c.x - a.x, c.y - a.y, c.z - a.z);
    let (dx, dy, dz) = (d.x - a.x, d.y - a.y, d.z - a.z);
    bx * (cy * dz - cz * dy) - by * (cx * dz - cz * dx) + bz * (cx * dy - cy * dx)
}

/// Error bounds of [`orient_det`] and [`insphere_det`] valid for any points whose
/// coordinate differences are at most `extent` per axis (the bounds of [`orient_filter`]
/// and [`insphere_filter`] with every per-call maximum replaced by the extent, which can
/// only raise them): `None` outside the magnitudes where those filters are usable. A
/// determinant beyond its bound has its sign; within it, ask the per-call filter.
pub fn static_bounds(extent: DVec3) -> Option<(f64, f64)> {
    let (lo, hi) = (extent.min_element(), extent.max_element());
    filter_usable(lo, hi).then(|| {
        let volume = extent.x * extent.y * extent.z;
        (1e-14 * volume, 5e-13 * volume * hi * hi)
    })
}

/// [`orient`] without the filter: fixed-width integers when the coordinates share a
/// binary grid, else `robust::orient3d` negated (its convention is the opposite).
pub fn orient_exact(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
    match exact_int::orient_sign(a, b, c, d) {
        Some(s) => Sign::of(f64::from(s)),
        None => orient_robust(a, b, c, d),
    }
}

/// [`orient_exact`] always through `robust` (reference for tests).
pub fn orient_robust(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
    Sign::of(-robust::orient3d(c3(a), c3(b), c3(c), c3(d)))
}

/// Exact sign of the in-sphere determinant: `Positive` when `e` is strictly inside the
/// circumsphere of the positive tetrahedron `abcd`, `Zero` when co-spherical.
#[inline]
pub fn insphere(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Sign {
    match insphere_filter(a, b, c, d, e) {
        Some(s) => s,
        None => insphere_exact(a, b, c, d, e),
    }
}

/// The float filter of [`insphere`]: the exact sign when the `f64` determinant's error
/// bound proves it, else `None`.
#[inline(always)]
pub fn insphere_filter(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Option<Sign> {
    let (det, lift) = insphere_det_lift(a, b, c, d, e);
    lift_bound(det, lift).or_else(|| insphere_filter_per_axis(a, b, c, d, e, det))
}

/// A bound that costs three `max` and a square root: every |difference| is at most
/// `r = sqrt(lift)` (the largest lifted value), so `r^5` bounds the product of the per-axis
/// maxima below, and `5e-13 r^5` bounds the error. It is looser than the per-axis bound
/// only on flat configurations, which then take the per-axis one. On integer grids it is
/// the only bound before the exact integers (their undecided tests are nearly all exact
/// ties, which no bound decides).
#[inline(always)]
pub(super) fn lift_bound(det: f64, lift: f64) -> Option<Sign> {
    (lift > 1e-100 && lift < 1e100)
        .then(|| sign_beyond(det, 5e-13 * lift * lift * lift.sqrt()))
        .flatten()
}

/// The per-axis bound of [`insphere_filter`], out of line: inlined, its maxima were
/// computed ahead of the cheaper bound's test on every call.
#[cold]
#[inline(never)]
fn insphere_filter_per_axis(
    a: DVec3,
    b: DVec3,
    c: DVec3,
    d: DVec3,
    e: DVec3,
    det: f64,
) -> Option<Sign> {
    let (adx, ady, adz) = (a.x - e.x, a.y - e.y, a.z - e.z);
    let (bdx, bdy, bdz) = (b.x - e.x, b.y - e.y, b.z - e.z);
    let (cdx, cdy, cdz) = (c.x - e.x, c.y - e.y, c.z - e.z);
    let (ddx, ddy, ddz) = (d.x - e.x, d.y - e.y, d.z - e.z);
    // Static filter: the permanent is <= 72 mx my mz m^2 (m the largest of mx, my, mz);
    // Shewchuk's isperrboundA (3.6e-15) times that is 2.6e-13; use 5e-13 for margin.
    let mx = adx.abs().max(bdx.abs()).max(cdx.abs()).max(ddx.abs());
    let my = ady.abs().max(bdy.abs()).max(cdy.abs()).max(ddy.abs());
    let mz = adz.abs().max(bdz.abs()).max(cdz.abs()).max(ddz.abs());
    let lo = mx.min(my).min(mz);
    let hi = mx.max(my).max(mz);
    if filter_usable(lo, hi) {
        let eps = 5e-13 * mx * my * mz * hi * hi;
        if det > eps {
            return Some(Sign::Positive);
        }
        if det < -eps {
            return Some(Sign::Negative);
        }
    }
    None
}

/// The `f64` determinant [`insphere_filter`] decides on (positive inside), without its
/// error bound.
#[inline]
pub fn insphere_det(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> f64 {
    insphere_det_lift(a, b, c, d, e).0
}

/// [`insphere_det`] and the largest of the four lifted values `|a - e|^2, ..`.
#[inline(always)]
pub(super) fn insphere_det_lift(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> (f64, f64) {
    let (adx, ady, adz) = (a.x - e.x, a.y - e.y, a.z - e.z);
    let (bdx, bdy, bdz) = (b.x - e.x, b.y - e.y, b.z - e.z);
    let (cdx, cdy, cdz) = (c.x - e.x, c.y - e.y, c.z - e.z);
    let (ddx, ddy, ddz) = (d.x - e.x, d.y - e.y, d.z - e.z);
    let ab = adx * bdy - bdx * ady;
    let bc = bdx * cdy - cdx * bdy;
    let cd = cdx * ddy - ddx * cdy;
    let da = ddx * ady - adx * ddy;
    let ac = adx * cdy - cdx * ady;
    let bd = bdx * ddy - ddx * bdy;
    let abc = adz * bc - bdz * ac + cdz * ab;
    let bcd = bdz * cd - cdz * bd + ddz * bc;
    let cda = cdz * da + ddz * ac + adz * cd;
    let dab = ddz * ab + adz * bd + bdz * da;
    let alift = adx * adx + ady * ady + adz * adz;
    let blift = bdx * bdx + bdy * bdy + bdz * bdz;
    let clift = cdx * cdx + cdy * cdy + cdz * cdz;
    let dlift = ddx * ddx + ddy * ddy + ddz * ddz;
    // Shewchuk's determinant: positive inside for tetrahedra robust calls positive, i.e.
    // negative orientation in our convention; negate.
    let det = -((dlift * abc - clift * dab) + (blift * cda - alift * bcd));
    let lift = max_of_numbers(max_of_numbers(alift, blift), max_of_numbers(clift, dlift));
    (det, lift)
}

/// [`insphere`] without the filter: fixed-width integers when the coordinates share a
/// binary grid, else `robust::insphere` negated.
pub fn insphere_exact(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Sign {
    match exact_int::insphere_sign(a, b, c, d, e) {
        Some(s) => Sign::of(f64::from(s)),
        None => insphere_robust(a, b, c, d, e),
    }
}

/// [`insphere_exact`] always through `robust` (reference for tests).
pub fn insphere_robust(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Sign {
    Sign::of(-robust::insphere(c3(a), c3(b), c3(c), c3(d), c3(e)))
}

/// Lexicographic order of `(x, y, z)`: the rank used by the symbolic perturbation.
#[inline]
pub fn lex_cmp(a: DVec3, b: DVec3) -> Ordering {
    a.x.total_cmp(&b.x)
        .then(a.y.total_cmp(&b.y))
        .then(a.z.total_cmp(&b.z))
}

/// Is `q` inside the circumsphere of the positive tetrahedron `t`, with co-spherical ties
/// broken by the symbolic perturbation? Never undecided for distinct points.
///
/// A zero determinant is resolved by the leading perturbed term: walking the five points from
/// the lexicographically largest down, if it is `q` then `q` is outside; if it is `t[k]` then
/// the answer is the sign of `orient(t with t[k] replaced by q)` when that is not zero.
pub fn in_sphere_perturbed(t: [DVec3; 4], q: DVec3) -> bool {
    match insphere(t[0], t[1], t[2], t[3], q) {
        Sign::Positive => return true,
        Sign::Negative => return false,
        Sign::Zero => {}
    }
    // Indices 0..4 are the tetrahedron's vertices, 4 is q; visit them from the
    // lexicographically largest down (rarely more than two steps, so select, not sort).
    let pts = [t[0], t[1], t[2], t[3], q];
    let mut done = [false; 5];
    for _ in 0..5 {
        let mut k = 5;
        for i in 0..5 {
            if !done[i] && (k == 5 || lex_cmp(pts[i], pts[k]) == Ordering::Greater) {
                k = i;
            }
        }
        done[k] = true;
        if k == 4 {
            return false;
        }
        let mut r = t;
        r[k] = q;
        match orient(r[0], r[1], r[2], r[3]) {
            Sign::Positive => return true,
            Sign::Negative => return false,
            Sign::Zero => {}
        }
    }
    false
}

/// A point off the plane of the non-degenerate triangle `abc`: `a` moved along a
/// coordinate axis, returned with `orient(a, b, c, apex)`'s sign (never zero).
fn apex_off_plane(a: DVec3, b: DVec3, c: DVec3) -> (DVec3, Sign) {
    let step = 1.0 + a.abs().max_element();
    // The axis nearest the plane's normal first: that orientation is far from zero, so the
    // float filter decides it (an axis within the plane, as on the flat top of well data,
    // would give an exact zero, and cost the exact predicate).
    let n = (b - a).cross(c - a).abs();
    let first = if n.x >= n.y && n.x >= n.z {
        0
    } else if n.y >= n.z {
        1
    } else {
        2
    };
    for axis in [first, (first + 1) % 3, (first + 2) % 3] {
        let mut apex = a;
        apex[axis] += step;
        let s = orient(a, b, c, apex);
        if s != Sign::Zero {
            return (apex, s);
        }
    }
    // abc is degenerate (collinear): callers never pass such triangles.
    (a, Sign::Zero)
}

/// For `q` coplanar with the non-degenerate triangle `abc`: is `q` strictly inside its
/// circumcircle, with co-circular ties broken by the same perturbation as
/// [`in_sphere_perturbed`] restricted to the plane (CGAL's `coplanar_side_of_bounded_circle`)?
///
/// Exact without a 2D projection: the sphere through `a, b, c` and any point off their plane
/// cuts the plane in the circumcircle of `abc`, so an `insphere` against such a point
/// decides the circle test.
pub fn in_circle_coplanar_perturbed(a: DVec3, b: DVec3, c: DVec3, q: DVec3) -> bool {
    let (apex, side) = apex_off_plane(a, b, c);
    if side == Sign::Zero {
        return false;
    }
    // Make the tetrahedron positive for insphere's convention.
    let s = if side == Sign::Positive {
        insphere(a, b, c, apex, q)
    } else {
        insphere(a, c, b, apex, q)
    };
    match s {
        Sign::Positive => return true,
        Sign::Negative => return false,
        Sign::Zero => {}
    }
    let tri = [a, b, c];
    let pts = [a, b, c, q];
    let mut order = [0usize, 1, 2, 3];
    order.sort_unstable_by(|&i, &j| lex_cmp(pts[j], pts[i]));
    for &k in &order {
        if k == 3 {
            return false;
        }
        // Same side of the edge opposite tri[k] as tri[k] <=> the triangle with tri[k]
        // replaced by q has the orientation of abc.
        let mut r = tri;
        r[k] = q;
        let o = orient(r[0], r[1], r[2], apex);
        if o != Sign::Zero {
            return o == side;
        }
    }
    false
}

/// Are `a`, `b`, `c` on one line (exactly)? All three coordinate projections are collinear.
pub fn collinear(a: DVec3, b: DVec3, c: DVec3) -> bool {
    let o2 = |u: [f64; 2], v: [f64; 2], w: [f64; 2]| {
        robust::orient2d(
            robust::Coord { x: u[0], y: u[1] },
            robust::Coord { x: v[0], y: v[1] },
            robust::Coord { x: w[0], y: w[1] },
        )
    };
    o2([a.x, a.y], [b.x, b.y], [c.x, c.y]) == 0.0
        && o2([a.y, a.z], [b.y, b.z], [c.y, c.z]) == 0.0
        && o2([a.x, a.z], [b.x, b.z], [c.x, c.z]) == 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orient_follows_the_right_hand_rule() {
        let o = DVec3::ZERO;
        assert_eq!(orient(o, DVec3::X, DVec3::Y, DVec3::Z), Sign::Positive);
        assert_eq!(orient(o, DVec3::Y, DVec3::X, DVec3::Z), Sign::Negative);
        assert_eq!(
            orient(o, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)),
            Sign::Zero
        );
    }

    #[test]
    fn insphere_is_positive_inside_a_positive_tetrahedron() {
        let (o, x, y, z) = (DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z);
        assert_eq!(insphere(o, x, y, z, DVec3::splat(0.25)), Sign::Positive);
        assert_eq!(insphere(o, x, y, z, DVec3::splat(2.0)), Sign::Negative);
        // (1, 1, 1) is on the sphere through the unit cube's corners.
        assert_eq!(insphere(o, x, y, z, DVec3::ONE), Sign::Zero);
    }

    #[test]
    fn the_filter_agrees_with_the_exact_predicate_at_utm_magnitudes() {
        let base = DVec3::new(500_000.0, 6_500_000.0, 300.0);
        let t = [
            base,
            base + DVec3::new(50.0, 0.0, 0.0),
            base + DVec3::new(0.0, 50.0, 0.0),
            base + DVec3::new(0.0, 0.0, 1.0),
        ];
        let q = base + DVec3::new(50.0, 50.0, 1.0);
        assert_eq!(insphere(t[0], t[1], t[2], t[3], q), Sign::Zero);
        assert_eq!(
            insphere(t[0], t[1], t[2], t[3], q),
            insphere_exact(t[0], t[1], t[2], t[3], q)
        );
    }

    #[test]
    fn the_filters_are_exact_wherever_they_decide_on_flat_and_round_near_ties() {
        // Jittered lattices from round boxes to flat slabs (one axis a millionth of the
        // others), at the origin and at UTM magnitudes: the filter's first bound (from the
        // largest lifted value) and its per-axis bound must never contradict the exact
        // sign, and between them they must decide the clear cases.
        // The orientation tests (four points) need a finer jitter than the insphere tests
        // to land near their bound: every other sample uses 1e-13.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |size: f64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let lattice = (state % 4) as f64;
            let jitter = ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * size;
            lattice + jitter
        };
        let (mut decided, mut decided_orient, mut checked) = (0, 0, 0);
        for scale in [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(50.0, 50.0, 1.0),
            DVec3::new(1.0, 1.0, 1e-6),
            DVec3::new(1e-6, 1.0, 1.0),
        ] {
            for origin in [DVec3::ZERO, DVec3::new(500_000.0, 6_500_000.0, 300.0)] {
                for k in 0..10_000 {
                    let size = if k % 2 == 0 { 1e-7 } else { 1e-13 };
                    let p: [DVec3; 5] = std::array::from_fn(|_| {
                        origin + DVec3::new(next(size), next(size), next(size)) * scale
                    });
                    let [a, b, c, d, e] = p;
                    if let Some(s) = insphere_filter(a, b, c, d, e) {
                        assert_eq!(s, insphere_robust(a, b, c, d, e), "{p:?}");
                        decided += 1;
                    }
                    let (det, lift) = insphere_det_lift(a, b, c, d, e);
                    if let Some(s) = lift_bound(det, lift) {
                        assert_eq!(s, insphere_robust(a, b, c, d, e), "{p:?}");
                    }
                    for s in [
                        orient_filter(a, b, c, d),
                        orient_len_bound(orient_det(a, b, c, d), a, b, c, d),
                    ]
                    .into_iter()
                    .flatten()
                    {
                        assert_eq!(s, orient_robust(a, b, c, d), "{p:?}");
                        decided_orient += 1;
                    }
                    checked += 1;
                }
            }
        }
        assert!(decided > checked / 4, "{decided} of {checked} decided");
        assert!(
            decided_orient > checked,
            "{decided_orient} of 2 x {checked} decided"
        );
    }

    #[test]
    fn determinants_beyond_the_static_bounds_have_the_exact_sign() {
        // Points in a flat box (wells-like extents), many of them near-degenerate: small
        // perturbations of a lattice, so determinants span from ties to large values.
        let extent = DVec3::new(400.0, 300.0, 20.0);
        let (orient_eps, insphere_eps) = static_bounds(extent).unwrap();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |scale: f64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let lattice = (state % 5) as f64 / 4.0;
            let jitter = ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-9;
            (lattice + jitter) * scale
        };
        let (mut decided, mut checked) = (0, 0);
        for _ in 0..20_000 {
            let mut p = [DVec3::ZERO; 5];
            for q in &mut p {
                *q = DVec3::new(next(extent.x), next(extent.y), next(extent.z));
            }
            let [a, b, c, d, e] = p;
            let det = orient_det(a, b, c, d);
            if det.abs() > orient_eps {
                assert_eq!(Sign::of(det), orient_exact(a, b, c, d), "{p:?}");
                decided += 1;
            }
            let det = insphere_det(a, b, c, d, e);
            if det.abs() > insphere_eps {
                assert_eq!(Sign::of(det), insphere_exact(a, b, c, d, e), "{p:?}");
                decided += 1;
            }
            checked += 2;
        }
        assert!(
            decided > checked / 4,
            "{decided} of {checked} decided statically"
        );
        assert!(static_bounds(DVec3::new(1.0, 1.0, 0.0)).is_none());
    }

    #[test]
    fn perturbation_decides_every_cospherical_tie_consistently() {
        // The eight corners of a cube are co-spherical: each tie gets an answer, and the
        // answer for the same five points does not depend on which four form the tetrahedron
        // as long as the tetrahedron is positive.
        let o = DVec3::ZERO;
        let t = [o, DVec3::X, DVec3::Y, DVec3::Z];
        let q = DVec3::ONE;
        let inside = in_sphere_perturbed(t, q);
        // q is the lexicographically largest point, so it is outside.
        assert!(!inside);
    }

    #[test]
    fn coplanar_circle_test_matches_geometry() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        assert!(in_circle_coplanar_perturbed(
            a,
            b,
            c,
            DVec3::new(0.4, 0.4, 0.0)
        ));
        assert!(!in_circle_coplanar_perturbed(
            a,
            b,
            c,
            DVec3::new(2.0, 2.0, 0.0)
        ));
    }

    #[test]
    fn integer_and_expansion_arithmetic_agree_on_ties_and_near_ties() {
        // UTM-like jittered lattice points: many exact ties, many near ties.
        let mut state = 0x1234_5678_9abc_def1u64;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut ties = 0;
        for _ in 0..20_000 {
            let mut pick = || {
                let r = rnd();
                let well = (r % 9) as f64;
                // Jittered collars, vertical holes: each well keeps its own offset.
                let jitter = (well * 0.618_033_988_749).fract() * 3.1;
                DVec3::new(
                    500_000.0 + (well % 3.0) * 50.0 + jitter,
                    6_500_000.0 + (well / 3.0).floor() * 50.0 - jitter,
                    300.0 - ((r >> 20) % 6) as f64,
                )
            };
            let (a, b, c, d, e) = (pick(), pick(), pick(), pick(), pick());
            assert_eq!(orient_exact(a, b, c, d), orient_robust(a, b, c, d));
            let (b, c) = if orient_exact(a, b, c, d) == Sign::Negative {
                (c, b)
            } else {
                (b, c)
            };
            let s = insphere_exact(a, b, c, d, e);
            assert_eq!(s, insphere_robust(a, b, c, d, e));
            ties += usize::from(s == Sign::Zero && orient_exact(a, b, c, d) != Sign::Zero);
        }
        assert!(ties > 100, "the sample must exercise exact ties ({ties})");
        // Coordinates too far apart for the integer path still get exact answers.
        let (a, b, c, d) = (DVec3::ZERO, DVec3::X * 1e30, DVec3::Y * 1e-30, DVec3::Z);
        assert_eq!(orient_exact(a, b, c, d), orient_robust(a, b, c, d));
    }

    #[test]
    fn collinearity_is_exact() {
        assert!(collinear(DVec3::ZERO, DVec3::ONE, DVec3::splat(3.0)));
        assert!(!collinear(
            DVec3::ZERO,
            DVec3::ONE,
            DVec3::new(3.0, 3.0, 3.0000000000000004)
        ));
    }
}
