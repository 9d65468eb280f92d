//! Incremental Bowyer–Watson construction of the 3D Delaunay tetrahedralization.
//!
//! Invariant: between insertions the structure is a triangulation of the 3-sphere: finite
//! tetrahedra tile the convex hull of the inserted points, one ghost tetrahedron (with the
//! infinite vertex [`INF`]) sits on each hull face, every tetrahedron is positive and
//! locally Delaunay under the symbolic perturbation of [`predicates`], and `nbrs` is
//! symmetric (`nbrs[t][i] = t2 * 4 + j` and `nbrs[t2][j] = t * 4 + i`).

use glam::DVec3;
use rayon::prelude::*;

use std::cmp::Ordering;
use std::ops::Range;
use std::sync::atomic::AtomicBool;
use std::sync::atomic::Ordering::Relaxed;

use super::exact_int::{self, Grid};
use super::predicates::{self, Sign};
use super::sort::{InsertionOrder, bounds, insertion_order, lex_ranks, normalized_bounds};
use super::{Cell, FACE_OUTWARD, NO_NEIGHBOUR, TetError, TetMesh, load4};
use crate::progress::{Progress, Stage};

/// The vertex at infinity of ghost tetrahedra (never in a finished [`TetMesh`]).
const INF: u32 = VERTEX_MASK;
/// `v[0]` and `v[1]` of a freed slot (a slot never written is all zero: also dead, since
/// its first two vertices are equal, which those of a tetrahedron never are).
const DEAD: u32 = VERTEX_MASK - 1;
/// The bits of `Cell::v` that hold a vertex id; the top bit of `v[0]` marks a
/// tetrahedron of the current cavity, that of `v[1]` one tested against the current point
/// and kept (marks in the cell itself, which the search reads anyway: no other memory).
const VERTEX_MASK: u32 = (1 << 31) - 1;
/// The mark bit of `Cell::v[0]` and `Cell::v[1]`.
const MARK: u32 = 1 << 31;
/// Largest number of distinct points (vertex ids stay below [`DEAD`]).
pub const MAX_POINTS: usize = DEAD as usize;
/// Insertions between two progress reports / cancellation checks.
const CHECK_EVERY: usize = 4096;
/// Empty slot of the edge table.
const EMPTY: u64 = u64::MAX;
/// Boundary vertices (the infinite one included) of a star linked through the edge
/// matrix; larger stars use the edge table.
const STAR_VERTICES: usize = 32;
/// Slots of the star's vertex table: `2^VERTEX_SLOT_BITS`, eight times [`STAR_VERTICES`]
/// (so a new vertex rarely probes past its first slot).
const VERTEX_SLOT_BITS: u32 = 8;
const VERTEX_SLOTS: usize = 1 << VERTEX_SLOT_BITS;
/// An empty slot of the star's vertex table (no vertex has this id).
const NO_VERTEX: u32 = u32::MAX;
/// Zones (and workers) of the parallel insertion. Fixed, not taken from the machine, so
/// the output (down to the order of the tetrahedra) is the same on any number of threads.
const ZONES: usize = 2;
/// Point sets below this size are inserted sequentially.
const PARALLEL_MIN_POINTS: usize = 50_000;
/// BRIO rounds below this size are inserted sequentially (see docs/tet.md, *Parallel
/// insertion*, for why 2,048).
const PARALLEL_MIN_ROUND: usize = 2048;
/// Largest piece of a round inserted in parallel at once (between sequential passes).
const CHUNK_POINTS: usize = 1 << 17;
/// Fewest vertices given up by a parallel pass worth a second one.
const SECOND_PASS_MIN: usize = 1024;
/// Slots handed to a worker at a time beyond what it is expected to need.
const SLOT_BATCH: usize = 1024;
/// Tetrahedra searched for a worker's start in its zone.
const ZONE_START_SEARCH: usize = 256;

/// The Delaunay tetrahedralization of `points`; see [`super::delaunay`]. With
/// [`InputMap::Drop`] the mesh's `vertex_of_input` is left empty.
pub fn build(
    points: Vec<DVec3>,
    map: InputMap,
    progress: &dyn Progress,
) -> Result<TetMesh, TetError> {
    let zones = if points.len() >= PARALLEL_MIN_POINTS {
        ZONES
    } else {
        1
    };
    build_with(points, zones, false, map, progress)
}

/// Whether a build keeps the map from input points to vertices (4 bytes per input point,
/// alive through the construction's peak).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputMap {
    Keep,
    Drop,
}

/// [`build_with`] keeping the input map.
#[cfg(test)]
fn build_in_zones(
    points: Vec<DVec3>,
    zones: usize,
    portable: bool,
    progress: &dyn Progress,
) -> Result<TetMesh, TetError> {
    build_with(points, zones, portable, InputMap::Keep, progress)
}

/// [`build`] with `zones` workers in the parallel chunks (1: all sequential), and with
/// the insertion's portable copy only if `portable` (else the x86-64-v3 one where the
/// processor has it; both give the same mesh, tetrahedron for tetrahedron).
fn build_with(
    mut points: Vec<DVec3>,
    zones: usize,
    portable: bool,
    map: InputMap,
    progress: &dyn Progress,
) -> Result<TetMesh, TetError> {
    if points.len() > MAX_POINTS {
        return Err(TetError::TooManyPoints {
            count: points.len(),
            max: MAX_POINTS,
        });
    }
    let Some((lo, hi, smallest)) = normalized_bounds(&mut points) else {
        let index = points.par_iter().position_first(|p| !p.is_finite());
        return Err(TetError::NonFinite {
            index: index.expect("a point is not finite"),
        });
    };
    let (shift, _) = exact_shift((lo, hi));
    let scale = exact_scale((lo, hi), shift, smallest, &points)?;
    if scale == 0 {
        return build_exact(points, (lo, hi), zones, portable, map, progress);
    }
    // Outside the predicates' window (see `exact_scale`): built on the points moved by
    // the exact local shift and scaled by a power of two, which changes no predicate's
    // sign, then moved back. Every step is exact, so the mesh's points are the input's.
    let (up, down) = (2f64.powi(scale), 2f64.powi(-scale));
    points.par_iter_mut().for_each(|p| *p = (*p - shift) * up);
    let (lo, hi, _) = bounds(&points);
    let mut mesh = build_exact(points, (lo, hi), zones, portable, map, progress)?;
    mesh.points
        .par_iter_mut()
        .for_each(|p| *p = *p * down + shift);
    Ok(mesh)
}

/// Smallest binary exponent a nonzero coordinate may have for the exact predicates: its
/// last bit is then at least `2^-200`, so every product of up to five coordinates (the
/// in-sphere determinant's degree) is a multiple of `2^-1000` and never underflows.
const EXPONENT_LOW: i32 = -148;
/// Largest binary exponent of a coordinate (after the local shift) for the exact
/// predicates: products of five stay below `2^750`, far from overflow.
const EXPONENT_HIGH: i32 = 149;

/// The power of two `2^k` by which the points, after [`exact_shift`] (`shift`), must be scaled so that
/// every nonzero coordinate's binary exponent lies in `EXPONENT_LOW..=EXPONENT_HIGH`, where
/// Shewchuk's expansions (and so `robust`) are exact: `k = 0` for anything real data holds
/// (magnitudes from about `1e-44` to `1e45`). Scaling by a power of two is itself exact in
/// that window and changes no orientation or in-sphere sign, so the mesh is the same.
/// (A shifted coordinate may be smaller than the smallest input one, but its last bit is
/// not below half the shift's, so the bound on the input's magnitudes suffices.)
/// An error naming two points when the nonzero magnitudes lie further apart than the
/// window is wide (about 89 orders of magnitude): no one scale fits them.
fn exact_scale(
    (lo, hi): (DVec3, DVec3),
    shift: DVec3,
    smallest: DVec3,
    points: &[DVec3],
) -> Result<i32, TetError> {
    let smallest = smallest.min_element();
    if points.is_empty() || !smallest.is_finite() {
        return Ok(0);
    }
    let largest = (lo - shift).abs().max((hi - shift).abs()).max_element();
    if largest == 0.0 {
        // One point, repeated: too few points, said later.
        return Ok(0);
    }
    let exponent = |v: f64| v.log2().floor() as i32;
    let (low, high) = (exponent(smallest), exponent(largest));
    if low >= EXPONENT_LOW && high <= EXPONENT_HIGH {
        return Ok(0);
    }
    if high - low > EXPONENT_HIGH - EXPONENT_LOW {
        let position = |key: &(dyn Fn(f64) -> f64 + Sync)| -> (usize, f64) {
            points
                .par_iter()
                .enumerate()
                .flat_map_iter(|(i, p)| p.to_array().map(|c| (i, c)))
                .map(|(i, c)| (i, c, key(c.abs())))
                .min_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)))
                .map(|(i, c, _)| (i, c))
                .unwrap_or((0, 0.0))
        };
        let small = position(&|a| if a == 0.0 { f64::INFINITY } else { a });
        let large = position(&|a| -a);
        return Err(TetError::MagnitudeRange { small, large });
    }
    // The scale nearest 1 that fits (|k| <= 926, so `2^k` is a normal float).
    Ok(0.clamp(EXPONENT_LOW - low, EXPONENT_HIGH - high))
}

/// [`build_with`] on points already checked, with `-0.0` made `0.0` and their bounding
/// box, whose nonzero coordinates (after [`exact_shift`]) lie in the exact predicates'
/// window ([`exact_scale`] is 0).
fn build_exact(
    points: Vec<DVec3>,
    bbox: (DVec3, DVec3),
    zones: usize,
    portable: bool,
    map: InputMap,
    progress: &dyn Progress,
) -> Result<TetMesh, TetError> {
    // Vertices are numbered in insertion order, so the points the construction touches
    // one after the other are neighbours in memory too; equal points are merged on the
    // way.
    let InsertionOrder {
        order,
        vertex_of_input,
        rounds,
    } = insertion_order(&points, bbox);
    let duplicates_merged = vertex_of_input.len() - order.len();
    let vertex_of_input = match map {
        InputMap::Keep => vertex_of_input,
        InputMap::Drop => {
            // Freed now, not when the build returns.
            drop(vertex_of_input);
            Vec::new()
        }
    };
    if order.len() < 4 {
        return Err(TetError::TooFewPoints {
            distinct: order.len(),
        });
    }
    // The input's bounding box is the distinct points' too; the shift is applied while
    // gathering.
    let (shift, extent) = exact_shift(bbox);
    let input = points;
    let mut points: Vec<DVec3> = order
        .par_iter()
        .map(|&i| input[i as usize] - shift)
        .collect();
    drop(input);
    drop(order);
    let x86_64_v3 = !portable && x86_64_v3_detected();
    let built = Builder::run(&points, extent, &rounds, zones, x86_64_v3, progress);
    points.par_iter_mut().for_each(|p| *p += shift);
    Ok(TetMesh::from_cells(
        points,
        built?,
        vertex_of_input,
        duplicates_merged,
    ))
}

/// For the points of bounding box `(lo, hi)`: a per-axis translation under which every
/// coordinate difference `x - shift` is exact (Sterbenz: `s/2 <= x <= 2s`), so predicates
/// on shifted points equal those on the input; zero on axes where no such shift exists
/// (coordinates spanning zero are small anyway).
/// Also returns the bounding box's extent per axis (the same before and after the shift,
/// since the shifted coordinates are exact).
fn exact_shift((lo, hi): (DVec3, DVec3)) -> (DVec3, DVec3) {
    let mut shift = DVec3::ZERO;
    for k in 0..3 {
        let (a, b) = (lo[k], hi[k]);
        let centre = 0.5 * a + 0.5 * b;
        if (a > 0.0 && b <= 2.5 * a) || (b < 0.0 && a >= 2.5 * b) {
            shift[k] = centre;
        }
    }
    (shift, hi - lo)
}

// One tetrahedron during construction is a [`Cell`] (32 bytes, its vertices and neighbour
// links side by side: the cavity search reads both together), the finished mesh's own
// storage, so the mesh is handed over without a copy. The zones (see [`Zone`]) keep every
// cell written by one worker out of every other worker's reach, so no value is ever raced
// for. During construction ghosts have [`INF`] last, freed slots `[DEAD, DEAD, ..]` and
// never written ones all zero.

impl Cell {
    fn dead() -> Cell {
        Cell::new([DEAD; 4], [NO_NEIGHBOUR; 4])
    }

    #[inline(always)]
    fn verts(&self) -> [u32; 4] {
        self.raw_verts().map(|u| u & VERTEX_MASK)
    }

    /// The vertex words with their mark bits.
    #[inline(always)]
    fn raw_verts(&self) -> [u32; 4] {
        load4(&self.v)
    }

    /// Sets (`on`) or clears the mark bit of `v[i]` (`i` 0: in the cavity, 1: kept).
    #[inline]
    fn mark(&self, i: usize, on: bool) {
        let x = self.v[i].load(Relaxed);
        self.v[i].store(if on { x | MARK } else { x & !MARK }, Relaxed);
    }

    /// A free slot: freed ([`Cell::kill`]) or never written (all zero).
    #[inline]
    fn is_dead(&self) -> bool {
        (self.v[0].load(Relaxed) ^ self.v[1].load(Relaxed)) & VERTEX_MASK == 0
    }

    /// Marks the slot free.
    #[inline]
    fn kill(&self) {
        self.v[0].store(DEAD, Relaxed);
        self.v[1].store(DEAD, Relaxed);
    }
}

/// Asks the processor to bring `cell` into the cache ahead of its use: the cavity search
/// calls it on the neighbours of each tetrahedron it adds, whose cache misses then overlap
/// the insphere tests in between.
#[inline(always)]
#[allow(unsafe_code)]
fn prefetch(cell: &Cell) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is only a hint to the cache: it reads no value, changes no memory
    // and cannot fault, whatever the address; `_MM_HINT_T0` needs only SSE, part of every
    // x86-64 target.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>((cell as *const Cell).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = cell;
}

/// Writes `link` into the face slot it names the other side of: `cells[t2].n[j]`.
#[inline]
fn set_link(cells: &[Cell], at: u32, link: u32) {
    cells[(at >> 2) as usize].n[(at & 3) as usize].store(link, Relaxed);
}

/// The points and the predicates on them, shared read-only by the workers.
struct Geometry<'a> {
    pts: &'a [DVec3],
    /// `pts` as one flat slice of coordinates (for [`Zone::owns`]).
    coords: &'a [f64],
    /// The points as integers on one binary grid, when they share one (lattices, UTM
    /// well data): exact predicates then skip the per-call float-to-integer conversion.
    grid: Option<Grid>,
    /// With a grid (where co-spherical ties are common): the lexicographic rank of each
    /// vertex, so the symbolic perturbation compares integers. Empty until a tie needs it:
    /// ties of vertical wells are broken without ([`Grid::wells_tie_inside`]), and on
    /// UTM well data (jittered collars) every tie is one, so there it is never computed. A tie that finds it
    /// empty compares the points themselves (the same order) and sets `wants_ranks`; the
    /// driver then computes the ranks between two passes ([`Builder::rank_if_wanted`]),
    /// never inside a worker's pass.
    lex_rank: Vec<u32>,
    wants_ranks: AtomicBool,
    /// Error bounds of the `f64` orientation and insphere determinants over the whole
    /// point set ([`predicates::static_bounds`]; infinite when unusable): beyond them a
    /// sign is decided without the per-call bound.
    orient_eps: f64,
    insphere_eps: f64,
    /// Insert with the copy compiled for x86-64-v3 (the processor has it, and the build
    /// was not asked for the portable one).
    x86_64_v3: bool,
}

/// The vertices a worker may remove tetrahedra of: those with `lo <= p[axis] < hi` and
/// the infinite vertex, or every vertex ([`Zone::ALL`], the sequential passes).
///
/// Why this makes the parallel chunks safe: a worker deletes (and writes over) only
/// tetrahedra whose four vertices are in its zone, and writes the neighbour link of a
/// tetrahedron only when it shares a face with one of those, so every tetrahedron it
/// writes has at least three vertices in its zone. It reads only tetrahedra it reached
/// through a face of one of its own (at least three vertices in its zone) or the start
/// the sequential driver found for it. No tetrahedron has three vertices in each of two
/// zones: the slabs are disjoint, and the infinite vertex, the one they share, is in a
/// ghost with three finite vertices, which cannot be two in each. So no tetrahedron one
/// worker writes is read or written by another during the chunk; an insertion that would need
/// one outside its zone is given up before it changes anything and done in the
/// sequential pass after the chunk. What each worker does is thus independent of the
/// others' timing, and the result is the same on any number of threads.
#[derive(Debug, Clone, Copy)]
struct Zone {
    all: bool,
    axis: usize,
    lo: f64,
    hi: f64,
}

impl Zone {
    const ALL: Zone = Zone {
        all: true,
        axis: 0,
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// Is `u` in the zone? The infinite vertex is in every zone. `coords` are the points'
    /// coordinates in one flat slice (`x y z` per point), so the zone's axis is an index,
    /// not a `match` on the axis (a branch in the cavity search's hottest loop).
    #[inline(always)]
    fn owns_vertex(&self, coords: &[f64], u: u32) -> bool {
        match coords.get(u as usize * 3 + self.axis) {
            Some(&c) => (self.lo <= c) & (c < self.hi),
            None => u == INF,
        }
    }

    /// May the worker of this zone remove a tetrahedron entered through a face of one it
    /// may remove? Only the vertex `u` opposite that face can be outside the zone.
    #[inline(always)]
    fn owns_beyond_owned_face(&self, coords: &[f64], u: u32) -> bool {
        self.all || self.owns_vertex(coords, u)
    }

    /// May the worker of this zone remove the tetrahedron `tv`? All four vertices are
    /// tested without short-circuits: nearly every tetrahedron is owned, and four
    /// predictable tests cost less than four branches.
    #[inline(always)]
    fn owns(&self, coords: &[f64], tv: [u32; 4]) -> bool {
        self.all
            || (self.owns_vertex(coords, tv[0])
                & self.owns_vertex(coords, tv[1])
                & self.owns_vertex(coords, tv[2])
                & self.owns_vertex(coords, tv[3]))
    }
}

/// Why an insertion was not done.
enum Missed {
    /// It needs a tetrahedron outside the worker's zone (or none of its zone to start
    /// from).
    Foreign,
    /// It needs this many more fresh slots than the worker holds.
    Slots(usize),
}

/// One inserting thread's state: reused buffers, its free slots and its place in the mesh.
/// Aligned to a 4 KiB page, so two workers' states, written on every insertion, share no
/// page, and a hardware prefetcher reading ahead of one worker's state (every insertion
/// clears its 1 KiB vertex table front to back) never pulls the other's lines away from
/// its core; prefetchers stay within a page. Aligned to two cache lines only, the second
/// worker ran 7-10% slower than the first in nearly every parallel pass while both ran,
/// and 1M uniform points took 7% longer (see docs/tet.md, *Parallel insertion*).
#[repr(align(4096))]
struct Worker {
    /// Tetrahedra the current cavity search tested and kept (marked `v[1]`).
    kept: Vec<u32>,
    cavity: Vec<u32>,
    /// New tetrahedra: vertices, apex position, link to the outside of the cavity.
    pending: Vec<([u32; 4], u32, u32)>,
    new_tets: Vec<u32>,
    edge_table: Vec<(u64, u32)>,
    /// [`Worker::link_by_edge_matrix`]'s scratch: vertex ids and their local ids
    /// (open addressing), the local ids of each new tetrahedron's boundary face, and the
    /// directed-edge matrix (in the state itself, on its worker's pages, not boxed).
    vertex_keys: [u32; VERTEX_SLOTS],
    vertex_ids: [u8; VERTEX_SLOTS],
    star_locals: Vec<[u8; 3]>,
    edge_matrix: [u32; STAR_VERTICES * STAR_VERTICES],
    /// Slots freed by this worker (dead cells), used before `fresh`.
    free: Vec<u32>,
    /// Never used slots handed to this worker by the driver (dead cells).
    fresh: Range<u32>,
    /// A live tetrahedron to start the next walk from.
    last: u32,
    /// The last insertion's star (`pending`, `new_tets`) was built by this worker since
    /// the driver last set `last`: the walk may start from it.
    star_hint: bool,
    rng: u64,
    /// Vertices of the current chunk this worker gave up (for the sequential pass).
    deferred: Vec<u32>,
}

/// The sign of `det()` when it lies beyond the static bound `eps` (never when the bound
/// is unusable, i.e. infinite: no finite determinant exceeds it). No test of `eps` first:
/// a branch between loading the points and the arithmetic made LLVM store the points to
/// the stack and load them again, on every test.
#[inline]
fn beyond(eps: f64, det: impl FnOnce() -> f64) -> Option<Sign> {
    let det = det();
    if det > eps {
        Some(Sign::Positive)
    } else if det < -eps {
        Some(Sign::Negative)
    } else {
        None
    }
}

impl Geometry<'_> {
    #[inline]
    fn p(&self, v: u32) -> DVec3 {
        self.pts[v as usize]
    }

    /// The grid, in the insertion's copy compiled for point sets with one (`GRID`; the
    /// driver picks that copy only then). Its float path is not compiled in: it made LLVM
    /// lay out the lattice kernel less well (3-6% slower at 1M points, fewer instructions).
    #[inline(always)]
    fn grid_of_kernel(&self) -> &Grid {
        match &self.grid {
            Some(g) => g,
            None => unreachable!("the grid kernel runs only on point sets with a grid"),
        }
    }

    /// [`predicates::orient`] of four vertices. `GRID`: the point set has an integer grid
    /// (then the grid's exact integers, else the float path; both exact). The insertion is
    /// compiled once for each, so a point set without a grid runs a kernel with no test
    /// for one, and LLVM keeps its straight-line hot path in registers.
    #[inline(always)]
    fn orient<const GRID: bool>(&self, a: u32, b: u32, c: u32, d: u32) -> Sign {
        let (pa, pb, pc, pd) = (self.p(a), self.p(b), self.p(c), self.p(d));
        if GRID {
            let g = self.grid_of_kernel();
            // In i64 the exact test costs no more than a filter. Otherwise the static bound,
            // then one cheap per-call bound on the same determinant (what they leave is
            // nearly always an exact zero, which the grid's test answers by construction),
            // then the integers.
            if !g.orient_is_cheap() {
                let det = predicates::orient_det(pa, pb, pc, pd);
                if let Some(s) = predicates::sign_beyond(det, self.orient_eps)
                    .or_else(|| predicates::orient_len_bound(det, pa, pb, pc, pd))
                {
                    return s;
                }
            }
            return Sign::of(f64::from(g.orient(pa, pb, pc, pd)));
        }
        match beyond(self.orient_eps, || predicates::orient_det(pa, pb, pc, pd)) {
            Some(s) => s,
            None => self.orient_undecided(a, b, c, d),
        }
    }

    /// What [`Geometry::orient`]'s static bound leaves off a grid (out of line, as
    /// [`Geometry::insphere_undecided`]).
    #[inline(never)]
    fn orient_undecided(&self, a: u32, b: u32, c: u32, d: u32) -> Sign {
        let (pa, pb, pc, pd) = (self.p(a), self.p(b), self.p(c), self.p(d));
        match predicates::orient_filter(pa, pb, pc, pd) {
            Some(s) => s,
            None => predicates::orient_exact(pa, pb, pc, pd),
        }
    }

    /// [`Geometry::orient`] outside the insertion's kernel.
    fn orient_any(&self, a: u32, b: u32, c: u32, d: u32) -> Sign {
        if self.grid.is_some() {
            self.orient::<true>(a, b, c, d)
        } else {
            self.orient::<false>(a, b, c, d)
        }
    }

    /// [`predicates::insphere`] of four vertices and the point `pe` (`GRID` as in
    /// [`Geometry::orient`]). On a grid, a tie of vertical wells comes back already broken
    /// by the symbolic perturbation (never [`Sign::Zero`]): see
    /// [`Geometry::insphere_undecided`].
    #[inline(always)]
    fn insphere<const GRID: bool>(&self, [a, b, c, d]: [u32; 4], pe: DVec3) -> Sign {
        let (pa, pb, pc, pd) = (self.p(a), self.p(b), self.p(c), self.p(d));
        let decided = if GRID {
            // On a grid the exact test is integer arithmetic, and what the cheap bound
            // leaves is nearly always an exact tie: no per-axis bound. Not the static
            // bound either: on the 1M well lattice it decides about as often as not, and
            // the mispredicted branch cost more than the bound saves.
            let (det, lift) = predicates::insphere_det_lift(pa, pb, pc, pd, pe);
            predicates::lift_bound(det, lift)
        } else {
            beyond(self.insphere_eps, || {
                predicates::insphere_det(pa, pb, pc, pd, pe)
            })
        };
        decided.unwrap_or_else(|| self.insphere_undecided::<GRID>([a, b, c, d], pe))
    }

    /// What [`Geometry::insphere`]'s first bound leaves: the per-call filter and the exact
    /// test. On a grid, first a tie of vertical wells ([`exact_int::vertical_wells_tie`]:
    /// every tie the bound leaves on UTM well data), answered with the perturbation's sign
    /// ([`Grid::wells_tie_inside`]: one orientation in the plane, where
    /// [`Geometry::perturbed_tie`] takes one or two in space, the ranks and a call); then
    /// the integers. Out of line, and the points loaded again here, so the
    /// kernel need not keep them past its determinant: it had stored them to the stack
    /// and loaded them back on every test.
    #[inline(never)]
    fn insphere_undecided<const GRID: bool>(&self, t: [u32; 4], pe: DVec3) -> Sign {
        if GRID {
            let g = self.grid_of_kernel();
            // The coordinates as three arrays of scalars, read back one scalar at a
            // time, not an array of points (see `vertical_wells_tie`).
            let q = t.map(|v| self.p(v));
            let (xs, ys, zs) = (q.map(|q| q.x), q.map(|q| q.y), q.map(|q| q.z));
            let p = |k: usize| DVec3::new(xs[k], ys[k], zs[k]);
            if let Some(tie) = exact_int::vertical_wells_tie(p, pe) {
                // Broken here already, as `perturbed_tie` would break it.
                let inside = g.wells_tie_inside(p, pe, tie);
                debug_assert_eq!(
                    inside,
                    predicates::in_sphere_perturbed(q, pe),
                    "a tie of wells is broken as the general tie-break does: {t:?} {pe}"
                );
                return if inside {
                    Sign::Positive
                } else {
                    Sign::Negative
                };
            }
            let [pa, pb, pc, pd] = q;
            return Sign::of(f64::from(g.insphere(pa, pb, pc, pd, pe)));
        }
        let [pa, pb, pc, pd] = t.map(|v| self.p(v));
        match predicates::insphere_filter(pa, pb, pc, pd, pe) {
            Some(s) => s,
            None => predicates::insphere_exact(pa, pb, pc, pd, pe),
        }
    }

    /// [`predicates::in_sphere_perturbed`] of the positive tetrahedron `t` and vertex `q`
    /// (at `pq`, loaded once per insertion by the caller).
    #[inline(always)]
    fn in_sphere_perturbed<const GRID: bool>(&self, t: [u32; 4], q: u32, pq: DVec3) -> bool {
        match self.insphere::<GRID>(t, pq) {
            Sign::Positive => true,
            Sign::Negative => false,
            Sign::Zero => self.perturbed_tie::<GRID>(t, q),
        }
    }

    /// The symbolic perturbation's answer where the in-sphere determinant is zero.
    #[inline(never)]
    fn perturbed_tie<const GRID: bool>(&self, t: [u32; 4], q: u32) -> bool {
        if !self.lex_rank.is_empty() {
            return self.perturbed_tie_ranked::<GRID>(t, q);
        }
        // Written once: the flag shares a cache line with what every worker reads.
        if GRID && !self.wants_ranks.load(Relaxed) {
            self.wants_ranks.store(true, Relaxed);
        }
        let ids = [t[0], t[1], t[2], t[3], q];
        let greater = |i: usize, k: usize| {
            predicates::lex_cmp(self.p(ids[i]), self.p(ids[k])) == Ordering::Greater
        };
        let mut done = [false; 5];
        for _ in 0..5 {
            let mut k = 5;
            for (i, &is_done) in done.iter().enumerate() {
                if !is_done && (k == 5 || greater(i, k)) {
                    k = i;
                }
            }
            done[k] = true;
            if k == 4 {
                return false;
            }
            if let Some(inside) = self.replaced_orient::<GRID>(t, k, q) {
                return inside;
            }
        }
        false
    }

    /// One step of the tie-break: the sign of `orient` of `t` with its vertex `k` replaced
    /// by `q` (true: `q` inside), or `None` when that is zero too.
    #[inline]
    fn replaced_orient<const GRID: bool>(&self, t: [u32; 4], k: usize, q: u32) -> Option<bool> {
        let mut r = t;
        r[k] = q;
        match self.orient::<GRID>(r[0], r[1], r[2], r[3]) {
            Sign::Positive => Some(true),
            Sign::Negative => Some(false),
            Sign::Zero => None,
        }
    }

    /// The tie-break of [`Geometry::in_sphere_perturbed`] with lexicographic ranks (grids,
    /// where ties are common): the points visited from the highest rank down, each next
    /// one picked as the largest of five keys `(rank + 1) * 8 + position` (a maximum,
    /// without the branches of a search, which mispredicted about twice per tie on well
    /// data; a visited point's key becomes 0).
    fn perturbed_tie_ranked<const GRID: bool>(&self, t: [u32; 4], q: u32) -> bool {
        let ids = [t[0], t[1], t[2], t[3], q];
        let mut keys = [0u64; 5];
        for (i, (key, &u)) in keys.iter_mut().zip(&ids).enumerate() {
            *key = (u64::from(self.lex_rank[u as usize]) + 1) << 3 | i as u64;
        }
        for _ in 0..5 {
            let top = keys[0].max(keys[1]).max(keys[2].max(keys[3])).max(keys[4]);
            let k = (top & 7) as usize;
            if k == 4 {
                return false;
            }
            keys[k] = 0;
            if let Some(inside) = self.replaced_orient::<GRID>(t, k, q) {
                return inside;
            }
        }
        false
    }

    /// Does vertex `v` conflict with the tetrahedron of vertices `tv` (inside its
    /// perturbed circumsphere, or for a ghost, strictly beyond its hull face or on it
    /// inside the face's circumcircle)?
    #[inline(always)]
    fn conflict<const GRID: bool>(&self, tv: [u32; 4], v: u32, pv: DVec3) -> bool {
        if tv[3] == INF {
            match self.orient::<GRID>(tv[0], tv[1], tv[2], v) {
                Sign::Positive => true,
                Sign::Negative => false,
                Sign::Zero => {
                    let [a, b, c] = [tv[0], tv[1], tv[2]].map(|u| self.p(u));
                    predicates::in_circle_coplanar_perturbed(a, b, c, self.p(v))
                }
            }
        } else {
            self.in_sphere_perturbed::<GRID>(tv, v, pv)
        }
    }

    /// [`Geometry::conflict`] off a grid, with its common outcome (a float determinant
    /// beyond the static bound) returned as data, not as a jump on the determinant's
    /// sign, so the cavity search can compute the tests of a tetrahedron's neighbours
    /// before it branches on any. Ghosts and determinants within the bound (rare off a
    /// grid) take [`Geometry::conflict`] itself.
    #[inline(always)]
    fn conflict_hoisted(&self, tv: [u32; 4], v: u32, pv: DVec3) -> bool {
        if tv[3] != INF {
            let [pa, pb, pc, pd] = tv.map(|u| self.p(u));
            let det = predicates::insphere_det(pa, pb, pc, pd, pv);
            if det.abs() > self.insphere_eps {
                return det > 0.0;
            }
        }
        self.conflict::<false>(tv, v, pv)
    }
}

impl Worker {
    fn new(seed: u64) -> Worker {
        Worker {
            kept: Vec::new(),
            cavity: Vec::new(),
            pending: Vec::new(),
            new_tets: Vec::new(),
            edge_table: Vec::new(),
            vertex_keys: [NO_VERTEX; VERTEX_SLOTS],
            vertex_ids: [0; VERTEX_SLOTS],
            star_locals: Vec::new(),
            edge_matrix: [NO_NEIGHBOUR; STAR_VERTICES * STAR_VERTICES],
            free: Vec::new(),
            fresh: 0..0,
            last: 0,
            star_hint: false,
            rng: seed,
            deferred: Vec::new(),
        }
    }

    /// Points the next walk at the live tetrahedron `t` (set by the driver: the last star
    /// may be stale or another worker's reach).
    fn place(&mut self, t: u32) {
        self.last = t;
        self.star_hint = false;
    }

    /// Slots this worker can fill without the driver.
    fn spare(&self) -> usize {
        self.free.len() + self.fresh.len()
    }

    #[inline]
    fn next_random(&mut self) -> u32 {
        // xorshift64
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        (self.rng >> 32) as u32
    }

    /// A slot for a new tetrahedron (the caller checked [`Worker::spare`]).
    #[inline]
    fn alloc(&mut self) -> u32 {
        if let Some(t) = self.free.pop() {
            return t;
        }
        self.fresh
            .next()
            .expect("slots were reserved before the insertion")
    }

    /// Visibility walk from `last` to a tetrahedron in conflict with vertex `q`: a finite
    /// tetrahedron containing `q`, or (in [`Zone::ALL`]) a ghost whose hull face `q` is
    /// strictly beyond. The face the walk came through is not tested again. `None` when
    /// the walk meets a tetrahedron outside `zone`.
    #[inline(always)]
    fn locate<const GRID: bool>(
        &mut self,
        g: &Geometry,
        cells: &[Cell],
        q: u32,
        zone: Zone,
    ) -> Option<u32> {
        let mut t = self.last;
        if self.star_hint {
            t = self.star_toward(g, cells, q).unwrap_or(t);
        }
        let mut from = 4;
        'walk: loop {
            let cell = &cells[t as usize];
            let tv = cell.verts();
            // Entered through a face of an owned tetrahedron: only its opposite vertex is new.
            let owned = if from < 4 {
                zone.owns_beyond_owned_face(g.coords, tv[from])
            } else {
                zone.owns(g.coords, tv)
            };
            if !owned {
                return None;
            }
            if tv[3] == INF {
                if from == 4 {
                    // Starting on a ghost: step inside through its hull face (and test
                    // that face again: nothing says the point is on its inner side).
                    t = cell.n[3].load(Relaxed) >> 2;
                    from = 5;
                    continue;
                }
                return Some(t);
            }
            let start = self.next_random();
            if !GRID {
                // Off a grid, the four faces' orientations first, into masks, then the
                // first face in the random order with the point beyond it: the step
                // the loop below takes, without a jump on each sign. A determinant
                // within the bound sends the step to that loop.
                let (mut beyond_face, mut open) = (0u32, 0u32);
                for f in 0..4 {
                    let mut r = tv;
                    r[f] = q;
                    let det = predicates::orient_det(g.p(r[0]), g.p(r[1]), g.p(r[2]), g.p(r[3]));
                    // Not beyond the bound either way: open (a NaN too).
                    let decided = det.abs() > g.orient_eps;
                    beyond_face |= u32::from(det < -g.orient_eps) << f;
                    open |= u32::from(!decided) << f;
                }
                let others = !(1u32 << from) & 0xf;
                if open & others == 0 {
                    let m = beyond_face & others;
                    if m == 0 {
                        return Some(t);
                    }
                    let turn = start & 3;
                    let rotated = ((m >> turn) | (m << (4 - turn))) & 0xf;
                    let f = ((turn + rotated.trailing_zeros()) & 3) as usize;
                    let link = cell.n[f].load(Relaxed);
                    t = link >> 2;
                    from = (link & 3) as usize;
                    continue 'walk;
                }
            }
            for s in 0..4u32 {
                let f = ((start + s) & 3) as usize;
                if f == from {
                    continue;
                }
                let mut r = tv;
                r[f] = q;
                if g.orient::<GRID>(r[0], r[1], r[2], r[3]) == Sign::Negative {
                    let link = cell.n[f].load(Relaxed);
                    t = link >> 2;
                    from = (link & 3) as usize;
                    continue 'walk;
                }
            }
            return Some(t);
        }
    }

    /// The finite tetrahedron of the last insertion's star whose face opposite the new
    /// vertex has its centroid nearest `q`, if it is still live as built.
    #[inline(always)]
    fn star_toward(&self, g: &Geometry, cells: &[Cell], q: u32) -> Option<u32> {
        if self.pending.is_empty() {
            return None;
        }
        // Three times the centroid of each face, against three times `q`.
        let target = g.p(q) * 3.0;
        let (mut best, mut best_k) = (f64::INFINITY, 0);
        for (k, &(nv, f, _)) in self.pending.iter().enumerate() {
            if nv[3] == INF {
                continue;
            }
            // The face opposite the new vertex `nv[f]`.
            let sum = g.p(nv[(f as usize + 1) & 3])
                + g.p(nv[(f as usize + 2) & 3])
                + g.p(nv[(f as usize + 3) & 3]);
            let d = (sum - target).length_squared();
            // Chosen by selects: which tetrahedron is nearer is unpredictable.
            let nearer = d < best;
            best = if nearer { d } else { best };
            best_k = if nearer { k } else { best_k };
        }
        let s = self.new_tets[best_k];
        (cells[s as usize].verts() == self.pending[best_k].0).then_some(s)
    }

    /// Clears the marks of the cavity search.
    fn unmark(&self, cells: &[Cell]) {
        for &t in &self.cavity {
            cells[t as usize].mark(0, false);
        }
        for &t in &self.kept {
            cells[t as usize].mark(1, false);
        }
    }

    /// Inserts vertex `v`: grows the conflict cavity breadth-first and stars it from `v`,
    /// writing the new tetrahedra over the cavity's slots first. Changes nothing when it
    /// misses (a tetrahedron outside `zone`, or too few slots).
    fn insert(&mut self, g: &Geometry, cells: &[Cell], v: u32, zone: Zone) -> Result<(), Missed> {
        let grid = g.grid.is_some();
        #[cfg(target_arch = "x86_64")]
        if g.x86_64_v3 {
            // SAFETY: `x86_64_v3` is true only when the processor reported every feature
            // `insert_x86_64_v3` is compiled for (see `x86_64_v3_detected`).
            #[allow(unsafe_code)]
            return unsafe {
                if grid {
                    self.insert_x86_64_v3::<true>(g, cells, v, zone)
                } else {
                    self.insert_x86_64_v3::<false>(g, cells, v, zone)
                }
            };
        }
        if grid {
            self.insert_body::<true>(g, cells, v, zone)
        } else {
            self.insert_body::<false>(g, cells, v, zone)
        }
    }

    /// [`Worker::insert`] compiled for the x86-64-v3 level (AVX2, BMI1/2, LZCNT, FMA,
    /// POPCNT: Intel since 2013, AMD since 2015); called only where the processor has
    /// them. The same source as the portable copy, so the same operations and the same
    /// result: Rust never fuses a multiplication and an addition on its own, FMA or not.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,fma,lzcnt,popcnt")]
    fn insert_x86_64_v3<const GRID: bool>(
        &mut self,
        g: &Geometry,
        cells: &[Cell],
        v: u32,
        zone: Zone,
    ) -> Result<(), Missed> {
        self.insert_body::<GRID>(g, cells, v, zone)
    }

    /// The insertion itself, inlined into both copies with everything it calls on the
    /// common path (the walk, the predicates' float filters, the star's linking); only
    /// rare paths (what the first bounds leave, exact ties, large stars, the grid's wide
    /// integers) stay shared calls.
    #[inline(always)]
    fn insert_body<const GRID: bool>(
        &mut self,
        g: &Geometry,
        cells: &[Cell],
        v: u32,
        zone: Zone,
    ) -> Result<(), Missed> {
        let t0 = self.locate::<GRID>(g, cells, v, zone);
        // The buffers are rebuilt below; only a complete insertion leaves a star.
        self.star_hint = false;
        let t0 = t0.ok_or(Missed::Foreign)?;
        self.cavity.clear();
        self.pending.clear();
        self.kept.clear();
        let pv = g.p(v);
        cells[t0 as usize].mark(0, true);
        self.cavity.push(t0);
        let mut i = 0;
        while i < self.cavity.len() {
            let t = self.cavity[i];
            i += 1;
            let cell = &cells[t as usize];
            let (tv, links) = (cell.verts(), cell.links());
            let near = links.map(|link| &cells[(link >> 2) as usize]);
            // The faces whose neighbour is not in the cavity yet, as a bit mask built
            // without branches: whether a neighbour is in the cavity is as likely as not,
            // and a branch on it per face was the search's most mispredicted one. The
            // four neighbours are read up front, so their cache misses overlap; only
            // their two first words are kept, as the masks `open` and `fresh` (not
            // tested yet); their vertices are read again below, from the first level
            // cache: four words kept per neighbour were stored to the stack and loaded
            // back one by one.
            let (mut open, mut fresh) = (0u32, 0u32);
            for (f, c2) in near.iter().enumerate() {
                open |= u32::from(c2.v[0].load(Relaxed) & MARK == 0) << f;
                if !GRID {
                    fresh |= u32::from(c2.v[1].load(Relaxed) & MARK == 0) << f;
                }
            }
            // Off a grid, the tests of all untested neighbours first, into a mask: no
            // jump on their answers until all are computed, so their latencies overlap
            // and a mispredicted jump on one no longer throws away the work on the
            // others. On a grid, where a fifth to a quarter of the tests leave the float
            // bound undecided (ties), each is tested where it is used, as before.
            let mut hit = 0u32;
            let mut test = if GRID { 0 } else { open & fresh };
            while test != 0 {
                let f = test.trailing_zeros() as usize;
                test &= test - 1;
                let tv2 = near[f].verts();
                hit |= u32::from(g.conflict_hoisted(tv2, v, pv)) << f;
            }
            while open != 0 {
                let f = open.trailing_zeros() as usize;
                open &= open - 1;
                let link = links[f];
                let t2 = link >> 2;
                let c2 = near[f];
                // On a grid the neighbour's words are read once here, its mark and its
                // vertices together (atomic loads are never merged by the compiler).
                let raw = if GRID { c2.raw_verts() } else { [0; 4] };
                let untested = if GRID {
                    raw[1] & MARK == 0
                } else {
                    fresh & (1 << f) != 0
                };
                if untested {
                    let conflict = if GRID {
                        g.conflict::<GRID>(raw.map(|u| u & VERTEX_MASK), v, pv)
                    } else {
                        hit & (1 << f) != 0
                    };
                    if conflict {
                        // `t` is owned, so the face it shares with `t2` is too.
                        let opposite = if GRID {
                            raw[(link & 3) as usize]
                        } else {
                            c2.v[(link & 3) as usize].load(Relaxed)
                        } & VERTEX_MASK;
                        if !zone.owns_beyond_owned_face(g.coords, opposite) {
                            self.unmark(cells);
                            return Err(Missed::Foreign);
                        }
                        c2.mark(0, true);
                        self.cavity.push(t2);
                        for link in c2.links() {
                            prefetch(&cells[(link >> 2) as usize]);
                        }
                        continue;
                    }
                    c2.mark(1, true);
                    self.kept.push(t2);
                }
                // Built by selects, not by a store into a copy: a 16-byte reload of
                // four 4-byte stores stalls (no store forwarding).
                let nv = [0, 1, 2, 3].map(|i| if i == f { v } else { tv[i] });
                self.pending.push((nv, f as u32, link));
            }
        }
        let need = self.pending.len().saturating_sub(self.cavity.len());
        if need > self.spare() {
            self.unmark(cells);
            return Err(Missed::Slots(need));
        }
        // The cavity's marks go with its cells, overwritten or freed below.
        for &t in &self.kept {
            cells[t as usize].mark(1, false);
        }
        self.new_tets.clear();
        for k in 0..self.pending.len() {
            let (nv, f, link) = self.pending[k];
            let s = if k < self.cavity.len() {
                self.cavity[k]
            } else {
                self.alloc()
            };
            let mut n = [NO_NEIGHBOUR; 4];
            n[f as usize] = link;
            let cell = &cells[s as usize];
            cell.set_verts(nv);
            cell.set_links(n);
            set_link(cells, link, s * 4 + f);
            self.new_tets.push(s);
        }
        for k in self.pending.len()..self.cavity.len() {
            let t = self.cavity[k];
            cells[t as usize].kill();
            self.free.push(t);
        }
        self.link_new_tets(cells);
        self.last = self
            .new_tets
            .iter()
            .copied()
            .find(|&s| cells[s as usize].v[3].load(Relaxed) != INF)
            .unwrap_or(self.new_tets[0]);
        self.star_hint = true;
        Ok(())
    }

    /// Links the new tetrahedra to each other: two of them share a face through the new
    /// vertex exactly when they share the cavity-boundary edge opposite it.
    #[inline(always)]
    fn link_new_tets(&mut self, cells: &[Cell]) {
        if !self.link_by_edge_matrix(cells) {
            self.link_by_edge_table(cells);
            return;
        }
        // Debug builds (the test suite) link every star both ways and compare.
        if cfg!(debug_assertions) {
            let by_matrix: Vec<[u32; 4]> = self
                .new_tets
                .iter()
                .map(|&s| cells[s as usize].links())
                .collect();
            self.link_by_edge_table(cells);
            let by_table: Vec<[u32; 4]> = self
                .new_tets
                .iter()
                .map(|&s| cells[s as usize].links())
                .collect();
            assert_eq!(
                by_matrix, by_table,
                "the edge matrix and table link a star alike"
            );
        }
    }

    /// [`Worker::link_new_tets`] for stars of at most [`STAR_VERTICES`] boundary vertices
    /// (nearly all): each boundary vertex gets a small local id, and each new tetrahedron
    /// writes its three boundary edges, directed as its boundary face runs, into a
    /// [`STAR_VERTICES`]-square matrix; its neighbour across the face through an edge is
    /// then the entry of the reversed edge (the boundary is a closed, consistently
    /// oriented surface, so every edge appears once each way). No probing and no clearing
    /// of the matrix: every entry read was written by this star. False (and nothing
    /// linked) when the star has more boundary vertices.
    #[inline(always)]
    fn link_by_edge_matrix(&mut self, cells: &[Cell]) -> bool {
        self.vertex_keys.fill(NO_VERTEX);
        self.star_locals.clear();
        let mut count = 0usize;
        for &(tv, apex, _) in &self.pending {
            let mut local = [0u8; 3];
            for (l, &p) in local.iter_mut().zip(&FACE_OUTWARD[apex as usize]) {
                let x = tv[p];
                let mut h = (x.wrapping_mul(0x9E37_79B9) >> (32 - VERTEX_SLOT_BITS)) as usize;
                loop {
                    let key = self.vertex_keys[h];
                    // Found (`key == x`) or new (`key` empty) in one test, and the id
                    // chosen by a mask: which of the two it is is as unpredictable as the
                    // star, so no branch may depend on it. A found slot is rewritten as is.
                    if (key ^ x).min(!key) == 0 {
                        let new = u8::from(key == NO_VERTEX).wrapping_neg();
                        let id = (count as u8 & new) | (self.vertex_ids[h] & !new);
                        self.vertex_keys[h] = x;
                        self.vertex_ids[h] = id;
                        count += usize::from(new & 1);
                        *l = id;
                        break;
                    }
                    h = (h + 1) & (VERTEX_SLOTS - 1);
                }
            }
            // At most STAR_VERTICES + 3 keys ever: the table never fills.
            if count > STAR_VERTICES {
                return false;
            }
            self.star_locals.push(local);
        }
        let m = &mut self.edge_matrix;
        for (&s, (&(_, apex, _), &[l0, l1, l2])) in self
            .new_tets
            .iter()
            .zip(self.pending.iter().zip(&self.star_locals))
        {
            let [p0, p1, p2] = FACE_OUTWARD[apex as usize].map(|p| p as u32);
            let (l0, l1, l2) = (usize::from(l0), usize::from(l1), usize::from(l2));
            m[l0 * STAR_VERTICES + l1] = s * 4 + p2;
            m[l1 * STAR_VERTICES + l2] = s * 4 + p0;
            m[l2 * STAR_VERTICES + l0] = s * 4 + p1;
        }
        for (&s, (&(_, apex, _), &[l0, l1, l2])) in self
            .new_tets
            .iter()
            .zip(self.pending.iter().zip(&self.star_locals))
        {
            let [p0, p1, p2] = FACE_OUTWARD[apex as usize];
            let (l0, l1, l2) = (usize::from(l0), usize::from(l1), usize::from(l2));
            let n = &cells[s as usize].n;
            n[p2].store(m[l1 * STAR_VERTICES + l0], Relaxed);
            n[p0].store(m[l2 * STAR_VERTICES + l1], Relaxed);
            n[p1].store(m[l0 * STAR_VERTICES + l2], Relaxed);
        }
        true
    }

    /// [`Worker::link_new_tets`] for any star: a small open-addressing table keyed by the
    /// boundary edge two new tetrahedra share.
    fn link_by_edge_table(&mut self, cells: &[Cell]) {
        /// For the new vertex at position `f`: the three faces through it (opposite `j`)
        /// and the two positions of the edge each is keyed by.
        const FACES_THROUGH: [[(u32, usize, usize); 3]; 4] = [
            [(1, 2, 3), (2, 1, 3), (3, 1, 2)],
            [(0, 2, 3), (2, 0, 3), (3, 0, 2)],
            [(0, 1, 3), (1, 0, 3), (3, 0, 1)],
            [(0, 1, 2), (1, 0, 2), (2, 0, 1)],
        ];
        let size = (self.new_tets.len() * 4).next_power_of_two().max(16);
        if self.edge_table.len() < size {
            self.edge_table.resize(size, (EMPTY, 0));
        }
        let mask = size - 1;
        self.edge_table[..size].fill((EMPTY, 0));
        for k in 0..self.new_tets.len() {
            let s = self.new_tets[k];
            let (tv, apex, _) = self.pending[k];
            for &(j, a, b) in &FACES_THROUGH[apex as usize] {
                let (x, y) = (tv[a], tv[b]);
                let key = (u64::from(x.min(y)) << 32) | u64::from(x.max(y));
                let mut h = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) as usize & mask;
                loop {
                    let (slot_key, slot_link) = self.edge_table[h];
                    if slot_key == EMPTY {
                        self.edge_table[h] = (key, s * 4 + j);
                        break;
                    }
                    if slot_key == key {
                        cells[s as usize].n[j as usize].store(slot_link, Relaxed);
                        set_link(cells, slot_link, s * 4 + j);
                        break;
                    }
                    h = (h + 1) & mask;
                }
            }
        }
    }
}

/// The sequential driver and its state: the cells and the workers.
struct Builder<'a> {
    g: Geometry<'a>,
    cells: Vec<Cell>,
    /// First never handed out slot (every slot below is live or dead).
    top: usize,
    workers: Vec<Worker>,
}

impl<'a> Builder<'a> {
    #[allow(clippy::type_complexity)]
    fn run(
        pts: &'a [DVec3],
        extent: DVec3,
        rounds: &[usize],
        zones: usize,
        x86_64_v3: bool,
        progress: &dyn Progress,
    ) -> Result<Vec<Cell>, TetError> {
        let first = initial_simplex(pts)?;
        let grid = Grid::new(pts);
        let (orient_eps, insphere_eps) =
            predicates::static_bounds(extent).unwrap_or((f64::INFINITY, f64::INFINITY));
        // Uniform points give ~6.7 tetrahedra per point. The array is allocated zeroed
        // (free slots, see `Cell::is_dead`), so its pages are neither written here nor
        // resident until a worker fills a slot there: no sequential pass over the array.
        let estimate = pts.len().saturating_mul(7) + 64;
        let mut b = Builder {
            g: Geometry {
                pts,
                coords: bytemuck::cast_slice(pts),
                grid,
                lex_rank: Vec::new(),
                wants_ranks: AtomicBool::new(false),
                orient_eps,
                insphere_eps,
                x86_64_v3,
            },
            cells: bytemuck::zeroed_vec(estimate),
            top: 0,
            workers: (0..zones)
                .map(|k| Worker::new(0x2545_F491_4F6C_DD1D ^ (k as u64 + 1)))
                .collect(),
        };
        b.start(first);
        let total = pts.len();
        let mut done = 0usize;
        let report = |done: usize| {
            if progress.is_cancelled() {
                return Err(TetError::Cancelled);
            }
            progress.report(Stage::Tetrahedralize, done as f64 / total as f64);
            Ok(())
        };
        for r in rounds.windows(2) {
            let (a, z) = (r[0], r[1]);
            if zones == 1 || z - a < PARALLEL_MIN_ROUND {
                for v in a as u32..z as u32 {
                    if (v as usize).is_multiple_of(CHECK_EVERY) {
                        report(v as usize)?;
                        b.rank_if_wanted();
                    }
                    if !first.contains(&v) {
                        b.insert_sequential(v);
                    }
                }
                done = z;
                continue;
            }
            let chunks = (z - a).div_ceil(CHUNK_POINTS);
            for c in 0..chunks {
                report(done)?;
                b.rank_if_wanted();
                let lo = a + (z - a) * c / chunks;
                let hi = a + (z - a) * (c + 1) / chunks;
                b.insert_parallel(lo as u32..hi as u32, &first);
                done = hi;
            }
        }
        report(total)?;
        let Builder { mut cells, top, .. } = b;
        cells.truncate(top);
        Ok(finish(cells))
    }

    /// Computes the lexicographic ranks once a tie has asked for them (see
    /// [`Geometry::lex_rank`]), between two passes, so in parallel and with no worker
    /// inserting.
    fn rank_if_wanted(&mut self) {
        if self.g.lex_rank.is_empty() && *self.g.wants_ranks.get_mut() {
            self.g.lex_rank = lex_ranks(self.g.pts);
        }
    }

    /// Hands `count` more never used slots to worker `w` (its unused fresh ones go to its
    /// free list), growing the array as needed.
    fn provide(&mut self, w: usize, count: usize) {
        let worker = &mut self.workers[w];
        let rest = std::mem::replace(&mut worker.fresh, 0..0);
        worker.free.extend(rest.rev());
        let end = self.top + count;
        if self.cells.len() < end {
            self.cells.resize_with(end, Cell::dead);
        }
        worker.fresh = self.top as u32..end as u32;
        self.top = end;
    }

    /// The first tetrahedron and its four ghosts.
    fn start(&mut self, [a, b, c, d]: [u32; 4]) {
        self.provide(0, 4096);
        let (a, b) = if self.g.orient_any(a, b, c, d) == Sign::Positive {
            (a, b)
        } else {
            (b, a)
        };
        let finite = [a, b, c, d];
        let w = &mut self.workers[0];
        let t0 = w.alloc();
        let mut all = vec![(t0, finite)];
        for f in 0..4 {
            let mut tv = finite;
            tv[f] = INF;
            // Swapping two other vertices puts the infinite vertex outside the face.
            tv.swap((f + 1) % 4, (f + 2) % 4);
            // Ghosts keep the infinite vertex last (two swaps keep the orientation).
            if f != 3 {
                tv.swap(f, 3);
                let others: Vec<usize> = (0..3).filter(|&i| i != f).collect();
                tv.swap(others[0], others[1]);
            }
            all.push((w.alloc(), tv));
        }
        for &(t, tv) in &all {
            self.cells[t as usize].set_verts(tv);
        }
        // Match the 20 faces pairwise.
        let faces: Vec<([u32; 3], u32)> = all
            .iter()
            .flat_map(|&(t, tv)| (0..4u32).map(move |i| (t, tv, i)))
            .map(|(t, tv, i)| {
                let mut key = [0u32; 3];
                let mut n = 0;
                for (k, &v) in tv.iter().enumerate() {
                    if k as u32 != i {
                        key[n] = v;
                        n += 1;
                    }
                }
                key.sort_unstable();
                (key, t * 4 + i)
            })
            .collect();
        for x in &faces {
            for y in &faces {
                if x.0 == y.0 && x.1 >> 2 != y.1 >> 2 {
                    set_link(&self.cells, x.1, y.1);
                }
            }
        }
        for w in &mut self.workers {
            w.place(t0);
        }
    }

    /// Inserts `v` with worker 0 over the whole mesh, providing slots as needed.
    fn insert_sequential(&mut self, v: u32) {
        self.revive_start();
        loop {
            let w = &mut self.workers[0];
            match w.insert(&self.g, &self.cells, v, Zone::ALL) {
                Ok(()) => return,
                Err(Missed::Slots(need)) => self.provide(0, need.max(SLOT_BATCH)),
                Err(Missed::Foreign) => unreachable!("the whole mesh is worker 0's zone"),
            }
        }
    }

    /// Points worker 0's walk start at a live tetrahedron (another worker may have
    /// deleted the one it had).
    fn revive_start(&mut self) {
        if self.cells[self.workers[0].last as usize].is_dead() {
            let t = self.any_live();
            self.workers[0].place(t);
        }
    }

    /// A live finite tetrahedron (there always is one once started).
    fn any_live(&self) -> u32 {
        for w in &self.workers {
            let c = &self.cells[w.last as usize];
            if !c.is_dead() && c.v[3].load(Relaxed) != INF {
                return w.last;
            }
        }
        (0..self.top)
            .find(|&t| !self.cells[t].is_dead() && self.cells[t].v[3].load(Relaxed) != INF)
            .expect("a started mesh has a finite tetrahedron") as u32
    }

    /// Inserts the vertices `range` (one Hilbert-ordered piece of a round): a parallel
    /// pass, a second one over the vertices it gave up (cut across another axis), and
    /// the rest sequentially, in order.
    fn insert_parallel(&mut self, range: Range<u32>, first: &[u32; 4]) {
        let (mut rest, axis) = self.zoned_pass(&range_without(range, first), None);
        // The vertices given up lie near the cut: split them again across another axis.
        // Not the longest of their box whatever it is: the few given up far from the cut
        // (a cavity reaching across it) stretch that box along the first axis as well,
        // and in the last BRIO round, whose pieces are about half as wide as they are
        // long, the second cut fell on the first one and gave up ~99% again.
        if rest.len() >= SECOND_PASS_MIN {
            rest = self.zoned_pass(&Ids::of_increasing(&rest), Some(axis)).0;
        }
        for v in rest {
            self.insert_sequential(v);
        }
    }

    /// One parallel pass over `ids`: split into slabs of equal counts across the longest
    /// axis of their bounding box other than `not_across`, one worker per slab. Returns
    /// the vertices the workers gave up, increasing, and the axis cut.
    ///
    /// `ids` is read several times and never collected: each worker walks all of it and
    /// takes the vertices of its slab, and the cut is found by [`nth_smallest`]. The
    /// lists this replaces (at 2^17 vertices, 2 MiB of ids, coordinates and per-worker
    /// lists) stayed resident in the allocator's heap through the construction's peak
    /// (`docs/tet.md`, *Parallel insertion*). The set-up's walks (the bounding box, the
    /// cut, the slab counts) run on all threads too, over [`Ids::parts`]: serial, they
    /// took 14.6-14.8 ms of a 1M lattice build while no worker inserted (2026-12-05).
    fn zoned_pass(&mut self, ids: &Ids, not_across: Option<usize>) -> (Vec<u32>, usize) {
        let pts = self.g.pts;
        let parts = ids.parts(rayon::current_num_threads());
        let count = ids.len();
        let empty = || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let (lo, hi) = parts
            .par_iter()
            .map(|part| {
                part.iter().fold(empty(), |(lo, hi), v| {
                    let p = pts[v as usize];
                    (lo.min(p), hi.max(p))
                })
            })
            .reduce(empty, |a, b| (a.0.min(b.0), a.1.max(b.1)));
        let mut extent = hi - lo;
        if let Some(a) = not_across {
            extent[a] = f64::NEG_INFINITY;
        }
        let axis = extent.max_position();
        let k = self.workers.len();
        let part_refs: Vec<&Ids> = parts.iter().collect();
        let mut cuts = vec![f64::NEG_INFINITY];
        for z in 1..k {
            cuts.push(nth_smallest(
                &part_refs,
                |&part| part.iter().map(move |v| pts[v as usize][axis]),
                (lo[axis], hi[axis]),
                count * z / k,
            ));
        }
        cuts.push(f64::INFINITY);
        let zones: Vec<Zone> = (0..k)
            .map(|z| Zone {
                all: false,
                axis,
                lo: cuts[z],
                hi: cuts[z + 1],
            })
            .collect();
        // Each slab's vertex count and first vertex; a vertex's slab is the zone that owns
        // it, as the workers decide below.
        let (g, zones_ref) = (&self.g, &zones);
        let per_part: Vec<(Vec<usize>, Vec<Option<u32>>)> = parts
            .par_iter()
            .map(|part| {
                let mut counts = vec![0usize; k];
                let mut firsts = vec![None; k];
                for v in part.iter() {
                    if let Some(z) = zones_ref
                        .iter()
                        .position(|zone| zone.owns_vertex(g.coords, v))
                    {
                        counts[z] += 1;
                        firsts[z].get_or_insert(v);
                    }
                }
                (counts, firsts)
            })
            .collect();
        let mut counts = vec![0usize; k];
        let mut firsts: Vec<Option<u32>> = vec![None; k];
        for (c, f) in &per_part {
            for z in 0..k {
                counts[z] += c[z];
                firsts[z] = firsts[z].or(f[z]);
            }
        }
        for w in &mut self.workers {
            w.deferred.clear();
        }
        // Slots: ~6.7 new tetrahedra per vertex on average; an insertion finding too few
        // is simply done in the sequential pass.
        for (z, &n) in counts.iter().enumerate() {
            let want = n * 7 + SLOT_BATCH;
            let have = self.workers[z].spare();
            if have < want {
                self.provide(z, want - have);
            }
        }
        // Each worker starts from a tetrahedron of its own zone near its first vertex,
        // found while nothing else runs; a worker without one gives up its slab.
        let mut started = vec![false; k];
        for (z, &zone) in zones.iter().enumerate() {
            if let Some(t) = firsts[z].and_then(|v| self.zone_start(z, v, zone)) {
                self.workers[z].place(t);
                started[z] = true;
            }
        }
        let (g, cells) = (&self.g, &self.cells[..]);
        self.workers
            .par_iter_mut()
            .zip(zones.par_iter())
            .zip(started.par_iter())
            .for_each(|((w, &zone), &started)| {
                for v in ids.iter() {
                    if !zone.owns_vertex(g.coords, v) {
                        continue;
                    }
                    if !started || w.insert(g, cells, v, zone).is_err() {
                        w.deferred.push(v);
                    }
                }
            });
        let mut rest: Vec<u32> = self
            .workers
            .iter_mut()
            .flat_map(|w| w.deferred.drain(..))
            .collect();
        rest.sort_unstable();
        (rest, axis)
    }

    /// A live tetrahedron with all four vertices in `zone` near vertex `v`: the one the
    /// walk for `v` ends in, or the nearest such one breadth-first from it.
    fn zone_start(&mut self, z: usize, v: u32, zone: Zone) -> Option<u32> {
        self.revive_start();
        let w0 = &mut self.workers[0];
        let t = if self.g.grid.is_some() {
            w0.locate::<true>(&self.g, &self.cells, v, Zone::ALL)
        } else {
            w0.locate::<false>(&self.g, &self.cells, v, Zone::ALL)
        }?;
        let w = &mut self.workers[z];
        w.place(t);
        let mut queue = vec![t];
        let mut k = 0;
        while k < queue.len() && k < ZONE_START_SEARCH {
            let t = queue[k];
            k += 1;
            let cell = &self.cells[t as usize];
            if zone.owns(self.g.coords, cell.verts()) {
                return Some(t);
            }
            for link in cell.links() {
                let t2 = link >> 2;
                if !queue.contains(&t2) {
                    queue.push(t2);
                }
            }
        }
        None
    }
}

/// The vertex ids of one zoned pass, increasing: a few plain ranges (a chunk without the
/// first tetrahedron's vertices) or the runs of consecutive ids of a list (the vertices a
/// first pass gave up). Walked several times by each pass, never collected one by one.
#[derive(Debug, Clone, Default, PartialEq)]
struct Ids(Vec<Range<u32>>);

impl Ids {
    /// The ids `list` holds (increasing), as runs.
    fn of_increasing(list: &[u32]) -> Ids {
        let mut runs: Vec<Range<u32>> = Vec::new();
        for &v in list {
            match runs.last_mut() {
                Some(r) if r.end == v => r.end += 1,
                _ => runs.push(v..v + 1),
            }
        }
        Ids(runs)
    }

    fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        self.0.iter().flat_map(Range::clone)
    }

    fn len(&self) -> usize {
        self.0.iter().map(|r| r.len()).sum()
    }

    /// The same ids cut into `k` consecutive parts of (nearly) equal counts, for walks
    /// on all threads whose results do not depend on where the cuts fall.
    fn parts(&self, k: usize) -> Vec<Ids> {
        let total = self.len();
        let k = k.clamp(1, total.max(1));
        // Part `p` ends before position `end(p)`, `total * (p + 1) / k` rounded up.
        let end = |p: usize| (total * (p + 1)).div_ceil(k);
        let mut parts = vec![Ids::default(); k];
        let (mut p, mut seen) = (0, 0);
        for r in &self.0 {
            let mut r = r.clone();
            while !r.is_empty() {
                while seen == end(p) {
                    p += 1;
                }
                let take = r.len().min(end(p) - seen) as u32;
                parts[p].0.push(r.start..r.start + take);
                r.start += take;
                seen += take as usize;
            }
        }
        parts
    }
}

/// The vertices of `range` but those of `skip` (distinct), in order: up to five plain
/// ranges one after the other. Each zoned pass walks them four times or more, and the
/// one-test-per-vertex `filter` this replaces compiled to a 16-wide search for each next
/// vertex, with a reduction through the stack: about 27 ns per vertex, 3.4 ms per walk
/// of a 2^17-vertex chunk, most of it while no worker was inserting.
fn range_without(range: Range<u32>, skip: &[u32; 4]) -> Ids {
    let mut cuts = *skip;
    cuts.sort_unstable();
    let mut pieces = Vec::with_capacity(5);
    let mut start = range.start;
    for c in cuts {
        if (start..range.end).contains(&c) {
            pieces.push(start..c);
            start = c + 1;
        }
    }
    pieces.push(start..range.end);
    pieces.retain(|r| !r.is_empty());
    Ids(pieces)
}

/// Number of bins of [`nth_smallest`]'s histogram.
const SELECT_BINS: usize = 4096;

/// The `at`-th smallest (from 0) of the values that `values` yields over all `parts`,
/// all in `lo..=hi`: the value `select_nth_unstable` would put at `at`, found without
/// collecting the values. One pass counts them in equal bins over `lo..=hi`; a second
/// collects those of the bin holding rank `at` (a few hundred for a chunk of 2^17
/// vertices) and selects among them. Both passes run over the parts in parallel. Values
/// in one bin are kept whatever their spread, so clustered input costs at worst the list
/// of all values. `at` must be below the number of values (a parallel pass has at least
/// `SECOND_PASS_MIN` vertices).
fn nth_smallest<P: Sync, I: Iterator<Item = f64>>(
    parts: &[P],
    values: impl Fn(&P) -> I + Sync,
    (lo, hi): (f64, f64),
    at: usize,
) -> f64 {
    let width = hi - lo;
    let per_unit = if width > 0.0 {
        SELECT_BINS as f64 / width
    } else {
        0.0
    };
    let bin = |x: f64| (((x - lo) * per_unit) as usize).min(SELECT_BINS - 1);
    let counts = parts
        .par_iter()
        .map(|part| {
            let mut counts = vec![0usize; SELECT_BINS];
            for x in values(part) {
                counts[bin(x)] += 1;
            }
            counts
        })
        .reduce_with(|mut a, b| {
            a.iter_mut().zip(&b).for_each(|(a, b)| *a += b);
            a
        })
        .unwrap_or_else(|| vec![0; SELECT_BINS]);
    let mut below = 0;
    let mut b = 0;
    while below + counts[b] <= at {
        below += counts[b];
        b += 1;
    }
    let mut in_bin: Vec<f64> = parts
        .par_iter()
        .flat_map_iter(|part| values(part).filter(|&x| bin(x) == b))
        .collect();
    *in_bin.select_nth_unstable_by(at - below, f64::total_cmp).1
}

/// Strips ghosts and free slots in place (moving tetrahedra from the end into holes) and
/// returns the finite tetrahedra, hull faces marked [`NO_NEIGHBOUR`]: the cells of the
/// [`TetMesh`], in the construction's own array (no copy, no new pages).
fn finish(mut cells: Vec<Cell>) -> Vec<Cell> {
    // Ghosts removed and the free slots listed in one parallel pass: each ghost writes
    // only its own vertex words and the one link of its finite neighbour across its hull
    // face, which no other ghost writes. The list is in slot order, so the holes to fill
    // (free slots below the number of finite tetrahedra) are its first part: no second
    // pass over the array to find them.
    let free: Vec<u32> = cells
        .par_iter()
        .enumerate()
        .filter_map(|(t, c)| {
            if c.is_dead() {
                return Some(t as u32);
            }
            if c.v[3].load(Relaxed) == INF {
                set_link(&cells, c.n[3].load(Relaxed), NO_NEIGHBOUR);
                c.kill();
                return Some(t as u32);
            }
            None
        })
        .collect();
    let live = cells.len() - free.len();
    let holes = &free[..free.partition_point(|&t| (t as usize) < live)];
    let mut top = cells.len();
    for &d in holes {
        let d = d as usize;
        loop {
            top -= 1;
            if !cells[top].is_dead() {
                break;
            }
        }
        let (v, n) = (cells[top].verts(), cells[top].links());
        cells[d].set_verts(v);
        cells[d].set_links(n);
        for (i, link) in n.into_iter().enumerate() {
            if link != NO_NEIGHBOUR {
                set_link(&cells, link, d as u32 * 4 + i as u32);
            }
        }
    }
    cells.truncate(live);
    cells.shrink_to_fit();
    cells
}

/// Four affinely independent vertices, the first ones in insertion order (vertex ids), so
/// the first tetrahedron comes from the first BRIO round.
fn initial_simplex(pts: &[DVec3]) -> Result<[u32; 4], TetError> {
    let p = |v: u32| pts[v as usize];
    let n = pts.len() as u32;
    let (a, b) = (0, 1);
    let c = (2..n)
        .find(|&c| !predicates::collinear(p(a), p(b), p(c)))
        .ok_or(TetError::AllCoplanar)?;
    let d = (2..n)
        .find(|&d| predicates::orient(p(a), p(b), p(c), p(d)) != Sign::Zero)
        .ok_or(TetError::AllCoplanar)?;
    Ok([a, b, c, d])
}

/// Does this processor have the x86-64-v3 features [`Worker::insert`] has a copy for?
fn x86_64_v3_detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
            && std::is_x86_feature_detected!("bmi1")
            && std::is_x86_feature_detected!("bmi2")
            && std::is_x86_feature_detected!("fma")
            && std::is_x86_feature_detected!("lzcnt")
            && std::is_x86_feature_detected!("popcnt")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;

    /// A parallel chunk walks every vertex of its range once, but the first tetrahedron's,
    /// wherever those lie: before, inside, at either end of or after the range, side by
    /// side or not.
    #[test]
    fn a_chunk_skips_exactly_the_first_tetrahedron_s_vertices() {
        let range = 100u32..140;
        for skip in [
            [0, 1, 2, 3],
            [100, 101, 102, 103],
            [139, 138, 137, 136],
            [100, 139, 120, 5],
            [120, 121, 300, 2],
            [141, 140, 99, 110],
            [7, 130, 105, 125],
        ] {
            let got: Vec<u32> = range_without(range.clone(), &skip).iter().collect();
            let want: Vec<u32> = range.clone().filter(|v| !skip.contains(v)).collect();
            assert_eq!(got, want, "skipping {skip:?}");
        }
        assert_eq!(range_without(5..5, &[5, 6, 7, 8]).iter().count(), 0);
    }

    /// The parts the set-up's parallel walks take: every id once, in order, counts within
    /// one of each other, consecutive ids kept as one range.
    #[test]
    fn a_pass_s_ids_cut_into_parts_keep_every_id_once_in_order_and_balanced() {
        let lists: [Vec<u32>; 5] = [
            (0..1000).collect(),
            vec![3, 4, 5, 9, 10, 20, 21, 22, 23, 99],
            vec![7],
            (0..500).map(|v| v * 3).collect(),
            Vec::new(),
        ];
        for list in &lists {
            let ids = Ids::of_increasing(list);
            assert_eq!(ids.iter().collect::<Vec<_>>(), *list);
            // Runs: consecutive ids share one range.
            assert!(ids.0.windows(2).all(|w| w[0].end < w[1].start));
            for k in [1, 2, 3, 4, 7, 16] {
                let parts = ids.parts(k);
                assert_eq!(parts.len(), k.clamp(1, list.len().max(1)));
                let joined: Vec<u32> = parts.iter().flat_map(Ids::iter).collect();
                assert_eq!(joined, *list, "{k} parts");
                let sizes: Vec<usize> = parts.iter().map(Ids::len).collect();
                let (lo, hi) = (sizes.iter().min(), sizes.iter().max());
                assert!(hi.unwrap() - lo.unwrap() <= 1, "{k} parts: {sizes:?}");
            }
        }
        let chunk = range_without(100..140, &[120, 3, 139, 100]);
        assert_eq!(chunk.0, vec![101..120, 121..139]);
        let halves = chunk.parts(2);
        assert_eq!(halves[0].0, vec![101..120]);
        assert_eq!(halves[1].0, vec![121..139]);
    }

    /// The cut of a parallel pass is the value a full selection finds, whatever the
    /// spread: uniform, clustered into one bin, repeated, all equal, negative.
    #[test]
    fn nth_smallest_is_the_selected_value_without_collecting_all() {
        let mut state = 0x9E37_79B9_7F4A_7C15;
        let uniform: Vec<f64> = (0..5000).map(|_| xorshift(&mut state)).collect();
        let mut clustered: Vec<f64> = (0..5000)
            .map(|_| 1.0 + xorshift(&mut state) * 1e-9)
            .collect();
        clustered.extend([0.0, 1e6]);
        let repeated: Vec<f64> = (0..5000).map(|i| f64::from(i % 7) * 50.0 - 100.0).collect();
        let equal = vec![-3.5; 100];
        for values in [uniform, clustered, repeated, equal] {
            let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let mut sorted = values.clone();
            sorted.sort_by(f64::total_cmp);
            for at in [0, 1, values.len() / 3, values.len() / 2, values.len() - 1] {
                for k in [1, 2, 3, 7] {
                    let parts: Vec<&[f64]> = values.chunks(values.len().div_ceil(k)).collect();
                    assert_eq!(
                        nth_smallest(&parts, |&part| part.iter().copied(), (lo, hi), at),
                        sorted[at],
                        "rank {at} of {} values in {lo}..={hi}, {k} parts",
                        values.len()
                    );
                }
                assert_eq!(
                    nth_smallest(&[&values[..]], |&part| part.iter().copied(), (lo, hi), at),
                    sorted[at],
                    "rank {at} of {} values in {lo}..={hi}",
                    values.len()
                );
            }
        }
    }

    #[test]
    fn never_written_and_freed_slots_read_as_free_and_tetrahedra_do_not() {
        let cells: Vec<Cell> = bytemuck::zeroed_vec(3);
        assert!(cells.iter().all(Cell::is_dead), "zeroed slots are free");
        cells[1].set_verts([0, 1, 2, 3]);
        cells[2].set_verts([7, 5, 9, INF]);
        assert!(!cells[1].is_dead() && !cells[2].is_dead());
        // The search's marks do not make a tetrahedron look free.
        cells[1].mark(0, true);
        cells[1].mark(1, true);
        assert!(!cells[1].is_dead());
        cells[2].kill();
        assert!(cells[2].is_dead());
        assert!(Cell::dead().is_dead());
    }

    fn xorshift(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Each tetrahedron as its sorted input-point positions, sorted: comparable across
    /// builds whatever their slot order.
    fn tet_set(mesh: &TetMesh) -> Vec<[[u64; 3]; 4]> {
        tet_set_mapped(mesh, |p| p)
    }

    /// The tetrahedra of `mesh` as [`tet_set`] does, each point first mapped by `back`.
    fn tet_set_mapped(mesh: &TetMesh, back: impl Fn(DVec3) -> DVec3) -> Vec<[[u64; 3]; 4]> {
        let mut set: Vec<[[u64; 3]; 4]> = mesh
            .tets()
            .map(|t| {
                let mut c = t.map(|v| back(mesh.points[v as usize]).to_array().map(f64::to_bits));
                c.sort_unstable();
                c
            })
            .collect();
        set.sort_unstable();
        set
    }

    #[test]
    fn points_at_any_magnitude_give_the_mesh_of_the_same_points_near_one() {
        // Points in [0, 1): random ones, a lattice full of co-spherical ties, and
        // duplicates; once as multiples of 2^-20 (an integer grid: `exact_int`) and once
        // of 2^-50 (no grid: `robust`'s expansions). Each case places them exactly at
        // another magnitude, beyond the range where products of five coordinates stay
        // normal and finite, or at the window's edges, where nothing is scaled.
        let two = |e: i32| 2f64.powi(e);
        let cases: [(&str, DVec3, f64); 7] = [
            // (name, offset, unit): a point is offset + m * unit.
            ("huge", DVec3::ZERO, two(1000)),
            (
                "huge, far from the origin",
                DVec3::splat(two(1000)),
                two(999),
            ),
            ("negative and huge", DVec3::splat(-two(1000)), two(999)),
            ("subnormal", DVec3::ZERO, two(-1024)),
            ("tiny, off the origin", DVec3::splat(two(-1000)), two(-1001)),
            ("top of the window", DVec3::ZERO, two(149)),
            ("bottom of the window", DVec3::ZERO, two(-98)),
        ];
        for bits in [20, 50] {
            let quantum = two(-bits);
            let mut state = 0x2545_F491_4F6C_DD1Du64;
            let mut base: Vec<DVec3> = (0..400)
                .map(|_| {
                    let p = DVec3::new(
                        xorshift(&mut state),
                        xorshift(&mut state),
                        xorshift(&mut state),
                    );
                    (p / quantum).floor() * quantum
                })
                .collect();
            for i in 0..6 {
                for j in 0..6 {
                    for k in 0..6 {
                        base.push(DVec3::new(i as f64, j as f64, k as f64) / 8.0);
                    }
                }
            }
            base.extend_from_within(..20);
            let reference = build_in_zones(base.clone(), 1, false, &NoProgress).unwrap();
            reference.validate().unwrap();
            let expected = tet_set(&reference);
            for (name, offset, unit) in cases {
                let name = format!("{name}, multiples of 2^-{bits}");
                let pts: Vec<DVec3> = base.iter().map(|&m| offset + m * unit).collect();
                assert!(
                    pts.iter()
                        .zip(&base)
                        .all(|(&p, &m)| (p - offset) / unit == m),
                    "{name}: the points are placed exactly"
                );
                let mesh = build_in_zones(pts.clone(), 1, false, &NoProgress)
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
                assert_eq!(mesh.duplicates_merged, 20, "{name}");
                for (i, &p) in pts.iter().enumerate() {
                    let q = mesh.points[mesh.vertex_of_input[i] as usize];
                    assert_eq!(
                        q.to_array().map(f64::to_bits),
                        p.to_array().map(f64::to_bits),
                        "{name}: input point {i} kept bit for bit"
                    );
                }
                assert!(
                    tet_set_mapped(&mesh, |p| (p - offset) / unit) == expected,
                    "{name}: not the mesh of the same points near one"
                );
            }
        }
    }

    #[test]
    fn coordinates_too_far_apart_in_magnitude_are_an_error_naming_them() {
        let mut pts = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::splat(1e300),
        ];
        match build_in_zones(pts.clone(), 1, false, &NoProgress) {
            Err(TetError::MagnitudeRange { small, large }) => {
                assert_eq!((small, large), ((1, 1.0), (4, 1e300)));
            }
            other => panic!("expected a magnitude error, got {other:?}"),
        }
        let message = build_in_zones(pts.clone(), 1, false, &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("point 1 has 1e0 and point 4 has 1e300"),
            "{message}"
        );
        // Tiny against ordinary, and the largest float against ordinary.
        pts[4] = DVec3::new(0.5, 0.5, 1e-300);
        assert!(matches!(
            build_in_zones(pts.clone(), 1, false, &NoProgress),
            Err(TetError::MagnitudeRange {
                small: (4, 1e-300),
                large: (1, 1.0)
            })
        ));
        pts[4] = DVec3::splat(f64::MAX);
        assert!(matches!(
            build_in_zones(pts.clone(), 1, false, &NoProgress),
            Err(TetError::MagnitudeRange {
                large: (4, f64::MAX),
                ..
            })
        ));
        // 89 orders of magnitude apart is still one mesh.
        pts[4] = DVec3::splat(1e88);
        build_in_zones(pts, 1, false, &NoProgress).unwrap();
    }

    #[test]
    fn a_star_with_more_boundary_vertices_than_the_edge_matrix_is_linked_by_the_table() {
        // 200 points on a sphere and its centre: when the centre comes, every tetrahedron
        // is in its cavity, so its star has every sphere point inserted so far on its
        // boundary, far more than the edge matrix takes.
        let n = 200;
        let pts: Vec<DVec3> = (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let a = i as f64 * 2.399_963_229_728_653;
                DVec3::new(r * a.cos(), r * a.sin(), z) * 100.0
            })
            .collect();
        // The insertion order depends on the input index: take the first place for the
        // centre that puts it after more than twice the matrix's vertices.
        let (mesh, id) = (0..10)
            .find_map(|centre| {
                let mut with_centre = pts.clone();
                with_centre.insert(centre, DVec3::ZERO);
                let mesh = build_in_zones(with_centre, 1, false, &NoProgress).unwrap();
                let id = mesh.vertex_of_input[centre];
                (id as usize > 2 * STAR_VERTICES).then_some((mesh, id))
            })
            .expect("one of ten places inserts the centre late");
        mesh.validate().unwrap();
        let degree = mesh.tets().filter(|t| t.contains(&id)).count();
        assert!(
            degree > 2 * STAR_VERTICES,
            "{degree} tetrahedra around the centre"
        );
    }

    #[test]
    fn parallel_zones_give_the_delaunay_mesh_of_one_worker_on_any_number_of_threads() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let uniform: Vec<DVec3> = (0..60_000)
            .map(|_| {
                DVec3::new(
                    xorshift(&mut state),
                    xorshift(&mut state),
                    xorshift(&mut state),
                )
            })
            .collect();
        // Clustered: most points in a few tight balls, with many exact duplicates.
        let clustered: Vec<DVec3> = (0..60_000)
            .map(|i| {
                let c = DVec3::splat((i % 5) as f64 * 10.0);
                let p = c + DVec3::new(
                    xorshift(&mut state),
                    xorshift(&mut state),
                    xorshift(&mut state),
                ) * 0.1;
                if i % 7 == 0 { c } else { p }
            })
            .collect();
        // A UTM well lattice: 25 x 25 vertical wells 50 m apart, 100 samples 1 m apart
        // (co-spherical everywhere), and the same jittered only in the collars.
        let lattice = |jitter: bool, state: &mut u64| -> Vec<DVec3> {
            let mut pts = Vec::new();
            for i in 0..25 {
                for j in 0..25 {
                    let dx = if jitter { xorshift(state) * 3.0 } else { 0.0 };
                    for k in 0..100 {
                        pts.push(DVec3::new(
                            500_000.0 + i as f64 * 50.0 + dx,
                            6_500_000.0 + j as f64 * 50.0,
                            300.0 - k as f64,
                        ));
                    }
                }
            }
            pts
        };
        let exact = lattice(false, &mut state);
        let jittered = lattice(true, &mut state);
        for (name, pts) in [
            ("uniform", uniform),
            ("clustered", clustered),
            ("utm lattice", exact),
            ("utm wells", jittered),
        ] {
            let one = build_in_zones(pts.clone(), 1, false, &NoProgress).unwrap();
            one.validate().unwrap();
            for zones in [2, 3] {
                let many = build_in_zones(pts.clone(), zones, false, &NoProgress).unwrap();
                many.validate()
                    .unwrap_or_else(|e| panic!("{name}, {zones} zones: {e}"));
                assert_eq!(many.duplicates_merged, one.duplicates_merged, "{name}");
                assert_eq!(many.vertex_of_input, one.vertex_of_input, "{name}");
                assert_eq!(tet_set(&many), tet_set(&one), "{name}, {zones} zones");
                // The same bytes on one thread as on the pool's threads.
                let single = rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .build()
                    .unwrap()
                    .install(|| build_in_zones(pts.clone(), zones, false, &NoProgress).unwrap());
                assert_eq!(single, many, "{name}, {zones} zones on one thread");
                // The portable copy of the insertion gives the same bytes as the one for
                // x86-64-v3, which the other builds here use where the processor has it.
                let portable = build_in_zones(pts.clone(), zones, true, &NoProgress).unwrap();
                assert_eq!(portable, many, "{name}, {zones} zones, portable insertion");
            }
        }
    }
}
