//! Changes of a parameter over a vehicle's drives ([`changes`]): binary segmentation with a
//! two-sample test at every split, its false-alarm rate fixed in advance.

use super::pool::{pool, Pooled};
use crate::signal::stats::normal_sf;

/// Fewest drives on either side of a change: a change needs three drives to stand on (one drive
/// is one road, one payload, one driver).
pub const MIN_SEGMENT: usize = 3;

/// False-alarm probability of one test (one series, or one segment of it, searched over all its
/// splits): 10⁻³. A vehicle has about ten persistent parameters, so a clean vehicle raises a
/// false alarm in about one evaluation in a hundred; nightly evaluations overlap (the same drives
/// plus one), so alarms on a clean vehicle are rarer than one per hundred nights.
pub const FALSE_ALARM: f64 = 1e-3;

/// One change found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Change {
    /// Index of the first drive after the change.
    pub at: usize,
    /// The two-sample statistic `(x̄_after − x̄_before) / √(se_before² + se_after²)`.
    pub z: f64,
    /// Its p-value, Bonferroni-adjusted over the splits searched (≤ [`FALSE_ALARM`]).
    pub p_value: f64,
}

/// The most significant split of `points` (`(value, standard error)` in time order): at each
/// split `k` with at least [`MIN_SEGMENT`] drives on either side, the segments are pooled
/// ([`pool`], each with its own dispersion) and compared by `z_k`; the split of largest `|z_k|`,
/// its two-sided normal p-value multiplied by the number of splits searched (Bonferroni, so the
/// search over splits keeps the false-alarm rate). `None` below `2 · MIN_SEGMENT` drives.
pub fn best_split(points: &[(f64, f64)]) -> Option<Change> {
    let n = points.len();
    if n < 2 * MIN_SEGMENT {
        return None;
    }
    let splits = n - 2 * MIN_SEGMENT + 1;
    let mut best: Option<Change> = None;
    for k in MIN_SEGMENT..=n - MIN_SEGMENT {
        let (Some(a), Some(b)) = (pool(&points[..k]), pool(&points[k..])) else {
            continue;
        };
        let z = (b.value - a.value) / (a.se * a.se + b.se * b.se).sqrt();
        if !z.is_finite() {
            continue;
        }
        if best.is_none_or(|c| z.abs() > c.z.abs()) {
            let p = 2.0 * normal_sf(z.abs());
            best = Some(Change {
                at: k,
                z,
                p_value: (p * splits as f64).min(1.0),
            });
        }
    }
    best
}

/// Every change of `points` by binary segmentation: the most significant split of the series
/// ([`best_split`]) is a change when its adjusted p-value is below `alpha`, and each side is
/// searched again; in time order.
pub fn changes(points: &[(f64, f64)], alpha: f64) -> Vec<Change> {
    let mut out = Vec::new();
    let mut stack = vec![(0, points.len())];
    while let Some((a, b)) = stack.pop() {
        if let Some(c) = best_split(&points[a..b]).filter(|c| c.p_value < alpha) {
            out.push(Change { at: a + c.at, ..c });
            stack.push((a, a + c.at));
            stack.push((a + c.at, b));
        }
    }
    out.sort_by_key(|c| c.at);
    out
}

/// The segments between `changes` (indices `[start, end)`), each pooled.
pub fn segments(points: &[(f64, f64)], changes: &[Change]) -> Vec<(usize, usize, Option<Pooled>)> {
    let mut bounds = vec![0];
    bounds.extend(changes.iter().map(|c| c.at));
    bounds.push(points.len());
    bounds
        .windows(2)
        .map(|w| (w[0], w[1], pool(&points[w[0]..w[1]])))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro256StarStar;

    fn gauss(rng: &mut Xoshiro256StarStar) -> f64 {
        let (u, v) = (rng.next_f64().max(1e-300), rng.next_f64());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    fn series(
        rng: &mut Xoshiro256StarStar,
        n: usize,
        shift_at: usize,
        shift: f64,
    ) -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                // drives of unequal information: standard errors 0.5 … 1.5
                let s = 0.5 + (i % 3) as f64 * 0.5;
                let mean = if i >= shift_at { shift } else { 0.0 };
                (mean + s * gauss(rng), s)
            })
            .collect()
    }

    #[test]
    fn a_step_is_found_where_it_is() {
        let mut rng = Xoshiro256StarStar::seed_from_u64(7);
        let pts = series(&mut rng, 30, 12, 3.0);
        let c = changes(&pts, FALSE_ALARM);
        assert_eq!(c.len(), 1, "{c:?}");
        assert!((c[0].at as i64 - 12).abs() <= 1, "{c:?}");
        let seg = segments(&pts, &c);
        let after = seg[1].2.unwrap();
        assert!(after.ci_low < 3.0 && 3.0 < after.ci_high, "{after:?}");
    }

    #[test]
    fn the_false_alarm_rate_holds_on_clean_series() {
        // 2 000 clean series of 30 drives: the rate of any change found is at most the level (a
        // Bonferroni bound; the expected count at 10⁻³ is 2 or fewer, 8 would be 4σ of a
        // binomial at the level)
        let mut rng = Xoshiro256StarStar::seed_from_u64(11);
        let found = (0..2000)
            .filter(|_| !changes(&series(&mut rng, 30, usize::MAX, 0.0), FALSE_ALARM).is_empty())
            .count();
        assert!(found <= 8, "{found} false alarms in 2000 clean series");
    }

    #[test]
    fn short_series_have_no_change() {
        assert!(best_split(&[(0.0, 1.0); 5]).is_none());
        assert!(changes(&[(0.0, 1.0), (9.0, 1.0)], FALSE_ALARM).is_empty());
    }
}
