//! Ordinary kriging in overlapping blocks, blended by a partition of unity.
//!
//! Space is in range units (the ellipsoid's frame divided by its ranges), where the
//! covariance is isotropic with range 1. Blocks sit on a lattice of spacing
//! [`BLOCK_SPACING`]; each solves one ordinary-kriging system (constant unknown mean, the
//! nugget on the diagonal) on the samples nearest its centre, in dual form: its prediction
//! anywhere is `mu + sum_i alpha_i * c0 * rho(|x - x_i|)`. A point's value blends the eight
//! blocks around it with tensor-product smoothstep weights that sum to one, so the field
//! is continuous (C1 across block boundaries) and costs one small solve per block rather
//! than per point.
//!
//! Invariants: predictions never use the nugget (filtered kriging: the model passes within
//! the nugget of each sample, not through it); a block with no sample within
//! [`Neighbourhood::radius`] predicts the global mean.

use std::collections::HashMap;

use foldhash::fast::FixedState;
use std::sync::Mutex;

use glam::{DVec3, IVec3};
use rayon::prelude::*;

use super::kernel::Spheroidal;

/// Hash maps keyed by lattice cells: a fixed fast hash (the keys are ours, not an
/// adversary's; SipHash took a fifth of a run's time).
pub(crate) type CellMap<K, V> = HashMap<K, V, FixedState>;

/// Block lattice spacing, in range units. Measured on the dipping-lens layouts: 1.0 blurs
/// thin lenses between sections (IoU 0.60), 0.5 keeps them (0.84); smaller costs more solves
/// for no gain (docs/field.md).
pub const BLOCK_SPACING: f64 = 0.5;

/// Which samples a block's system uses.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Neighbourhood {
    /// At most this many samples per block.
    pub max_samples: usize,
    /// At most this many from one hole (the nearest of them).
    pub max_per_hole: usize,
    /// Samples farther than this from the block's centre (range units) are never used.
    pub radius: f64,
}

impl Default for Neighbourhood {
    fn default() -> Self {
        Neighbourhood {
            max_samples: 96,
            max_per_hole: 12,
            radius: 2.0,
        }
    }
}

/// One block's solved system: its samples (range units) and dual weights.
#[derive(Debug)]
struct Block {
    points: Vec<DVec3>,
    alpha: Vec<f64>,
    mu: f64,
}

/// A uniform hash grid of the samples in range units, cell size [`BLOCK_SPACING`].
#[derive(Debug)]
struct CellGrid {
    cells: CellMap<IVec3, Vec<u32>>,
}

fn cell_of(p: DVec3) -> IVec3 {
    (p / BLOCK_SPACING).floor().as_ivec3()
}

impl CellGrid {
    fn new(points: &[DVec3]) -> Self {
        let mut cells: CellMap<IVec3, Vec<u32>> = CellMap::default();
        for (i, p) in points.iter().enumerate() {
            cells.entry(cell_of(*p)).or_default().push(i as u32);
        }
        CellGrid { cells }
    }

    /// The samples in cells `lo..=hi` on every axis.
    fn gather(&self, lo: IVec3, hi: IVec3, out: &mut Vec<u32>) {
        out.clear();
        for x in lo.x..=hi.x {
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    if let Some(v) = self.cells.get(&IVec3::new(x, y, z)) {
                        out.extend_from_slice(v);
                    }
                }
            }
        }
    }
}

/// The kriging model: samples in range units, their values, and the blocks solved so far.
#[derive(Debug)]
pub struct BlockKriging {
    kernel: Spheroidal,
    /// The structured share of the sill, `1 - nugget / sill`, in `(0, 1]`.
    c0: f64,
    points: Vec<DVec3>,
    values: Vec<f64>,
    holes: Vec<u32>,
    mean: f64,
    neighbourhood: Neighbourhood,
    grid: CellGrid,
    blocks: Mutex<CellMap<IVec3, Option<Block>>>,
}

impl BlockKriging {
    /// `points` in range units; `nugget_share` is nugget / sill in `[0, 1)`.
    pub fn new(
        kernel: Spheroidal,
        nugget_share: f64,
        points: Vec<DVec3>,
        values: Vec<f64>,
        holes: Vec<u32>,
        neighbourhood: Neighbourhood,
    ) -> Self {
        let mean = values.iter().sum::<f64>() / values.len().max(1) as f64;
        let grid = CellGrid::new(&points);
        BlockKriging {
            kernel,
            c0: (1.0 - nugget_share).clamp(1e-6, 1.0),
            points,
            values,
            holes,
            mean,
            neighbourhood,
            grid,
            blocks: Mutex::new(CellMap::default()),
        }
    }

    /// How many blocks have been solved.
    pub fn blocks_solved(&self) -> usize {
        self.blocks.lock().map(|b| b.len()).unwrap_or(0)
    }

    /// `true` when some sample lies within `reach` (range units) of `p`; stops at the
    /// first one found, searching the cells nearest `p` first.
    pub fn any_within(&self, p: DVec3, reach: f64) -> bool {
        let span = (reach / BLOCK_SPACING).ceil() as i32;
        let c = cell_of(p);
        let r2 = reach * reach;
        // Rings of cells by Chebyshev distance from p's own cell.
        for ring in 0..=span {
            for x in -ring..=ring {
                for y in -ring..=ring {
                    for z in -ring..=ring {
                        if x.abs().max(y.abs()).max(z.abs()) != ring {
                            continue;
                        }
                        let Some(v) = self.grid.cells.get(&(c + IVec3::new(x, y, z))) else {
                            continue;
                        };
                        if v.iter()
                            .any(|&i| self.points[i as usize].distance_squared(p) <= r2)
                        {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }

    /// The model's values at `queries` (range units), solving the blocks they need.
    /// Stops early (returning `None`) when `cancelled` turns true.
    pub fn evaluate(
        &self,
        queries: &[DVec3],
        cancelled: &(dyn Fn() -> bool + Sync),
    ) -> Option<Vec<f64>> {
        self.solve_blocks_for(queries, cancelled)?;
        let blocks = self.blocks.lock().ok()?;
        let blocks = &*blocks;
        let values = queries
            .par_iter()
            .with_min_len(256)
            .map(|&q| self.blend(blocks, q))
            .collect();
        Some(values)
    }

    fn solve_blocks_for(
        &self,
        queries: &[DVec3],
        cancelled: &(dyn Fn() -> bool + Sync),
    ) -> Option<()> {
        let mut needed: Vec<IVec3> = {
            let known = self.blocks.lock().ok()?;
            let mut set = std::collections::HashSet::with_hasher(FixedState::default());
            for q in queries {
                let base = cell_of(*q);
                for corner in CORNERS {
                    let key = base + corner;
                    if !known.contains_key(&key) {
                        set.insert(key);
                    }
                }
            }
            set.into_iter().collect()
        };
        needed.sort_by_key(|k| (k.x, k.y, k.z));
        let solved: Vec<(IVec3, Option<Block>)> = needed
            .par_iter()
            .with_min_len(4)
            .map(|&key| {
                if cancelled() {
                    return None;
                }
                Some((key, self.solve_block(key)))
            })
            .collect::<Option<Vec<_>>>()?;
        let mut blocks = self.blocks.lock().ok()?;
        blocks.extend(solved);
        Some(())
    }

    /// The blend of the eight blocks around `q`.
    fn blend(&self, blocks: &CellMap<IVec3, Option<Block>>, q: DVec3) -> f64 {
        let s = q / BLOCK_SPACING;
        let base = s.floor();
        let t = s - base;
        let base = base.as_ivec3();
        let mut sum = 0.0;
        for corner in CORNERS {
            let w = weight(t.x, corner.x) * weight(t.y, corner.y) * weight(t.z, corner.z);
            if w == 0.0 {
                continue;
            }
            let value = match blocks.get(&(base + corner)) {
                Some(Some(block)) => self.predict(block, q),
                _ => self.mean,
            };
            sum += w * value;
        }
        sum
    }

    #[inline]
    fn predict(&self, block: &Block, q: DVec3) -> f64 {
        let mut sum = 0.0;
        for (p, a) in block.points.iter().zip(&block.alpha) {
            sum += a * self.kernel.rho_sq(p.distance_squared(q));
        }
        block.mu + self.c0 * sum
    }

    /// The samples of the block at lattice node `key`: nearest to its centre first, at most
    /// `max_per_hole` per hole, within the radius.
    fn neighbours(&self, key: IVec3) -> Vec<u32> {
        let centre = key.as_dvec3() * BLOCK_SPACING;
        let n = self.neighbourhood;
        let max_span = (n.radius / BLOCK_SPACING).ceil() as i32;
        let mut candidates = Vec::new();
        // Widen the search ring by ring until it holds enough samples.
        let mut span = 1;
        loop {
            self.grid.gather(
                key - IVec3::splat(span),
                key + IVec3::splat(span - 1),
                &mut candidates,
            );
            if candidates.len() >= n.max_samples * 2 || span >= max_span {
                break;
            }
            span += 1;
        }
        let r2 = n.radius * n.radius;
        let mut ranked: Vec<(f64, u32)> = candidates
            .iter()
            .map(|&i| (self.points[i as usize].distance_squared(centre), i))
            .filter(|(d, _)| *d <= r2)
            .collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut per_hole: CellMap<u32, usize> = CellMap::default();
        let mut chosen = Vec::with_capacity(n.max_samples);
        for (_, i) in ranked {
            let count = per_hole.entry(self.holes[i as usize]).or_default();
            if *count >= n.max_per_hole {
                continue;
            }
            *count += 1;
            chosen.push(i);
            if chosen.len() == n.max_samples {
                break;
            }
        }
        chosen
    }

    /// Solves the ordinary-kriging system of one block in dual form.
    fn solve_block(&self, key: IVec3) -> Option<Block> {
        let chosen = self.neighbours(key);
        if chosen.is_empty() {
            return None;
        }
        let points: Vec<DVec3> = chosen.iter().map(|&i| self.points[i as usize]).collect();
        let z: Vec<f64> = chosen.iter().map(|&i| self.values[i as usize]).collect();
        let n = points.len();
        // K = c0 * rho + (1 - c0) * I, plus a relative jitter for coincident samples.
        let mut k = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..i {
                let v = self.c0 * self.kernel.rho_sq(points[i].distance_squared(points[j]));
                k[i * n + j] = v;
                k[j * n + i] = v;
            }
            k[i * n + i] = 1.0 + 1e-9;
        }
        let l = cholesky(&mut k, n)?;
        // alpha = K^-1 (z - mu 1), mu = 1'K^-1 z / 1'K^-1 1 (the Schur complement).
        let kz = solve(l, n, &z);
        let k1 = solve(l, n, &vec![1.0; n]);
        let mu = kz.iter().sum::<f64>() / k1.iter().sum::<f64>();
        let alpha = kz.iter().zip(&k1).map(|(a, b)| a - mu * b).collect();
        Some(Block { points, alpha, mu })
    }
}

/// The eight lattice corners of a cell.
const CORNERS: [IVec3; 8] = [
    IVec3::new(0, 0, 0),
    IVec3::new(1, 0, 0),
    IVec3::new(0, 1, 0),
    IVec3::new(1, 1, 0),
    IVec3::new(0, 0, 1),
    IVec3::new(1, 0, 1),
    IVec3::new(0, 1, 1),
    IVec3::new(1, 1, 1),
];

/// The smoothstep weight of the corner at offset `corner` (0 or 1) for fraction `t`: the
/// two weights along an axis sum to one.
#[inline]
fn weight(t: f64, corner: i32) -> f64 {
    let u = if corner == 0 { 1.0 - t } else { t };
    u * u * (3.0 - 2.0 * u)
}

/// In-place Cholesky factor (lower) of the symmetric positive definite `a` (row-major);
/// `None` if it is not positive definite.
fn cholesky(a: &mut [f64], n: usize) -> Option<&[f64]> {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    Some(a)
}

/// Solves `L L' x = b` with the factor from [`cholesky`].
fn solve(l: &[f64], n: usize, b: &[f64]) -> Vec<f64> {
    let mut y = b.to_vec();
    for i in 0..n {
        let mut s = y[i];
        for k in 0..i {
            s -= l[i * n + k] * y[k];
        }
        y[i] = s / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= l[k * n + i] * y[k];
        }
        y[i] = s / l[i * n + i];
    }
    y
}

#[cfg(test)]
mod tests {
    use super::*;

    fn never() -> bool {
        false
    }

    #[test]
    fn weights_partition_unity() {
        for t in [0.0, 0.1, 0.37, 0.5, 0.99] {
            assert!((weight(t, 0) + weight(t, 1) - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn cholesky_solves_a_small_system() {
        let mut a = vec![4.0, 2.0, 0.6, 2.0, 5.0, 1.0, 0.6, 1.0, 3.0];
        let orig = a.clone();
        let l = cholesky(&mut a, 3).unwrap().to_vec();
        let x = solve(&l, 3, &[1.0, 2.0, 3.0]);
        for i in 0..3 {
            let r: f64 = (0..3).map(|j| orig[i * 3 + j] * x[j]).sum();
            assert!((r - [1.0, 2.0, 3.0][i]).abs() < 1e-12);
        }
    }

    #[test]
    fn honours_samples_without_nugget_and_reverts_to_the_mean_far_away() {
        let kernel = Spheroidal::new(3).unwrap();
        let points: Vec<DVec3> = (0..40)
            .map(|i| {
                let f = f64::from(i);
                DVec3::new(
                    (f * 0.37).sin() * 0.8,
                    (f * 0.91).cos() * 0.8,
                    f * 0.02 - 0.4,
                )
            })
            .collect();
        let values: Vec<f64> = points.iter().map(|p| 2.0 + p.x - 0.5 * p.z).collect();
        let holes = (0..40).map(|i| i / 4).collect();
        let model = BlockKriging::new(
            kernel,
            0.0,
            points.clone(),
            values.clone(),
            holes,
            Neighbourhood::default(),
        );
        let got = model.evaluate(&points, &never).unwrap();
        for (g, v) in got.iter().zip(&values) {
            assert!((g - v).abs() < 1e-4, "{g} vs {v}");
        }
        // Far from every sample, beyond the radius: the global mean.
        let far = model.evaluate(&[DVec3::splat(50.0)], &never).unwrap()[0];
        let mean = values.iter().sum::<f64>() / 40.0;
        assert!((far - mean).abs() < 1e-12);
        // With a nugget, samples are smoothed but the field stays within their range.
        let smooth = BlockKriging::new(
            kernel,
            0.5,
            points.clone(),
            values.clone(),
            (0..40).collect(),
            Neighbourhood::default(),
        );
        let got = smooth.evaluate(&points, &never).unwrap();
        let (lo, hi) = values
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
        assert!(got.iter().all(|g| *g > lo - 0.2 && *g < hi + 0.2));
        assert!(got.iter().zip(&values).any(|(g, v)| (g - v).abs() > 1e-3));
    }
}
