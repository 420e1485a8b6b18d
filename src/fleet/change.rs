//! Changes of a parameter over a vehicle's drives ([`changes`]): binary segmentation with a
//! random-effects two-sample test at every split, its false-alarm rate fixed in advance.

use super::pool::{fit_groups, is_usable, pool, Pooled};
use crate::signal::stats::t_cdf;

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
    /// The two-sample statistic `(x̄_after − x̄_before) / √(se_before² + se_after²)` of the
    /// random-effects fit of the two segments ([`fit_groups`]).
    pub z: f64,
    /// Its two-sided Student t p-value on `n − 2` degrees of freedom, Bonferroni-adjusted over
    /// the splits searched (≤ [`FALSE_ALARM`] for a change).
    pub p_value: f64,
}

/// The most significant split of `points` (`(value, standard error)` in time order; points
/// with a non-finite value or a standard error that is not positive are left out, `at` counts
/// all). At each split `k` with at least [`MIN_SEGMENT`] usable drives on either side the two
/// segments are fitted together ([`fit_groups`]: one between-drive variance `τ²` estimated from
/// the scatter within both segments, each segment's mean weighted by `1/(sᵢ² + τ²)`) and
/// compared by `z_k = (x̄_b − x̄_a) / √(se_a² + se_b²)`, read as Student t on `n − 2` degrees of
/// freedom. The split of largest `|z_k|` is returned with its two-sided p-value multiplied by
/// the number of splits searched (Bonferroni, so the search over splits keeps the false-alarm
/// rate). Drives that scatter beyond their intervals widen both segments alike, so a truck
/// whose estimates move with the weather and the road is not read as changing; a normal
/// quantile on each segment's own scatter would be (three drives estimate a scale badly).
/// `None` below `2 · MIN_SEGMENT` usable drives.
pub fn best_split(points: &[(f64, f64)]) -> Option<Change> {
    let index: Vec<usize> = (0..points.len())
        .filter(|&i| is_usable(&points[i]))
        .collect();
    let ok: Vec<(f64, f64)> = index.iter().map(|&i| points[i]).collect();
    let n = ok.len();
    if n < 2 * MIN_SEGMENT {
        return None;
    }
    let splits = n - 2 * MIN_SEGMENT + 1;
    let mut best: Option<Change> = None;
    for k in MIN_SEGMENT..=n - MIN_SEGMENT {
        let fit = fit_groups(&[&ok[..k], &ok[k..]]);
        let ((a, sa), (b, sb)) = (fit.means[0], fit.means[1]);
        let z = (b - a) / (sa * sa + sb * sb).sqrt();
        if !z.is_finite() {
            continue;
        }
        if best.is_none_or(|c| z.abs() > c.z.abs()) {
            let p = 2.0 * t_cdf(-z.abs(), fit.dof as f64);
            best = Some(Change {
                at: index[k],
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

    /// A clean series whose drives scatter `tau` beyond their stated errors, with heavy tails:
    /// Student t with 4 degrees of freedom, scaled to the variance `sᵢ² + τ²`.
    fn overdispersed(rng: &mut Xoshiro256StarStar, n: usize, tau: f64) -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                let s = 0.5 + (i % 3) as f64 * 0.5;
                let chi2: f64 = (0..4).map(|_| gauss(rng).powi(2)).sum();
                let t4 = gauss(rng) / (chi2 / 4.0).sqrt() / 2f64.sqrt();
                ((s * s + tau * tau).sqrt() * t4, s)
            })
            .collect()
    }

    #[test]
    fn drives_scattering_beyond_their_intervals_raise_no_more_alarms() {
        // 1 000 clean series each of 8, 15 and 30 drives that scatter 1 and 3 times their
        // largest stated error beyond it, heavy-tailed: the test must stay near its level (at
        // most 5 in 1 000 per setting, where the level expects 1; the t reference is exact
        // only for normal scatter, and these tails are heavier)
        let mut rng = Xoshiro256StarStar::seed_from_u64(13);
        for tau in [1.5, 4.5] {
            for n in [8, 15, 30] {
                let found = (0..1000)
                    .filter(|_| !changes(&overdispersed(&mut rng, n, tau), FALSE_ALARM).is_empty())
                    .count();
                assert!(
                    found <= 5,
                    "τ {tau}, {n} drives: {found} false alarms in 1000"
                );
            }
        }
    }

    #[test]
    fn a_step_is_found_through_overdispersed_scatter() {
        // a step of 4 standard deviations of the drives' whole scatter (τ = 3 beyond errors of
        // 0.5–1.5) after 12 of 30 drives is found on at least 9 of 10 series, near where it is
        let mut rng = Xoshiro256StarStar::seed_from_u64(17);
        let mut hit = 0;
        for _ in 0..10 {
            let mut pts = overdispersed(&mut rng, 30, 3.0);
            for p in pts.iter_mut().skip(12) {
                p.0 += 4.0 * (p.1 * p.1 + 9.0).sqrt();
            }
            let c = changes(&pts, FALSE_ALARM);
            hit += c.iter().any(|c| (c.at as i64 - 12).abs() <= 2) as usize;
        }
        assert!(hit >= 9, "{hit} of 10");
    }

    #[test]
    fn unusable_drives_are_skipped_and_indices_count_every_drive() {
        // a NaN estimate before the step: the change is reported at the first drive after it,
        // counted over all drives
        let mut pts: Vec<(f64, f64)> = (0..12)
            .map(|i| (if i >= 6 { 10.0 } else { 0.0 } + 0.01 * (i % 3) as f64, 0.1))
            .collect();
        pts.insert(2, (f64::NAN, 0.1));
        let c = changes(&pts, FALSE_ALARM);
        assert_eq!(c.len(), 1, "{c:?}");
        assert_eq!(c[0].at, 7);
    }

    #[test]
    fn short_series_have_no_change() {
        assert!(best_split(&[(0.0, 1.0); 5]).is_none());
        assert!(changes(&[(0.0, 1.0), (9.0, 1.0)], FALSE_ALARM).is_empty());
    }
}
