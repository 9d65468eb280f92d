//! The figures `sample_wells/README.md` and `README.md` give that the program prints are the
//! program's own: each row of the sample wells' tables is run as written (output files moved
//! to a scratch directory) and every figure compared with the program's to the precision
//! printed; the counts of the synthetic files' table and the up-hole stations named in the
//! prose are compared with `inspect`'s; the defaults the README states with `serve --help`.
//! The documents are the only place those figures live: after a change that moves them,
//! update the document (command, options and figures together), not this test.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

const README: &str = "sample_wells/README.md";

/// One table row: header text -> cell text (backticks kept).
type Row = HashMap<String, String>;

/// The rows of the first table under the heading that starts with `heading`.
fn table(readme: &str, heading: &str) -> Vec<Row> {
    let mut lines = readme
        .lines()
        .skip_while(|l| !l.starts_with(heading))
        .skip(1)
        .skip_while(|l| !l.starts_with('|'));
    let cells = |line: &str| -> Vec<String> {
        let inner = line.trim().trim_start_matches('|').trim_end_matches('|');
        inner.split('|').map(|c| c.trim().to_string()).collect()
    };
    let header = cells(
        lines
            .next()
            .unwrap_or_else(|| panic!("{README}: no table under {heading:?}")),
    );
    let rows: Vec<Row> = lines
        .skip(1) // the |---| line
        .take_while(|l| l.starts_with('|'))
        .map(|l| header.iter().cloned().zip(cells(l)).collect())
        .collect();
    assert!(
        !rows.is_empty(),
        "{README}: the table under {heading:?} has no rows"
    );
    rows
}

fn cell<'a>(row: &'a Row, column: &str) -> &'a str {
    row.get(column)
        .unwrap_or_else(|| panic!("{README}: no column {column:?} in {row:?}"))
}

/// The command of a row, as its words (the cell is one code span).
fn command(row: &Row) -> Vec<String> {
    let text = cell(row, "command");
    let text = text
        .strip_prefix('`')
        .and_then(|t| t.strip_suffix('`'))
        .unwrap_or_else(|| panic!("{README}: the command {text:?} is not one code span"));
    let words: Vec<String> = text.split_whitespace().map(String::from).collect();
    assert_eq!(words[0], "wellmesh", "{README}: {text:?}");
    words
}

/// Runs `wellmesh` with `args` from the repository root; its standard output on success.
fn wellmesh(args: &[String]) -> Vec<u8> {
    let out = Command::new(env!("CARGO_BIN_EXE_wellmesh"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "wellmesh {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// Whether `text` (a figure as printed: spaces or commas between thousands, an optional sign
/// and `%`) is `value` rounded to the decimals it shows.
fn printed(value: f64, text: &str) -> bool {
    let figure: String = text
        .chars()
        .filter(|c| !c.is_whitespace() && *c != ',' && *c != '%')
        .collect();
    // A leading `+` marks a positive figure; the digits are compared without it.
    let (digits, plus) = match figure.strip_prefix('+') {
        Some(rest) => (rest, true),
        None => (figure.as_str(), false),
    };
    let decimals = digits.split_once('.').map_or(0, |(_, d)| d.len());
    format!("{value:.decimals$}") == digits && (!plus || value > 0.0)
}

fn assert_printed(value: f64, text: &str, what: &str) {
    assert!(
        printed(value, text),
        "{README}: {what} is printed as {text:?}, the program gives {value}"
    );
}

/// A cell holding one figure per shell, `sep` between them.
fn per_shell<'a>(row: &'a Row, column: &str, sep: &str, shells: usize) -> Vec<&'a str> {
    let parts: Vec<&str> = cell(row, column).split(sep).map(str::trim).collect();
    assert_eq!(
        parts.len(),
        shells,
        "{README}: {column:?} {:?} has one figure per threshold ({shells})",
        cell(row, column)
    );
    parts
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wellmesh-readme-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs a `contour` row's command with its GLB and summary written to `dir`; the summary.
fn contour_summary(row: &Row, dir: &Path) -> Value {
    let mut args = command(row)[1..].to_vec();
    let glb = args.iter().position(|a| a == "-o" || a == "--output");
    let glb =
        glb.unwrap_or_else(|| panic!("{README}: {:?} writes no -o GLB", cell(row, "command")));
    args[glb + 1] = dir.join("out.glb").to_string_lossy().into_owned();
    let summary = dir.join("summary.json");
    match args.iter().position(|a| a == "--summary") {
        Some(i) => args[i + 1] = summary.to_string_lossy().into_owned(),
        None => args.extend(["--summary".into(), summary.to_string_lossy().into_owned()]),
    }
    args.push("-q".into());
    wellmesh(&args);
    serde_json::from_slice(&std::fs::read(&summary).unwrap()).unwrap()
}

#[test]
fn every_contour_row_of_the_sample_wells_table_is_what_the_program_prints() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(README)).unwrap();
    let rows = table(&readme, "## What wellmesh makes of them");
    for (i, row) in rows.iter().enumerate() {
        let dir = scratch(&format!("contour{i}"));
        let summary = contour_summary(row, &dir);
        let what = |column: &str| format!("{column:?} of {:?}", cell(row, "command"));
        assert_eq!(summary["method"], cell(row, "method"), "{}", what("method"));
        assert_eq!(
            summary["interpolant"],
            cell(row, "interpolant"),
            "{}",
            what("interpolant")
        );
        let shells = summary["shells"].as_array().unwrap();
        let n = shells.len();
        let bodies = per_shell(row, "bodies", "+", n);
        let closed = per_shell(row, "closed", "+", n);
        let truncated = per_shell(row, "truncated at the hull", "+", n);
        let volumes = per_shell(row, "volume (m3)", ";", n);
        for (s, shell) in shells.iter().enumerate() {
            let list = shell["bodies"].as_array().unwrap();
            let count = |key: &str| list.iter().filter(|b| b[key] == true).count() as f64;
            assert_printed(list.len() as f64, bodies[s], &what("bodies"));
            assert_printed(count("closed"), closed[s], &what("closed"));
            assert_printed(
                count("truncated"),
                truncated[s],
                &what("truncated at the hull"),
            );
            let volume = shell["volume"].as_f64().unwrap();
            assert_printed(volume, volumes[s], &what("volume (m3)"));
            if cell(row, "exact (m3)") != "-" {
                let exact = per_shell(row, "exact (m3)", ";", n)[s];
                let exact: f64 = exact.replace([' ', ','], "").parse().unwrap();
                let error = per_shell(row, "error", ";", n)[s];
                assert_printed((volume / exact - 1.0) * 100.0, error, &what("error"));
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn the_inspect_row_of_the_sample_wells_table_is_what_the_program_prints() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(README)).unwrap();
    for row in table(&readme, "## What wellmesh reads from them") {
        let args = command(&row)[1..].to_vec();
        assert_eq!(args[0], "inspect");
        assert!(
            args.iter().any(|a| a == "--json"),
            "{README}: {args:?} without --json"
        );
        let set: Value = serde_json::from_slice(&wellmesh(&args)).unwrap();
        let report = &set["report"];
        for (column, value) in [
            ("holes read", &report["holes_read"]),
            ("with samples", &report["holes_used"]),
            ("samples", &set["samples"]),
            ("don't know", &set["unknown_values"]),
            ("gaps between intervals", &report["gaps"]),
            ("holes with a station pointing up", &report["up_holes"]),
        ] {
            assert_printed(value.as_f64().unwrap(), cell(&row, column), column);
        }
        let (lo, hi) = cell(&row, "values").split_once(" - ").unwrap_or_else(|| {
            panic!(
                "{README}: values {:?} are not `LO - HI`",
                cell(&row, "values")
            )
        });
        assert_printed(
            set["value_range"][0].as_f64().unwrap(),
            lo,
            "smallest value",
        );
        assert_printed(set["value_range"][1].as_f64().unwrap(), hi, "largest value");
    }
}

#[test]
fn the_resource_report_row_of_tom_zone_is_what_the_program_prints() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(README)).unwrap();
    for (i, row) in table(&readme, "## The resource report of Tom Zone")
        .iter()
        .enumerate()
    {
        let dir = scratch(&format!("report{i}"));
        let summary = contour_summary(row, &dir);
        let shell = &summary["shells"][0]["resource"];
        let cv = &summary["report"]["cross_validation"];
        for (column, value) in [
            ("volume (m3)", &shell["volume_m3"]),
            ("tonnes (t)", &shell["tonnes"]),
            ("mean grade (%)", &shell["mean_grade"]),
            ("metal (t)", &shell["metal"]),
            ("samples inside", &shell["samples"]["count"]),
            ("their mean (%)", &shell["samples"]["mean"]),
            (
                "balanced accuracy",
                &cv["thresholds"][0]["balanced_accuracy"],
            ),
            ("mean abs error (%)", &cv["grade"]["mean_abs_error"]),
        ] {
            let value = value
                .as_f64()
                .unwrap_or_else(|| panic!("{README}: no figure for {column:?} in the summary"));
            assert_printed(value, cell(row, column), column);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// The number a cell or phrase starts with (spaces between thousands), e.g. 12000 of
/// "12 000 intervals of 2 m".
fn leading_number(text: &str) -> f64 {
    let digits: String = text
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == ' ')
        .filter(|c| c.is_ascii_digit())
        .collect();
    digits
        .parse()
        .unwrap_or_else(|_| panic!("{README}: {text:?} does not start with a number"))
}

/// The code spans of a cell, in order.
fn code_spans(text: &str) -> Vec<&str> {
    text.split('`').skip(1).step_by(2).collect()
}

#[test]
fn the_synthetic_files_hold_the_wells_and_samples_the_table_gives() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(README)).unwrap();
    let rows = table(&readme, "## Synthetic copper");
    assert_eq!(
        rows.len(),
        3,
        "{README}: the synthetic table has three rows"
    );
    for row in rows {
        let files: Vec<String> = code_spans(cell(&row, "file"))
            .iter()
            .map(|f| format!("sample_wells/{f}"))
            .collect();
        let mut args: Vec<String> = vec!["inspect".into()];
        match files.as_slice() {
            [samples] => args.push(samples.clone()),
            [collars, surveys, intervals] => {
                let variable = code_spans(cell(&row, "value"))[0];
                for (flag, file) in [
                    ("--collars", collars),
                    ("--surveys", surveys),
                    ("--intervals", intervals),
                ] {
                    args.extend([flag.into(), file.clone()]);
                }
                args.extend(["--variable".into(), variable.into()]);
            }
            other => panic!("{README}: a row names {other:?}"),
        }
        args.push("--json".into());
        let set: Value = serde_json::from_slice(&wellmesh(&args)).unwrap();
        let what = |column: &str| format!("{column:?} of {files:?}");
        assert_eq!(
            set["wells"].as_f64().unwrap(),
            leading_number(cell(&row, "wells")),
            "{}",
            what("wells")
        );
        assert_eq!(
            set["samples"].as_f64().unwrap(),
            leading_number(cell(&row, "samples")),
            "{}",
            what("samples")
        );
    }
}

#[test]
fn the_up_hole_stations_named_under_the_inspect_table_are_those_the_program_warns_of() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(README)).unwrap();
    let phrase = "warnings name the ";
    let at = readme
        .find(phrase)
        .unwrap_or_else(|| panic!("{README}: no {phrase:?}"));
    let stations = leading_number(&readme[at + phrase.len()..]);
    let row = &table(&readme, "## What wellmesh reads from them")[0];
    let set: Value = serde_json::from_slice(&wellmesh(&command(row)[1..])).unwrap();
    let warnings: Vec<&str> = set["report"]["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    let expected = format!("the other {stations} stations are read as pointing up");
    assert!(
        warnings.iter().any(|w| w.contains(&expected)),
        "{README}: {stations} up-hole stations; the program warns: {warnings:?}"
    );
}

#[test]
fn the_service_defaults_the_readme_states_are_those_of_serve_help() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let help = String::from_utf8(wellmesh(&["serve".into(), "--help".into()])).unwrap();
    // `--flag` (default VALUE) in the prose, and [--flag VALUE] in the synopsis.
    let mut stated: Vec<(String, String)> = Vec::new();
    for (i, _) in readme.match_indices("` (default ") {
        let flag = &readme[readme[..i].rfind('`').unwrap() + 1..i];
        let rest = &readme[i + "` (default ".len()..];
        stated.push((flag.to_owned(), rest[..rest.find(')').unwrap()].to_owned()));
    }
    let synopsis = readme
        .lines()
        .find(|l| l.starts_with("`wellmesh serve ["))
        .expect("README.md: the serve synopsis");
    for option in synopsis.split('[').skip(1) {
        let option = &option[..option.find(']').unwrap()];
        if let Some((flag, value)) = option.split_once(' ')
            && !value.chars().all(|c| c.is_ascii_uppercase())
        {
            stated.push((flag.to_owned(), value.to_owned()));
        }
    }
    assert!(
        stated.len() >= 3,
        "README.md: expected the stated defaults of --bind, --lease-secs and --retention, found {stated:?}"
    );
    for (flag, value) in stated {
        // The option's help runs from its `--flag <` line to the next option.
        let start = help
            .find(&format!("{flag} <"))
            .unwrap_or_else(|| panic!("serve --help has no {flag}"));
        let end = help[start..]
            .find("\n      --")
            .map_or(help.len(), |e| start + e);
        let default = help[start..end]
            .split_once("[default: ")
            .map(|(_, d)| &d[..d.find(']').unwrap()])
            .unwrap_or_else(|| panic!("serve --help gives no default for {flag}"));
        assert_eq!(
            default,
            value.replace(' ', ""),
            "README.md states {flag} (default {value}); serve --help: {default}"
        );
    }
}

/// The figure that follows `phrase` in `text`.
fn figure_after<'a>(text: &'a str, phrase: &str) -> &'a str {
    let at = text
        .find(phrase)
        .unwrap_or_else(|| panic!("{README}: no {phrase:?}"))
        + phrase.len();
    let rest = &text[at..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == ' '))
        .unwrap_or(rest.len());
    rest[..end].trim()
}

#[test]
fn the_figures_in_the_prose_under_the_resource_report_are_the_programs() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(README)).unwrap();
    let heading = "## The resource report of Tom Zone";
    let row = &table(&readme, heading)[0];
    let section = &readme[readme.find(heading).unwrap()..];
    let dir = scratch("report-prose");
    let summary = contour_summary(row, &dir);
    let shell = &summary["shells"][0]["resource"];
    let cv = &summary["report"]["cross_validation"]["thresholds"][0];
    let percent = |v: &Value| v.as_f64().unwrap() * 100.0;
    for (phrase, value, what) in [
        (
            "The model's mean (",
            shell["mean_grade"].as_f64().unwrap(),
            "the model's mean grade",
        ),
        (
            "below the samples' (",
            shell["samples"]["mean"].as_f64().unwrap(),
            "the samples' mean grade",
        ),
        (
            "Held out, ",
            percent(&cv["ore_inside_share"]),
            "held-out ore assays inside",
        ),
        (
            "inside the shell and ",
            percent(&cv["waste_outside_share"]),
            "held-out waste assays outside",
        ),
    ] {
        assert_printed(value, figure_after(section, phrase), what);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
