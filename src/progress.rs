//! Progress reporting and cancellation, shared by every long-running stage.
//!
//! Invariant: geometry code calls [`Progress::is_cancelled`] between stages and inside
//! long loops (at least every few thousand iterations) and stops with a `Cancelled`
//! error as soon as it answers `true`. Implementations must be cheap and thread-safe.

/// Receives stage names and completion fractions from a running pipeline.
pub trait Progress: Sync {
    /// `stage` is a short human-readable name ("tetrahedralize", "contour 0.5"),
    /// `fraction` the completed share of that stage in `0.0..=1.0`.
    fn report(&self, stage: &str, fraction: f64);

    /// `true` once the caller wants the work abandoned.
    fn is_cancelled(&self) -> bool {
        false
    }
}

/// A [`Progress`] that ignores reports and never cancels.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn report(&self, _stage: &str, _fraction: f64) {}
}
