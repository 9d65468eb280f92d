//! Sample values as geologists write them: numbers, "don't know" tokens, below- and
//! above-detection limits, and categorical codes.
//!
//! Invariant: a value is either a finite number or "don't know" (`None`); text that is
//! none of the recognised forms is an error, never a silent zero.

use serde::Serialize;

/// What a below-detection value (`<0.01`, or a negative sentinel `-0.01`) becomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BelowDetection {
    /// Half the detection limit (`<0.01` -> 0.005), the common geochemical convention.
    #[default]
    Half,
    /// Zero.
    Zero,
}

impl std::str::FromStr for BelowDetection {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "half" => Ok(Self::Half),
            "zero" => Ok(Self::Zero),
            other => Err(format!(
                "below-detection rule '{other}' is neither half nor zero"
            )),
        }
    }
}

/// Tokens meaning "don't know" (compared case-insensitively after trimming).
pub(crate) const UNKNOWN_TOKENS: &[&str] = &[
    "", "na", "n/a", "nan", "?", "null", "none", "-", "--", "ns", "nr", "lnr", "is", "nodata",
];

/// The reading of one value field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Reading {
    Unknown,
    Value(f64),
    /// Below a detection limit; the limit (positive).
    Below(f64),
    /// Above an upper detection limit; the limit.
    Above(f64),
}

/// Rules for turning a field into a [`Reading`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct ValueRules {
    pub below: BelowDetection,
    pub negative_is_below: bool,
}

impl ValueRules {
    /// Parses a field; `Err(())` for text that is not a recognised value.
    pub fn read(&self, text: &str) -> Result<Reading, ()> {
        let t = text.trim();
        if UNKNOWN_TOKENS.iter().any(|u| t.eq_ignore_ascii_case(u)) {
            return Ok(Reading::Unknown);
        }
        if let Some(rest) = t.strip_prefix('<') {
            let limit = rest.trim().parse::<f64>().map_err(|_| ())?;
            if !limit.is_finite() {
                return Err(());
            }
            return Ok(Reading::Below(limit.abs()));
        }
        if let Some(rest) = t.strip_prefix('>') {
            let limit = rest.trim().parse::<f64>().map_err(|_| ())?;
            if !limit.is_finite() {
                return Err(());
            }
            return Ok(Reading::Above(limit));
        }
        let v = t.parse::<f64>().map_err(|_| ())?;
        if !v.is_finite() {
            return Err(());
        }
        if self.negative_is_below && v < 0.0 {
            return Ok(Reading::Below(-v));
        }
        Ok(Reading::Value(v))
    }

    /// The number a reading stands for (`None`: don't know).
    pub fn number(&self, reading: Reading) -> Option<f64> {
        match reading {
            Reading::Unknown => None,
            Reading::Value(v) | Reading::Above(v) => Some(v),
            Reading::Below(limit) => Some(match self.below {
                BelowDetection::Half => limit * 0.5,
                BelowDetection::Zero => 0.0,
            }),
        }
    }
}

/// Categorical codes to 0/1: a code in `inside` is 1, another code 0, a don't-know token
/// `None`.
pub(crate) fn read_code(text: &str, inside: &[String]) -> Option<f64> {
    let t = text.trim();
    if UNKNOWN_TOKENS.iter().any(|u| t.eq_ignore_ascii_case(u)) {
        return None;
    }
    Some(if inside.iter().any(|c| c.trim().eq_ignore_ascii_case(t)) {
        1.0
    } else {
        0.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const RULES: ValueRules = ValueRules {
        below: BelowDetection::Half,
        negative_is_below: true,
    };

    #[test]
    fn dont_know_tokens_are_none_not_zero() {
        for t in ["", " NA ", "?", "null", "NaN", "-"] {
            assert_eq!(RULES.read(t), Ok(Reading::Unknown), "{t:?}");
        }
    }

    #[test]
    fn below_detection_is_half_the_limit_and_distinct_from_missing() {
        assert_eq!(RULES.read("<0.01"), Ok(Reading::Below(0.01)));
        assert_eq!(RULES.read("-0.5"), Ok(Reading::Below(0.5)));
        assert_eq!(RULES.number(Reading::Below(0.01)), Some(0.005));
        let zero = ValueRules {
            below: BelowDetection::Zero,
            negative_is_below: false,
        };
        assert_eq!(zero.number(Reading::Below(0.01)), Some(0.0));
        assert_eq!(zero.read("-0.5"), Ok(Reading::Value(-0.5)));
    }

    #[test]
    fn text_and_infinities_are_rejected() {
        assert!(RULES.read("abc").is_err());
        assert!(RULES.read("inf").is_err());
        assert!(RULES.read("<x").is_err());
    }

    #[test]
    fn codes_are_case_insensitive() {
        let inside = vec!["TSBF".to_owned(), "tsgf".to_owned()];
        assert_eq!(read_code("tsbf", &inside), Some(1.0));
        assert_eq!(read_code("TSGF ", &inside), Some(1.0));
        assert_eq!(read_code("HW", &inside), Some(0.0));
        assert_eq!(read_code("", &inside), None);
    }
}
