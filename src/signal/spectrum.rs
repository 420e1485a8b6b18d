//! Summaries of one-sided power spectra (used for road spectra).

/// Cumulative share of power up to each frequency, normalised so that the
/// last value is 1.
///
/// Trapezoidal integral of `psd` over `freq` (ascending), starting at 0 at
/// `freq[0]`. Returns all zeros if the total power is 0 or not finite.
/// `freq` and `psd` must have equal length (the shorter length is used).
pub fn cumulative_power(freq: &[f64], psd: &[f64]) -> Vec<f64> {
    let n = freq.len().min(psd.len());
    let mut out = vec![0.0; n];
    for i in 1..n {
        out[i] = out[i - 1] + 0.5 * (psd[i] + psd[i - 1]) * (freq[i] - freq[i - 1]);
    }
    let total = out.last().copied().unwrap_or(0.0);
    if total > 0.0 && total.is_finite() {
        out.iter_mut().for_each(|v| *v /= total);
    } else {
        out.iter_mut().for_each(|v| *v = 0.0);
    }
    out
}

/// Frequency below which `fraction` (0..=1) of the power lies, by linear
/// interpolation of [`cumulative_power`] between bins (same unit as
/// `freq`). NaN if there is no power or fewer than 2 bins.
pub fn knee_frequency(freq: &[f64], psd: &[f64], fraction: f64) -> f64 {
    let cum = cumulative_power(freq, psd);
    if cum.len() < 2 || cum[cum.len() - 1] != 1.0 || !(0.0..=1.0).contains(&fraction) {
        return f64::NAN;
    }
    for i in 1..cum.len() {
        if cum[i] >= fraction {
            let (c0, c1) = (cum[i - 1], cum[i]);
            let t = if c1 > c0 {
                (fraction - c0) / (c1 - c0)
            } else {
                0.0
            };
            return freq[i - 1] + t * (freq[i] - freq[i - 1]);
        }
    }
    freq[cum.len() - 1]
}

/// Share of the power below frequency `f`: the cumulative share (`cumulative`, from
/// [`cumulative_power`] over `freq`) interpolated linearly at `f`; 0 below the first bin, 1 above
/// the last, NaN without bins or power.
pub fn share_below(freq: &[f64], cumulative: &[f64], f: f64) -> f64 {
    let n = freq.len().min(cumulative.len());
    if n < 2 || cumulative[n - 1] != 1.0 || f.is_nan() {
        return f64::NAN;
    }
    if f <= freq[0] {
        return 0.0;
    }
    let i = freq[..n].partition_point(|&x| x < f);
    if i >= n {
        return 1.0;
    }
    let t = (f - freq[i - 1]) / (freq[i] - freq[i - 1]);
    cumulative[i - 1] + t * (cumulative[i] - cumulative[i - 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn share_below_interpolates_the_cumulative_power() {
        let f: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01).collect();
        let c = cumulative_power(&f, &vec![2.0; f.len()]);
        assert!((share_below(&f, &c, 0.255) - 0.255).abs() < 1e-12);
        assert_eq!(share_below(&f, &c, -1.0), 0.0);
        assert_eq!(share_below(&f, &c, 2.0), 1.0);
        assert!(share_below(&f, &[0.0; 101], 0.5).is_nan());
    }

    #[test]
    fn flat_spectrum_knee_is_linear() {
        let f: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01).collect();
        let p = vec![2.0; f.len()];
        let c = cumulative_power(&f, &p);
        assert!((c[50] - 0.5).abs() < 1e-12);
        assert!((knee_frequency(&f, &p, 0.9) - 0.9).abs() < 1e-12);
        assert!(knee_frequency(&f, &[0.0; 101], 0.5).is_nan());
    }
}
