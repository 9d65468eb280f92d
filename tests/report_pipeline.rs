//! The resource report through the whole pipeline: on a linear grade in a box of vertical
//! holes the tonnes and mean grades are the closed form; the summary, the CSV and the
//! chart hold the same figures; cross-validation predicts a linear field exactly.

use glam::DVec3;
use serde_json::Value;
use wellmesh::contour::{self, ContourOptions, Source};
use wellmesh::export::{self, OutputOptions};
use wellmesh::progress::NoProgress;
use wellmesh::wells::{ReadReport, SampleSet, Well};

const ORIGIN: DVec3 = DVec3::new(600_000.0, 7_100_000.0, 500.0);

/// `n x n` vertical holes 10 apart (x and y from 0 to 10(n-1)), sampled every 2 from z = 0
/// down to z = -40, valued by `field` (local coordinates). Holes are named `H00`, `H01`...
fn box_of_holes(n: usize, field: impl Fn(DVec3) -> f64) -> SampleSet {
    let mut points = Vec::new();
    let mut values = Vec::new();
    let mut well_of = Vec::new();
    let mut wells = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let collar = DVec3::new(10.0 * i as f64, 10.0 * j as f64, 0.0);
            wells.push(Well {
                id: format!("H{:02}", wells.len()),
                collar,
                trace: vec![collar, collar - DVec3::Z * 40.0],
            });
            for k in 0..=20 {
                let p = collar - DVec3::Z * (2.0 * k as f64);
                points.push(p);
                values.push(Some(field(p)));
                well_of.push((wells.len() - 1) as u32);
            }
        }
    }
    SampleSet {
        origin: ORIGIN,
        crs: Some("EPSG:32633".into()),
        unit: "m".into(),
        wells,
        points,
        values,
        well_of,
        report: ReadReport::default(),
    }
}

/// f = 1 + x/10 + (-z)/20: from 1 to 1 + (n-1) + 2.
fn linear(p: DVec3) -> f64 {
    1.0 + p.x / 10.0 - p.z / 20.0
}

/// Runs on the samples' own tetrahedra (the linear interpolant) unless `options` names
/// another: the closed forms here are of the linear interpolation of the samples.
fn run(samples: SampleSet, options: ContourOptions) -> contour::ContourResult {
    let options = ContourOptions {
        interpolant: options.interpolant.clone().or(Some("linear".into())),
        ..options
    };
    let request = options
        .into_request(Source::Samples(samples))
        .expect("valid options");
    contour::run(&request, &NoProgress).expect("the pipeline runs")
}

/// The exact volume and ∫f of {f >= t} in the box [0,a]×[0,a]×[-40,0] for `linear`, by
/// integrating over x in slabs (f >= t  <=>  -z >= 20(t - 1 - x/10)).
fn closed_form(a: f64, t: f64) -> (f64, f64) {
    // For fixed x, depth d = -z in [0, 40]; f = c + d/20 with c = 1 + x/10; f >= t for
    // d >= 20(t - c). Integrate numerically in x exactly: the integrand is piecewise
    // polynomial in x, so a fine Simpson rule on each piece is exact to rounding.
    let slab = |x: f64| {
        let c = 1.0 + x / 10.0;
        let d0 = (20.0 * (t - c)).clamp(0.0, 40.0);
        let len = 40.0 - d0;
        // ∫_{d0}^{40} (c + d/20) dd
        let int = c * len + (40.0f64.powi(2) - d0 * d0) / 40.0;
        (len * a, int * a)
    };
    // Breakpoints where d0 hits 0 or 40.
    let mut cuts = vec![0.0, a];
    for d in [0.0, 40.0] {
        let x = 10.0 * (t - 1.0 - d / 20.0);
        if x > 0.0 && x < a {
            cuts.push(x);
        }
    }
    cuts.sort_by(f64::total_cmp);
    let (mut v, mut g) = (0.0, 0.0);
    for w in cuts.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        let mid = (lo + hi) / 2.0;
        let (a0, b0) = slab(lo);
        let (a1, b1) = slab(mid);
        let (a2, b2) = slab(hi);
        v += (hi - lo) / 6.0 * (a0 + 4.0 * a1 + a2);
        g += (hi - lo) / 6.0 * (b0 + 4.0 * b1 + b2);
    }
    (v, g)
}

#[test]
fn tonnes_and_mean_grade_of_a_linear_grade_are_the_closed_form() {
    let n = 5;
    let a = 10.0 * (n - 1) as f64;
    let result = run(
        box_of_holes(n, linear),
        ContourOptions {
            thresholds: vec![2.5, 4.0],
            variable: Some("Zn_pct".into()),
            density: Some(2.8),
            ..ContourOptions::default()
        },
    );
    let report = result.summary.report.as_ref().expect("a report");
    assert_eq!(report.units.grade, "%");
    assert_eq!(report.units.metal, "t");
    for shell in &result.summary.shells {
        let (v, g) = closed_form(a, shell.threshold);
        assert_eq!(shell.bodies.len(), 1);
        let body = shell.bodies[0].resource.expect("body resource");
        let r = body.resource;
        assert!(
            (r.volume_m3 - v).abs() <= 1e-9 * v,
            "{} vs {v}",
            r.volume_m3
        );
        let tonnes = r.tonnes.unwrap();
        assert!((tonnes - 2.8 * v).abs() <= 1e-9 * tonnes);
        let grade = r.mean_grade.unwrap();
        assert!(
            (grade - g / v).abs() <= 1e-9 * grade,
            "{grade} vs {}",
            g / v
        );
        let metal = r.metal.unwrap();
        assert!((metal - tonnes * grade / 100.0).abs() <= 1e-9 * metal);
        // The DMT body is balanced to the same support (to f32 positions and the balance's
        // tolerance).
        assert!((shell.bodies[0].volume - v).abs() <= 1e-3 * v);
        // Samples inside: exactly those at or above the threshold.
        let inside: Vec<f64> = box_of_holes(n, linear)
            .values
            .iter()
            .flatten()
            .copied()
            .filter(|&x| x >= shell.threshold)
            .collect();
        assert_eq!(body.samples.count, inside.len());
        let min = inside.iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(body.samples.min, Some(min));
        assert_eq!(shell.resource.unwrap().resource, r);
    }
}

#[test]
fn an_anisotropic_frame_and_feet_leave_the_report_in_cubic_metres() {
    let n = 4;
    let a = 10.0 * (n - 1) as f64;
    let t = 2.5;
    let (v, g) = closed_form(a, t);
    let mut feet = box_of_holes(n, linear);
    feet.unit = "ft".into();
    let result = run(
        feet,
        ContourOptions {
            thresholds: vec![t],
            anisotropy: Some([1.0, 2.0, 5.0]),
            azimuth: Some(30.0),
            density: Some(2.0),
            ..ContourOptions::default()
        },
    );
    let r = result.summary.shells[0].resource.unwrap().resource;
    let cubic_foot = 0.3048f64.powi(3);
    assert!((r.volume_m3 - v * cubic_foot).abs() <= 1e-9 * r.volume_m3);
    assert!((r.mean_grade.unwrap() - g / v).abs() <= 1e-9 * g / v);
    assert_eq!(
        result.summary.report.as_ref().unwrap().units.grade,
        "as given"
    );
}

/// The numbers in a CSV line.
fn csv_numbers(line: &str) -> Vec<Option<f64>> {
    line.split(',').map(|c| c.parse::<f64>().ok()).collect()
}

/// An attribute's value in one SVG element's text.
fn attribute(element: &str, name: &str) -> Option<f64> {
    let start = element.find(&format!(" {name}=\""))? + name.len() + 3;
    let end = start + element[start..].find('"')?;
    element[start..end].parse().ok()
}

#[test]
fn the_summary_the_csv_and_the_chart_hold_the_same_figures() {
    let result = run(
        box_of_holes(4, linear),
        ContourOptions {
            thresholds: vec![2.5],
            variable: Some("Au_gpt".into()),
            density: Some(2.7),
            grade_tonnage: Some("1:5:0.25".into()),
            ..ContourOptions::default()
        },
    );
    let outputs = export::all_outputs(&result, &OutputOptions::default()).unwrap();
    let get = |id: &str| {
        String::from_utf8(outputs.iter().find(|o| o.id == id).unwrap().bytes.clone()).unwrap()
    };
    // The summary as written (serde_json with `float_roundtrip` parses it back exactly),
    // the CSV and the chart: the same numbers to the last bit.
    let summary: Value = serde_json::from_str(&get("summary")).unwrap();
    let json_rows = summary["report"]["grade_tonnage"].as_array().unwrap();
    let report = result.summary.report.as_ref().unwrap();
    let rows = &report.grade_tonnage;
    assert_eq!(rows.len(), 17);
    assert_eq!(json_rows.len(), rows.len());
    assert_eq!(summary["report"]["units"]["metal"], "g");
    let csv = get("report");
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "cutoff_gpt,volume_m3,tonnes_t,mean_grade_gpt,metal_g"
    );
    let svg = get("chart");
    let points: Vec<&str> = svg
        .split("<circle ")
        .filter(|e| e.contains("class=\"point\""))
        .collect();
    assert_eq!(points.len(), rows.len());
    let close = |a: Option<f64>, b: Option<f64>| a == b;
    for (((row, json), line), point) in rows.iter().zip(json_rows).zip(lines).zip(points) {
        let r = &row.resource;
        let csv = csv_numbers(line);
        assert_eq!(csv[0], Some(row.cutoff));
        assert_eq!(csv[1], Some(r.volume_m3));
        assert_eq!(csv[2], r.tonnes);
        assert_eq!(csv[3], r.mean_grade);
        assert_eq!(csv[4], r.metal);
        assert_eq!(attribute(point, "data-cutoff"), Some(row.cutoff));
        assert_eq!(attribute(point, "data-tonnes"), r.tonnes);
        assert_eq!(attribute(point, "data-grade"), r.mean_grade);
        assert!(close(json["cutoff"].as_f64(), Some(row.cutoff)));
        assert!(close(json["volume_m3"].as_f64(), Some(r.volume_m3)));
        assert!(close(json["tonnes"].as_f64(), r.tonnes));
        assert!(close(json["mean_grade"].as_f64(), r.mean_grade));
        assert!(close(json["metal"].as_f64(), r.metal));
        // Ounces beside grams.
        if let (Some(metal), Some(oz)) = (r.metal, r.metal_oz) {
            assert!((oz * 31.1034768 - metal).abs() <= 1e-9 * metal.max(1.0));
        }
    }
    // Tonnes fall and mean grade rises with the cut-off.
    let tonnes: Vec<f64> = rows.iter().map(|r| r.resource.tonnes.unwrap()).collect();
    assert!(tonnes.windows(2).all(|w| w[1] <= w[0]));
}

#[test]
fn cross_validation_predicts_a_linear_field_exactly_inside_and_counts_the_rest() {
    let n = 5;
    let result = run(
        box_of_holes(n, linear),
        ContourOptions {
            thresholds: vec![2.5, 4.0],
            cross_validate: Some(5),
            ..ContourOptions::default()
        },
    );
    let cv = result
        .summary
        .report
        .as_ref()
        .unwrap()
        .cross_validation
        .as_ref()
        .expect("cross-validation");
    assert_eq!(cv.folds, 5);
    assert_eq!(cv.holes, n * n);
    assert_eq!(cv.samples, n * n * 21);
    assert_eq!(cv.per_hole.len(), n * n);
    // Holes on the hull's edges fall outside the others' hull when held out; interior
    // holes are predicted exactly (the field is linear).
    assert!(cv.outside_mesh > 0 && cv.outside_mesh < cv.samples);
    assert!(cv.grade.mean_abs_error.unwrap() < 1e-9);
    assert!(cv.grade.bias.unwrap().abs() < 1e-9);
    for hole in &cv.per_hole {
        let index: usize = hole.hole[1..].parse().unwrap();
        assert_eq!(hole.fold as usize, index % 5);
        let (i, j) = (index / n, index % n);
        let interior = i > 0 && i < n - 1 && j > 0 && j < n - 1;
        if interior {
            assert_eq!(hole.outside_mesh, 0, "{}", hole.hole);
        }
    }
    // Every sample predicted inside the mesh is on the right side (the field is exact),
    // so the ore share misses exactly the ore samples outside the mesh.
    for t in &cv.thresholds {
        assert!(t.balanced_accuracy.unwrap() > 0.5);
        assert_eq!(t.waste_outside_share, Some(1.0));
    }
}

#[test]
fn bad_report_options_name_the_option() {
    let bad = [
        (
            ContourOptions {
                density: Some(-1.0),
                ..ContourOptions::default()
            },
            "density",
        ),
        (
            ContourOptions {
                density: Some(2.0),
                density_column: Some("SG".into()),
                ..ContourOptions::default()
            },
            "density_column",
        ),
        (
            ContourOptions {
                grade_tonnage: Some("5:1:1".into()),
                ..ContourOptions::default()
            },
            "grade_tonnage",
        ),
        (
            ContourOptions {
                cross_validate: Some(1),
                ..ContourOptions::default()
            },
            "cross_validate",
        ),
    ];
    for (options, field) in bad {
        let mut options = options;
        options.thresholds = vec![1.0];
        assert_eq!(options.check().unwrap_err().field, field);
    }
    // More folds than holes: refused when run, naming the option.
    let request = ContourOptions {
        thresholds: vec![2.5],
        cross_validate: Some(10),
        ..ContourOptions::default()
    }
    .into_request(Source::Samples(box_of_holes(3, linear)))
    .unwrap();
    let err = contour::run(&request, &NoProgress).unwrap_err();
    assert!(err.to_string().contains("10 folds for 9 holes"), "{err}");
}
