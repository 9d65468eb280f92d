//! Insertion order: biased randomized insertion order (BRIO) rounds, each sorted along a
//! 3D Hilbert curve, so consecutive insertions are spatial neighbours.
//!
//! Invariant: the order is a permutation of the given vertices and depends only on the
//! coordinates and the vertex ids (a fixed seed), never on timing or thread count.

use glam::DVec3;
use rayon::prelude::*;

/// Bits per axis of the Hilbert key (3 x 21 = 63 bits).
const HILBERT_BITS: u32 = 21;

/// Position along the 3D Hilbert curve of a point with `HILBERT_BITS`-bit integer
/// coordinates (Skilling's transpose algorithm, then bit interleaving).
fn hilbert_key(mut x: [u32; 3]) -> u64 {
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

/// SplitMix64: a fixed, well-mixed hash of a vertex id for the round draw.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The insertion order of all `points`: round 0 (about 64 points) first, each later round
/// about twice as large, the last holding about half of the points; within a round,
/// Hilbert order. Sorted in parallel. Also returns where each round starts in the order,
/// followed by `points.len()`.
pub fn brio_hilbert_order(points: &[DVec3]) -> (Vec<u32>, Vec<usize>) {
    let n = points.len();
    if n == 0 {
        return (Vec::new(), vec![0]);
    }
    let (lo, hi) = points
        .par_iter()
        .fold(
            || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
        .reduce(
            || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    let extent = (hi - lo).max_element();
    let cells = f64::from((1u32 << HILBERT_BITS) - 1);
    let scale = if extent > 0.0 { cells / extent } else { 0.0 };
    // Rounds: a vertex with `tz` trailing zero bits in its hash goes to round
    // `max_level - min(tz, max_level)`; round 0 gets ~ n / 2^max_level ~ 64 vertices.
    let max_level = (n / 64).max(1).ilog2().min(31);
    let mut keyed: Vec<(u64, u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, &p)| {
            let g = ((p - lo) * scale).clamp(DVec3::ZERO, DVec3::splat(cells));
            let h = hilbert_key([g.x as u32, g.y as u32, g.z as u32]);
            let tz = mix(i as u64).trailing_zeros().min(max_level);
            let round = u64::from(max_level - tz);
            ((round << 58) | (h >> 5), i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    let mut starts = vec![0];
    for k in 1..n {
        if keyed[k].0 >> 58 != keyed[k - 1].0 >> 58 {
            starts.push(k);
        }
    }
    starts.push(n);
    (keyed.into_iter().map(|(_, i)| i).collect(), starts)
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

    #[test]
    fn order_is_a_permutation() {
        let pts: Vec<DVec3> = (0..1000)
            .map(|i| DVec3::new((i % 10) as f64, ((i / 10) % 10) as f64, (i / 100) as f64))
            .collect();
        let (mut order, starts) = brio_hilbert_order(&pts);
        assert_eq!((starts[0], *starts.last().unwrap()), (0, 1000));
        assert!(starts.windows(2).all(|w| w[0] < w[1]));
        order.sort_unstable();
        assert_eq!(order, (0..1000).collect::<Vec<u32>>());
    }
}
