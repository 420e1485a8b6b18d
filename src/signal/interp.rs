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

/// [`interp_linear_at`] of `N` series sharing their sample times, fed one sample at a time in
/// nondecreasing time, without keeping the samples: each query gets its value as soon as the
/// first sample after it arrives, bit for bit the value [`interp_linear_at`] gives over all the
/// samples (the same sample pair, the same expression). For a simulation whose integration step
/// is far finer than the rows it is read on (a 10-hour drive at 1 ms is 36 million samples per
/// series, its rows 1.8 million), only the rows are held. Queries that decrease somewhere fall
/// back to keeping the samples and searching each query at the end, as [`interp_linear_at`]
/// does. Without any sample every query reads NaN.
#[derive(Debug, Clone)]
pub struct LinearResampler<'a, const N: usize> {
    queries: &'a [f64],
    out: [Vec<f64>; N],
    /// First query without a value.
    next: usize,
    /// The last sample pushed.
    last: Option<(f64, [f64; N])>,
    /// Every sample, when the queries are not sorted.
    kept: Option<(Vec<f64>, [Vec<f64>; N])>,
}

impl<'a, const N: usize> LinearResampler<'a, N> {
    /// A resampler onto `queries`.
    pub fn new(queries: &'a [f64]) -> Self {
        let sorted = queries.windows(2).all(|w| w[0] <= w[1]);
        LinearResampler {
            queries,
            out: std::array::from_fn(|_| {
                Vec::with_capacity(if sorted { queries.len() } else { 0 })
            }),
            next: 0,
            last: None,
            kept: (!sorted).then(|| (Vec::new(), std::array::from_fn(|_| Vec::new()))),
        }
    }

    /// The next sample: time `t` (not before the last one's) and the value of each series.
    pub fn push(&mut self, t: f64, y: [f64; N]) {
        debug_assert!(
            self.last
                .is_none_or(|(t0, _)| t >= t0 || t.is_nan() || t0.is_nan()),
            "a sample at {t} s after one at a later time"
        );
        if let Some((ts, ys)) = &mut self.kept {
            ts.push(t);
            for (k, v) in ys.iter_mut().zip(y) {
                k.push(v);
            }
            return;
        }
        // every query left is at or after each earlier sample: those before `t` lie between
        // the last sample and this one (before the first sample, they read the first)
        while self.next < self.queries.len() && self.queries[self.next] < t {
            let q = self.queries[self.next];
            match self.last {
                None => {
                    for (o, v) in self.out.iter_mut().zip(y) {
                        o.push(v);
                    }
                }
                Some((t0, y0)) => {
                    let w = (q - t0) / (t - t0);
                    for ((o, a), b) in self.out.iter_mut().zip(y0).zip(y) {
                        o.push(a + w * (b - a));
                    }
                }
            }
            self.next += 1;
        }
        self.last = Some((t, y));
    }

    /// The values at every query, per series: the queries after the last sample read it.
    pub fn finish(mut self) -> [Vec<f64>; N] {
        if let Some((ts, ys)) = &self.kept {
            if ts.is_empty() {
                return std::array::from_fn(|_| vec![f64::NAN; self.queries.len()]);
            }
            return std::array::from_fn(|k| interp_linear_at(ts, &ys[k], self.queries));
        }
        let rest = self.queries.len() - self.next;
        let tail = self.last.map_or([f64::NAN; N], |(_, y)| y);
        for (o, v) in self.out.iter_mut().zip(tail) {
            o.extend(std::iter::repeat_n(v, rest));
        }
        self.out
    }
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

    #[test]
    fn the_resampler_gives_the_walks_values_bit_for_bit() {
        // duplicates among the samples and the queries, queries before, on and after samples
        let ts = [0.0, 0.5, 0.5, 1.25, 2.0, 3.5];
        let ys = [1.0, -2.0, 3.0, 0.1, 7.0, 2.5];
        let zs = [f64::NAN, 4.0, 1.0, -3.0, 0.5, 9.0];
        for q in [
            vec![-1.0, 0.0, 0.25, 0.5, 0.5, 0.7, 1.25, 1.9, 3.5, 4.0],
            vec![2.0, 0.1, 3.0],
            vec![],
            vec![5.0, 6.0],
        ] {
            let mut r = LinearResampler::<2>::new(&q);
            for i in 0..ts.len() {
                r.push(ts[i], [ys[i], zs[i]]);
            }
            let [a, b] = r.finish();
            for (got, want) in [
                (a, interp_linear_at(&ts, &ys, &q)),
                (b, interp_linear_at(&ts, &zs, &q)),
            ] {
                assert_eq!(got.len(), q.len());
                for (g, w) in got.iter().zip(&want) {
                    assert_eq!(
                        g.to_bits(),
                        w.to_bits(),
                        "queries {q:?}: {got:?} against {want:?}"
                    );
                }
            }
        }
        // a fine random walk onto coarse rows
        let mut rng = crate::rng::Xoshiro256StarStar::seed_from_u64(7);
        let n = 5000;
        let ts: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let ys: Vec<f64> = (0..n).map(|_| rng.standard_normal()).collect();
        let q: Vec<f64> = (0..260).map(|i| -0.01 + i as f64 * 0.02 + 1e-4).collect();
        let mut r = LinearResampler::<1>::new(&q);
        for (t, y) in ts.iter().zip(&ys) {
            r.push(*t, [*y]);
        }
        let [got] = r.finish();
        let want = interp_linear_at(&ts, &ys, &q);
        assert!(got
            .iter()
            .zip(&want)
            .all(|(g, w)| g.to_bits() == w.to_bits()));
        // nothing pushed: NaN
        let [e] = LinearResampler::<1>::new(&[0.0, 1.0]).finish();
        assert!(e.iter().all(|v| v.is_nan()));
    }
}
