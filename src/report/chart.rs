//! The grade–tonnage chart as SVG: tonnes (or volume, without a density) on the left
//! axis and mean grade on the right, against cut-off.
//!
//! Invariant: every point drawn carries its figures as data attributes
//! (`data-cutoff`, `data-tonnes` or `data-volume`, `data-grade`) written with Rust's
//! shortest round-trip formatting, so a reader (or a test) finds exactly the summary's
//! numbers in the chart. Plain SVG 1.1, no script, no external resource.

use std::fmt::Write;

use super::{GradeTonnageRow, ReportUnits};

const WIDTH: f64 = 720.0;
const HEIGHT: f64 = 420.0;
const LEFT: f64 = 86.0;
const RIGHT: f64 = 86.0;
const TOP: f64 = 48.0;
const BOTTOM: f64 = 56.0;
/// Colours of the two series (tonnes, grade).
const TONNES_COLOUR: &str = "#1f77b4";
const GRADE_COLOUR: &str = "#d95f02";

/// Round tick values covering `[lo, hi]` (about `n` of them) and the axis range they span.
fn ticks(lo: f64, hi: f64, n: usize) -> (Vec<f64>, f64, f64) {
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5 * lo.abs().max(1.0), hi + 0.5 * hi.abs().max(1.0))
    };
    let raw = (hi - lo) / n.max(1) as f64;
    let power = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * power)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * power);
    let first = (lo / step).floor() * step;
    let last = (hi / step).ceil() * step;
    let count = ((last - first) / step).round() as usize;
    let values = (0..=count).map(|i| first + step * i as f64).collect();
    (values, first, last)
}

/// A tick label: short, without float noise.
fn label(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e7).contains(&a) {
        format!("{v:.1e}")
    } else if a >= 1e6 {
        format!("{:.1}M", v / 1e6)
    } else if a >= 1e4 {
        format!("{:.0}k", v / 1e3)
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The plot area's width and height.
const PLOT_W: f64 = WIDTH - LEFT - RIGHT;
const PLOT_H: f64 = HEIGHT - TOP - BOTTOM;

/// The chart of `rows` with `title` (e.g. the variable and the density).
pub fn grade_tonnage_svg(rows: &[GradeTonnageRow], units: &ReportUnits, title: &str) -> String {
    let left = LeftAxis::new(rows, units);
    let frame = Frame::new(rows, &left);
    let mut s = String::new();
    write_axes(&mut s, &frame, &left, units, title);
    write_series(&mut s, &frame, &left, rows, units);
    // Legend.
    let _ = writeln!(
        s,
        r#"<g transform="translate({:.1} {:.1})"><line x1="0" y1="0" x2="24" y2="0" stroke="{TONNES_COLOUR}" stroke-width="2.5"/><text x="30" y="4">{}</text><line x1="110" y1="0" x2="134" y2="0" stroke="{GRADE_COLOUR}" stroke-width="2.5" stroke-dasharray="7 4"/><text x="140" y="4">mean grade</text></g>"#,
        LEFT + 12.0,
        TOP + 16.0,
        left.name
    );
    s.push_str("</svg>\n");
    s
}

/// What the left axis shows: tonnes when any row has them, else volume.
struct LeftAxis {
    tonnes: bool,
    name: &'static str,
    unit: &'static str,
    /// The data attribute carrying a point's figure.
    attr: &'static str,
}

impl LeftAxis {
    fn new(rows: &[GradeTonnageRow], units: &ReportUnits) -> Self {
        let tonnes = rows.iter().any(|r| r.resource.tonnes.is_some());
        let (name, unit, attr) = if tonnes {
            ("tonnes", units.tonnes, "data-tonnes")
        } else {
            ("volume", units.volume, "data-volume")
        };
        Self {
            tonnes,
            name,
            unit,
            attr,
        }
    }

    /// Row `r`'s figure on the left axis.
    fn value(&self, r: &GradeTonnageRow) -> f64 {
        if self.tonnes {
            r.resource.tonnes.unwrap_or(0.0)
        } else {
            r.resource.volume_m3
        }
    }
}

/// The three axes' ticks and ranges (cut-off; tonnes or volume; grade), and where a figure
/// lands on the chart.
struct Frame {
    xs: Vec<f64>,
    x0: f64,
    x1: f64,
    ls: Vec<f64>,
    l0: f64,
    l1: f64,
    gs: Vec<f64>,
    g0: f64,
    g1: f64,
}

impl Frame {
    fn new(rows: &[GradeTonnageRow], left: &LeftAxis) -> Self {
        let cut =
            |f: fn(f64, f64) -> f64, init: f64, v: &dyn Fn(&GradeTonnageRow) -> Option<f64>| {
                rows.iter().filter_map(v).fold(init, f)
            };
        let (xs, x0, x1) = ticks(
            cut(f64::min, f64::INFINITY, &|r| Some(r.cutoff)),
            cut(f64::max, f64::NEG_INFINITY, &|r| Some(r.cutoff)),
            8,
        );
        let (ls, l0, l1) = ticks(0.0, cut(f64::max, 0.0, &|r| Some(left.value(r))), 6);
        let grades = |r: &GradeTonnageRow| r.resource.mean_grade;
        let (gs, g0, g1) = ticks(
            cut(f64::min, f64::INFINITY, &grades).min(0.0),
            cut(f64::max, f64::NEG_INFINITY, &grades).max(0.0),
            6,
        );
        Self {
            xs,
            x0,
            x1,
            ls,
            l0,
            l1,
            gs,
            g0,
            g1,
        }
    }

    fn px(&self, x: f64) -> f64 {
        LEFT + (x - self.x0) / (self.x1 - self.x0) * PLOT_W
    }

    fn py_left(&self, y: f64) -> f64 {
        TOP + PLOT_H - (y - self.l0) / (self.l1 - self.l0) * PLOT_H
    }

    fn py_grade(&self, y: f64) -> f64 {
        TOP + PLOT_H - (y - self.g0) / (self.g1 - self.g0) * PLOT_H
    }
}

/// The SVG's opening, background and title, the grid with its tick labels, the plot's
/// frame and the three axis titles.
fn write_axes(s: &mut String, frame: &Frame, left: &LeftAxis, units: &ReportUnits, title: &str) {
    let (plot_w, plot_h) = (PLOT_W, PLOT_H);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        s,
        r##"<rect width="{WIDTH}" height="{HEIGHT}" fill="#ffffff"/>"##
    );
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" text-anchor="middle" font-size="15" font-weight="bold">{}</text>"#,
        WIDTH / 2.0,
        escape(title)
    );
    for &x in &frame.xs {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" y1="{TOP}" x2="{0:.1}" y2="{1:.1}" stroke="#e0e0e0"/><text x="{0:.1}" y="{2:.1}" text-anchor="middle">{3}</text>"##,
            frame.px(x),
            TOP + plot_h,
            TOP + plot_h + 18.0,
            label(x)
        );
    }
    for &y in &frame.ls {
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="#e0e0e0"/><text x="{2:.1}" y="{3:.1}" text-anchor="end" fill="{TONNES_COLOUR}">{4}</text>"##,
            frame.py_left(y),
            LEFT + plot_w,
            LEFT - 6.0,
            frame.py_left(y) + 4.0,
            label(y)
        );
    }
    for &g in &frame.gs {
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" fill="{GRADE_COLOUR}">{}</text>"#,
            LEFT + plot_w + 6.0,
            frame.py_grade(g) + 4.0,
            label(g)
        );
    }
    let _ = writeln!(
        s,
        r##"<rect x="{LEFT}" y="{TOP}" width="{plot_w}" height="{plot_h}" fill="none" stroke="#333333"/>"##
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">cut-off ({})</text>"#,
        LEFT + plot_w / 2.0,
        HEIGHT - 14.0,
        escape(units.grade)
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate(20 {:.1}) rotate(-90)" text-anchor="middle" fill="{TONNES_COLOUR}">{} ({})</text>"#,
        TOP + plot_h / 2.0,
        left.name,
        escape(left.unit)
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate({:.1} {:.1}) rotate(90)" text-anchor="middle" fill="{GRADE_COLOUR}">mean grade ({})</text>"#,
        WIDTH - 18.0,
        TOP + plot_h / 2.0,
        escape(units.grade)
    );
}

/// The two series as lines, and every row's points carrying its figures.
fn write_series(
    s: &mut String,
    frame: &Frame,
    left: &LeftAxis,
    rows: &[GradeTonnageRow],
    units: &ReportUnits,
) {
    let path = |points: Vec<(f64, f64)>| {
        points
            .iter()
            .enumerate()
            .map(|(i, (x, y))| format!("{}{x:.2},{y:.2}", if i == 0 { "M" } else { " L" }))
            .collect::<String>()
    };
    let left_points: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (frame.px(r.cutoff), frame.py_left(left.value(r))))
        .collect();
    let grade_points: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            r.resource
                .mean_grade
                .map(|g| (frame.px(r.cutoff), frame.py_grade(g)))
        })
        .collect();
    let _ = writeln!(
        s,
        r#"<path class="tonnes" d="{}" fill="none" stroke="{TONNES_COLOUR}" stroke-width="2.5"/>"#,
        path(left_points)
    );
    let _ = writeln!(
        s,
        r#"<path class="grade" d="{}" fill="none" stroke="{GRADE_COLOUR}" stroke-width="2.5" stroke-dasharray="7 4"/>"#,
        path(grade_points)
    );
    let (left_name, left_attr) = (left.name, left.attr);
    for r in rows {
        let grade_attr = r
            .resource
            .mean_grade
            .map(|g| format!(r#" data-grade="{g}""#))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            r#"<circle class="point" cx="{:.2}" cy="{:.2}" r="3.5" fill="{TONNES_COLOUR}" data-cutoff="{}" {left_attr}="{}"{grade_attr}><title>cut-off {} {}: {left_name} {} {}, mean grade {}</title></circle>"#,
            frame.px(r.cutoff),
            frame.py_left(left.value(r)),
            r.cutoff,
            left.value(r),
            r.cutoff,
            escape(units.grade),
            label(left.value(r)),
            escape(left.unit),
            r.resource
                .mean_grade
                .map(label)
                .unwrap_or_else(|| "-".into()),
        );
        if let Some(g) = r.resource.mean_grade {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.2}" cy="{:.2}" r="3" fill="{GRADE_COLOUR}"/>"#,
                frame.px(r.cutoff),
                frame.py_grade(g)
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::{GradeUnit, Resource};

    fn row(cutoff: f64, tonnes: Option<f64>, grade: Option<f64>) -> GradeTonnageRow {
        GradeTonnageRow {
            cutoff,
            resource: Resource {
                volume_m3: 10.0,
                tonnes,
                mean_grade: grade,
                metal: None,
                metal_oz: None,
            },
        }
    }

    #[test]
    fn every_point_carries_its_figures_exactly() {
        let rows = vec![
            row(0.0, Some(1234.5678), Some(1.25)),
            row(0.5, Some(0.1 + 0.2), Some(2.0 / 3.0)),
            row(1.0, Some(0.0), None),
        ];
        let svg = grade_tonnage_svg(&rows, &ReportUnits::new(GradeUnit::Percent), "Zn <pct>");
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("Zn &lt;pct&gt;"));
        assert!(svg.contains(
            r#"data-cutoff="0.5" data-tonnes="0.30000000000000004" data-grade="0.6666666666666666""#
        ));
        assert!(svg.contains(r#"data-cutoff="1" data-tonnes="0"><title>"#));
        assert_eq!(svg.matches(r#"class="point""#).count(), 3);
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let (t, lo, hi) = ticks(0.0, 38.0, 8);
        assert_eq!((lo, hi), (0.0, 40.0));
        assert_eq!(t, vec![0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0]);
        let (t, lo, hi) = ticks(3.0, 3.0, 6);
        assert!(lo < 3.0 && hi > 3.0 && t.len() >= 2);
        assert_eq!(label(2_500_000.0), "2.5M");
        assert_eq!(label(0.25), "0.25");
    }
}
