//! Shuffle attributable to the road-slope signal, per gear: what the slope filter removes from
//! the simulated driveline shuffle.
//!
//! Two simulations of the same drive differ only in their slope input: the raw sensor slope and
//! the filtered one. Their shuffle indicators (the simulated vehicle speed band-passed 1–5 Hz,
//! zero phase, [`super::validate::ShuffleValidation::shuffle_indicator`]) are linear in the speed,
//! so the indicator of the difference of the speeds is the difference of the indicators,
//! `s_slope = s_raw − s_filtered`: the shuffle that the slope content removed by the filter
//! excites. Its mean square per engaged gear, beside the total shuffle with the raw slope
//! (`s_raw`), shows where the filter acts. Myklebust & Eriksson (2012) find the effect in the low
//! gears, where the truck is slow and a driveline resonance of a few hertz lies at a spatial
//! frequency above the filter's cut-off, and none in the high gears; the torque-driven shuffle,
//! common to both runs, cancels in the difference.

use serde::{Deserialize, Serialize};

/// One gear's shuffle, mean squares in (m/s)².
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GearShuffle {
    /// Engaged gear (1 = lowest).
    pub gear: i32,
    /// Samples in that gear with both indicators finite.
    pub samples: u64,
    /// Mean square of `s_raw − s_filtered`, m²/s²: shuffle the filter removes.
    pub ms_slope_m2_per_s2: f64,
    /// Mean square of `s_raw`, m²/s²: all shuffle with the raw sensor slope.
    pub ms_total_m2_per_s2: f64,
}

/// Per gear (gears ≥ 1, in increasing order; samples whose gear is missing, neutral or reverse
/// are left out), the mean squares of `raw − filtered` and of `raw`, from the two shuffle
/// indicators and the gear column on the same time axis.
pub fn by_gear(raw: &[f64], filtered: &[f64], gear: &[f64]) -> Vec<GearShuffle> {
    let mut acc: std::collections::BTreeMap<i32, (u64, f64, f64)> = Default::default();
    for ((r, f), g) in raw.iter().zip(filtered).zip(gear) {
        if !(r.is_finite() && f.is_finite() && g.is_finite()) || g.round() < 1.0 {
            continue;
        }
        let e = acc.entry(g.round() as i32).or_default();
        let d = r - f;
        e.0 += 1;
        e.1 += d * d;
        e.2 += r * r;
    }
    finish(acc)
}

/// Sums per gear (samples, Σ slope part, Σ total) into mean squares; gears without samples left
/// out.
fn finish(acc: std::collections::BTreeMap<i32, (u64, f64, f64)>) -> Vec<GearShuffle> {
    acc.into_iter()
        .filter(|(_, e)| e.0 > 0)
        .map(|(gear, (n, sd, sr))| GearShuffle {
            gear,
            samples: n,
            ms_slope_m2_per_s2: sd / n as f64,
            ms_total_m2_per_s2: sr / n as f64,
        })
        .collect()
}

/// Pools per-drive tables: per gear, the sample-weighted means of both mean squares.
pub fn pool<'a>(drives: impl IntoIterator<Item = &'a [GearShuffle]>) -> Vec<GearShuffle> {
    let mut acc: std::collections::BTreeMap<i32, (u64, f64, f64)> = Default::default();
    for d in drives {
        for g in d {
            let e = acc.entry(g.gear).or_default();
            e.0 += g.samples;
            e.1 += g.ms_slope_m2_per_s2 * g.samples as f64;
            e.2 += g.ms_total_m2_per_s2 * g.samples as f64;
        }
    }
    finish(acc)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_gear_mean_squares_of_the_difference_and_the_total() {
        let raw = [1.0, 2.0, 3.0, 4.0, f64::NAN, 1.0];
        let filt = [1.0, 1.0, 1.0, 1.0, 0.0, 0.0];
        let gear = [1.0, 1.0, 2.0, 2.0, 2.0, 0.0];
        let t = by_gear(&raw, &filt, &gear);
        assert_eq!(t.len(), 2, "neutral and the NaN sample left out");
        assert_eq!((t[0].gear, t[0].samples), (1, 2));
        assert!((t[0].ms_slope_m2_per_s2 - 0.5).abs() < 1e-15); // (0 + 1) / 2
        assert!((t[0].ms_total_m2_per_s2 - 2.5).abs() < 1e-15); // (1 + 4) / 2
        assert!((t[1].ms_slope_m2_per_s2 - 6.5).abs() < 1e-15); // (4 + 9) / 2
        let p = pool([t.as_slice(), t.as_slice()]);
        assert_eq!(p[1].samples, 4);
        assert!((p[1].ms_total_m2_per_s2 - 12.5).abs() < 1e-15);
    }
}
