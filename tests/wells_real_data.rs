//! Every real data set loads with a clear account of what was dropped and why; the figures
//! asserted are the data sets' documented oddities. Tom Zone, Forrestania (its gold column)
//! and the deepest 20 m of the NLOG L07 logs ship in `sample_wells/` and are read on every
//! clone; the others are in the shared corpus `../shared/data`, and their tests skip with a
//! printed note when it is absent (`common`).

mod common;

use std::path::{Path, PathBuf};

use common::shared_data;
use wellmesh::wells::{Input, InputFile, SampleSet};

/// A folder of `sample_wells/`, shipped with the repository.
fn sample(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("sample_wells")
        .join(name)
}

fn file(dir: &Path, name: &str) -> InputFile {
    let path = dir.join(name);
    InputFile::new(
        name,
        std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
}

fn drillholes(dir: &Path, c: &str, s: Option<&str>, i: &str, variable: &str) -> Input {
    Input::from_drillholes(
        file(dir, c),
        s.map(|s| file(dir, s)),
        file(dir, i),
        Some(variable),
    )
}

/// Checks what every load must give: finite local points, every sample's well in range,
/// counts consistent with the values, and one warning per kind of drop.
fn sane(set: &SampleSet) {
    assert!(!set.points.is_empty());
    assert!(set.points.iter().all(|p| p.is_finite()));
    assert_eq!(set.points.len(), set.values.len());
    assert!(set.well_of.iter().all(|&w| (w as usize) < set.wells.len()));
    assert_eq!(
        set.report.unknown_values,
        set.values.iter().filter(|v| v.is_none()).count()
    );
    assert_eq!(
        set.report.holes_used + set.report.holes_without_samples,
        set.report.holes_read
    );
    eprintln!("{}", serde_json::to_string_pretty(&set.summary()).unwrap());
}

fn warned(set: &SampleSet, needle: &str) -> bool {
    set.report.warnings.iter().any(|w| w.contains(needle))
}

#[test]
fn tom_zone_assays_and_facies_codes_load() {
    let d = sample("tom_zone");
    let set = drillholes(&d, "collar.csv", Some("survey.csv"), "assay.csv", "Zn_pct")
        .load()
        .unwrap();
    sane(&set);
    assert_eq!(set.report.holes_without_samples, 67);
    assert_eq!(set.report.gaps, 471);
    assert!(set.report.up_holes > 0 && warned(&set, "up-holes"));

    let mut facies = drillholes(&d, "collar.csv", Some("survey.csv"), "interp.csv", "code");
    facies.inside_codes = vec!["TSBF".into(), "TSGF".into(), "TSPF".into()];
    let set = facies.load().unwrap();
    sane(&set);
    assert!(set.summary().binary);
    assert_eq!(set.report.holes_without_samples, 79);
}

#[test]
fn copper_creek_loads_with_bom_below_detection_duplicates_and_overlaps_reported() {
    let Some(d) = shared_data("drilldown_copper_creek") else {
        return;
    };
    let set = drillholes(&d, "collar.csv", Some("survey.csv"), "assay.csv", "Cu_pct")
        .load()
        .unwrap();
    sane(&set);
    let r = &set.report;
    assert_eq!(r.holes_read, 545);
    assert_eq!(r.holes_without_samples, 57);
    assert!(r.below_detection > 0 && warned(&set, "below-detection"));
    assert!(r.duplicate_intervals >= 141 && warned(&set, "duplicate intervals"));
    assert!(r.overlapping_intervals > 0 && warned(&set, "CA28_PLUS_8"));
    assert!(r.azimuths_wrapped >= 139);
    assert_eq!(r.dip_convention.as_deref(), Some("negative-down"));
    // Lithology uses `to_depth`.
    let mut lith = drillholes(
        &d,
        "collar.csv",
        Some("survey.csv"),
        "lithology.csv",
        "rock code",
    );
    lith.inside_codes = vec!["mgp".into()];
    sane(&lith.load().unwrap());
}

#[test]
fn babbitt_loads_in_feet_positive_down_with_end_markers_handled() {
    let Some(d) = shared_data("babbitt_pygslib") else {
        return;
    };
    let mut input = drillholes(
        &d,
        "collar_BABBITT.csv",
        Some("survey_BABBITT.csv"),
        "assay_BABBITT.csv",
        "CU",
    );
    input.unit = Some("ft".into());
    let set = input.load().unwrap();
    sane(&set);
    assert_eq!(set.unit, "ft");
    assert_eq!(set.report.holes_read, 399);
    assert_eq!(set.report.dip_convention.as_deref(), Some("positive-down"));
    assert!(set.report.unknown_values > 0, "blank grades are don't know");
    // No sample lies near the 90000 ft end markers.
    let deepest = set.points.iter().map(|p| p.z).fold(f64::MAX, f64::min) + set.origin.z;
    assert!(deepest > -5000.0, "{deepest}");
}

#[test]
fn forrestania_loads_with_unsurveyed_holes_and_negative_below_detection() {
    let d = sample("forrestania");
    let set = drillholes(&d, "collar.csv", Some("survey.csv"), "assay.csv", "Au_ppm")
        .load()
        .unwrap();
    sane(&set);
    assert_eq!(set.report.holes_read, 100);
    assert_eq!(set.report.holes_without_samples, 28);
    assert!(set.report.below_detection > 0);
}

#[test]
fn thalanga_massive_sulphide_loads_with_mixed_dip_signs_warned() {
    let Some(d) = shared_data("thalanga_loopresources") else {
        return;
    };
    let mut input = drillholes(
        &d,
        "ThalangaML_collar.csv",
        Some("ThalangaML_survey.csv"),
        "ThalangaML_Geology.csv",
        "Lith1_Validated",
    );
    input.inside_codes = vec!["MS".into()];
    let set = input.load().unwrap();
    sane(&set);
    assert!(set.summary().binary);
    assert_eq!(set.report.holes_read, 5277);
    assert!(set.report.azimuths_wrapped > 0);
    assert!(warned(&set, "dip convention detected"));
    assert!(set.values.contains(&Some(1.0)));
}

#[test]
fn ararangua_thirteen_vertical_holes_give_a_coal_indicator() {
    let Some(d) = shared_data("ararangua_coal_geomod3D") else {
        return;
    };
    let mut input = Input::from_drillholes(
        file(&d, "ara_collar.csv"),
        None,
        file(&d, "ara_lito.csv"),
        Some("LITO"),
    );
    input.inside_codes = vec!["Carvão".into()];
    let set = input.load().unwrap();
    sane(&set);
    assert_eq!(set.wells.len(), 13);
    assert_eq!(set.report.unsurveyed_holes, 13);
    assert_eq!(set.points.len(), 507);
    assert!(set.values.contains(&Some(1.0)));
}

#[test]
fn mcmurray_las_logs_load_with_the_derived_locations_table() {
    let Some(d) = shared_data("mcmurray_athabasca_las_subset") else {
        return;
    };
    let mut las: Vec<InputFile> = std::fs::read_dir(d.join("logs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("las")))
        .map(|p| {
            InputFile::new(
                p.file_name().unwrap().to_string_lossy(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    las.sort_by(|a, b| a.name.cmp(&b.name));
    let count = las.len();
    let set = Input::from_las(las, Some(file(&d, "DERIVED_wells_utm12_kb_tops.csv")), "GR")
        .load()
        .unwrap();
    sane(&set);
    assert_eq!(set.wells.len(), count);
    // Samples lie below the kelly bushing (KB_m ~ 600-700 m) and above sea level.
    let z = set.points.iter().map(|p| p.z + set.origin.z);
    let (lo, hi) = z.fold((f64::MAX, f64::MIN), |(a, b), z| (a.min(z), b.max(z)));
    assert!(lo > 0.0 && hi < 750.0, "{lo} {hi}");
}

#[test]
fn nlog_las_logs_need_locations_and_load_with_a_table() {
    let d = sample("nlog_l07");
    let names = [
        "7264_l0701_1971_comp.las",
        "7265_l0704_1973_comp.las",
        "7266_l0705_1974_comp.las",
    ];
    let las: Vec<InputFile> = names.iter().map(|n| file(&d, n)).collect();
    let e = Input::from_las(las.clone(), None, "GR")
        .load()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("7264_l0701_1971_comp.las") && e.contains("locations"),
        "{e}"
    );
    // A locations table by well name (positions here are made up for the test).
    let table = "well,x,y,kb\nL07-01,600000,5900000,37\nL07-04,605000,5901000,38\nL07-05,603000,5904000,40\n";
    let set = Input::from_las(las, Some(InputFile::new("loc.csv", table)), "GR")
        .load()
        .unwrap();
    sane(&set);
    assert_eq!(set.wells.len(), 3);
    assert!(set.report.unknown_values > 0, "NULL -999.25 is do not know");
}

#[test]
fn the_broken_las_folder_loads_or_fails_cleanly_as_a_whole() {
    let Some(d) = shared_data("las_kansas_alberta_broken") else {
        return;
    };
    let mut las: Vec<InputFile> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("las")))
        .map(|p| {
            InputFile::new(
                p.file_name().unwrap().to_string_lossy(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    las.sort_by(|a, b| a.name.cmp(&b.name));
    let mut table = String::from("file,x,y,kb\n");
    for (i, f) in las.iter().enumerate() {
        table += &format!("{},{},{},500\n", f.name, 1000 * i, 2000);
    }
    let set = Input::from_las(las, Some(InputFile::new("loc.csv", table)), "GR")
        .load()
        .unwrap();
    sane(&set);
    assert!(warned(&set, "have no curve 'GR'"));
}
