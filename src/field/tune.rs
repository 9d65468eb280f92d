//! The orientation and ranges chosen by cross-validation over whole holes
//! (`--shape-from cross-validation`).
//!
//! The intercepts give the ore's extent and thickness, which is the right scale for one
//! lens drilled closely; on a field of many small lenses (Tom Zone) the extent is the
//! field's, bounded at six hole spacings, and a minor range of one lens's thickness makes
//! the model so anisotropic that a few degrees of error in its single plane miss the next
//! hole; and the variogram map's plane can swing with the holes it is given. [`search`]
//! scores the run's own plane beside the other planes of [`Problem::orientations`] at the
//! intercepts' ranges, then with the best plane scales the minor range by [`MINOR_SCALES`]
//! and the in-plane ranges by [`PLANE_SCALES`], and keeps the candidate whose field puts
//! held-out holes' samples on the right side of the level most often (balanced accuracy:
//! the mean of the ore samples' share inside and the waste samples' share outside). Hole
//! `h` (its rank among the holes, by id) is held out in fold `h % FOLDS`, and the model
//! that predicts it is the same block kriging as the run's, fitted on the other holes.
//!
//! Invariants: a held-out sample never takes part in its own prediction (its whole hole is
//! left out); the run's own model is kept unless a candidate beats it by more than
//! [`MARGIN`], so noise in the score does not move a model that is already right.

use glam::DVec3;
use serde::Serialize;

use super::estimate::Samples;
use super::frame::{Ellipsoid, Orientation};
use super::kernel::Spheroidal;
use super::kriging::{BlockKriging, Neighbourhood};

/// Folds of holes.
pub const FOLDS: usize = 5;
/// Factors on the intercepts' minor range (the ore's thickness), tried first with the
/// in-plane ranges as they are.
pub const MINOR_SCALES: [f64; 5] = [1.0, 1.5, 2.0, 3.0, 4.0];
/// Factors on the intercepts' major and semi-major ranges, tried next with the best minor.
pub const PLANE_SCALES: [f64; 4] = [0.8, 0.65, 0.5, 0.4];
/// Planes from the variogram map tried beside the run's own and the intercepts'.
pub const MAP_PLANES: usize = 4;
/// Planes whose normals are closer than this (degrees) count as one.
pub const PLANE_SEPARATION: f64 = 15.0;
/// A candidate replaces the intercepts' ranges only when its balanced accuracy is higher
/// by more than this.
pub const MARGIN: f64 = 0.01;
/// The search needs at least this many holes with a sample at or above the level.
pub const MIN_ORE_HOLES: usize = 2 * FOLDS;

/// The search was cancelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cancelled;

/// One candidate's orientation, ranges and score.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ShapeCandidate {
    pub orientation: Orientation,
    /// Major, semi-major, minor, input units.
    pub ranges: [f64; 3],
    /// The mean of the held-out ore samples' share inside and waste samples' share outside.
    pub balanced_accuracy: f64,
}

/// The search's candidates, in the order tried (the run's own model first), and the one
/// kept.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShapeSearch {
    pub folds: usize,
    /// Held-out samples scored per candidate (every sample once).
    pub samples: usize,
    /// Of them, those the model was evaluated at: the others lie farther than every
    /// candidate's range from the ore of the other holes and count as outside.
    pub evaluated: usize,
    pub candidates: Vec<ShapeCandidate>,
    /// Index into `candidates` of the orientation and ranges used.
    pub chosen: usize,
}

/// What the search works on: the fitted values, the level the shell is drawn at, and the
/// model's fixed parts.
pub struct Problem<'a> {
    pub samples: &'a Samples,
    /// The level in the field's values (ore: at or above it).
    pub level: f64,
    /// The planes to try, the run's own first (the others: the variogram map's other
    /// minima and the intercepts' plane, `mod.rs`).
    pub orientations: Vec<Orientation>,
    /// The intercepts' ranges.
    pub ranges: [f64; 3],
    /// The smallest in-plane range allowed (input units).
    pub min_plane: f64,
    pub kernel: Spheroidal,
    pub nugget_share: f64,
    pub neighbourhood: Neighbourhood,
}

/// The held-out samples of one fold: those scored by evaluating the model, and the tally
/// of those counted as outside without it.
struct Fold {
    train: Vec<usize>,
    evaluate: Vec<usize>,
    /// (ore, ore inside, waste, waste outside) of the samples not evaluated.
    far: [usize; 4],
}

/// Searches the candidates — the planes at the intercepts' ranges first, then with the
/// best plane the minor range, then the in-plane ranges with the best minor; `Ok(None)`
/// when too few holes cut the ore for the folds to mean anything, `Err(Cancelled)` when
/// cancelled.
pub fn search(
    problem: &Problem,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Result<Option<ShapeSearch>, Cancelled> {
    let t = problem.samples;
    let Some(fold_of) = folds(t, problem.level) else {
        return Ok(None);
    };
    let mut candidates: Vec<ShapeCandidate> = Vec::new();
    let mut splits: Vec<Vec<Fold>> = Vec::new();
    for &orientation in &problem.orientations {
        let folds = split(problem, orientation, &fold_of);
        let ranges = problem.ranges;
        let balanced = score(problem, orientation, ranges, &folds, cancelled).ok_or(Cancelled)?;
        candidates.push(ShapeCandidate {
            orientation,
            ranges,
            balanced_accuracy: balanced,
        });
        splits.push(folds);
    }
    let plane = kept(&candidates);
    let (orientation, folds) = (candidates[plane].orientation, &splits[plane]);
    let try_ranges = |ranges: [f64; 3], candidates: &mut Vec<ShapeCandidate>| {
        let seen = candidates
            .iter()
            .any(|c| c.orientation == orientation && same(&c.ranges, &ranges));
        if seen {
            return Ok(());
        }
        let balanced = score(problem, orientation, ranges, folds, cancelled).ok_or(Cancelled)?;
        candidates.push(ShapeCandidate {
            orientation,
            ranges,
            balanced_accuracy: balanced,
        });
        Ok(())
    };
    for across in MINOR_SCALES {
        try_ranges(scaled(problem, 1.0, across), &mut candidates)?;
    }
    let minor = best_with(&candidates, orientation).ranges[2] / problem.ranges[2];
    for in_plane in PLANE_SCALES {
        try_ranges(scaled(problem, in_plane, minor), &mut candidates)?;
    }
    let chosen = kept(&candidates);
    Ok(Some(ShapeSearch {
        folds: FOLDS,
        samples: t.values.len(),
        evaluated: splits[plane].iter().map(|f| f.evaluate.len()).sum(),
        candidates,
        chosen,
    }))
}

/// The index of the best candidate if it beats the first (the run's own model) by more
/// than [`MARGIN`], else 0.
fn kept(candidates: &[ShapeCandidate]) -> usize {
    let top = (0..candidates.len()).fold(0, |a, i| {
        if candidates[i].balanced_accuracy > candidates[a].balanced_accuracy {
            i
        } else {
            a
        }
    });
    if candidates[top].balanced_accuracy > candidates[0].balanced_accuracy + MARGIN {
        top
    } else {
        0
    }
}

/// The candidate with `orientation` with the highest score, the first of equals.
fn best_with(candidates: &[ShapeCandidate], orientation: Orientation) -> ShapeCandidate {
    candidates
        .iter()
        .filter(|c| c.orientation == orientation)
        .fold(None, |a: Option<ShapeCandidate>, c| match a {
            Some(a) if a.balanced_accuracy >= c.balanced_accuracy => Some(a),
            _ => Some(*c),
        })
        .unwrap_or(candidates[0])
}

fn same(a: &[f64; 3], b: &[f64; 3]) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (x - y).abs() <= 1e-9 * y.abs())
}

/// The intercepts' ranges scaled by `plane` in the plane and `across` across it: in-plane
/// ranges no shorter than `min_plane` (unless already shorter), the minor no longer than
/// the semi-major.
fn scaled(problem: &Problem, plane: f64, across: f64) -> [f64; 3] {
    let [major, semi, minor] = problem.ranges;
    let m = (major * plane).max(problem.min_plane.min(major));
    let s = (semi * plane).max(problem.min_plane.min(semi)).min(m);
    [m, s, (minor * across).min(s)]
}

/// The largest ranges any candidate may have: every candidate's ellipsoid lies inside it.
fn enclosing(problem: &Problem) -> [f64; 3] {
    let [major, semi, minor] = problem.ranges;
    let most = MINOR_SCALES.iter().copied().fold(1.0, f64::max);
    [major, semi, (minor * most).min(semi).max(minor)]
}

/// The fold of every sample (by its hole's rank), or `None` when fewer than
/// [`MIN_ORE_HOLES`] holes have a sample at or above `level`.
fn folds(t: &Samples, level: f64) -> Option<Vec<usize>> {
    let mut ids: Vec<u32> = t.holes.clone();
    ids.sort_unstable();
    ids.dedup();
    let mut ore_holes: Vec<u32> = t
        .holes
        .iter()
        .zip(&t.values)
        .filter(|(_, v)| **v >= level)
        .map(|(h, _)| *h)
        .collect();
    ore_holes.sort_unstable();
    ore_holes.dedup();
    if ore_holes.len() < MIN_ORE_HOLES {
        return None;
    }
    Some(
        t.holes
            .iter()
            .map(|h| ids.binary_search(h).unwrap_or(0) % FOLDS)
            .collect(),
    )
}

/// Splits the samples into folds. A held-out sample farther than one range of the
/// enclosing ellipsoid from every ore sample of the training holes is beyond the reach of
/// the ore in every candidate: the model there is the local mean, below the level, so it
/// counts as outside without being evaluated (most waste down long holes).
fn split(problem: &Problem, orientation: Orientation, fold_of: &[usize]) -> Vec<Fold> {
    let t = problem.samples;
    let ellipsoid = Ellipsoid::new(orientation, enclosing(problem));
    let unit: Vec<DVec3> = t.points.iter().map(|p| ellipsoid.to_unit(*p)).collect();
    (0..FOLDS)
        .map(|fold| {
            let (train, held): (Vec<usize>, Vec<usize>) =
                (0..unit.len()).partition(|&i| fold_of[i] != fold);
            let ore: Vec<usize> = train
                .iter()
                .copied()
                .filter(|&i| t.values[i] >= problem.level)
                .collect();
            let near = BlockKriging::new(
                problem.kernel,
                0.0,
                ore.iter().map(|&i| unit[i]).collect(),
                vec![0.0; ore.len()],
                vec![0; ore.len()],
                problem.neighbourhood,
            );
            let mut far = [0usize; 4];
            let mut evaluate = Vec::new();
            for i in held {
                if near.any_within(unit[i], 1.0) {
                    evaluate.push(i);
                } else {
                    tally(&mut far, t.values[i] >= problem.level, false);
                }
            }
            Fold {
                train,
                evaluate,
                far,
            }
        })
        .collect()
}

/// Adds one held-out sample to (ore, ore inside, waste, waste outside).
fn tally(sides: &mut [usize; 4], ore: bool, inside: bool) {
    if ore {
        sides[0] += 1;
        sides[1] += usize::from(inside);
    } else {
        sides[2] += 1;
        sides[3] += usize::from(!inside);
    }
}

/// The balanced accuracy of held-out samples with `ranges`; `None` if cancelled.
fn score(
    problem: &Problem,
    orientation: Orientation,
    ranges: [f64; 3],
    folds: &[Fold],
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<f64> {
    let t = problem.samples;
    let ellipsoid = Ellipsoid::new(orientation, ranges);
    let unit: Vec<DVec3> = t.points.iter().map(|p| ellipsoid.to_unit(*p)).collect();
    let mut sides = [0usize; 4];
    for fold in folds {
        for (s, f) in sides.iter_mut().zip(fold.far) {
            *s += f;
        }
        if fold.evaluate.is_empty() || fold.train.is_empty() {
            continue;
        }
        let kriging = BlockKriging::new(
            problem.kernel,
            problem.nugget_share,
            fold.train.iter().map(|&i| unit[i]).collect(),
            fold.train.iter().map(|&i| t.values[i]).collect(),
            fold.train.iter().map(|&i| t.holes[i]).collect(),
            problem.neighbourhood,
        );
        let queries: Vec<DVec3> = fold.evaluate.iter().map(|&i| unit[i]).collect();
        let predicted = kriging.evaluate(&queries, cancelled)?;
        for (&i, q) in fold.evaluate.iter().zip(predicted) {
            tally(&mut sides, t.values[i] >= problem.level, q >= problem.level);
        }
    }
    let share = |part: usize, whole: usize| {
        if whole == 0 {
            1.0
        } else {
            part as f64 / whole as f64
        }
    };
    Some((share(sides[1], sides[0]) + share(sides[3], sides[2])) / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problem(samples: &Samples) -> Problem<'_> {
        Problem {
            samples,
            level: 0.5,
            orientations: vec![Orientation::FLAT],
            ranges: [100.0, 80.0, 5.0],
            min_plane: 60.0,
            kernel: Spheroidal::new(7).expect("order 7"),
            nugget_share: 0.1,
            neighbourhood: Neighbourhood::default(),
        }
    }

    #[test]
    fn candidates_respect_the_bounds() {
        let s = Samples {
            points: vec![],
            values: vec![],
            holes: vec![],
        };
        let p = problem(&s);
        assert_eq!(scaled(&p, 1.0, 1.0), [100.0, 80.0, 5.0]);
        assert_eq!(scaled(&p, 0.5, 3.0), [60.0, 60.0, 15.0]);
        assert_eq!(scaled(&p, 1.0, 40.0), [100.0, 80.0, 80.0]);
        assert_eq!(enclosing(&p), [100.0, 80.0, 20.0]);
        for plane in PLANE_SCALES {
            for across in MINOR_SCALES {
                let r = scaled(&p, plane, across);
                let e = enclosing(&p);
                assert!(r.iter().zip(e).all(|(a, b)| *a <= b), "{r:?} inside {e:?}");
            }
        }
    }

    #[test]
    fn folds_need_enough_ore_holes() {
        let holes: Vec<u32> = (0..20).flat_map(|h| [h, h]).collect();
        let mut values = vec![0.0; 40];
        let s = |values: Vec<f64>| Samples {
            points: vec![DVec3::ZERO; 40],
            values,
            holes: holes.clone(),
        };
        for v in values.iter_mut().take(2 * (MIN_ORE_HOLES - 1)).step_by(2) {
            *v = 1.0;
        }
        assert!(folds(&s(values.clone()), 0.5).is_none());
        values[2 * MIN_ORE_HOLES] = 1.0;
        let f = folds(&s(values), 0.5).expect("enough ore holes");
        assert_eq!(f[0], 0);
        assert_eq!(f[2 * 7], 7 % FOLDS);
        assert_eq!(f[2 * 7 + 1], 7 % FOLDS);
    }
}
