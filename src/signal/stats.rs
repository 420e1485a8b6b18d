//! Small statistics shared by the diagnosis, the proof and the noise estimates: the median, run
//! finders, Holm's step-down adjustment of a family of p-values, the upper tail of the F
//! distribution, the standard normal quantile and tail, the Student t quantile and distribution
//! function, and the cross-correlation sums of two series by
//! FFT.

use statrs::distribution::{ContinuousCDF, FisherSnedecor, Normal, StudentsT};

/// Median of `v` (sorted in place by `f64::total_cmp`; the mean of the two middle values for an
/// even count); NaN for an empty slice.
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Contiguous runs `[a, b)` of `true` rows of `ok`, in order.
pub fn runs(ok: &[bool]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < ok.len() {
        if !ok[i] {
            i += 1;
            continue;
        }
        let a = i;
        while i < ok.len() && ok[i] {
            i += 1;
        }
        out.push((a, i));
    }
    out
}

/// The runs of consecutive indices in `rows` (increasing), as ranges of positions in `rows` (and
/// so in a vector gathered at `rows`): `[3, 4, 5, 9, 10]` → `[0..3, 3..5]`.
pub fn run_positions(rows: &[usize]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..=rows.len() {
        if k == rows.len() || rows[k] != rows[k - 1] + 1 {
            if k > start {
                out.push(start..k);
            }
            start = k;
        }
    }
    out
}

/// Holm step-down adjusted p-values (same order as `p`).
pub fn holm(p: &[f64]) -> Vec<f64> {
    let m = p.len();
    let mut idx: Vec<usize> = (0..m).collect();
    idx.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let mut out = vec![1.0; m];
    let mut run = 0.0f64;
    for (rank, &i) in idx.iter().enumerate() {
        let adj = ((m - rank) as f64 * p[i]).min(1.0);
        run = run.max(adj);
        out[i] = run;
    }
    out
}

/// Upper tail of `F(d1, d2)` at `x` (1 for x ≤ 0 or degenerate degrees of freedom).
pub fn f_sf(x: f64, d1: f64, d2: f64) -> f64 {
    if !(x.is_finite() && x > 0.0 && d1 > 0.0 && d2 > 0.0) {
        return if x == f64::INFINITY { 0.0 } else { 1.0 };
    }
    FisherSnedecor::new(d1, d2).map_or(1.0, |f| f.sf(x).clamp(0.0, 1.0))
}

/// Standard normal quantile.
pub fn z_quantile(p: f64) -> f64 {
    Normal::new(0.0, 1.0).map_or(f64::NAN, |n| n.inverse_cdf(p))
}

/// Standard normal upper tail `P(Z > x)`.
pub fn normal_sf(x: f64) -> f64 {
    Normal::new(0.0, 1.0).map_or(f64::NAN, |n| n.sf(x))
}

/// Student t quantile with `dof` degrees of freedom; NaN for `dof` that is not positive.
pub fn t_quantile(p: f64, dof: f64) -> f64 {
    StudentsT::new(0.0, 1.0, dof).map_or(f64::NAN, |t| t.inverse_cdf(p))
}

/// Student t distribution function with `dof` degrees of freedom; NaN for `dof` that is not
/// positive.
pub fn t_cdf(x: f64, dof: f64) -> f64 {
    StudentsT::new(0.0, 1.0, dof).map_or(f64::NAN, |t| t.cdf(x))
}

/// Σ_t a(t)·b(t+k) for k = −max_lag..=max_lag, by FFT (index k + max_lag).
pub fn xcorr_sums(a: &[f64], b: &[f64], max_lag: usize) -> Vec<f64> {
    let n = a.len();
    if n == 0 {
        return vec![0.0; 2 * max_lag + 1];
    }
    let m = (2 * n).next_power_of_two();
    let fwd = super::fft_plans::forward(m);
    let inv = super::fft_plans::inverse(m);
    let spec = |x: &[f64]| {
        let mut buf = fwd.make_input_vec();
        buf[..n].copy_from_slice(x);
        let mut s = fwd.make_output_vec();
        fwd.process(&mut buf, &mut s).expect("plan sizes");
        s
    };
    let (sa, sb) = (spec(a), spec(b));
    let mut prod: Vec<num_complex::Complex64> =
        sa.iter().zip(&sb).map(|(x, y)| x.conj() * y).collect();
    let mut out = inv.make_output_vec();
    inv.process(&mut prod, &mut out).expect("plan sizes");
    let l = max_lag as i64;
    (-l..=l)
        .map(|k| {
            if k.unsigned_abs() as usize >= n {
                0.0
            } else if k >= 0 {
                out[k as usize] / m as f64
            } else {
                out[(m as i64 + k) as usize] / m as f64
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_even_and_empty() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&mut []).is_nan());
    }

    #[test]
    fn runs_of_rows_and_of_indices() {
        assert_eq!(
            runs(&[true, true, false, true, false, false, true]),
            vec![(0, 2), (3, 4), (6, 7)]
        );
        assert!(runs(&[false, false]).is_empty());
        let rows = [1, 2, 3, 7, 9, 10];
        assert_eq!(run_positions(&rows), vec![0..3, 3..4, 4..6]);
        assert!(run_positions(&[]).is_empty());
    }

    #[test]
    fn holm_matches_the_step_down_rule() {
        let p = [0.01, 0.04, 0.03, 0.005];
        let a = holm(&p);
        // sorted: 0.005·4 = 0.02, 0.01·3 = 0.03, 0.03·2 = 0.06, 0.04·1 → max(0.06, 0.04)
        let want = [0.03, 0.06, 0.06, 0.02];
        for (x, y) in a.iter().zip(want) {
            assert!((x - y).abs() < 1e-12, "{a:?}");
        }
        assert!(holm(&[]).is_empty());
    }

    #[test]
    fn xcorr_finds_a_shift() {
        let a: Vec<f64> = (0..200).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let b: Vec<f64> = (0..200)
            .map(|i| if i >= 3 { a[i - 3] } else { 0.0 })
            .collect();
        let x = xcorr_sums(&a, &b, 5);
        let k = x
            .iter()
            .enumerate()
            .max_by(|p, q| p.1.total_cmp(q.1))
            .unwrap()
            .0;
        assert_eq!(k as i64 - 5, 3);
    }
}
