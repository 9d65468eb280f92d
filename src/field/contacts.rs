//! Signed distance to the contacts down each hole: the field a 0/1 flag (or `--inside
//! CODE`) is modelled as with `--flag-field distance`.
//!
//! A sample inside the ore gets its distance along the hole to the nearest contact, a
//! sample outside minus that distance, both capped at a distance `cap`; a hole with no
//! contact gets `cap` (all ore) or `-cap` (all waste) everywhere. The contacts are the
//! midpoints between consecutive samples on either side of the level after the same
//! internal dilution the intercepts bridge ([`ore_runs`]: at most
//! [`MAX_DILUTION`](super::estimate::MAX_DILUTION) waste samples between ore samples
//! count as ore), so an assay of waste inside an ore run does not cut
//! the run in two. The kriged distance is contoured at zero: thickness is interpolated
//! between holes instead of a 0/1 step, which an indicator smooths away across a thin
//! lens.
//!
//! Invariant: a sample's value is positive exactly when it lies in an ore run (after the
//! bridging), and its magnitude never exceeds `cap`.

use super::estimate::{Samples, ore_runs};

/// Samples' signed distances to the contacts at `level` along their holes (`holes`: the
/// sample indices of each hole in down-hole order), capped at `cap` (> 0).
pub fn signed_distances(samples: &Samples, holes: &[Vec<u32>], level: f64, cap: f64) -> Vec<f64> {
    let mut out = vec![0.0; samples.values.len()];
    for hole in holes {
        let inside = bridged(hole.iter().map(|&i| samples.values[i as usize] >= level));
        let along = along_hole(hole.iter().map(|&i| samples.points[i as usize]));
        let contacts: Vec<f64> = (1..hole.len())
            .filter(|&k| inside[k] != inside[k - 1])
            .map(|k| 0.5 * (along[k - 1] + along[k]))
            .collect();
        let mut next = 0;
        for (k, &i) in hole.iter().enumerate() {
            while next < contacts.len() && contacts[next] < along[k] {
                next += 1;
            }
            let after = contacts.get(next).map(|c| c - along[k]);
            let before = next.checked_sub(1).map(|j| along[k] - contacts[j]);
            let d = match (before, after) {
                (Some(b), Some(a)) => b.min(a),
                (Some(b), None) => b,
                (None, Some(a)) => a,
                (None, None) => f64::INFINITY,
            }
            .min(cap);
            out[i as usize] = if inside[k] { d } else { -d };
        }
    }
    out
}

/// Ore flags with the waste that [`ore_runs`] bridges inside a run counted as ore.
fn bridged(flags: impl Iterator<Item = bool>) -> Vec<bool> {
    let flags: Vec<bool> = flags.collect();
    let mut inside = vec![false; flags.len()];
    for (first, last) in ore_runs(flags) {
        inside[first..=last].iter_mut().for_each(|f| *f = true);
    }
    inside
}

/// Distance along the hole of each sample from the first (through the samples).
fn along_hole(points: impl Iterator<Item = glam::DVec3>) -> Vec<f64> {
    let mut out = Vec::new();
    let mut last = None;
    let mut t = 0.0;
    for p in points {
        if let Some(q) = last {
            t += p.distance(q);
        }
        out.push(t);
        last = Some(p);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn hole(values: &[f64]) -> (Samples, Vec<Vec<u32>>) {
        let samples = Samples {
            points: (0..values.len())
                .map(|k| DVec3::new(0.0, 0.0, -1.5 * k as f64))
                .collect(),
            values: values.to_vec(),
            holes: vec![0; values.len()],
        };
        let order = vec![(0..values.len() as u32).collect()];
        (samples, order)
    }

    #[test]
    fn distances_are_signed_capped_and_zero_at_the_contacts() {
        let (s, h) = hole(&[0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let d = signed_distances(&s, &h, 0.5, 3.0);
        assert_eq!(
            d,
            vec![
                -3.0, -2.25, -0.75, 0.75, 2.25, 2.25, 0.75, -0.75, -2.25, -3.0, -3.0, -3.0
            ]
        );
    }

    #[test]
    fn dilution_within_a_run_is_bridged_and_holes_without_contacts_take_the_cap() {
        let (s, h) = hole(&[1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        let d = signed_distances(&s, &h, 0.5, 10.0);
        assert!(d[..4].iter().all(|v| *v > 0.0), "{d:?}");
        assert!(d[4..7].iter().all(|v| *v < 0.0), "{d:?}");
        assert!(d[7] > 0.0);
        let (s, h) = hole(&[0.0; 4]);
        assert_eq!(signed_distances(&s, &h, 0.5, 2.0), vec![-2.0; 4]);
    }
}
