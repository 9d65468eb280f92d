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

use glam::{DMat3, DVec3, IVec3};
use rayon::prelude::*;

use super::estimate::principal_axes;
use super::kernel::Spheroidal;
use super::local::LocalFrames;

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
    /// At most this many samples per block whose nearest `max_samples` straddle a level
    /// (hold values on both sides of it): where the surface is, more samples average more
    /// of the assays' noise. Not above `max_samples` turns it off.
    pub max_samples_near: usize,
}

impl Default for Neighbourhood {
    fn default() -> Self {
        Neighbourhood {
            max_samples: 96,
            max_per_hole: 12,
            radius: 2.0,
            max_samples_near: 192,
        }
    }
}

/// One block's solved system: its samples (range units, in its own frame when it has
/// one) and dual weights.
#[derive(Debug)]
struct Block {
    /// The map from the global range units to the block's, where the orientation turns
    /// (`local.rs`).
    frame: Option<DMat3>,
    points: Vec<DVec3>,
    alpha: Vec<f64>,
    mu: f64,
}

/// A uniform hash grid of the samples in range units, cell size [`BLOCK_SPACING`].
#[derive(Debug)]
struct CellGrid {
    cells: CellMap<IVec3, Vec<u32>>,
    rings: Rings,
}

fn cell_of(p: DVec3) -> IVec3 {
    (p / BLOCK_SPACING).floor().as_ivec3()
}

/// Rings the ring distances count up to; farther cells read `RING_CAP + 1`.
const RING_CAP: i32 = 4;
/// The dense ring grid is not built past this many cells (a search then starts at ring 0).
const MAX_RING_CELLS: usize = 1 << 24;

/// For every cell of the samples' box (grown by [`RING_CAP`]), the Chebyshev distance in
/// cells to the nearest cell holding a sample, capped at `RING_CAP + 1`: a search for a
/// sample near a point skips the rings it proves empty (most lattice nodes far from the
/// data are answered by one read instead of hundreds of hash lookups).
#[derive(Debug, Default)]
struct Rings {
    lo: IVec3,
    dims: IVec3,
    distance: Vec<u8>,
}

impl Rings {
    fn new(cells: &CellMap<IVec3, Vec<u32>>) -> Self {
        let far = (RING_CAP + 1) as u8;
        let Some((lo, hi)) = cells.keys().fold(None, |acc: Option<(IVec3, IVec3)>, &c| {
            Some(acc.map_or((c, c), |(lo, hi)| (lo.min(c), hi.max(c))))
        }) else {
            return Rings::default();
        };
        let lo = lo - IVec3::splat(RING_CAP);
        let dims = hi + IVec3::splat(RING_CAP + 1) - lo;
        let count = dims.as_i64vec3().element_product();
        if count <= 0 || count as usize > MAX_RING_CELLS {
            return Rings::default();
        }
        let mut rings = Rings {
            lo,
            dims,
            distance: vec![far; count as usize],
        };
        for &c in cells.keys() {
            let i = rings.index(c).unwrap_or(0);
            rings.distance[i] = 0;
        }
        // Chebyshev distance is separable: a bounded min-max pass along each axis.
        for axis in 0..3 {
            rings.pass(axis);
        }
        rings
    }

    fn index(&self, c: IVec3) -> Option<usize> {
        let d = c - self.lo;
        if d.cmplt(IVec3::ZERO).any() || d.cmpge(self.dims).any() {
            return None;
        }
        Some(
            ((d.z as usize * self.dims.y as usize) + d.y as usize) * self.dims.x as usize
                + d.x as usize,
        )
    }

    /// `d(i) = min over |t| <= RING_CAP of max(|t|, d(i + t))` along `axis`.
    fn pass(&mut self, axis: usize) {
        let n = self.dims[axis] as usize;
        let stride = match axis {
            0 => 1,
            1 => self.dims.x as usize,
            _ => (self.dims.x * self.dims.y) as usize,
        };
        let far = (RING_CAP + 1) as u8;
        let mut line = vec![far; n];
        for start in 0..self.distance.len() {
            // Each line once: from the cells whose coordinate along `axis` is 0.
            if (start / stride) % n != 0 {
                continue;
            }
            for (k, v) in line.iter_mut().enumerate() {
                *v = self.distance[start + k * stride];
            }
            for k in 0..n {
                let mut best = line[k];
                for t in 1..=RING_CAP as usize {
                    let t8 = t as u8;
                    if t8 >= best {
                        break;
                    }
                    let below = k.checked_sub(t).map_or(far, |j| line[j]);
                    let above = line.get(k + t).copied().unwrap_or(far);
                    best = best.min(t8.max(below.min(above)));
                }
                self.distance[start + k * stride] = best;
            }
        }
    }

    /// The first ring around cell `c` that may hold a sample.
    fn first(&self, c: IVec3) -> i32 {
        if self.distance.is_empty() {
            return 0;
        }
        self.index(c)
            .map_or(RING_CAP + 1, |i| i32::from(self.distance[i]))
    }
}

impl CellGrid {
    fn new(points: &[DVec3]) -> Self {
        let mut cells: CellMap<IVec3, Vec<u32>> = CellMap::default();
        for (i, p) in points.iter().enumerate() {
            cells.entry(cell_of(*p)).or_default().push(i as u32);
        }
        let rings = Rings::new(&cells);
        CellGrid { cells, rings }
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
    frames: Option<LocalFrames>,
    /// The (transformed) levels the surfaces are drawn at; blocks that straddle one take
    /// the larger neighbourhood.
    levels: Vec<f64>,
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
            frames: None,
            levels: Vec::new(),
            blocks: Mutex::new(CellMap::default()),
        }
    }

    /// The same model with each block's anisotropy turned by `frames` (before any block
    /// is solved).
    pub fn with_frames(mut self, frames: Option<LocalFrames>) -> Self {
        self.frames = frames;
        self
    }

    /// The same model with the larger neighbourhood where a block's samples straddle one
    /// of `levels` (transformed).
    pub fn with_levels(mut self, levels: &[f64]) -> Self {
        self.levels = levels.to_vec();
        self
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
        // Rings of cells by Chebyshev distance from p's own cell, from the first that may
        // hold a sample.
        for ring in self.grid.rings.first(c)..=span {
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
        let q = block.frame.map_or(q, |m| m * q);
        let mut sum = 0.0;
        for (p, a) in block.points.iter().zip(&block.alpha) {
            sum += a * self.kernel.rho_sq(p.distance_squared(q));
        }
        block.mu + self.c0 * sum
    }

    /// The samples of the block at lattice node `key`: nearest to its centre first (in the
    /// block's `frame` when it has one), at most `max_per_hole` per hole, within the
    /// radius.
    fn neighbours(&self, key: IVec3, frame: Option<DMat3>, max_samples: usize) -> Vec<u32> {
        let centre = key.as_dvec3() * BLOCK_SPACING;
        let n = self.neighbourhood;
        // The frame's unit ball reaches this far in the global units.
        let stretch = frame.map_or(1.0, |m| {
            let inverse = m.inverse();
            principal_axes(inverse.transpose() * inverse).0[0].sqrt()
        });
        let max_span = (n.radius * stretch / BLOCK_SPACING).ceil() as i32;
        let enough = if frame.is_some() { 4 } else { 2 } * max_samples;
        let mut candidates = Vec::new();
        // Widen the search ring by ring until it holds enough samples.
        let mut span = 1;
        loop {
            self.grid.gather(
                key - IVec3::splat(span),
                key + IVec3::splat(span - 1),
                &mut candidates,
            );
            if candidates.len() >= enough || span >= max_span {
                break;
            }
            span += 1;
        }
        let r2 = n.radius * n.radius;
        let distance = |p: DVec3| match frame {
            Some(m) => (m * (p - centre)).length_squared(),
            None => p.distance_squared(centre),
        };
        let mut ranked: Vec<(f64, u32)> = candidates
            .iter()
            .map(|&i| (distance(self.points[i as usize]), i))
            .filter(|(d, _)| *d <= r2)
            .collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut per_hole: CellMap<u32, usize> = CellMap::default();
        let mut chosen = Vec::with_capacity(max_samples);
        for (_, i) in ranked {
            let count = per_hole.entry(self.holes[i as usize]).or_default();
            if *count >= n.max_per_hole {
                continue;
            }
            *count += 1;
            chosen.push(i);
            if chosen.len() == max_samples {
                break;
            }
        }
        chosen
    }

    /// `true` when the samples `chosen` hold values on both sides of some level.
    fn straddles(&self, chosen: &[u32]) -> bool {
        let (lo, hi) = chosen
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &i| {
                let v = self.values[i as usize];
                (lo.min(v), hi.max(v))
            });
        super::straddles(&self.levels, lo, hi)
    }

    /// Solves the ordinary-kriging system of one block in dual form.
    fn solve_block(&self, key: IVec3) -> Option<Block> {
        let frame = self
            .frames
            .as_ref()
            .and_then(|f| f.map_at(key.as_dvec3() * BLOCK_SPACING));
        let n = self.neighbourhood;
        let mut chosen = self.neighbours(key, frame, n.max_samples);
        if n.max_samples_near > n.max_samples && self.straddles(&chosen) {
            chosen = self.neighbours(key, frame, n.max_samples_near);
        }
        if chosen.is_empty() {
            return None;
        }
        let points: Vec<DVec3> = chosen
            .iter()
            .map(|&i| {
                let p = self.points[i as usize];
                frame.map_or(p, |m| m * p)
            })
            .collect();
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
        Some(Block {
            frame,
            points,
            alpha,
            mu,
        })
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
        let (done, rest) = a.split_at_mut(j * n + n);
        let row_j = &mut done[j * n..];
        let d = row_j[j] - dot(&row_j[..j], &row_j[..j]);
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        let d = d.sqrt();
        row_j[j] = d;
        let row_j = &row_j[..j];
        for row_i in rest.chunks_exact_mut(n) {
            row_i[j] = (row_i[j] - dot(&row_i[..j], row_j)) / d;
        }
    }
    Some(a)
}

/// The dot product of two equal-length slices, in four running sums (so the compiler
/// can keep them in vector registers: the factorisation's inner loop).
#[inline]
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
    let tail: f64 = xc
        .remainder()
        .iter()
        .zip(yc.remainder())
        .map(|(a, b)| a * b)
        .sum();
    for (a, b) in xc.zip(yc) {
        for k in 0..4 {
            acc[k] += a[k] * b[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Solves `L L' x = b` with the factor from [`cholesky`].
fn solve(l: &[f64], n: usize, b: &[f64]) -> Vec<f64> {
    let mut y = b.to_vec();
    for i in 0..n {
        y[i] = (y[i] - dot(&l[i * n..i * n + i], &y[..i])) / l[i * n + i];
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
    fn any_within_agrees_with_a_search_of_every_sample() {
        // Samples down a few lines, and queries from inside them to far beyond every ring.
        let points: Vec<DVec3> = (0..300)
            .map(|i| {
                let f = f64::from(i);
                let hole = f64::from(i / 60);
                DVec3::new(hole * 1.7 - 3.0, (hole * 2.3).sin() * 2.0, f * 0.013 - 2.0)
            })
            .collect();
        let holes = (0..300).map(|i| i / 60).collect();
        let values = vec![1.0; points.len()];
        let model = BlockKriging::new(
            Spheroidal::new(7).unwrap(),
            0.2,
            points.clone(),
            values,
            holes,
            Neighbourhood::default(),
        );
        let mut checked = [0usize; 2];
        for i in 0..4000 {
            let f = f64::from(i);
            let q = DVec3::new(
                (f * 0.731).sin() * 5.0,
                (f * 0.417).cos() * 4.0,
                (f * 0.263).sin() * 4.0,
            );
            for reach in [0.3, 0.75, 1.5, 2.0, 2.6, 3.2] {
                let truth = points.iter().any(|p| p.distance(q) <= reach);
                assert_eq!(model.any_within(q, reach), truth, "{q} within {reach}");
                checked[usize::from(truth)] += 1;
            }
        }
        assert!(checked[0] > 1000 && checked[1] > 1000, "{checked:?}");
    }

    #[test]
    fn blocks_whose_samples_straddle_a_level_take_the_larger_neighbourhood() {
        // Vertical holes on a 7x7 plan; ore (1) west of x = 0, waste (0) east of it.
        let mut points = Vec::new();
        let mut holes = Vec::new();
        for h in 0..49 {
            let (x, y) = (f64::from(h % 7) - 3.05, f64::from(h / 7) - 3.0);
            for k in 0..30 {
                points.push(DVec3::new(x, y, f64::from(k) * 0.1 - 1.5));
                holes.push(h as u32);
            }
        }
        let values: Vec<f64> = points.iter().map(|p| f64::from(p.x < 0.0)).collect();
        let neighbourhood = Neighbourhood {
            max_samples: 16,
            max_per_hole: 4,
            radius: 2.0,
            max_samples_near: 48,
        };
        let queries: Vec<DVec3> = (-6..=6)
            .flat_map(|i| (-2..=2).map(move |j| DVec3::new(f64::from(i) * 0.5, f64::from(j), 0.0)))
            .collect();
        let sizes = |levels: &[f64]| {
            let model = BlockKriging::new(
                Spheroidal::new(3).unwrap(),
                0.1,
                points.clone(),
                values.clone(),
                holes.clone(),
                neighbourhood,
            )
            .with_levels(levels);
            model.evaluate(&queries, &never).unwrap();
            let blocks = model.blocks.lock().unwrap();
            let mut sizes: Vec<(i32, usize)> = blocks
                .iter()
                .filter_map(|(k, b)| b.as_ref().map(|b| (k.x, b.points.len())))
                .collect();
            sizes.sort_unstable();
            sizes
        };
        let near = sizes(&[0.5]);
        // The blocks on the contact see both sides; one centred 2 ranges or more from it
        // sees one side only.
        for (x, n) in &near {
            let centre = f64::from(*x) * BLOCK_SPACING;
            if centre.abs() >= 2.0 {
                assert!(*n <= 16, "block at x = {centre}: {n}");
            }
            if *x == 0 {
                // More than the base's 16 (up to 48, as many as lie within the radius).
                assert!(*n > 16 && *n <= 48, "block at x = {centre}: {n}");
            }
        }
        // No level, or a level no sample straddles: the base neighbourhood everywhere.
        for levels in [&[][..], &[2.0][..]] {
            assert!(sizes(levels).iter().all(|(_, n)| *n <= 16), "{levels:?}");
        }
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
