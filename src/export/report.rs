//! The resource report's files: the grade–tonnage curve as CSV and as an SVG chart.
//!
//! Invariant: both are written from `Summary::report`, so the CSV's rows, the chart's
//! points and the summary's `grade_tonnage` hold the same numbers.

use crate::contour::{ReportSummary, Summary};
use crate::report::{chart, grade_tonnage_csv};

/// The curve's title: what is on it and with which density.
pub fn chart_title(report: &ReportSummary) -> String {
    let density = match (
        report.density.source,
        report.density.value,
        &report.density.column,
    ) {
        ("constant", Some(r), _) => format!("density {r} t/m3"),
        ("column", _, Some(c)) => format!("density from {c}"),
        _ => "no density: volume".to_string(),
    };
    format!("Grade–tonnage curve ({density})")
}

/// The grade–tonnage CSV, when the summary has a curve.
pub fn report_csv(summary: &Summary) -> Option<Vec<u8>> {
    let report = summary.report.as_ref()?;
    (!report.grade_tonnage.is_empty())
        .then(|| grade_tonnage_csv(&report.grade_tonnage, &report.units).into_bytes())
}

/// The grade–tonnage chart (SVG), when the summary has a curve.
pub fn report_svg(summary: &Summary) -> Option<Vec<u8>> {
    let report = summary.report.as_ref()?;
    (!report.grade_tonnage.is_empty()).then(|| {
        chart::grade_tonnage_svg(&report.grade_tonnage, &report.units, &chart_title(report))
            .into_bytes()
    })
}
