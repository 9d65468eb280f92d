//! The last step of every reader: absolute hole samples to a [`SampleSet`] around a local
//! origin.
//!
//! Invariant: the output holds only finite coordinates and finite known values; the origin
//! is the centre of the samples' bounding box, so local coordinates are small.

use glam::DVec3;

use super::{ReadReport, SampleSet, Unit, Well, WellsError};

/// One hole as a reader produced it, in absolute input coordinates.
#[derive(Debug, Clone, Default)]
pub(crate) struct HoleSamples {
    pub id: String,
    /// Collar first, then the path down to (at least) the deepest sample.
    pub trace: Vec<DVec3>,
    /// Sample position and value (`None`: don't know).
    pub samples: Vec<(DVec3, Option<f64>)>,
}

/// Everything a reader hands to [`finish`].
#[derive(Debug, Clone, Default)]
pub(crate) struct Holes {
    /// The file name(s) read, for messages.
    pub name: String,
    pub holes: Vec<HoleSamples>,
    pub crs: Option<String>,
    pub report: ReadReport,
}

/// Caps a list of examples for warnings: the first few, then a count of the rest.
pub(crate) fn examples(items: &[String]) -> String {
    const SHOWN: usize = 8;
    if items.len() <= SHOWN {
        items.join("; ")
    } else {
        format!(
            "{}; and {} more",
            items[..SHOWN].join("; "),
            items.len() - SHOWN
        )
    }
}

/// Largest coordinate magnitude a sample position may have, in the input's unit: `1e9`
/// metres is 25 times round the Earth, so no coordinate reference system (projected,
/// geographic or geocentric, in metres or feet) comes near it, while anything beyond is
/// an error in the data (a wrong column, a unit, an exponent) that would otherwise reach
/// the output as floats too large for glTF's 32-bit positions.
pub(crate) const MAX_COORDINATE: f64 = 1e9;

pub(crate) fn finish(
    holes: Holes,
    crs: Option<String>,
    unit: Unit,
) -> Result<SampleSet, WellsError> {
    let mut report = holes.report;
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut count = 0usize;
    for hole in &holes.holes {
        for (p, v) in &hole.samples {
            if !p.is_finite() {
                return Err(WellsError::Invalid {
                    file: holes.name.clone(),
                    message: format!(
                        "hole '{}': a sample position is not finite ({p}); check depths and coordinates",
                        hole.id
                    ),
                });
            }
            if p.abs().max_element() > MAX_COORDINATE {
                return Err(WellsError::Invalid {
                    file: holes.name.clone(),
                    message: format!(
                        "hole '{}': a sample position ({:e}, {:e}, {:e}) lies more than {MAX_COORDINATE:e} from the coordinate system's origin, farther than any place on Earth in metres or feet; check the coordinate columns and the depth unit",
                        hole.id, p.x, p.y, p.z
                    ),
                });
            }
            if let Some(v) = v
                && !v.is_finite()
            {
                return Err(WellsError::Invalid {
                    file: holes.name.clone(),
                    message: format!("hole '{}': a value is not finite", hole.id),
                });
            }
            lo = lo.min(*p);
            hi = hi.max(*p);
            count += 1;
        }
    }
    if count == 0 {
        return Err(WellsError::Empty {
            file: holes.name.clone(),
            message: "no samples left to contour after reading".into(),
        });
    }
    let origin = (lo + hi) * 0.5;
    let mut set = SampleSet {
        origin,
        crs,
        unit: unit.name().to_owned(),
        wells: Vec::new(),
        points: Vec::with_capacity(count),
        values: Vec::with_capacity(count),
        well_of: Vec::with_capacity(count),
        report: ReadReport::default(),
    };
    let mut without = 0usize;
    for hole in holes.holes {
        if hole.samples.is_empty() {
            without += 1;
            continue;
        }
        let index = set.wells.len() as u32;
        let trace: Vec<DVec3> = hole
            .trace
            .iter()
            .filter(|p| p.is_finite())
            .map(|p| *p - origin)
            .collect();
        let collar = trace.first().copied().unwrap_or(hole.samples[0].0 - origin);
        for (p, v) in hole.samples {
            set.points.push(p - origin);
            set.values.push(v);
            set.well_of.push(index);
        }
        set.wells.push(Well {
            id: hole.id,
            collar,
            trace,
        });
    }
    report.holes_without_samples += without;
    report.holes_used = set.wells.len();
    report.unknown_values = set.values.iter().filter(|v| v.is_none()).count();
    set.report = report;
    Ok(set)
}
