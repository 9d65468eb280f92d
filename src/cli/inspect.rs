//! `wellmesh inspect`: what was read from the inputs (holes, samples, ranges, what was
//! dropped and why), as text or JSON, for CI logs.
//!
//! Invariant: it reads through the same `InputArgs::load` as `contour`, so what it reports
//! is exactly what `contour` would tetrahedralize.
use std::process::ExitCode;

use super::input::InputArgs;

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub input: InputArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let set = args.input.load()?;
    let summary = set.summary();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
        return Ok(ExitCode::SUCCESS);
    }
    let r = &summary.report;
    println!("source        {}", summary.source);
    println!("unit          {}", summary.unit);
    println!(
        "crs           {}",
        summary.crs.as_deref().unwrap_or("(none given)")
    );
    println!(
        "origin        {:.3} {:.3} {:.3}",
        summary.origin[0], summary.origin[1], summary.origin[2]
    );
    println!(
        "holes         {} read, {} with samples, {} without samples",
        r.holes_read, summary.wells, r.holes_without_samples
    );
    println!(
        "samples       {} ({} known, {} don't know)",
        summary.samples, summary.known_values, summary.unknown_values
    );
    match summary.value_range {
        Some([lo, hi]) => println!(
            "values        {lo} .. {hi}{}",
            if summary.binary { " (0/1)" } else { "" }
        ),
        None => println!("values        none known"),
    }
    let [lo, hi] = summary.bbox;
    println!("x             {:.3} .. {:.3}", lo[0], hi[0]);
    println!("y             {:.3} .. {:.3}", lo[1], hi[1]);
    println!("z             {:.3} .. {:.3}", lo[2], hi[2]);
    if let Some(d) = &r.dip_convention {
        println!("dip           {d}");
    }
    let counts = [
        ("rows read", r.rows_read),
        ("below detection", r.below_detection),
        ("above detection", r.above_detection),
        ("intervals without collar", r.intervals_without_collar),
        ("collars without coordinates", r.collars_without_coordinates),
        ("duplicate collars", r.duplicate_collars),
        ("unsurveyed holes (vertical)", r.unsurveyed_holes),
        ("survey rows dropped", r.survey_rows_dropped),
        ("azimuths wrapped", r.azimuths_wrapped),
        ("up-holes", r.up_holes),
        ("bad intervals", r.bad_intervals),
        ("duplicate intervals", r.duplicate_intervals),
        ("overlapping intervals", r.overlapping_intervals),
        ("gaps (unknown samples)", r.gaps),
    ];
    for (name, n) in counts {
        if n > 0 {
            println!("{name:<29} {n}");
        }
    }
    for w in &r.warnings {
        println!("warning: {w}");
    }
    Ok(ExitCode::SUCCESS)
}
