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

#[cfg(test)]
mod tests {
    use super::*;

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
