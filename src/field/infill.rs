//! Infill points: where the field is evaluated and added to the samples before the Delaunay,
//! so DMT contours a refined piecewise-linear image of the model.
//!
//! A lattice in the model's frame (range units, so steps follow the anisotropy) covers the
//! data; a node is *inside* the model when a sample lies within [`INSIDE_REACH`] ranges,
//! a *sentinel* when it is beyond that but within [`SENTINEL_REACH`], and dropped farther
//! out. Sentinels take a value below every level, so every body closes at the model's
//! extent (and is flagged truncated there) rather than running along the hull to far holes.
//! Cells whose corners straddle a level are split in eight, level after level, down to the
//! resolution: points go where the surface is. An axis whose finest step would fall below
//! [`FLOOR_SAMPLES`] sample spacings stops splitting early (its cells split in four or two
//! after that), so a thin lens is not resolved across far below its assays.
//!
//! Invariants: no inside node is farther than [`INSIDE_REACH`] ranges from a sample;
//! points are jittered by a deterministic hash (a fraction [`JITTER`] of the finest step)
//! so the Delaunay never meets a co-spherical lattice; the same input gives the same points.

use glam::{BVec3, DVec3, I64Vec3};
use rayon::prelude::*;

use super::Field;
use super::kriging::CellMap;

/// Inside nodes lie within this many ranges of a sample.
pub const INSIDE_REACH: f64 = 0.75;
/// Sentinel nodes lie beyond [`INSIDE_REACH`], within this many ranges of a sample.
pub const SENTINEL_REACH: f64 = 1.5;
/// The coarse lattice step, in ranges.
pub const COARSE_STEP: f64 = 0.5;
/// Refinement levels by default: the finest step is `COARSE_STEP / 2^levels` ranges
/// (1/32 of the ranges). Measured against 3 levels on the lens layouts (docs/field.md).
pub const DEFAULT_LEVELS: u32 = 4;
/// Most levels `--resolution` may ask for.
pub const MAX_LEVELS: u32 = 7;
/// The coarse lattice grows its step past this many nodes.
pub const MAX_COARSE_NODES: usize = 1_000_000;
/// Refinement stops before a level that would pass this many points.
pub const MAX_INFILL_POINTS: usize = 1_500_000;
/// No axis is refined below this many sample spacings (down the holes): finer steps
/// across a thin lens resolve nothing the assays say and multiply the points.
pub const FLOOR_SAMPLES: f64 = 0.25;
/// Jitter of each coordinate, as a fraction of the finest step. Under a half, so nodes
/// never meet; large, because a nearly co-spherical lattice tetrahedralizes into flat
/// tetrahedra and DMT into thin triangles (0.2: 5.2-5.7 % slivers on the geology
/// benchmark, 0.45: 3.2-3.8 %; docs/field.md).
pub const JITTER: f64 = 0.45;

/// The infill points and what the refinement did.
#[derive(Debug, Clone, Default)]
pub struct Infill {
    /// Local coordinates.
    pub points: Vec<DVec3>,
    /// The field's (transformed) value at each point; sentinels get `outside`.
    pub values: Vec<f64>,
    pub sentinel: Vec<bool>,
    pub stats: InfillStats,
}

/// What the summary reports of the refinement.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct InfillStats {
    /// Coarse lattice step in ranges.
    pub coarse_step: f64,
    /// Levels of refinement asked and reached (fewer when [`MAX_INFILL_POINTS`] stopped it).
    pub levels: u32,
    pub levels_reached: u32,
    /// The finest step along the major, semi-major and minor axes, in input units.
    pub finest_step: [f64; 3],
    pub inside_points: usize,
    pub sentinel_points: usize,
    pub cells_refined: usize,
}

/// Where a lattice node stands.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Node {
    Inside(usize),
    Sentinel,
    Out,
}

struct Lattice<'a> {
    field: &'a Field,
    /// Lattice units per axis: the finest step, `coarse / 2^levels` ranges (fewer levels
    /// on an axis the floor stops).
    unit: DVec3,
    origin: DVec3,
    /// Jitter amplitude per axis, range units.
    shake: DVec3,
    nodes: CellMap<I64Vec3, Node>,
    inside: Vec<(I64Vec3, f64)>,
    sentinels: Vec<I64Vec3>,
}

impl Lattice<'_> {
    /// A node's jittered position in range units: where it is classified, evaluated and
    /// placed.
    fn unit_position(&self, key: I64Vec3) -> DVec3 {
        self.origin + key.as_dvec3() * self.unit + jitter(key) * self.shake
    }

    /// Classifies new nodes and evaluates the inside ones; `None` if cancelled.
    fn add(&mut self, keys: Vec<I64Vec3>, cancelled: &(dyn Fn() -> bool + Sync)) -> Option<()> {
        let mut fresh: Vec<I64Vec3> = keys
            .into_iter()
            .filter(|k| !self.nodes.contains_key(k))
            .collect();
        fresh.sort_by_key(|k| (k.x, k.y, k.z));
        fresh.dedup();
        let kriging = &self.field.kriging;
        let classes: Vec<Node> = fresh
            .par_iter()
            .with_min_len(1024)
            .map(|&k| {
                let u = self.unit_position(k);
                if kriging.any_within(u, INSIDE_REACH) {
                    Node::Inside(0)
                } else if kriging.any_within(u, SENTINEL_REACH) {
                    Node::Sentinel
                } else {
                    Node::Out
                }
            })
            .collect();
        let mut inside_keys = Vec::new();
        for (k, node) in fresh.into_iter().zip(classes) {
            match node {
                Node::Inside(_) => inside_keys.push(k),
                Node::Sentinel => {
                    self.sentinels.push(k);
                    self.nodes.insert(k, node);
                }
                Node::Out => {
                    self.nodes.insert(k, node);
                }
            }
        }
        let queries: Vec<DVec3> = inside_keys.iter().map(|k| self.unit_position(*k)).collect();
        let values = kriging.evaluate(&queries, cancelled)?;
        for (k, v) in inside_keys.into_iter().zip(values) {
            self.nodes.insert(k, Node::Inside(self.inside.len()));
            self.inside.push((k, v));
        }
        Some(())
    }

    /// The value of a node for the straddle test: sentinels count as `outside`.
    fn value(&self, key: I64Vec3, outside: f64) -> Option<f64> {
        match self.nodes.get(&key)? {
            Node::Inside(i) => Some(self.inside[*i].1),
            Node::Sentinel => Some(outside),
            Node::Out => None,
        }
    }
}

const CORNERS: [I64Vec3; 8] = [
    I64Vec3::new(0, 0, 0),
    I64Vec3::new(1, 0, 0),
    I64Vec3::new(0, 1, 0),
    I64Vec3::new(1, 1, 0),
    I64Vec3::new(0, 0, 1),
    I64Vec3::new(1, 0, 1),
    I64Vec3::new(0, 1, 1),
    I64Vec3::new(1, 1, 1),
];

/// A deterministic offset in `[-1, 1]^3` from a node's key.
fn jitter(key: I64Vec3) -> DVec3 {
    let mut h = (key.x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (key.y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (key.z as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
    let mut next = || {
        h ^= h >> 33;
        h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        h ^= h >> 33;
        (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    DVec3::new(next(), next(), next())
}

/// Refinement levels per axis: `refinements`, fewer on an axis whose finest step would
/// fall below [`FLOOR_SAMPLES`] sample spacings (`coarse` in ranges).
fn axis_levels(field: &Field, coarse: f64, refinements: u32) -> [u32; 3] {
    let floor = FLOOR_SAMPLES * field.params.spacing.sample;
    std::array::from_fn(|a| {
        let room = (coarse * field.ellipsoid.ranges[a] / floor).log2().floor();
        if room.is_finite() {
            (room.max(0.0) as u32).min(refinements)
        } else {
            refinements
        }
    })
}

/// Pushes `corner + (x, y, z) * step` for `x < count.x`, `y < count.y`, `z < count.z`.
fn grid_points(corner: I64Vec3, count: I64Vec3, step: I64Vec3, out: &mut Vec<I64Vec3>) {
    for x in 0..count.x {
        for y in 0..count.y {
            for z in 0..count.z {
                out.push(corner + I64Vec3::new(x, y, z) * step);
            }
        }
    }
}

/// The infill of `field` for the (transformed) `levels`: `levels` refinement steps below the
/// coarse lattice (see the module's notes). `None` if cancelled.
pub fn infill(
    field: &Field,
    levels: &[f64],
    outside: f64,
    refinements: u32,
    cancelled: &(dyn Fn() -> bool + Sync),
    report: &dyn Fn(f64),
) -> Option<Infill> {
    let samples_unit = field.samples_unit();
    let (lo, hi) = samples_unit
        .iter()
        .fold((DVec3::MAX, DVec3::MIN), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let (lo, hi) = (
        lo - DVec3::splat(SENTINEL_REACH),
        hi + DVec3::splat(SENTINEL_REACH),
    );
    // The coarse step grows past the node budget.
    let mut coarse = COARSE_STEP;
    let count = |step: f64| -> f64 {
        let n = ((hi - lo) / step).ceil() + DVec3::ONE;
        n.x * n.y * n.z
    };
    while count(coarse) > MAX_COARSE_NODES as f64 {
        coarse *= 1.25;
    }
    let ranges = field.ellipsoid.ranges;
    let axis_levels = axis_levels(field, coarse, refinements);
    let scale = I64Vec3::from_array(axis_levels.map(|l| 1i64 << l));
    let unit = coarse / scale.as_dvec3();
    let mut lattice = Lattice {
        field,
        unit,
        origin: lo,
        shake: JITTER * unit,
        nodes: CellMap::default(),
        inside: Vec::new(),
        sentinels: Vec::new(),
    };
    let n = ((hi - lo) / coarse).ceil().as_i64vec3();
    let mut keys = Vec::new();
    for x in 0..=n.x {
        for y in 0..=n.y {
            for z in 0..=n.z {
                keys.push(I64Vec3::new(x, y, z) * scale);
            }
        }
    }
    lattice.add(keys, cancelled)?;
    let mut cells: Vec<I64Vec3> = Vec::new();
    for x in 0..n.x {
        for y in 0..n.y {
            for z in 0..n.z {
                cells.push(I64Vec3::new(x, y, z) * scale);
            }
        }
    }
    let mut stats = InfillStats {
        coarse_step: coarse,
        levels: refinements,
        ..InfillStats::default()
    };
    let straddles = |lattice: &Lattice, cell: I64Vec3, size: I64Vec3| -> bool {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for c in CORNERS {
            match lattice.value(cell + c * size, outside) {
                Some(v) => {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                None => return false,
            }
        }
        super::straddles(levels, lo, hi)
    };
    let mut size = scale;
    for level in 0..refinements {
        // An axis with fewer levels splits at the first ones (the coarse cells' straddle
        // test stays as tight as before) and keeps its size after.
        let splits = BVec3::from_array(axis_levels.map(|l| level < l));
        report(f64::from(level) / f64::from(refinements.max(1)));
        let split: Vec<I64Vec3> = cells
            .into_iter()
            .filter(|&c| straddles(&lattice, c, size))
            .collect();
        let half = I64Vec3::select(splits, size / 2, size);
        let along = I64Vec3::select(splits, I64Vec3::splat(3), I64Vec3::splat(2));
        let projected = lattice.inside.len() + lattice.sentinels.len() + split.len() * 19;
        if split.is_empty() || projected > MAX_INFILL_POINTS {
            cells = Vec::new();
            break;
        }
        stats.cells_refined += split.len();
        let mut keys = Vec::with_capacity(split.len() * 27);
        let mut next = Vec::with_capacity(split.len() * 8);
        for &c in &split {
            grid_points(c, along, half, &mut keys);
            grid_points(c, along - I64Vec3::ONE, half, &mut next);
        }
        lattice.add(keys, cancelled)?;
        cells = next;
        size = half;
        stats.levels_reached = level + 1;
    }
    drop(cells);
    report(1.0);
    let finest: [f64; 3] = std::array::from_fn(|a| {
        let reached = stats.levels_reached.min(axis_levels[a]);
        unit[a] * f64::from(1u32 << (axis_levels[a] - reached)) * ranges[a]
    });
    stats.finest_step = finest;
    stats.inside_points = lattice.inside.len();
    stats.sentinel_points = lattice.sentinels.len();
    let place = |k: I64Vec3| field.ellipsoid.from_unit(lattice.unit_position(k));
    let mut out = Infill {
        stats,
        ..Infill::default()
    };
    for &(k, v) in &lattice.inside {
        out.points.push(place(k));
        out.values.push(v);
        out.sentinel.push(false);
    }
    for &k in &lattice.sentinels {
        out.points.push(place(k));
        out.values.push(outside);
        out.sentinel.push(true);
    }
    Some(out)
}
