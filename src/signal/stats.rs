//! Small order statistics and run finders shared by the diagnosis, the proof and the noise
//! estimates.

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

/// Contiguous runs of `rows` (sorted row indices): consecutive indices belong to one run.
pub fn index_runs(rows: &[usize]) -> Vec<&[usize]> {
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..=rows.len() {
        if k == rows.len() || rows[k] != rows[k - 1] + 1 {
            if k > start {
                out.push(&rows[start..k]);
            }
            start = k;
        }
    }
    out
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
        assert_eq!(
            index_runs(&rows),
            vec![&[1, 2, 3][..], &[7][..], &[9, 10][..]]
        );
        assert!(index_runs(&[]).is_empty());
    }
}
