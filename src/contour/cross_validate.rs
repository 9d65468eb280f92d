//! Cross-validation by whole holes: every K-th hole is held out in turn, the field is built
//! without it through the same step as the run's ([`super::prepare`]), and its samples
//! are predicted by the piecewise-linear field of the training mesh.
//!
//! Invariant: a held-out sample never takes part in its own prediction (its whole hole is
//! "don't know" in the training set); a sample outside the training mesh's hull is
//! predicted below every threshold (outside) and counted, never dropped.

use serde::Serialize;

use super::{Cancellable, Classified, ContourError, Frame, Source};
use crate::progress::{Progress, Stage};
use crate::report::locate::Locator;
use crate::wells::SampleSet;

/// The held-out predictions of one run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrossValidation {
    /// K: hole `i` (holes with values sorted by id) is held out in fold `i % K`.
    pub folds: u32,
    /// Holes with at least one known value.
    pub holes: usize,
    /// Samples with a known value, each held out once.
    pub samples: usize,
    /// Held-out samples outside the training mesh (predicted outside every shell).
    pub outside_mesh: usize,
    /// Per threshold: the share of held-out samples on the right side.
    pub thresholds: Vec<ThresholdScore>,
    /// Grade errors over the samples inside the training mesh.
    pub grade: GradeScore,
    /// One row per hole, in the order of their ids.
    pub per_hole: Vec<HoleScore>,
}

/// How well held-out samples land on the right side of one threshold.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ThresholdScore {
    pub threshold: f64,
    /// Held-out samples at or above the threshold (ore).
    pub ore_samples: usize,
    /// The share of them predicted at or above it (inside).
    pub ore_inside_share: Option<f64>,
    /// Held-out samples below the threshold (waste).
    pub waste_samples: usize,
    /// The share of them predicted below it (outside; outside the mesh counts).
    pub waste_outside_share: Option<f64>,
    /// The mean of the two shares (either alone when the other class is empty).
    pub balanced_accuracy: Option<f64>,
}

/// Grade errors (predicted − observed) over predicted samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct GradeScore {
    pub predicted: usize,
    /// Mean absolute error, in the grade's unit.
    pub mean_abs_error: Option<f64>,
    /// Mean signed error (positive: the model runs high), in the grade's unit.
    pub bias: Option<f64>,
}

/// The figures of one held-out hole.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HoleScore {
    pub hole: String,
    pub fold: u32,
    pub samples: usize,
    pub outside_mesh: usize,
    pub mean_abs_error: Option<f64>,
    pub bias: Option<f64>,
    /// Per threshold (in the order of `thresholds`), the share of the hole's samples on the
    /// right side.
    pub right_side_share: Vec<Option<f64>>,
}

/// One held-out sample: its observed value and the prediction (`None` outside the mesh).
#[derive(Debug, Clone, Copy)]
struct Prediction {
    observed: f64,
    predicted: Option<f64>,
}

/// Accumulates the right-side counts and grade errors of a set of predictions.
#[derive(Debug, Clone, Default)]
struct Tally {
    samples: usize,
    outside: usize,
    abs_error: f64,
    error: f64,
    predicted: usize,
    /// Per threshold: (ore, ore inside, waste, waste outside).
    sides: Vec<[usize; 4]>,
}

impl Tally {
    fn new(thresholds: usize) -> Self {
        Tally {
            sides: vec![[0; 4]; thresholds],
            ..Tally::default()
        }
    }

    fn add(&mut self, p: Prediction, thresholds: &[f64]) {
        self.samples += 1;
        match p.predicted {
            Some(q) => {
                self.predicted += 1;
                self.abs_error += (q - p.observed).abs();
                self.error += q - p.observed;
            }
            None => self.outside += 1,
        }
        for (side, &t) in self.sides.iter_mut().zip(thresholds) {
            let inside = p.predicted.is_some_and(|q| q >= t);
            if p.observed >= t {
                side[0] += 1;
                side[1] += usize::from(inside);
            } else {
                side[2] += 1;
                side[3] += usize::from(!inside);
            }
        }
    }

    fn grade(&self) -> GradeScore {
        let n = self.predicted as f64;
        GradeScore {
            predicted: self.predicted,
            mean_abs_error: (self.predicted > 0).then(|| self.abs_error / n),
            bias: (self.predicted > 0).then(|| self.error / n),
        }
    }

    fn share(part: usize, whole: usize) -> Option<f64> {
        (whole > 0).then(|| part as f64 / whole as f64)
    }

    fn right_side(&self) -> Vec<Option<f64>> {
        self.sides
            .iter()
            .map(|s| Self::share(s[1] + s[3], s[0] + s[2]))
            .collect()
    }

    fn scores(&self, thresholds: &[f64]) -> Vec<ThresholdScore> {
        self.sides
            .iter()
            .zip(thresholds)
            .map(|(s, &threshold)| {
                let ore = Self::share(s[1], s[0]);
                let waste = Self::share(s[3], s[2]);
                let balanced = match (ore, waste) {
                    (Some(a), Some(b)) => Some((a + b) / 2.0),
                    (a, b) => a.or(b),
                };
                ThresholdScore {
                    threshold,
                    ore_samples: s[0],
                    ore_inside_share: ore,
                    waste_samples: s[2],
                    waste_outside_share: waste,
                    balanced_accuracy: balanced,
                }
            })
            .collect()
    }
}

/// The holes with at least one known value, sorted by id: (well index, id).
fn holes_with_values(samples: &SampleSet) -> Vec<(u32, String)> {
    let mut has = vec![false; samples.wells.len()];
    for (v, &w) in samples.values.iter().zip(&samples.well_of) {
        if v.is_some() {
            has[w as usize] = true;
        }
    }
    let mut holes: Vec<(u32, String)> = has
        .iter()
        .enumerate()
        .filter(|(_, h)| **h)
        .map(|(w, _)| (w as u32, samples.wells[w].id.clone()))
        .collect();
    holes.sort_by(|a, b| a.1.cmp(&b.1).then(a.0.cmp(&b.0)));
    holes
}

/// Predicts the held-out samples `held` of `samples` with the field built on `training`.
fn predict(
    training: &Classified,
    samples: &SampleSet,
    held: &[usize],
    frame: &Frame,
) -> Vec<Prediction> {
    let locator = Locator::new(&training.mesh);
    let mut hint = 0;
    held.iter()
        .map(|&i| {
            let q = frame.forward * samples.points[i];
            let predicted = locator
                .interpolate(&training.values, q, hint)
                .map(|(value, t)| {
                    hint = t;
                    value
                });
            Prediction {
                observed: samples.values[i].unwrap_or(f64::NAN),
                predicted,
            }
        })
        .collect()
}

/// Runs K-fold cross-validation by whole holes on the request's samples.
pub(super) fn cross_validate(
    source: &Source,
    folds: u32,
    thresholds: &[f64],
    frame: &Frame,
    fit: &dyn Fn(&SampleSet, &dyn Progress) -> Result<Classified, ContourError>,
    progress: &dyn Progress,
) -> Result<CrossValidation, ContourError> {
    let Source::Samples(samples) = source else {
        return Err(ContourError::CrossValidation(
            "a grid has no holes to hold out; cross-validation needs samples".into(),
        ));
    };
    let holes = holes_with_values(samples);
    if folds < 2 || folds as usize > holes.len() {
        return Err(ContourError::CrossValidation(format!(
            "{folds} folds for {} holes with values: give K from 2 to the number of holes",
            holes.len()
        )));
    }
    progress.report(Stage::CrossValidate, 0.0);
    let mut fold_of_well = vec![u32::MAX; samples.wells.len()];
    for (index, (w, _)) in holes.iter().enumerate() {
        fold_of_well[*w as usize] = index as u32 % folds;
    }
    let mut per_sample: Vec<Option<Prediction>> = vec![None; samples.values.len()];
    for fold in 0..folds {
        if progress.is_cancelled() {
            return Err(ContourError::Cancelled);
        }
        let held: Vec<usize> = (0..samples.values.len())
            .filter(|&i| {
                samples.values[i].is_some() && fold_of_well[samples.well_of[i] as usize] == fold
            })
            .collect();
        let mut training = samples.clone();
        for &i in &held {
            training.values[i] = None;
        }
        let fitted = fit(&training, &Cancellable(progress)).map_err(|e| match e {
            ContourError::Cancelled => e,
            other => ContourError::CrossValidation(format!("fold {fold}: {other}")),
        })?;
        for (&i, p) in held.iter().zip(predict(&fitted, samples, &held, frame)) {
            per_sample[i] = Some(p);
        }
        progress.report(Stage::CrossValidate, f64::from(fold + 1) / f64::from(folds));
    }
    Ok(tally(
        samples,
        &holes,
        &fold_of_well,
        &per_sample,
        folds,
        thresholds,
    ))
}

/// The overall and per-hole figures of the predictions.
fn tally(
    samples: &SampleSet,
    holes: &[(u32, String)],
    fold_of_well: &[u32],
    per_sample: &[Option<Prediction>],
    folds: u32,
    thresholds: &[f64],
) -> CrossValidation {
    let mut all = Tally::new(thresholds.len());
    let mut by_well: Vec<Tally> = vec![Tally::new(thresholds.len()); samples.wells.len()];
    for (i, p) in per_sample.iter().enumerate() {
        if let Some(p) = p {
            all.add(*p, thresholds);
            by_well[samples.well_of[i] as usize].add(*p, thresholds);
        }
    }
    let per_hole = holes
        .iter()
        .map(|(w, id)| {
            let t = &by_well[*w as usize];
            let g = t.grade();
            HoleScore {
                hole: id.clone(),
                fold: fold_of_well[*w as usize],
                samples: t.samples,
                outside_mesh: t.outside,
                mean_abs_error: g.mean_abs_error,
                bias: g.bias,
                right_side_share: t.right_side(),
            }
        })
        .collect();
    CrossValidation {
        folds,
        holes: holes.len(),
        samples: all.samples,
        outside_mesh: all.outside,
        thresholds: all.scores(thresholds),
        grade: all.grade(),
        per_hole,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_count_outside_the_mesh_as_outside() {
        let thresholds = [1.0];
        let mut t = Tally::new(1);
        for (observed, predicted) in [(2.0, Some(1.5)), (2.0, None), (0.5, None), (0.5, Some(1.2))]
        {
            t.add(
                Prediction {
                    observed,
                    predicted,
                },
                &thresholds,
            );
        }
        let s = &t.scores(&thresholds)[0];
        assert_eq!((s.ore_samples, s.waste_samples), (2, 2));
        assert_eq!(s.ore_inside_share, Some(0.5));
        assert_eq!(s.waste_outside_share, Some(0.5));
        assert_eq!(s.balanced_accuracy, Some(0.5));
        let g = t.grade();
        assert_eq!(g.predicted, 2);
        assert!((g.mean_abs_error.unwrap() - 0.6).abs() < 1e-12);
        assert!((g.bias.unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(t.right_side(), vec![Some(0.5)]);
    }
}
