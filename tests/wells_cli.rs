//! `wellmesh inspect` end to end: text and JSON reports, and errors with exit code 1 that
//! name the file and line.

use std::process::Command;

fn wellmesh(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_wellmesh"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

#[test]
fn inspect_json_reports_the_copper_wells() {
    let out = wellmesh(&["inspect", "sample_wells/copper_wells.csv", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["wells"], 13);
    assert_eq!(v["samples"], 335);
    assert_eq!(v["binary"], true);
    assert_eq!(v["unit"], "m");
    assert_eq!(v["report"]["source"], "samples_csv");
}

#[test]
fn inspect_text_reports_drill_hole_tables_and_their_warnings() {
    let out = wellmesh(&[
        "inspect",
        "--collars",
        "sample_wells/tom_zone/collar.csv",
        "--surveys",
        "sample_wells/tom_zone/survey.csv",
        "--intervals",
        "sample_wells/tom_zone/interp.csv",
        "--variable",
        "code",
        "--inside",
        "TSBF,TSGF",
        "--composite",
        "3",
        "--crs",
        "EPSG:32609",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("source        drillholes"), "{text}");
    assert!(text.contains("crs           EPSG:32609"), "{text}");
    assert!(text.contains("values        0 .. 1"), "{text}");
    assert!(text.contains("warning: "), "{text}");
}

#[test]
fn a_malformed_samples_csv_exits_1_naming_file_line_and_column() {
    let dir = std::env::temp_dir().join(format!("wellmesh-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.csv");
    std::fs::write(&path, "well,x,y,z,value\nA,1,2,3,1\nA,1,2,x4,1\n").unwrap();
    let out = wellmesh(&["inspect", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.csv, line 3, column 'z'"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_missing_file_and_an_unknown_kind_exit_1() {
    let out = wellmesh(&["inspect", "no/such/file.csv"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/file.csv"));
    let out = wellmesh(&["inspect", "Cargo.toml"]);
    assert_eq!(out.status.code(), Some(1));
    let out = wellmesh(&["inspect"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no input"));
}

#[test]
fn a_bad_dip_convention_value_is_a_usage_error() {
    let out = wellmesh(&["inspect", "--dip-down", "sideways", "x.csv"]);
    assert_eq!(out.status.code(), Some(2));
}
