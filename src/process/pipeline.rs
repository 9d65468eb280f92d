//! What a worker runs for one `dmt-contour` job: stored execute inputs in, outputs out.
//!
//! Invariant: the same [`ProcessInputs`] the API accepted are read back, so a job runs
//! exactly what was submitted.

use crate::contour::{self, ContourError};
use crate::dmt::DmtError;
use crate::export::{self, OutputOptions};
use crate::progress::{Progress, Stage};
use crate::tet::TetError;
use crate::wells::{Input, SampleSet};

use super::ProcessInputs;
use crate::jobs::{JobFailure, Pipeline, StoredOutput};

/// The real pipeline: read wells, `contour::run`, export every output.
#[derive(Debug, Default, Clone, Copy)]
pub struct ContourPipeline;

impl Pipeline for ContourPipeline {
    fn run(&self, inputs: &[u8], progress: &dyn Progress) -> Result<Vec<StoredOutput>, JobFailure> {
        let inputs: ProcessInputs = serde_json::from_slice(inputs)
            .map_err(|e| JobFailure::Internal(format!("the stored inputs are unreadable: {e}")))?;
        self.run_inputs(&inputs, progress)
    }
}

impl ContourPipeline {
    /// Runs already-parsed inputs.
    pub fn run_inputs(
        &self,
        inputs: &ProcessInputs,
        progress: &dyn Progress,
    ) -> Result<Vec<StoredOutput>, JobFailure> {
        progress.report(Stage::Read, 0.0);
        let samples = load_samples(&inputs.wells_input(), inputs)?;
        progress.report(Stage::Read, 1.0);
        if progress.is_cancelled() {
            return Err(JobFailure::Cancelled);
        }
        let mut request = inputs
            .contour_request(samples)
            .map_err(|e| JobFailure::input_field(e.field.clone(), e.to_string()))?;
        contour::load_density_column(&mut request, &inputs.wells_input())
            .map_err(contour_failure)?;
        let result = contour::run(&request, progress).map_err(contour_failure)?;
        if progress.is_cancelled() {
            return Err(JobFailure::Cancelled);
        }
        progress.report(Stage::Export, 0.0);
        let defaults = OutputOptions::default();
        let options = OutputOptions {
            well_traces: inputs.well_traces.unwrap_or(defaults.well_traces),
            well_samples: inputs.well_samples.unwrap_or(defaults.well_samples),
            ..defaults
        };
        let outputs = export::all_outputs(&result, &options)
            .map_err(|e| JobFailure::Internal(format!("exporting the results: {e}")))?;
        progress.report(Stage::Export, 1.0);
        Ok(outputs
            .into_iter()
            .map(|output| StoredOutput {
                id: output.id.to_string(),
                file_name: output.file_name,
                media_type: output.media_type.to_string(),
                bytes: output.bytes,
            })
            .collect())
    }
}

/// Reads the wells; a refusal names the input it came from (the readers' errors start with
/// the file name, which is the input's name here).
fn load_samples(input: &Input, inputs: &ProcessInputs) -> Result<SampleSet, JobFailure> {
    input.load().map_err(|e| {
        let message = e.to_string();
        let given = [
            ("wells", inputs.wells.is_some()),
            ("samples_csv", inputs.samples_csv.is_some()),
            ("collars_csv", inputs.collars_csv.is_some()),
            ("surveys_csv", inputs.surveys_csv.is_some()),
            ("intervals_csv", inputs.intervals_csv.is_some()),
        ];
        let named = given
            .iter()
            .find(|(name, is_given)| *is_given && message.starts_with(name))
            .map(|(name, _)| *name);
        match named {
            Some(field) => JobFailure::input_field(field, message),
            None => JobFailure::input(message),
        }
    })
}

/// The one place a contouring error is judged: cancellation, a broken invariant of the
/// engine (an invalid mesh, values or thresholds the engine should never have been
/// handed: `Internal`, answered 500), or input that cannot be contoured (`Input`, 422).
fn contour_failure(error: ContourError) -> JobFailure {
    match error {
        ContourError::Cancelled
        | ContourError::Tet(TetError::Cancelled)
        | ContourError::Dmt(DmtError::Cancelled) => JobFailure::Cancelled,
        ContourError::Tet(TetError::Invalid(_))
        | ContourError::Dmt(
            DmtError::ValueCount { .. } | DmtError::NonFinite(_) | DmtError::BadThreshold(_),
        ) => JobFailure::Internal(error.to_string()),
        ContourError::NoThresholds => JobFailure::input_field("thresholds", error.to_string()),
        ContourError::Density(_) => JobFailure::input_field("density_column", error.to_string()),
        ContourError::CrossValidation(_) => {
            JobFailure::input_field("cross_validate", error.to_string())
        }
        ContourError::NoKnownSamples { .. }
        | ContourError::Grid(_)
        | ContourError::Tet(_)
        | ContourError::Field(_) => JobFailure::input(error.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn broken_invariants_are_internal_and_bad_input_is_the_users() {
        let internal = [
            ContourError::Tet(TetError::Invalid("tet 3 faces itself".into())),
            ContourError::Dmt(DmtError::ValueCount {
                expected: 4,
                got: 3,
            }),
            ContourError::Dmt(DmtError::NonFinite(2)),
            ContourError::Dmt(DmtError::BadThreshold(f64::NAN)),
        ];
        for error in internal {
            assert!(matches!(contour_failure(error), JobFailure::Internal(_)));
        }
        let input = [
            ContourError::Tet(TetError::AllCoplanar),
            ContourError::Tet(TetError::TooFewPoints { distinct: 3 }),
            ContourError::NoKnownSamples { unknown: 9 },
            ContourError::Density("column SG: no sample with a grade has a density".into()),
            ContourError::CrossValidation("5 folds for 3 holes".into()),
        ];
        for error in input {
            assert!(matches!(contour_failure(error), JobFailure::Input { .. }));
        }
        assert_eq!(
            contour_failure(ContourError::NoThresholds),
            JobFailure::input_field("thresholds", ContourError::NoThresholds.to_string())
        );
        for cancelled in [
            ContourError::Cancelled,
            ContourError::Tet(TetError::Cancelled),
            ContourError::Dmt(DmtError::Cancelled),
        ] {
            assert_eq!(contour_failure(cancelled), JobFailure::Cancelled);
        }
    }
}
