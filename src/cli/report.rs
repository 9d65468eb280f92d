//! The resource report on the terminal and in the files `--report` and `--chart` name.
//!
//! Invariant: what is printed and written is `Summary::report` and the shells' `resource`,
//! the figures of the summary JSON.
use std::path::Path;

use anyhow::Context;
use wellmesh::contour::Summary;
use wellmesh::export;

/// Writes the grade–tonnage CSV and SVG when asked (an error when there is no curve).
pub fn write(summary: &Summary, csv: Option<&Path>, svg: Option<&Path>) -> anyhow::Result<()> {
    let files = [
        (csv, export::report_csv(summary)),
        (svg, export::report_svg(summary)),
    ];
    for (path, bytes) in files {
        let Some(path) = path else { continue };
        let bytes = bytes.with_context(|| {
            format!(
                "{}: no grade–tonnage curve (0/1 data has none unless --grade-tonnage asks)",
                path.display()
            )
        })?;
        std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

fn num(x: Option<f64>) -> String {
    x.map_or_else(|| "-".to_string(), |v| format!("{v:.4}"))
}

fn big(x: Option<f64>) -> String {
    x.map_or_else(|| "-".to_string(), |v| format!("{v:.0}"))
}

/// Prints the bodies' resources, the curve and cross-validation to standard error.
pub fn print(summary: &Summary) {
    let Some(report) = &summary.report else {
        return;
    };
    let u = &report.units;
    for shell in &summary.shells {
        let Some(total) = &shell.resource else {
            continue;
        };
        let r = &total.resource;
        eprintln!(
            "threshold {}: {:.0} m3, {} t at {} {} mean grade, metal {} {} ({} samples inside, mean {})",
            shell.threshold,
            r.volume_m3,
            big(r.tonnes),
            num(r.mean_grade),
            u.grade,
            big(r.metal),
            u.metal,
            total.samples.count,
            num(total.samples.mean),
        );
    }
    if !report.grade_tonnage.is_empty() {
        eprintln!(
            "grade–tonnage: cut-off ({g}) | volume (m3) | tonnes (t) | mean grade ({g}) | metal ({m})",
            g = u.grade,
            m = u.metal
        );
        for row in &report.grade_tonnage {
            let r = &row.resource;
            eprintln!(
                "  {:>8} | {:>12.0} | {:>12} | {:>8} | {:>12}",
                row.cutoff,
                r.volume_m3,
                big(r.tonnes),
                num(r.mean_grade),
                big(r.metal)
            );
        }
    }
    if let Some(cv) = &report.cross_validation {
        eprintln!(
            "cross-validation, {} folds of {} holes ({} samples, {} outside the training mesh): \
             mean abs error {} {g}, bias {} {g}",
            cv.folds,
            cv.holes,
            cv.samples,
            cv.outside_mesh,
            num(cv.grade.mean_abs_error),
            num(cv.grade.bias),
            g = u.grade
        );
        for t in &cv.thresholds {
            eprintln!(
                "  threshold {}: ore inside {} of {}, waste outside {} of {}, balanced accuracy {}",
                t.threshold,
                num(t.ore_inside_share),
                t.ore_samples,
                num(t.waste_outside_share),
                t.waste_samples,
                num(t.balanced_accuracy)
            );
        }
    }
}
