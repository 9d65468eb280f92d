//! What a worker runs for one `dmt-contour` job: stored execute inputs in, outputs out.
//!
//! Invariant: the same [`ProcessInputs`] the API accepted are read back, so a job runs
//! exactly what was submitted.

use crate::contour::{self, ContourError};
use crate::export::{self, OutputOptions};
use crate::progress::{Progress, Stage};
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
        let samples = load_samples(&inputs.wells_input())?;
        progress.report(Stage::Read, 1.0);
        if progress.is_cancelled() {
            return Err(JobFailure::Cancelled);
        }
        let request = inputs
            .contour_request(samples)
            .map_err(|e| JobFailure::Input(e.to_string()))?;
        let result = contour::run(&request, progress).map_err(|e| match e {
            ContourError::Cancelled => JobFailure::Cancelled,
            other => JobFailure::Input(other.to_string()),
        })?;
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

fn load_samples(input: &Input) -> Result<SampleSet, JobFailure> {
    input.load().map_err(|e| JobFailure::Input(e.to_string()))
}
