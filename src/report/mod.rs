//! The resource report: tonnes, mean grade and contained metal per body and shell, the
//! grade–tonnage curve, and the figures of cross-validation — from a [`TetMesh`] with one
//! value per vertex, the piecewise-linear field every shell contours.
//!
//! Invariant: every figure is an exact integral of that piecewise-linear field (module
//! [`integrate`]) or a count over the samples; units are stated beside every figure
//! ([`ReportUnits`]). This is a geometry room: it imports nothing of tokio, axum or sqlx.

pub mod chart;
pub mod integrate;
pub mod locate;

use serde::Serialize;

pub use integrate::{DensityField, Moments};

use crate::tet::TetMesh;

/// Grams in a troy ounce.
pub const GRAMS_PER_TROY_OUNCE: f64 = 31.103_476_8;

/// The unit of the grade variable, read from its name (`Zn_pct`, `Au_gpt`, `Ag_ppm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GradeUnit {
    /// Mass per cent: metal in tonnes (tonnes × grade / 100).
    Percent,
    /// Grams per tonne: metal in grams (and troy ounces).
    GramsPerTonne,
    /// Parts per million by mass (= g/t): metal in grams (and troy ounces).
    Ppm,
    /// Unknown: metal is tonnes × grade, in "t × grade unit".
    AsGiven,
}

impl GradeUnit {
    /// The unit a variable's name states: a `pct`/`%` word gives per cent, `gpt`/`g/t`/`gt`
    /// grams per tonne, `ppm` parts per million; anything else is "as given".
    pub fn from_variable(name: Option<&str>) -> GradeUnit {
        let Some(name) = name else {
            return GradeUnit::AsGiven;
        };
        let lower = name.to_ascii_lowercase();
        let words: Vec<&str> = lower
            .split(|c: char| !(c.is_ascii_alphanumeric() || c == '%' || c == '/'))
            .filter(|w| !w.is_empty())
            .collect();
        let has = |w: &[&str]| words.iter().any(|x| w.contains(x));
        if lower.contains('%') || has(&["pct", "percent", "perc"]) {
            GradeUnit::Percent
        } else if has(&["gpt", "g/t", "gt", "gpt_au", "gram_per_tonne"]) {
            GradeUnit::GramsPerTonne
        } else if has(&["ppm"]) {
            GradeUnit::Ppm
        } else {
            GradeUnit::AsGiven
        }
    }

    /// How the grade's unit is written.
    pub fn symbol(self) -> &'static str {
        match self {
            GradeUnit::Percent => "%",
            GradeUnit::GramsPerTonne => "g/t",
            GradeUnit::Ppm => "ppm",
            GradeUnit::AsGiven => "as given",
        }
    }

    /// How the metal's unit is written.
    pub fn metal_symbol(self) -> &'static str {
        match self {
            GradeUnit::Percent => "t",
            GradeUnit::GramsPerTonne | GradeUnit::Ppm => "g",
            GradeUnit::AsGiven => "t x grade unit",
        }
    }

    /// Metal from `∫ρ f` (tonnes × grade, integrated): in the unit of [`Self::metal_symbol`].
    pub fn metal(self, tonne_grade: f64) -> f64 {
        match self {
            GradeUnit::Percent => tonne_grade / 100.0,
            _ => tonne_grade,
        }
    }

    /// Troy ounces of a metal figure, for grades in g/t or ppm.
    pub fn ounces(self, metal: f64) -> Option<f64> {
        matches!(self, GradeUnit::GramsPerTonne | GradeUnit::Ppm)
            .then_some(metal / GRAMS_PER_TROY_OUNCE)
    }
}

/// The units of every figure in the report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReportUnits {
    /// `m3`: volumes are converted from the input's length unit.
    pub volume: &'static str,
    pub density: &'static str,
    pub tonnes: &'static str,
    pub grade: &'static str,
    pub metal: &'static str,
}

impl ReportUnits {
    pub fn new(grade: GradeUnit) -> Self {
        ReportUnits {
            volume: "m3",
            density: "t/m3",
            tonnes: "t",
            grade: grade.symbol(),
            metal: grade.metal_symbol(),
        }
    }
}

/// The resource in one region: volume, tonnes, mean grade, metal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Resource {
    /// Volume of the region `{f >= threshold}` of the piecewise-linear field, m3.
    pub volume_m3: f64,
    /// Tonnes (`∫ρ`), when a density is known.
    pub tonnes: Option<f64>,
    /// The field's mean over the region: `∫ρf / ∫ρ` with a density column (the
    /// tonnage-weighted mean), else `∫f / volume`; `None` for an empty region.
    pub mean_grade: Option<f64>,
    /// Contained metal (tonnes × grade integrated), in [`ReportUnits::metal`].
    pub metal: Option<f64>,
    /// The metal in troy ounces, for grades in g/t or ppm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub metal_oz: Option<f64>,
}

impl Resource {
    /// The figures of `m` (integrals in m3), with or without a density.
    pub fn from_moments(m: Moments, has_density: bool, unit: GradeUnit) -> Resource {
        let mean_grade = if has_density {
            (m.mass > 0.0).then(|| m.metal / m.mass)
        } else {
            (m.volume > 0.0).then(|| m.grade / m.volume)
        };
        let metal = has_density.then(|| unit.metal(m.metal));
        Resource {
            volume_m3: m.volume,
            tonnes: has_density.then_some(m.mass),
            mean_grade,
            metal,
            metal_oz: metal.and_then(|x| unit.ounces(x)),
        }
    }
}

/// The samples whose mesh vertex lies in a region, with their values as read.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct SampleStats {
    pub count: usize,
    pub mean: Option<f64>,
    pub min: Option<f64>,
    pub max: Option<f64>,
}

impl SampleStats {
    pub fn add(&mut self, value: f64) {
        let n = self.count as f64;
        self.mean = Some((self.mean.unwrap_or(0.0) * n + value) / (n + 1.0));
        self.min = Some(self.min.map_or(value, |m| m.min(value)));
        self.max = Some(self.max.map_or(value, |m| m.max(value)));
        self.count += 1;
    }

    pub fn merge(&mut self, other: &SampleStats) {
        if other.count == 0 {
            return;
        }
        let (n, m) = (self.count as f64, other.count as f64);
        self.mean = Some((self.mean.unwrap_or(0.0) * n + other.mean.unwrap_or(0.0) * m) / (n + m));
        self.min = match (self.min, other.min) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        self.max = match (self.max, other.max) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        self.count += other.count;
    }
}

/// The resource of one body (or shell) and the samples inside it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BodyResource {
    #[serde(flatten)]
    pub resource: Resource,
    /// The samples inside, beside the model's mean: the support of the figures.
    pub samples: SampleStats,
}

/// One point of the grade–tonnage curve: everything at or above `cutoff`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GradeTonnageRow {
    pub cutoff: f64,
    #[serde(flatten)]
    pub resource: Resource,
}

/// Cut-offs `from, from + step, ..` up to `to` (inclusive, within rounding).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CutoffSweep {
    pub from: f64,
    pub to: f64,
    pub step: f64,
}

/// Most cut-offs one grade–tonnage curve may have.
pub const MAX_CUTOFFS: usize = 1000;

/// Cut-offs of the default sweep.
pub const DEFAULT_CUTOFFS: usize = 20;

impl CutoffSweep {
    /// Parses `FROM:TO:STEP`; `step > 0`, `from <= to`, at most [`MAX_CUTOFFS`] cut-offs.
    pub fn parse(text: &str) -> Result<CutoffSweep, String> {
        let parts: Vec<&str> = text.split(':').collect();
        let [from, to, step] = parts.as_slice() else {
            return Err(format!("{text:?}: expected FROM:TO:STEP (e.g. 0.5:10:0.5)"));
        };
        let number = |name: &str, s: &str| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("{text:?}: {name} {s:?} is not a finite number"))
        };
        CutoffSweep::new(
            number("FROM", from)?,
            number("TO", to)?,
            number("STEP", step)?,
        )
        .map_err(|e| format!("{text:?}: {e}"))
    }

    pub fn new(from: f64, to: f64, step: f64) -> Result<CutoffSweep, String> {
        if !(from.is_finite() && to.is_finite() && step.is_finite()) {
            return Err("FROM, TO and STEP must be finite numbers".into());
        }
        if step <= 0.0 {
            return Err(format!("STEP {step} must be positive"));
        }
        if from > to {
            return Err(format!("FROM {from} is above TO {to}"));
        }
        let sweep = CutoffSweep { from, to, step };
        if sweep.count() > MAX_CUTOFFS {
            return Err(format!(
                "{} cut-offs; at most {MAX_CUTOFFS} (take a larger STEP)",
                sweep.count()
            ));
        }
        Ok(sweep)
    }

    fn count(&self) -> usize {
        ((self.to - self.from) / self.step * (1.0 + 1e-9) + 1e-9).floor() as usize + 1
    }

    /// The cut-offs, each rounded to 12 significant digits (`0.1 × 14` is 1.4, not
    /// 1.4000000000000001).
    pub fn cutoffs(&self) -> Vec<f64> {
        (0..self.count())
            .map(|i| {
                let x = self.from + self.step * i as f64;
                format!("{x:.11e}").parse().unwrap_or(x)
            })
            .collect()
    }

    /// About [`DEFAULT_CUTOFFS`] cut-offs at a round step (1, 2, 2.5 or 5 × 10ⁿ) from the
    /// smallest value down to a multiple of the step, below the largest value.
    pub fn default_for(lo: f64, hi: f64) -> Option<CutoffSweep> {
        if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
            return None;
        }
        let raw = (hi - lo) / DEFAULT_CUTOFFS as f64;
        let power = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 2.5, 5.0, 10.0]
            .iter()
            .map(|m| m * power)
            .find(|&s| s >= raw)
            .unwrap_or(10.0 * power);
        let from = (lo / step).floor() * step;
        let count = ((hi - from) / step).ceil().max(1.0) as usize;
        let to = from + step * (count - 1) as f64;
        Some(CutoffSweep { from, to, step })
    }
}

/// The grade–tonnage curve of `values` on `mesh` at `cutoffs`: `volume_factor` turns mesh
/// volumes into m3 (the input unit cubed and the anisotropic frame's determinant).
pub fn grade_tonnage(
    mesh: &TetMesh,
    values: &[f64],
    density: DensityField,
    has_density: bool,
    volume_factor: f64,
    unit: GradeUnit,
    cutoffs: &[f64],
) -> Vec<GradeTonnageRow> {
    integrate::cutoff_moments(mesh, values, density, cutoffs)
        .into_iter()
        .zip(cutoffs)
        .map(|(m, &cutoff)| GradeTonnageRow {
            cutoff,
            resource: Resource::from_moments(m.scaled(volume_factor), has_density, unit),
        })
        .collect()
}

/// The grade–tonnage curve as CSV: one header line, one row per cut-off, units in the
/// header; empty cells where a figure is unknown (no density, empty region).
pub fn grade_tonnage_csv(rows: &[GradeTonnageRow], units: &ReportUnits) -> String {
    let mut out = format!(
        "cutoff_{g},volume_{v},tonnes_{t},mean_grade_{g},metal_{m}\n",
        g = csv_unit(units.grade),
        v = units.volume,
        t = units.tonnes,
        m = csv_unit(units.metal),
    );
    let cell = |x: Option<f64>| x.map(|v| format!("{v}")).unwrap_or_default();
    for row in rows {
        let r = &row.resource;
        out.push_str(&format!(
            "{},{},{},{},{}\n",
            row.cutoff,
            r.volume_m3,
            cell(r.tonnes),
            cell(r.mean_grade),
            cell(r.metal)
        ));
    }
    out
}

/// A unit as a column-name suffix (`%` -> `pct`, `g/t` -> `gpt`, spaces -> `_`).
fn csv_unit(unit: &str) -> String {
    match unit {
        "%" => "pct".into(),
        "g/t" => "gpt".into(),
        other => other.replace(' ', "_"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grade_units_come_from_the_variable_name() {
        assert_eq!(GradeUnit::from_variable(Some("Zn_pct")), GradeUnit::Percent);
        assert_eq!(GradeUnit::from_variable(Some("Cu %")), GradeUnit::Percent);
        assert_eq!(
            GradeUnit::from_variable(Some("Au_gpt")),
            GradeUnit::GramsPerTonne
        );
        assert_eq!(
            GradeUnit::from_variable(Some("Au g/t")),
            GradeUnit::GramsPerTonne
        );
        assert_eq!(GradeUnit::from_variable(Some("Ag_ppm")), GradeUnit::Ppm);
        assert_eq!(GradeUnit::from_variable(Some("cu")), GradeUnit::AsGiven);
        assert_eq!(GradeUnit::from_variable(None), GradeUnit::AsGiven);
        assert_eq!(GradeUnit::Percent.metal(200.0), 2.0);
        assert_eq!(GradeUnit::Ppm.ounces(GRAMS_PER_TROY_OUNCE), Some(1.0));
        assert_eq!(GradeUnit::Percent.ounces(1.0), None);
    }

    #[test]
    fn sweeps_parse_count_inclusively_and_refuse_nonsense() {
        let s = CutoffSweep::parse("0.5:2:0.5").unwrap();
        assert_eq!(s.cutoffs(), vec![0.5, 1.0, 1.5, 2.0]);
        assert_eq!(CutoffSweep::parse("0:1:0.1").unwrap().cutoffs().len(), 11);
        assert!(CutoffSweep::parse("1:0:0.1").unwrap_err().contains("above"));
        assert!(
            CutoffSweep::parse("0:1:0")
                .unwrap_err()
                .contains("positive")
        );
        assert!(
            CutoffSweep::parse("0:1")
                .unwrap_err()
                .contains("FROM:TO:STEP")
        );
        assert!(CutoffSweep::parse("a:1:1").unwrap_err().contains("FROM"));
        assert!(
            CutoffSweep::parse("0:1:1e-6")
                .unwrap_err()
                .contains("at most")
        );
        let d = CutoffSweep::default_for(0.0002, 39.0).unwrap();
        assert_eq!(d.step, 2.0);
        assert_eq!(d.from, 0.0);
        assert_eq!(d.cutoffs().len(), 20);
        assert!(*d.cutoffs().last().unwrap() < 39.0);
        assert!(CutoffSweep::default_for(1.0, 1.0).is_none());
        let tenths = CutoffSweep::default_for(0.0, 2.0).unwrap().cutoffs();
        assert_eq!(tenths[14], 1.4);
        assert_eq!(tenths[19], 1.9);
    }

    #[test]
    fn sample_stats_merge_like_adding_one_by_one() {
        let mut a = SampleStats::default();
        let mut b = SampleStats::default();
        let mut all = SampleStats::default();
        for v in [1.0, 4.0, 2.0] {
            a.add(v);
            all.add(v);
        }
        for v in [8.0, 0.5] {
            b.add(v);
            all.add(v);
        }
        a.merge(&b);
        assert_eq!(a.count, all.count);
        assert!((a.mean.unwrap() - all.mean.unwrap()).abs() < 1e-12);
        assert_eq!((a.min, a.max), (Some(0.5), Some(8.0)));
    }
}
