//! The 13 deliberately broken LAS files of `../shared/data/las_kansas_alberta_broken`: each
//! reads cleanly (with the defect repaired and noted) or fails with an error naming the file
//! and line; none panics. Skipped with a note when the shared corpus is absent (`common`).

mod common;

use wellmesh::wells::{Input, InputFile, las};

fn data(name: &str) -> Option<(String, Vec<u8>)> {
    let path = common::shared_data(&format!("las_kansas_alberta_broken/{name}"))?;
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Some((name.to_owned(), bytes))
}

/// Reads the file, checks the depth rows against the header's STRT/STOP/STEP, and loads it
/// through the whole `Input` path with a one-row locations table, contouring `curve`.
fn check(name: &str, curve: &str, warning: Option<&str>) -> Option<las::LasFile> {
    let (name, bytes) = data(name)?;
    let file = las::parse(&name, &bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(file.curves.len() >= 2, "{name}: curves");
    let header = |m: &str| -> f64 { file.item(m).unwrap().data.trim().parse().unwrap() };
    let (start, stop, step) = (header("STRT"), header("STOP"), header("STEP"));
    let first = file.rows[0][0].unwrap();
    let last = file.rows.last().unwrap()[0].unwrap();
    assert!(
        (first - start).abs() < 1e-3,
        "{name}: first depth {first} is STRT {start}"
    );
    assert!(
        (last - stop).abs() < 1e-3,
        "{name}: last depth {last} is STOP {stop}"
    );
    if step != 0.0 {
        let expected = ((stop - start) / step).round() as usize + 1;
        assert_eq!(file.rows.len(), expected, "{name}: one row per STEP");
    }
    assert!(file.rows.iter().all(|r| r.len() == file.curves.len()));
    match warning {
        Some(w) => assert!(
            file.warnings.iter().any(|x| x.contains(w)),
            "{name}: expected a warning with {w:?}, got {:?}",
            file.warnings
        ),
        None => assert!(file.warnings.is_empty(), "{name}: {:?}", file.warnings),
    }
    let locations = format!("file,x,y,kb\n{name},500000,6000000,700\n");
    let input = Input::from_las(
        vec![InputFile::new(name.clone(), bytes)],
        Some(InputFile::new("locations.csv", locations)),
        curve,
    );
    let set = input.load().unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(set.wells.len(), 1);
    assert_eq!(set.report.rows_read, file.rows.len());
    assert_eq!(
        set.report.unknown_values,
        set.values.iter().filter(|v| v.is_none()).count()
    );
    Some(file)
}

#[test]
fn ex1_data_and_description_swapped_reads_the_well_name_from_the_description() {
    if let Some(f) = check("ex1_1044859098.las", "GR", None) {
        assert_eq!(f.text("WELL").as_deref(), Some("Roger SWD 1"));
    }
}

#[test]
fn ex2_start_below_stop_with_depth_listed_last_in_curves_reads_depth_first() {
    if let Some(f) = check("ex2_1046102222.las", "GR", Some("~A line lists the curves")) {
        assert_eq!(f.curves[0].mnemonic, "DEPT");
        assert!(
            f.rows[0][0] > f.rows[1][0],
            "depth decreases (negative STEP)"
        );
    }
}

#[test]
fn ex4_missing_parameter_section_reads_the_survey_curves() {
    if let Some(f) = check("ex4_1044782786.las", "INC", None) {
        assert!(f.parameters.is_empty());
        assert_eq!(f.curves[1].mnemonic, "INC");
    }
}

#[test]
fn ex4_without_the_requested_curve_is_an_error_naming_the_curve() {
    if let Some((name, bytes)) = data("ex4_1044782786.las") {
        let input = Input::from_las(
            vec![InputFile::new(name, bytes)],
            Some(InputFile::new(
                "l.csv",
                "file,x,y\nex4_1044782786.las,1,2\n",
            )),
            "GR",
        );
        let e = input.load().unwrap_err().to_string();
        assert!(
            e.contains("ex4_1044782786.las") && e.contains("'GR'"),
            "{e}"
        );
    }
}

#[test]
fn ex5_unknown_defect_reads_cleanly() {
    check("ex5_1045399772.las", "GR_EDTC", None);
}

#[test]
fn ex9_1046102218_depth_not_first_in_curves_uses_the_data_line_order() {
    if let Some(f) = check("ex9_1046102218.las", "GR", Some("~A line lists the curves")) {
        assert_eq!(f.curves[0].mnemonic, "DEPT");
    }
}

#[test]
fn ex9_1046102267_depth_not_first_in_curves_uses_the_data_line_order() {
    check("ex9_1046102267.las", "GR", Some("~A line lists the curves"));
}

#[test]
fn ex9_1046102271_depth_not_first_in_curves_uses_the_data_line_order() {
    check("ex9_1046102271.las", "GR", Some("~A line lists the curves"));
}

#[test]
fn ex10_blank_lines_in_header_and_a_trailing_fragment_read_cleanly() {
    check(
        "ex10_1046102494.las",
        "GR",
        Some("line 6315: an incomplete last line"),
    );
}

#[test]
fn ex11_1046102494_fragment_of_numbers_at_end_is_dropped_with_its_line() {
    check(
        "ex11_1046102494.las",
        "GR",
        Some("line 6312: an incomplete last line"),
    );
}

#[test]
fn ex11_1046139290_fragment_of_numbers_at_end_is_dropped_with_its_line() {
    check(
        "ex11_1046139290.las",
        "GR",
        Some("line 6311: an incomplete last line"),
    );
}

#[test]
fn ex13_a_remark_broken_over_lines_is_skipped_with_its_line_numbers() {
    let skipped = "2 header lines without 'MNEMONIC.' skipped: line 105; line 107";
    if let Some(f) = check("ex13_1046410674.las", "GR", Some(skipped)) {
        assert_eq!(f.version.as_deref(), Some("1.2"));
        assert_eq!(f.text("WELL").as_deref(), Some("FORD LAND & CATTLE 12-1"));
    }
}

#[test]
fn mcmurray_00_10_04_081_05w4_reads_cleanly_in_metres() {
    if let Some(f) = check("00-10-04-081-05W4-0.LAS", "GR", None) {
        assert_eq!(f.depth_unit().as_deref(), Some("M"));
    }
}

#[test]
fn mcmurray_00_10_26_083_05w4_reads_cleanly_with_unit_meter() {
    if let Some(f) = check("00-10-26-083-05W4-0.LAS", "GR", None) {
        assert_eq!(f.depth_unit().as_deref(), Some("METER"));
        assert_eq!(f.rows[0][1], None, "NULL -999.25 is don't know");
    }
}

#[test]
fn without_a_location_a_las_well_is_an_error_naming_the_file() {
    if let Some((name, bytes)) = data("ex1_1044859098.las") {
        let e = Input::from_las(vec![InputFile::new(name, bytes)], None, "GR")
            .load()
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("ex1_1044859098.las:") && e.contains("locations"),
            "{e}"
        );
    }
}
