//! Progress reporting and cancellation, shared by every long-running stage.
//!
//! Invariant: geometry code calls [`Progress::is_cancelled`] between stages and inside
//! long loops (at least every few thousand iterations) and stops with a `Cancelled`
//! error as soon as it answers `true`. Implementations must be cheap and thread-safe.
//! Stages are a closed set ([`Stage`]): whoever shows progress maps every one of them.

use std::fmt;

/// A stage of the pipeline, in the order a job goes through them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Reading, desurveying and compositing the input.
    Read,
    /// Fitting the field between the holes (variograms, orientation, the kriging model).
    Fit,
    /// Evaluating the field and placing the infill points where the surface is.
    Refine,
    /// The Delaunay tetrahedralization (or a grid's cube split).
    Tetrahedralize,
    /// Extracting the shells (DMT or marching tetrahedra). The fraction runs over all the
    /// shells of the request, not one.
    Contour,
    /// The curvature placement's search, inside [`Stage::Contour`]: its fractions are on the
    /// same scale (the search takes [`CURVATURE_SHARE`] of a shell's extraction).
    Curvature,
    /// The pessimistic and optimistic bodies of "don't know" samples.
    Bounds,
    /// Holding out holes in turn and predicting them.
    CrossValidate,
    /// Writing the outputs.
    Export,
}

/// The part `[start, end)` of one shell's extraction that its curvature search takes; the
/// extraction reports [`Stage::Contour`] before and after it.
pub const CURVATURE_SHARE: (f64, f64) = (0.3, 0.7);

impl Stage {
    /// Every stage, in pipeline order.
    pub const ALL: [Stage; 9] = [
        Stage::Read,
        Stage::Fit,
        Stage::Refine,
        Stage::Tetrahedralize,
        Stage::Contour,
        Stage::Curvature,
        Stage::Bounds,
        Stage::CrossValidate,
        Stage::Export,
    ];

    /// The short name shown to users ("tetrahedralize").
    pub fn name(self) -> &'static str {
        match self {
            Stage::Read => "read",
            Stage::Fit => "fit",
            Stage::Refine => "refine",
            Stage::Tetrahedralize => "tetrahedralize",
            Stage::Contour => "contour",
            Stage::Curvature => "curvature",
            Stage::Bounds => "unknown bounds",
            Stage::CrossValidate => "cross-validate",
            Stage::Export => "export",
        }
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Receives stages and completion fractions from a running pipeline.
pub trait Progress: Sync {
    /// `fraction` is the completed share of `stage` in `0.0..=1.0`.
    fn report(&self, stage: Stage, fraction: f64);

    /// `true` once the caller wants the work abandoned.
    fn is_cancelled(&self) -> bool {
        false
    }
}

/// A [`Progress`] that ignores reports and never cancels.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn report(&self, _stage: Stage, _fraction: f64) {}
}

/// Reports one part of a stage's work: fraction `f` of the part is reported to `inner` as
/// `(index + f) / count` of `stage`-valued reports (the shells of a request share the
/// [`Stage::Contour`] and [`Stage::Curvature`] scale this way). Other stages pass through.
pub struct Part<'a> {
    pub inner: &'a dyn Progress,
    pub index: usize,
    pub count: usize,
}

impl Progress for Part<'_> {
    fn report(&self, stage: Stage, fraction: f64) {
        match stage {
            Stage::Contour | Stage::Curvature => {
                let count = self.count.max(1) as f64;
                self.inner.report(
                    stage,
                    (self.index as f64 + fraction.clamp(0.0, 1.0)) / count,
                )
            }
            _ => self.inner.report(stage, fraction),
        }
    }

    fn is_cancelled(&self) -> bool {
        self.inner.is_cancelled()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[derive(Default)]
    struct Log(Mutex<Vec<(Stage, f64)>>);

    impl Progress for Log {
        fn report(&self, stage: Stage, fraction: f64) {
            self.0.lock().unwrap().push((stage, fraction));
        }
    }

    #[test]
    fn a_part_maps_shell_fractions_onto_the_whole_request() {
        let log = Log::default();
        let part = Part {
            inner: &log,
            index: 1,
            count: 4,
        };
        part.report(Stage::Contour, 0.0);
        part.report(Stage::Curvature, 1.0);
        part.report(Stage::Export, 0.5);
        assert_eq!(
            *log.0.lock().unwrap(),
            vec![
                (Stage::Contour, 0.25),
                (Stage::Curvature, 0.5),
                (Stage::Export, 0.5)
            ]
        );
    }

    #[test]
    fn every_stage_has_a_distinct_name() {
        let mut names: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), Stage::ALL.len());
    }
}
