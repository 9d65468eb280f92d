//! Transforms of skewed grades before the fit, as resource geologists use them: a top-cut
//! (capping) of outliers, then none, a logarithm, or normal scores.
//!
//! Invariant: every transform is monotone increasing, so a threshold maps to the level of
//! the transformed field that separates the same samples; shells are contoured on the
//! transformed level and reported at the threshold given.

use serde::Serialize;

/// Which transform the values get before the fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TransformKind {
    #[default]
    None,
    /// `ln(v + shift)`, the shift making the smallest value positive.
    Log,
    /// Normal scores: the standard normal quantile of each value's rank.
    NormalScore,
}

impl std::str::FromStr for TransformKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().replace('_', "-").as_str() {
            "none" => Ok(TransformKind::None),
            "log" => Ok(TransformKind::Log),
            "normal-score" | "nscore" => Ok(TransformKind::NormalScore),
            other => Err(format!(
                "unknown transform {other:?}: expected none, log or normal-score"
            )),
        }
    }
}

/// A fitted transform: maps values (already top-cut) and thresholds alike.
#[derive(Debug, Clone)]
pub enum Transform {
    None,
    Log {
        shift: f64,
    },
    /// Sorted distinct values and their scores, interpolated linearly between them.
    NormalScore {
        values: Vec<f64>,
        scores: Vec<f64>,
    },
    /// A flag modelled as the signed distance to its contacts (`contacts.rs`): thresholds
    /// map linearly so that `level` is distance zero and `level +- 0.5` is `+-cap`; back
    /// from distances, values are clamped to `level +- 0.5` (0 and 1 for a flag at 0.5).
    Contacts {
        level: f64,
        cap: f64,
    },
}

impl Transform {
    /// Fits `kind` to `values` (finite, at least one).
    pub fn fit(kind: TransformKind, values: &[f64]) -> Transform {
        match kind {
            TransformKind::None => Transform::None,
            TransformKind::Log => {
                let min = values.iter().copied().fold(f64::INFINITY, f64::min);
                let mut positive: Vec<f64> = values.iter().copied().filter(|v| *v > 0.0).collect();
                positive.sort_by(f64::total_cmp);
                // A small positive offset keeps zeros (below detection) finite: a tenth of
                // the smallest positive value, or 1e-3 when none is positive.
                let floor = positive.first().map_or(1e-3, |v| v * 0.1);
                let shift = if min > 0.0 { 0.0 } else { floor - min };
                Transform::Log { shift }
            }
            TransformKind::NormalScore => {
                let mut sorted = values.to_vec();
                sorted.sort_by(f64::total_cmp);
                let n = sorted.len() as f64;
                let mut distinct = Vec::new();
                let mut scores = Vec::new();
                let mut i = 0;
                while i < sorted.len() {
                    let mut j = i;
                    while j + 1 < sorted.len() && sorted[j + 1] == sorted[i] {
                        j += 1;
                    }
                    // Ties share the score of their mean rank.
                    let rank = (i + j) as f64 / 2.0;
                    distinct.push(sorted[i]);
                    scores.push(normal_quantile((rank + 0.5) / n));
                    i = j + 1;
                }
                Transform::NormalScore {
                    values: distinct,
                    scores,
                }
            }
        }
    }

    pub fn kind(&self) -> TransformKind {
        match self {
            Transform::None => TransformKind::None,
            Transform::Log { .. } => TransformKind::Log,
            Transform::NormalScore { .. } => TransformKind::NormalScore,
            Transform::Contacts { .. } => TransformKind::None,
        }
    }

    /// The transformed value of `v` (a sample value or a threshold).
    pub fn apply(&self, v: f64) -> f64 {
        match self {
            Transform::None => v,
            Transform::Log { shift } => (v + shift).max(f64::MIN_POSITIVE).ln(),
            Transform::NormalScore { values, scores } => interpolate(values, scores, v),
            Transform::Contacts { level, cap } => (v - level) * 2.0 * cap,
        }
    }

    /// The value whose transform is `y` (for reporting the model's values back).
    pub fn invert(&self, y: f64) -> f64 {
        match self {
            Transform::None => y,
            Transform::Log { shift } => y.exp() - shift,
            Transform::NormalScore { values, scores } => interpolate(scores, values, y),
            Transform::Contacts { level, cap } => {
                (level + y / (2.0 * cap)).clamp(level - 0.5, level + 0.5)
            }
        }
    }
}

/// Piecewise-linear interpolation on sorted `xs`, extended with the end slopes (or flat
/// for a single point).
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    if n == 1 {
        return ys[0];
    }
    let i = xs.partition_point(|&v| v < x).clamp(1, n - 1);
    let (x0, x1, y0, y1) = (xs[i - 1], xs[i], ys[i - 1], ys[i]);
    y0 + (y1 - y0) * (x - x0) / (x1 - x0)
}

/// The standard normal quantile (Acklam's rational approximation, relative error < 1.2e-9).
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let low = 0.024_25;
    if p < low {
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else if p <= 1.0 - low {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        -normal_quantile(1.0 - p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_known_values() {
        assert!(normal_quantile(0.5).abs() < 1e-12);
        assert!((normal_quantile(0.975) - 1.959_963_985).abs() < 1e-8);
        assert!((normal_quantile(0.01) + 2.326_347_874).abs() < 1e-8);
    }

    #[test]
    fn transforms_are_monotone_and_invert() {
        let values = [0.0, 0.1, 0.1, 0.5, 2.0, 7.5, 30.0];
        for kind in [
            TransformKind::None,
            TransformKind::Log,
            TransformKind::NormalScore,
        ] {
            let t = Transform::fit(kind, &values);
            let mut last = f64::NEG_INFINITY;
            for v in [0.0, 0.05, 0.1, 0.3, 1.0, 5.0, 7.5, 20.0, 30.0] {
                let y = t.apply(v);
                assert!(y.is_finite() && y > last, "{kind:?} at {v}");
                assert!(
                    (t.invert(y) - v).abs() < 1e-9 * (1.0 + v),
                    "{kind:?} at {v}"
                );
                last = y;
            }
        }
    }
}
