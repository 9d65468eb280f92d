//! Property tests: the CSV, JSON and LAS readers never panic, whatever the bytes; a load
//! that succeeds keeps the `SampleSet` invariants. Any crash found is kept below as a
//! named test.

use proptest::prelude::*;
use wellmesh::wells::{Input, InputFile, SampleSet, las};

fn check(set: &SampleSet) {
    assert!(set.points.iter().all(|p| p.is_finite()));
    assert!(set.origin.is_finite());
    assert_eq!(set.points.len(), set.values.len());
    assert_eq!(set.points.len(), set.well_of.len());
    assert!(set.values.iter().flatten().all(|v| v.is_finite()));
    assert!(set.well_of.iter().all(|&w| (w as usize) < set.wells.len()));
}

fn load(input: Input) {
    if let Ok(set) = input.load() {
        check(&set);
    }
}

/// Text made of the characters that matter to these formats.
fn csvish() -> impl Strategy<Value = String> {
    proptest::collection::vec(
        proptest::string::string_regex(
            "([A-Za-z_]{0,6}|-?[0-9]{1,6}(\\.[0-9]{0,3})?|NaN|inf|1e308|<0\\.01|NA|\\?|\"[a-z,\n]*\")([,;\t]|\r?\n)",
        )
        .unwrap(),
        0..60,
    )
    .prop_map(|v| v.concat())
}

const LAS_HEAD: &str = "~V\nVERS. 2.0 :\nWRAP. NO :\n~W\nSTRT.M 1 :\nNULL. -999.25 :\nWELL. W :\n~C\nDEPT.M :\nGR.API :\n~A\n";

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, .. ProptestConfig::default() })]

    #[test]
    fn samples_csv_never_panics_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        load(Input::from_samples_csv("s.csv", bytes));
    }

    #[test]
    fn samples_csv_never_panics_on_csv_like_text(body in csvish()) {
        load(Input::from_samples_csv("s.csv", format!("well,x,y,z,value\n{body}")));
    }

    #[test]
    fn drill_hole_tables_never_panic_on_csv_like_text(
        collars in csvish(), surveys in csvish(), intervals in csvish(),
        composite in proptest::option::of(0.1f64..50.0),
    ) {
        let mut input = Input::from_drillholes(
            InputFile::new("c.csv", format!("hole_id,x,y,z\nA,0,0,0\n{collars}")),
            Some(InputFile::new("s.csv", format!("hole_id,depth,azimuth,dip\n{surveys}"))),
            InputFile::new("i.csv", format!("hole_id,from,to,value\nA,0,1,1\n{intervals}")),
            Some("value"),
        );
        input.composite_length = composite;
        load(input);
    }

    #[test]
    fn drill_hole_tables_never_panic_on_arbitrary_bytes(
        a in proptest::collection::vec(any::<u8>(), 0..200),
        b in proptest::collection::vec(any::<u8>(), 0..200),
        c in proptest::collection::vec(any::<u8>(), 0..200),
    ) {
        load(Input::from_drillholes(
            InputFile::new("c.csv", a),
            Some(InputFile::new("s.csv", b)),
            InputFile::new("i.csv", c),
            None,
        ));
    }

    #[test]
    fn wells_json_never_panics_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        load(Input::from_wells_json("w.json", bytes));
    }

    #[test]
    fn las_never_panics_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = las::parse("f.las", &bytes);
        load(Input::from_las(
            vec![InputFile::new("f.las", bytes)],
            Some(InputFile::new("l.csv", "file,x,y,kb\nf.las,0,0,10\n")),
            "GR",
        ));
    }

    #[test]
    fn las_never_panics_on_las_like_text(
        body in proptest::collection::vec(
            proptest::string::string_regex("(~[AVWCPO][a-z ]{0,4}|[A-Z]{1,4}\\.[A-Z]{0,2} {1,3}-?[0-9.]{0,6} ?:? ?[a-z]{0,4}|-?[0-9]{1,5}(\\.[0-9]{0,2})?|-999\\.25|#x)( |\r?\n)").unwrap(),
            0..80,
        ),
        wrap in any::<bool>(),
        composite in proptest::option::of(0.1f64..10.0),
    ) {
        let head = if wrap { LAS_HEAD.replace("WRAP. NO", "WRAP. YES") } else { LAS_HEAD.to_owned() };
        let text = format!("{head}{}", body.concat());
        let _ = las::parse("f.las", text.as_bytes());
        let mut input = Input::from_las(
            vec![InputFile::new("f.las", text)],
            Some(InputFile::new("l.csv", "well,x,y,kb\nW,0,0,10\n")),
            "GR",
        );
        input.composite_length = composite;
        load(input);
    }
}

#[test]
fn huge_depths_overflow_to_an_error_not_infinite_points() {
    let input = Input::from_drillholes(
        InputFile::new("c.csv", "hole_id,x,y,z\nA,0,0,0\n"),
        None,
        InputFile::new("i.csv", "hole_id,from,to,v\nA,1e308,1.7e308,1\n"),
        None,
    );
    let e = input.load().unwrap_err().to_string();
    assert!(e.contains("not finite"), "{e}");
}

#[test]
fn a_las_file_of_only_a_tilde_is_an_error_not_a_panic() {
    assert!(las::parse("t.las", b"~").is_err());
    assert!(las::parse("t.las", b"~A").is_err());
    assert!(las::parse("t.las", b"").is_err());
}
