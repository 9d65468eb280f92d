//! Reading the samples CSV, the wells JSON and drill-hole tables: aliases, BOM, don't-know
//! values, below detection, categorical codes, composites, duplicates, and errors that name
//! file, line and column. Uses only inline data and `sample_wells/`.

use wellmesh::wells::{BelowDetection, Input, InputFile, WellsError};

fn samples(text: &str) -> Result<wellmesh::wells::SampleSet, WellsError> {
    Input::from_samples_csv("s.csv", text).load()
}

#[test]
fn samples_csv_with_aliases_bom_and_crlf_is_read_around_the_bbox_centre() {
    let text = "\u{feff}HOLE_ID;Easting;Northing;RL;Grade\r\nA;500000;7000000;100;1.5\r\nA;500000;7000000;90;NA\r\nB;500010;7000020;80;?\r\n";
    let set = samples(text).unwrap();
    assert_eq!(set.points.len(), 3);
    assert_eq!(set.wells.len(), 2);
    assert_eq!(set.origin.to_array(), [500005.0, 7000010.0, 90.0]);
    assert_eq!(set.points[0].to_array(), [-5.0, -10.0, 10.0]);
    assert_eq!(set.values, vec![Some(1.5), None, None]);
    assert_eq!(set.report.unknown_values, 2);
    assert_eq!(set.well_of, vec![0, 0, 1]);
    assert_eq!(set.unit, "m");
}

#[test]
fn a_value_that_is_not_a_number_names_line_and_column() {
    let e = samples("well,x,y,z,value\nA,1,2,3,0.5\nA,1,2,4,high\n").unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("s.csv, line 3, column 'value'") && text.contains("'high'"),
        "{text}"
    );
}

#[test]
fn a_row_with_more_fields_than_the_header_is_an_error_not_a_lost_value() {
    // A decimal comma in a comma-separated file: the grade 1,5 would otherwise be read
    // as 1 and its 5 dropped.
    let e = samples("well,x,y,z,value\nA,1,2,3,0.5\nA,1,2,4,1,5\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.csv, line 3")
            && e.contains("6 fields, but the header names 5 columns")
            && e.contains("'5'"),
        "{e}"
    );
    // Trailing empty fields (a trailing delimiter, as spreadsheets write) are harmless.
    let set = samples("well,x,y,z,value\nA,1,2,3,0.5,\nA,1,2,4,1.5,,\n").unwrap();
    assert_eq!(set.values, vec![Some(0.5), Some(1.5)]);
}

#[test]
fn nan_and_infinite_coordinates_are_errors_naming_line_and_column() {
    for bad in ["NaN", "inf", "-inf"] {
        let e = samples(&format!("well,x,y,z,value\nA,1,2,3,1\nA,1,{bad},4,1\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3, column 'y'"), "{e}");
    }
    let e = samples("well,x,y,z,value\nA,1,,3,1\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 2, column 'y'") && e.contains("empty"),
        "{e}"
    );
}

#[test]
fn empty_inputs_are_errors() {
    assert!(matches!(samples(""), Err(WellsError::Empty { .. })));
    assert!(matches!(
        samples("well,x,y,z,value\n"),
        Err(WellsError::Empty { .. })
    ));
    assert!(matches!(Input::default().load(), Err(WellsError::NoInput)));
    let e = samples("a,b\n1,2\n").unwrap_err().to_string();
    assert!(e.contains("columns found: a, b"), "{e}");
}

#[test]
fn two_kinds_of_input_at_once_are_refused() {
    let mut input = Input::from_samples_csv("s.csv", "well,x,y,z,value\nA,1,2,3,1\n");
    input.wells_json = Some(InputFile::new("w.json", "{}"));
    assert!(matches!(input.load(), Err(WellsError::MixedInput(_))));
}

#[test]
fn wells_json_reads_depths_elevations_nulls_and_crs() {
    let json = r#"{"crs": "EPSG:32633", "wells": [
        {"id": "W1", "x": 500000, "y": 7000000, "z": 100,
         "samples": [{"depth": 10, "value": 1}, {"depth": 20, "value": null}]},
        {"id": "W2", "x": 500100, "y": 7000000,
         "samples": [{"z": 95, "value": 0}]}]}"#;
    let set = Input::from_wells_json("w.json", json).load().unwrap();
    assert_eq!(set.crs.as_deref(), Some("EPSG:32633"));
    assert_eq!(set.points.len(), 3);
    assert_eq!((set.points[0] + set.origin).z, 90.0);
    assert_eq!(set.values, vec![Some(1.0), None, Some(0.0)]);
    assert_eq!(set.report.unknown_values, 1);
}

#[test]
fn wells_json_errors_name_the_path() {
    let cases = [
        (
            r#"{"wells": [{"id": "A", "x": 1, "y": 2, "samples": [{"depth": 1, "value": 1}]}]}"#,
            "wells[0].samples[0].depth",
        ),
        (
            r#"{"wells": [{"id": "A", "x": "abc", "y": 2}]}"#,
            "wells[0].x",
        ),
        (
            r#"{"wells": [{"id": "A", "x": 1, "y": 2, "z": 0, "samples": [{"depth": 1, "value": "lots"}]}]}"#,
            "wells[0].samples[0].value",
        ),
        (r#"{"wells": []}"#, "empty"),
        (r#"{"wells": [1,"#, "line 1"),
    ];
    for (json, needle) in cases {
        let e = Input::from_wells_json("w.json", json)
            .load()
            .unwrap_err()
            .to_string();
        assert!(e.contains("w.json") && e.contains(needle), "{e}");
    }
}

const COLLARS: &str =
    "HOLEID,EAST,NORTH,RL,DEPTH\nH1,1000,2000,300,50\nH2,1100,2000,300,40\nH3,1200,2000,300,40\n";

fn tables(intervals: &str, variable: Option<&str>) -> Input {
    Input::from_drillholes(
        InputFile::new("collar.csv", COLLARS),
        None,
        InputFile::new("assay.csv", intervals),
        variable,
    )
}

#[test]
fn intervals_become_midpoint_samples_with_below_detection_counted() {
    let assays = "hole_id,depth_from,depth_to,Cu_pct,Au_ppm\nH1,0,2,<0.01,1\nH1,2,4,-0.02,\nH1,4,6,NA,2\nH1,6,8,1.25,3\nH1,10,12,0.5,1\n";
    let set = tables(assays, Some("cu_pct")).load().unwrap();
    // 5 intervals + 1 gap (8..10) as a don't-know sample.
    assert_eq!(
        set.values,
        vec![Some(0.005), Some(0.01), None, Some(1.25), None, Some(0.5)]
    );
    assert_eq!(set.report.below_detection, 2);
    assert_eq!(set.report.gaps, 1);
    assert_eq!(set.report.unknown_values, 2);
    assert_eq!((set.points[0] + set.origin).z, 299.0);
    assert_eq!(set.report.holes_without_samples, 2);

    let mut zero = tables(assays, Some("Cu_pct"));
    zero.below_detection = BelowDetection::Zero;
    zero.negative_is_below_detection = Some(false);
    let set = zero.load().unwrap();
    assert_eq!(set.values[0], Some(0.0));
    assert_eq!(set.values[1], Some(-0.02));
}

#[test]
fn several_value_columns_without_a_variable_is_an_error_listing_them() {
    let e = tables("hole_id,from,to,Cu,Au\nH1,0,1,1,1\n", None)
        .load()
        .unwrap_err()
        .to_string();
    assert!(e.contains("--variable") && e.contains("Cu, Au"), "{e}");
}

#[test]
fn text_in_a_numeric_interval_column_names_line_and_column() {
    let e = tables("hole_id,from,to,code\nH1,0,1,0.5\nH1,1,2,MS\n", None)
        .load()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("assay.csv, line 3, column 'code'") && e.contains("--inside"),
        "{e}"
    );
}

#[test]
fn categorical_codes_become_zero_one_and_composites_average_them() {
    let geology = "hole_id,from,to,lith\nH1,0,1,MS\nH1,1,2,ms\nH1,2,3,SED\nH1,3,4,\nH2,0,4,MS\n";
    let mut input = tables(geology, Some("lith"));
    input.inside_codes = vec!["MS".into()];
    let set = input.load().unwrap();
    assert_eq!(
        set.values,
        vec![Some(1.0), Some(1.0), Some(0.0), None, Some(1.0)]
    );

    input.composite_length = Some(2.0);
    let set = input.load().unwrap();
    // H1: [0,2) = 1, [2,4) = half known (0) -> 0; H2: [0,2), [2,4) = 1.
    assert_eq!(set.values, vec![Some(1.0), Some(0.0), Some(1.0), Some(1.0)]);
    assert_eq!((set.points[0] + set.origin).z, 299.0);
}

#[test]
fn duplicate_overlapping_orphan_and_reversed_intervals_are_counted() {
    let assays = "hole_id,from,to,cu\nH1,0,2,1\nH1,0,2,9\nH1,1,3,2\nH1,5,4,1\nH1,6,6,1\nZZ,0,1,1\nH2,0,1,1\n";
    let set = tables(assays, None).load().unwrap();
    let r = &set.report;
    assert_eq!(r.duplicate_intervals, 1);
    assert_eq!(r.overlapping_intervals, 1);
    assert_eq!(r.bad_intervals, 2);
    assert_eq!(r.intervals_without_collar, 1);
    assert_eq!(r.rows_read, 7);
    // H1 keeps 0-2 (value 1) and 2-3 (clipped, value 2); H2 keeps 0-1.
    assert_eq!(set.values, vec![Some(1.0), Some(2.0), Some(1.0)]);
    let joined = r.warnings.join("\n");
    assert!(
        joined.contains("hole H1 line 3 repeats line 2, different value"),
        "{joined}"
    );
    assert!(joined.contains("ZZ"), "{joined}");
}

#[test]
fn a_bad_composite_length_is_refused() {
    let mut input = tables("hole_id,from,to,cu\nH1,0,2,1\n", None);
    input.composite_length = Some(0.0);
    assert!(matches!(input.load(), Err(WellsError::BadOption(_))));
    input.composite_length = Some(1e-9);
    let e = input.load().unwrap_err().to_string();
    assert!(e.contains("composites"), "{e}");
}

#[test]
fn feet_are_kept_and_stated() {
    let mut input = tables("hole_id,from,to,cu\nH1,0,2,1\n", None);
    input.unit = Some("ft".into());
    assert_eq!(input.load().unwrap().unit, "ft");
    input.unit = Some("yards".into());
    assert!(matches!(input.load(), Err(WellsError::BadOption(_))));
}

fn sample_file(name: &str) -> InputFile {
    let path = format!("{}/sample_wells/{name}", env!("CARGO_MANIFEST_DIR"));
    InputFile::new(name, std::fs::read(&path).expect(&path))
}

#[test]
fn the_synthetic_copper_wells_are_thirteen_wells_of_nine_to_43_zero_one_samples() {
    let set = Input {
        samples_csv: Some(sample_file("copper_wells.csv")),
        ..Input::default()
    }
    .load()
    .unwrap();
    assert_eq!(set.wells.len(), 13);
    for w in 0..13u32 {
        let n = set.well_of.iter().filter(|&&i| i == w).count();
        assert!((9..=43).contains(&n), "well {w}: {n} samples");
    }
    let s = set.summary();
    assert!(s.binary);
    assert!(set.values.contains(&Some(1.0)));
    assert_eq!(s.unknown_values, 0);
}

#[test]
fn the_synthetic_grade_wells_are_247_wells_at_utm_coordinates() {
    let set = Input {
        samples_csv: Some(sample_file("copper_grade.csv")),
        ..Input::default()
    }
    .load()
    .unwrap();
    assert_eq!(set.wells.len(), 247);
    assert_eq!(set.points.len(), 10012);
    assert!(set.origin.x > 5e5 && set.origin.y > 7e6);
    let [lo, hi] = set.summary().value_range.unwrap();
    assert_eq!(lo, 0.0);
    assert!(hi > 1.5 && hi <= 2.0, "{hi}");
}

#[test]
fn the_shipped_tom_zone_tables_load_with_their_gaps_and_up_holes_counted() {
    let set = Input::from_drillholes(
        sample_file("tom_zone/collar.csv"),
        Some(sample_file("tom_zone/survey.csv")),
        sample_file("tom_zone/assay.csv"),
        Some("Zn_pct"),
    )
    .load()
    .unwrap();
    let r = &set.report;
    assert_eq!(r.holes_read, 273);
    assert_eq!(r.holes_used, 206);
    assert_eq!(r.holes_without_samples, 67);
    assert_eq!(r.rows_read, 6215);
    assert_eq!(r.gaps, 471);
    assert_eq!(r.dip_convention.as_deref(), Some("negative-down"));
    assert!(r.up_holes > 0);
    assert!(
        set.points
            .iter()
            .all(|p| p.is_finite() && p.length() < 5000.0)
    );
}
