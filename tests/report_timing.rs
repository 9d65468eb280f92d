//! Timings of the resource report on Tom Zone (zinc, 5 % shell), printed, never asserted:
//! the grade–tonnage curve against one shell, cross-validation against one fit.
//! Run: `cargo test --test report_timing -- --ignored --nocapture` (the test profile is
//! optimised, opt-level 2); docs/report.md quotes its output.

use std::time::Instant;

use wellmesh::contour::{self, ContourOptions, Source};
use wellmesh::dmt::{self, Placement, Triangulation};
use wellmesh::progress::NoProgress;
use wellmesh::report::{self, CutoffSweep, DensityField, GradeUnit};
use wellmesh::wells::{Input, InputFile};

fn tom_zone() -> wellmesh::wells::SampleSet {
    let file = |name: &str| {
        let path = format!("sample_wells/tom_zone/{name}");
        InputFile::new(
            path.clone(),
            std::fs::read(&path).expect("sample_wells/tom_zone"),
        )
    };
    Input::from_drillholes(
        file("collar.csv"),
        Some(file("survey.csv")),
        file("assay.csv"),
        Some("Zn_pct"),
    )
    .load()
    .expect("Tom Zone reads")
}

/// The fastest of `runs` timings of `f`, in seconds.
fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..runs {
        let t0 = Instant::now();
        let value = f();
        best = best.min(t0.elapsed().as_secs_f64());
        out = Some(value);
    }
    (best, out.expect("at least one run"))
}

#[test]
#[ignore = "a measurement: run with --ignored --nocapture"]
fn grade_tonnage_and_cross_validation_cost_against_one_shell_and_one_fit() {
    let samples = tom_zone();
    let (points, values): (Vec<_>, Vec<f64>) = samples
        .points
        .iter()
        .zip(&samples.values)
        .filter_map(|(p, v)| v.map(|v| (*p, v)))
        .unzip();
    println!("Tom Zone Zn_pct: {} samples with a value", values.len());

    let (tet_s, mesh) = best(3, || wellmesh::tet::delaunay(&points, &NoProgress).unwrap());
    // One value per vertex, duplicates averaged as the pipeline does.
    let mut sum = vec![0.0; mesh.points.len()];
    let mut count = vec![0.0; mesh.points.len()];
    for (i, &v) in mesh.vertex_of_input.iter().enumerate() {
        sum[v as usize] += values[i];
        count[v as usize] += 1.0;
    }
    let field: Vec<f64> = sum
        .iter()
        .zip(&count)
        .map(|(s, c)| s / f64::max(*c, 1.0))
        .collect();
    let (shell_s, shell) = best(3, || {
        dmt::extract_shell(
            &mesh,
            &field,
            5.0,
            Placement::Ibc,
            Triangulation::default(),
            &NoProgress,
        )
        .unwrap()
    });
    let sweep = CutoffSweep::new(0.0, 38.0, 2.0).unwrap().cutoffs();
    let (curve_s, rows) = best(3, || {
        report::grade_tonnage(
            &mesh,
            &field,
            DensityField::Constant(3.0),
            true,
            1.0,
            GradeUnit::Percent,
            &sweep,
        )
    });
    println!(
        "tetrahedralization {:.3} s ({} tets); one IbC shell at 5 % {:.3} s ({} bodies); \
         {}-cut-off grade–tonnage curve {:.4} s = {:.3} x one shell",
        tet_s,
        mesh.tet_count(),
        shell_s,
        shell.bodies.len(),
        rows.len(),
        curve_s,
        curve_s / shell_s
    );

    let options = |cv: Option<u32>| ContourOptions {
        thresholds: vec![5.0],
        variable: Some("Zn_pct".into()),
        density: Some(3.0),
        cross_validate: cv,
        ..ContourOptions::default()
    };
    let run = |cv| {
        let request = options(cv)
            .into_request(Source::Samples(samples.clone()))
            .unwrap();
        contour::run(&request, &NoProgress).unwrap()
    };
    let (fit_s, _) = best(2, || run(None));
    let (cv_s, result) = best(2, || run(Some(5)));
    let cv = result.summary.report.unwrap().cross_validation.unwrap();
    println!(
        "one fit (contour::run, one shell and the report) {:.3} s; with --cross-validate 5 \
         {:.3} s: cross-validation {:.3} s = {:.2} x one fit, {:.2} x one tetrahedralization \
         ({} samples held out, {} outside the training mesh)",
        fit_s,
        cv_s,
        cv_s - fit_s,
        (cv_s - fit_s) / fit_s,
        (cv_s - fit_s) / tet_s,
        cv.samples,
        cv.outside_mesh
    );
}
