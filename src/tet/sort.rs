//! Insertion order: biased randomized insertion order (BRIO) rounds, each sorted along a
//! 3D Hilbert curve, so consecutive insertions are spatial neighbours; equal points are
//! found on the way and merged.
//!
//! Invariant: the order holds each distinct point once and depends only on the
//! coordinates (and, among equal points, the input index), never on timing or thread
//! count.

use std::ops::Range;
use std::sync::atomic::AtomicU32;
use std::sync::atomic::Ordering::Relaxed;

use glam::DVec3;
use rayon::prelude::*;

use super::predicates::lex_cmp;

/// Bits per axis of the Hilbert key (3 x 21 = 63 bits).
const HILBERT_BITS: u32 = 21;

/// Points whose Hilbert keys [`hilbert_keys`] computes at once.
const LANES: usize = 8;

/// Position along the 3D Hilbert curve of a point with `HILBERT_BITS`-bit integer
/// coordinates (Skilling's transpose algorithm, then bit interleaving).
#[cfg(test)]
fn hilbert_key(x: [u32; 3]) -> u64 {
    hilbert_keys::<1>(x.map(|c| [c]))[0]
}

/// [`hilbert_key`] of `L` points, given as `[xs, ys, zs]`. Branch-free (the coordinate
/// bits steer masks, not jumps: they are random, so jumps mispredict) and lane by lane,
/// so the compiler keeps the lanes side by side in vector registers: the transform is a
/// chain of ~60 dependent steps per point, which one point at a time leaves the
/// processor waiting on.
fn hilbert_keys<const L: usize>(xs: [[u32; L]; 3]) -> [u64; L] {
    let [mut x0, mut x1, mut x2] = xs;
    let m = 1u32 << (HILBERT_BITS - 1);
    let mut q = m;
    while q > 1 {
        let p = q - 1;
        // Per axis i: all ones when bit `q` of x[i] is set: then x[0] ^= p; else swap
        // the low bits of x[0] and x[i] (a no-op for i = 0).
        for x in &mut x0 {
            let set = 0u32.wrapping_sub(u32::from(*x & q != 0));
            *x ^= p & set;
        }
        for xi in [&mut x1, &mut x2] {
            for l in 0..L {
                let set = 0u32.wrapping_sub(u32::from(xi[l] & q != 0));
                let t = (x0[l] ^ xi[l]) & p & !set;
                x0[l] ^= (p & set) | t;
                xi[l] ^= t;
            }
        }
        q >>= 1;
    }
    let mut keys = [0u64; L];
    for l in 0..L {
        x1[l] ^= x0[l];
        x2[l] ^= x1[l];
        let mut t = 0;
        let mut q = m;
        while q > 1 {
            t ^= (q - 1) & 0u32.wrapping_sub(u32::from(x2[l] & q != 0));
            q >>= 1;
        }
        keys[l] =
            (spread_bits(x0[l] ^ t) << 2) | (spread_bits(x1[l] ^ t) << 1) | spread_bits(x2[l] ^ t);
    }
    keys
}

/// The 21 low bits of `v` moved to every third bit (bit `b` to bit `3 b`).
fn spread_bits(v: u32) -> u64 {
    let mut x = u64::from(v) & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// SplitMix64: a fixed, well-mixed hash of a vertex id for the round draw.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A hash of a point's coordinate bits: equal points (`-0.0` made `0.0` by the caller)
/// draw the same round.
fn coordinate_hash(p: DVec3) -> u64 {
    mix(mix(mix(p.x.to_bits()) ^ p.y.to_bits()) ^ p.z.to_bits())
}

/// Where each input point goes: see [`insertion_order`].
#[derive(Debug)]
pub struct InsertionOrder {
    /// The distinct points' input indices in insertion order (equal points: the smallest
    /// index).
    pub order: Vec<u32>,
    /// For each input point, the position of its point in `order`.
    pub vertex_of_input: Vec<u32>,
    /// Where each round starts in `order`, followed by `order.len()`.
    pub rounds: Vec<usize>,
}

/// The lowest and highest coordinates of points per axis (infinities when empty), and
/// the smallest nonzero magnitude of a coordinate per axis (infinity where every
/// coordinate is zero).
type Bounds = (DVec3, DVec3, DVec3);

fn no_bounds() -> Bounds {
    let inf = DVec3::splat(f64::INFINITY);
    (inf, -inf, inf)
}

fn widen((lo, hi, small): Bounds, p: DVec3) -> Bounds {
    let a = p.abs();
    let nonzero = DVec3::select(a.cmpeq(DVec3::ZERO), DVec3::splat(f64::INFINITY), a);
    (lo.min(p), hi.max(p), small.min(nonzero))
}

fn merge(a: Bounds, b: Bounds) -> Bounds {
    (a.0.min(b.0), a.1.max(b.1), a.2.min(b.2))
}

/// The [`Bounds`] of `points`, in one parallel pass.
pub fn bounds(points: &[DVec3]) -> Bounds {
    points
        .par_iter()
        .fold(no_bounds, |b, &p| widen(b, p))
        .reduce(no_bounds, merge)
}

/// [`bounds`] of `points` with every `-0.0` made `0.0` on the way (one bit pattern for
/// one coordinate, before sorting), or `None` when a coordinate is not finite: the
/// checks a construction starts with, in one pass over the points instead of three.
pub fn normalized_bounds(points: &mut [DVec3]) -> Option<Bounds> {
    let (b, finite) = points
        .par_iter_mut()
        .fold(
            || (no_bounds(), true),
            |(b, finite), p| {
                *p += DVec3::ZERO;
                (widen(b, *p), finite & p.is_finite())
            },
        )
        .reduce(|| (no_bounds(), true), |x, y| (merge(x.0, y.0), x.1 & y.1));
    finite.then_some(b)
}

/// The insertion order of the distinct `points`, finding equal points on the way: round 0
/// (about 64 points) first, each later round about twice as large, the last holding about
/// half of the points; within a round, Hilbert order. A point's round is drawn from a
/// hash of its coordinates, so equal points share a round and a Hilbert key and meet in
/// the one parallel sort of the keys; points with equal keys are ordered by coordinates
/// (then index) to bring equal ones together. No NaN allowed; `-0.0` must already be
/// `0.0`. `(lo, hi)` is the points' bounding box ([`bounds`]; the caller needs it too).
pub fn insertion_order(points: &[DVec3], (lo, hi): (DVec3, DVec3)) -> InsertionOrder {
    let n = points.len();
    if n == 0 {
        return InsertionOrder {
            order: Vec::new(),
            vertex_of_input: Vec::new(),
            rounds: vec![0],
        };
    }
    // Each axis scaled to the curve's whole range on its own (the bounding box, not its
    // cube): well data spans kilometres across and a few hundred metres down, and a cube
    // would leave the curve's coarse levels blind to depth. The walks on the 1M UTM lattice
    // visit 4.4 cells instead of 10.1, ~10% less time on both lattices
    // (docs/benchmarks-history.md in git history).
    let extent = hi - lo;
    let cells = f64::from((1u32 << HILBERT_BITS) - 1);
    let scale = DVec3::select(
        extent.cmpgt(DVec3::ZERO),
        DVec3::splat(cells) / extent,
        DVec3::ZERO,
    );
    // Rounds: a point with `tz` trailing zero bits in its hash goes to round
    // `max_level - min(tz, max_level)`; round 0 gets ~ n / 2^max_level ~ 64 points.
    let max_level = (n / 64).max(1).ilog2().min(31);
    let mut keyed: Vec<(u64, u32)> = vec![(0, 0); n];
    keyed
        .par_chunks_mut(LANES)
        .zip(points.par_chunks(LANES))
        .enumerate()
        .for_each(|(c, (out, pts))| {
            let mut xs = [[0u32; LANES]; 3];
            for (l, &p) in pts.iter().enumerate() {
                let g = ((p - lo) * scale).clamp(DVec3::ZERO, DVec3::splat(cells));
                for (axis, x) in xs.iter_mut().enumerate() {
                    x[l] = g[axis] as u32;
                }
            }
            let h = hilbert_keys(xs);
            for (l, (slot, &p)) in out.iter_mut().zip(pts).enumerate() {
                let tz = coordinate_hash(p).trailing_zeros().min(max_level);
                let round = u64::from(max_level - tz);
                *slot = ((round << 58) | (h[l] >> 5), (c * LANES + l) as u32);
            }
        });
    // By the key alone: pairs of one key are put in order just below, so the index need
    // not be compared here (a 1M-point sort 22-31 ms instead of 33-43, two threads).
    keyed.par_sort_unstable_by_key(|&(key, _)| key);
    // Distinct points can share a key (closer than the key's resolution); equal ones
    // always do. What follows is in parallel over pieces of the sorted keys cut where the
    // key changes, so a run of one key (and every point with its equals) lies in one
    // piece: its runs ordered by coordinates so equal points are adjacent, the distinct
    // points counted, then numbered from the counts of the pieces before. (One serial
    // pass until 2026-12-05: 9-14 ms of a 1M build, its random writes to
    // `vertex_of_input` most of it.)
    // An entry of the sorted keys is the same point as the one before it.
    let again = |(before, j): (u64, u32), (key, i): (u64, u32)| {
        before == key && points[j as usize] == points[i as usize]
    };
    let pieces = key_pieces(&keyed);
    let distinct: Vec<usize> = split_lengths(&mut keyed, pieces.iter().map(Range::len))
        .into_par_iter()
        .map(|piece| {
            for run in piece.chunk_by_mut(|a, b| a.0 == b.0) {
                if run.len() > 1 {
                    run.sort_unstable_by(|a, b| {
                        lex_cmp(points[a.1 as usize], points[b.1 as usize]).then(a.1.cmp(&b.1))
                    });
                }
            }
            piece.len() - piece.windows(2).filter(|w| again(w[0], w[1])).count()
        })
        .collect();
    let keyed = &keyed[..];
    let mut order = vec![0u32; distinct.iter().sum()];
    let vertex_of_input: Vec<AtomicU32> =
        (0..n).into_par_iter().map(|_| AtomicU32::new(0)).collect();
    let first_ids = distinct.iter().scan(0, |next, &count| {
        let first = *next;
        *next += count;
        Some(first)
    });
    let outs: Vec<_> = pieces
        .into_iter()
        .zip(split_lengths(&mut order, distinct.iter().copied()))
        .zip(first_ids)
        .collect();
    // Each piece numbers its distinct points and lists the rounds starting in it.
    let starts: Vec<Vec<usize>> = outs
        .into_par_iter()
        .map(|((range, out), first_id)| {
            let mut starts = Vec::new();
            let mut id = first_id;
            for k in range {
                let (key, i) = keyed[k];
                if k > 0 {
                    let before = keyed[k - 1];
                    if again(before, keyed[k]) {
                        // `j`'s vertex: the last numbered, in this piece.
                        vertex_of_input[i as usize].store(id as u32 - 1, Relaxed);
                        continue;
                    }
                    if before.0 >> 58 != key >> 58 {
                        starts.push(id);
                    }
                }
                vertex_of_input[i as usize].store(id as u32, Relaxed);
                out[id - first_id] = i;
                id += 1;
            }
            starts
        })
        .collect();
    let mut rounds = vec![0];
    rounds.extend(starts.into_iter().flatten());
    rounds.push(order.len());
    let vertex_of_input = vertex_of_input
        .into_iter()
        .map(AtomicU32::into_inner)
        .collect();
    InsertionOrder {
        order,
        vertex_of_input,
        rounds,
    }
}

/// Pieces of `keyed` (sorted by key) for the parallel passes of [`insertion_order`]:
/// about 16 per thread, each cut moved forward to where the key changes, so all the
/// points of one key lie in one piece. Consecutive, covering `keyed`; none empty.
fn key_pieces(keyed: &[(u64, u32)]) -> Vec<Range<usize>> {
    let n = keyed.len();
    let want = (rayon::current_num_threads() * 16).clamp(1, n.max(1));
    let mut pieces = Vec::with_capacity(want);
    let mut start = 0;
    for c in 1..=want {
        let mut end = (n * c / want).max(start);
        while end > 0 && end < n && keyed[end].0 == keyed[end - 1].0 {
            end += 1;
        }
        if end > start {
            pieces.push(start..end);
            start = end;
        }
    }
    pieces
}

/// `slice` cut into consecutive pieces of `lengths` (which sum to at most its length).
fn split_lengths<T>(
    mut slice: &mut [T],
    lengths: impl IntoIterator<Item = usize>,
) -> Vec<&mut [T]> {
    lengths
        .into_iter()
        .map(|len| {
            let (head, tail) = std::mem::take(&mut slice).split_at_mut(len);
            slice = tail;
            head
        })
        .collect()
}

/// The rank of each point in the lexicographic order of `(x, y, z)` (distinct points).
///
/// The coordinates are sorted as integer keys beside the vertex ids, not the ids through
/// the points: a third less time than comparing points fetched from memory at every step
/// (0.056–0.087 s against 0.076–0.104 s on a 1M UTM well lattice, two threads).
pub fn lex_ranks(pts: &[DVec3]) -> Vec<u32> {
    let mut sorted: Vec<([i64; 3], u32)> = pts
        .par_iter()
        .enumerate()
        .map(|(v, p)| (p.to_array().map(total_order_key), v as u32))
        .collect();
    sorted.par_sort_unstable();
    let mut rank = vec![0u32; pts.len()];
    for (k, &(_, v)) in sorted.iter().enumerate() {
        rank[v as usize] = k as u32;
    }
    rank
}

/// An integer that orders as [`f64::total_cmp`] orders `x` (so the keys of two points
/// compare as [`lex_cmp`] compares the points).
fn total_order_key(x: f64) -> i64 {
    let bits = x.to_bits() as i64;
    bits ^ (((bits >> 63) as u64) >> 1) as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hilbert_keys_of_adjacent_cells_are_distinct_and_follow_the_curve() {
        // On a 2x2x2 block at the origin the curve visits all 8 cells, consecutive cells
        // sharing a face.
        let mut cells: Vec<([u32; 3], u64)> = (0..8u32)
            .map(|i| {
                let c = [i & 1, (i >> 1) & 1, (i >> 2) & 1];
                (c, hilbert_key(c))
            })
            .collect();
        cells.sort_by_key(|c| c.1);
        for w in cells.windows(2) {
            let d: u32 = (0..3).map(|k| w[0].0[k].abs_diff(w[1].0[k])).sum();
            assert_eq!(d, 1, "{:?} -> {:?}", w[0].0, w[1].0);
        }
    }

    /// Skilling's algorithm with branches and a bit-by-bit interleave, as first written.
    fn hilbert_key_by_branches(mut x: [u32; 3]) -> u64 {
        let m = 1u32 << (HILBERT_BITS - 1);
        let mut q = m;
        while q > 1 {
            let p = q - 1;
            for i in 0..3 {
                if x[i] & q != 0 {
                    x[0] ^= p;
                } else {
                    let t = (x[0] ^ x[i]) & p;
                    x[0] ^= t;
                    x[i] ^= t;
                }
            }
            q >>= 1;
        }
        x[1] ^= x[0];
        x[2] ^= x[1];
        let mut t = 0;
        let mut q = m;
        while q > 1 {
            if x[2] & q != 0 {
                t ^= q - 1;
            }
            q >>= 1;
        }
        for v in &mut x {
            *v ^= t;
        }
        let mut key = 0u64;
        for b in (0..HILBERT_BITS).rev() {
            for v in &x {
                key = (key << 1) | u64::from((v >> b) & 1);
            }
        }
        key
    }

    #[test]
    fn branch_free_hilbert_keys_equal_the_branching_algorithm() {
        let mut state = 0x1234_5678_9abc_def1u64;
        let top = (1u32 << HILBERT_BITS) - 1;
        let mut cases = vec![[0, 0, 0], [top, top, top], [top, 0, top], [1, 2, 3]];
        for _ in 0..20_000 {
            state = mix(state);
            let c = [0, 21, 42].map(|s| (state >> s) as u32 & top);
            cases.push(c);
        }
        for c in cases {
            assert_eq!(hilbert_key(c), hilbert_key_by_branches(c), "{c:?}");
        }
    }

    #[test]
    fn keys_computed_in_lanes_equal_those_of_one_point_at_a_time() {
        let mut state = 0x0fed_cba9_8765_4321u64;
        let top = (1u32 << HILBERT_BITS) - 1;
        for _ in 0..2_000 {
            let mut xs = [[0u32; LANES]; 3];
            for l in 0..LANES {
                state = mix(state);
                for (axis, x) in xs.iter_mut().enumerate() {
                    x[l] = (state >> (21 * axis)) as u32 & top;
                }
            }
            let keys = hilbert_keys(xs);
            for (l, &key) in keys.iter().enumerate() {
                let c = [xs[0][l], xs[1][l], xs[2][l]];
                assert_eq!(key, hilbert_key_by_branches(c), "{c:?}");
            }
        }
    }

    #[test]
    fn order_holds_each_distinct_point_once_and_maps_duplicates_to_it() {
        let mut pts: Vec<DVec3> = (0..1000)
            .map(|i| DVec3::new((i % 10) as f64, ((i / 10) % 10) as f64, (i / 100) as f64))
            .collect();
        // Every tenth point again, and a point a hair away from another (one key).
        let again: Vec<DVec3> = (0..1000).step_by(10).map(|i| pts[i]).collect();
        pts.extend(again);
        pts.push(DVec3::new(5.0, 5.0, 5.0 + 1e-12));
        let (lo, hi, _) = bounds(&pts);
        let o = insertion_order(&pts, (lo, hi));
        assert_eq!((o.rounds[0], *o.rounds.last().unwrap()), (0, 1001));
        assert!(o.rounds.windows(2).all(|w| w[0] < w[1]));
        let mut seen = o.order.clone();
        seen.sort_unstable();
        let mut expected: Vec<u32> = (0..1000).collect();
        expected.push(1100);
        assert_eq!(
            seen, expected,
            "each distinct point once, by its first index"
        );
        for (i, &v) in o.vertex_of_input.iter().enumerate() {
            assert_eq!(pts[o.order[v as usize] as usize], pts[i], "input {i}");
        }
        // The pieces numbered in parallel depend on the thread count; the result not.
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let p = pool.install(|| insertion_order(&pts, (lo, hi)));
            assert_eq!(
                (&p.order, &p.vertex_of_input, &p.rounds),
                (&o.order, &o.vertex_of_input, &o.rounds),
                "{threads} threads"
            );
        }
    }

    #[test]
    fn lexicographic_ranks_follow_the_point_order_of_the_perturbation() {
        // Signs, zeros, infinities, subnormals and shared coordinates, so the integer keys
        // meet every case of the order they stand for.
        let xs = [
            -1e300,
            -2.5,
            -f64::MIN_POSITIVE / 4.0,
            0.0,
            f64::MIN_POSITIVE / 4.0,
            1.0,
            2.5,
            f64::INFINITY,
        ];
        // Every combination, each twice (equal points).
        let n = xs.len();
        let pts: Vec<DVec3> = (0..2 * n.pow(3))
            .map(|i| DVec3::new(xs[i % n], xs[i / n % n], xs[i / (n * n) % n]))
            .collect();
        let rank = lex_ranks(&pts);
        for (i, &a) in pts.iter().enumerate() {
            for (j, &b) in pts.iter().enumerate() {
                // (Equal points get distinct ranks in either order.)
                let order = lex_cmp(a, b);
                if order != std::cmp::Ordering::Equal {
                    assert_eq!(rank[i].cmp(&rank[j]), order, "{a} against {b}");
                }
            }
        }
    }
}
