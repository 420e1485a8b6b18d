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

/// [`median`] by selection instead of a sort: the same value to the bit (the elements of rank
/// `⌊n/2⌋` and, for an even count, `n/2 − 1` in `f64::total_cmp` order), in linear time; `v` is
/// left partly ordered, not sorted. For the many short windows of a running median.
pub fn median_unordered(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let (lower, mid, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    let mid = *mid;
    if n % 2 == 1 {
        mid
    } else {
        let below = lower
            .iter()
            .copied()
            .max_by(f64::total_cmp)
            .expect("an even count of at least 2");
        0.5 * (below + mid)
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

/// FFT length of one block of [`xcorr_sums`]: a block of `a` is `m − 2·max_lag` samples long
/// for a transform length `m` of this, or of the power of two from `4·max_lag + 2` when the
/// lags reach further (a block at least as long as the lag span), or of the power of two from
/// the series' length plus `2·max_lag` when that is shorter.
pub const XCORR_FFT_LEN: usize = 1 << 15;

/// Σ_t a(t)·b(t+k) for k = −max_lag..=max_lag (index k + max_lag; `b` read as zero outside
/// its samples, t over `a`'s), by FFT a block of `a` at a time: each block is correlated
/// with the stretch of `b` its lags reach (length block + 2·max_lag, zero outside `b`) in one
/// transform long enough that no lag wraps, and the blocks' sums are added in order. The
/// working memory is a few transforms of [`XCORR_FFT_LEN`] (or of the series, when shorter),
/// whatever the series' length: a 10-hour drive's 1.8 million rows never need the ~170 MB of
/// one zero-padded transform of the whole.
pub fn xcorr_sums(a: &[f64], b: &[f64], max_lag: usize) -> Vec<f64> {
    let n = a.len();
    let l = max_lag;
    let mut sums = vec![0.0; 2 * l + 1];
    if n == 0 {
        return sums;
    }
    let m = (n + 2 * l)
        .next_power_of_two()
        .min(XCORR_FFT_LEN.max((4 * l + 2).next_power_of_two()));
    let block = m - 2 * l;
    let fwd = super::fft_plans::forward(m);
    let inv = super::fft_plans::inverse(m);
    let mut buf = fwd.make_input_vec();
    let mut sa = fwd.make_output_vec();
    let mut sb = fwd.make_output_vec();
    let mut out = inv.make_output_vec();
    for s in (0..n).step_by(block) {
        let len = block.min(n - s);
        buf.iter_mut().for_each(|x| *x = 0.0);
        buf[..len].copy_from_slice(&a[s..s + len]);
        fwd.process(&mut buf, &mut sa).expect("plan sizes");
        // b from s − l on: b_seg[u] = b[s − l + u], u < block + 2l = m
        for (u, x) in buf.iter_mut().enumerate() {
            *x = (s + u)
                .checked_sub(l)
                .and_then(|i| b.get(i))
                .copied()
                .unwrap_or(0.0);
        }
        fwd.process(&mut buf, &mut sb).expect("plan sizes");
        for (x, y) in sa.iter_mut().zip(&sb) {
            *x = x.conj() * y;
        }
        inv.process(&mut sa, &mut out).expect("plan sizes");
        // out[j] = Σ_t a(s + t)·b(s − l + t + j): lag k = j − l
        for (acc, v) in sums.iter_mut().zip(&out) {
            *acc += v / m as f64;
        }
    }
    sums
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
    fn the_median_by_selection_is_the_sorted_median_to_the_bit() {
        // odd and even counts, repeated values, signed zeros and infinities, and pseudo-random
        // windows like a running median's
        let mut cases: Vec<Vec<f64>> = vec![
            vec![3.0, 1.0, 2.0],
            vec![4.0, 1.0, 3.0, 2.0],
            vec![0.0, -0.0, 0.0, -0.0],
            vec![-0.0, 0.0],
            vec![f64::INFINITY, 1.0, f64::NEG_INFINITY, 2.0],
            vec![5.0; 6],
            vec![1.0],
        ];
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for n in 2..60 {
            cases.push(
                (0..n)
                    .map(|_| {
                        x ^= x << 13;
                        x ^= x >> 7;
                        x ^= x << 17;
                        ((x % 2001) as f64 - 1000.0) * 0.01
                    })
                    .collect(),
            );
        }
        for c in cases {
            let sorted = median(&mut c.clone());
            let selected = median_unordered(&mut c.clone());
            assert_eq!(sorted.to_bits(), selected.to_bits(), "{c:?}");
        }
        assert!(median_unordered(&mut []).is_nan());
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

    #[test]
    fn blocked_xcorr_equals_the_direct_sums_across_blocks() {
        // three and a half blocks, and a series shorter than one; tolerance: 1e-12 of
        // Σ|a||b| (the transforms' rounding, about log2(n)·ε per sum)
        for n in [1000, 3 * XCORR_FFT_LEN + XCORR_FFT_LEN / 2] {
            let a: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1013) as f64 - 506.0).collect();
            let b: Vec<f64> = (0..n)
                .map(|i| ((i * 104_729) % 997) as f64 - 498.0)
                .collect();
            let l = 100;
            let x = xcorr_sums(&a, &b, l);
            let scale: f64 = a.iter().map(|v| v.abs()).sum::<f64>()
                * b.iter().map(|v| v.abs()).fold(0.0, f64::max);
            for (j, got) in x.iter().enumerate() {
                let k = j as i64 - l as i64;
                let direct: f64 = (0..n as i64)
                    .filter(|t| (0..n as i64).contains(&(t + k)))
                    .map(|t| a[t as usize] * b[(t + k) as usize])
                    .sum();
                assert!(
                    (got - direct).abs() <= 1e-12 * scale,
                    "n {n} lag {k}: {got} against {direct}"
                );
            }
        }
    }
}
