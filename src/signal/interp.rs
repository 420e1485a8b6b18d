//! Reading a sampled series at an arbitrary time: linear between samples, held beyond the
//! ends (the convention of `numpy.interp`).

/// `ys` (on the increasing times `ts`, same length, at least one sample) at `t`: linear between
/// the samples around it, the first or last value before or after them.
pub fn interp_linear(ts: &[f64], ys: &[f64], t: f64) -> f64 {
    let k = ts.partition_point(|&x| x <= t);
    if k == 0 {
        return ys[0];
    }
    if k >= ts.len() {
        return ys[ys.len() - 1];
    }
    let w = (t - ts[k - 1]) / (ts[k] - ts[k - 1]);
    ys[k - 1] + w * (ys[k] - ys[k - 1])
}

/// [`interp_linear`] at every time of `queries`, bit for bit the same values. When `ts` and
/// `queries` both never decrease, one forward walk finds each sample pair (linear time instead
/// of a binary search per query); otherwise each query is searched as `interp_linear` does.
pub fn interp_linear_at(ts: &[f64], ys: &[f64], queries: &[f64]) -> Vec<f64> {
    let sorted = |x: &[f64]| x.windows(2).all(|w| w[0] <= w[1]);
    if ts.is_empty() || !sorted(ts) || !sorted(queries) {
        return queries.iter().map(|&t| interp_linear(ts, ys, t)).collect();
    }
    let mut k = 0;
    queries
        .iter()
        .map(|&t| {
            // the first index whose time exceeds t, as `partition_point` finds it
            while k < ts.len() && ts[k] <= t {
                k += 1;
            }
            if k == 0 {
                ys[0]
            } else if k >= ts.len() {
                ys[ys.len() - 1]
            } else {
                let w = (t - ts[k - 1]) / (ts[k] - ts[k - 1]);
                ys[k - 1] + w * (ys[k] - ys[k - 1])
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_walk_gives_the_searched_values_bit_for_bit() {
        let ts = [0.0, 0.5, 0.5, 1.25, 2.0, 3.5];
        let ys = [1.0, -2.0, 3.0, 0.1, 7.0, 2.5];
        let q = [-1.0, 0.0, 0.25, 0.5, 0.5, 0.7, 1.25, 1.9, 3.5, 4.0];
        let many = interp_linear_at(&ts, &ys, &q);
        for (v, &t) in many.iter().zip(&q) {
            assert_eq!(v.to_bits(), interp_linear(&ts, &ys, t).to_bits(), "t = {t}");
        }
        // unsorted queries fall back to the search
        let back = [2.0, 0.1, 3.0];
        let many = interp_linear_at(&ts, &ys, &back);
        for (v, &t) in many.iter().zip(&back) {
            assert_eq!(v.to_bits(), interp_linear(&ts, &ys, t).to_bits());
        }
    }

    #[test]
    fn linear_inside_held_outside_exact_on_samples() {
        let (ts, ys) = ([0.0, 1.0, 3.0], [2.0, 4.0, 0.0]);
        assert_eq!(interp_linear(&ts, &ys, -1.0), 2.0);
        assert_eq!(interp_linear(&ts, &ys, 0.5), 3.0);
        assert_eq!(interp_linear(&ts, &ys, 1.0), 4.0);
        assert_eq!(interp_linear(&ts, &ys, 2.0), 2.0);
        assert_eq!(interp_linear(&ts, &ys, 3.0), 0.0);
        assert_eq!(interp_linear(&ts, &ys, 9.0), 0.0);
    }
}
