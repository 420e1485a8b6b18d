//! First-order lag of a sampled signal read as linear between its samples:
//! `τ ẏ = u − y`, solved exactly over each sample interval.
//!
//! With `u` linear on `[t_k, t_{k+1}]` (slope `s = (u_{k+1} − u_k)/h`, `h = t_{k+1} − t_k`), the
//! error `e = y − u + τ s` obeys `ė = −e/τ`, so
//!
//! `y_{k+1} = u_{k+1} − τ s + e^{−h/τ} (y_k − u_k + τ s)`,
//!
//! exact at the samples for any step, uneven steps included. The lag starts in steady state
//! (`y_0 = u_0`). Why our own: this is the first-order-hold discretisation (scipy's
//! `cont2discrete(..., method='foh')`) taken afresh on every step, because a log's time stamps
//! are uneven (dropouts, jitter), which a fixed-step filter design does not allow; a dozen lines
//! against a dependency. The tests check it against the closed form of a ramp's and a step's
//! response.

/// The first-order lag with time constant `tau_s` (s) of `u` sampled at the strictly increasing
/// times `t_s` (s), on the same samples. `tau_s <= 0` returns `u` unchanged. A non-finite sample
/// of `u` gives a non-finite output sample; the lag's state runs through it as if `u` were linear
/// between its finite neighbours (held before the first finite sample and after the last).
///
/// # Panics
/// When `t_s` and `u` differ in length.
pub fn first_order_lag(t_s: &[f64], u: &[f64], tau_s: f64) -> Vec<f64> {
    assert_eq!(t_s.len(), u.len(), "one time per sample");
    if tau_s <= 0.0 || u.is_empty() {
        return u.to_vec();
    }
    let filled = filled_linearly(t_s, u);
    let mut y = Vec::with_capacity(u.len());
    let mut state = filled[0];
    y.push(state);
    for k in 1..u.len() {
        let h = t_s[k] - t_s[k - 1];
        let s = (filled[k] - filled[k - 1]) / h;
        let a = (-h / tau_s).exp();
        state = filled[k] - tau_s * s + a * (state - filled[k - 1] + tau_s * s);
        y.push(state);
    }
    for (out, x) in y.iter_mut().zip(u) {
        if !x.is_finite() {
            *out = f64::NAN;
        }
    }
    y
}

/// `u` with its non-finite samples replaced by linear interpolation in time between the finite
/// neighbours (held at the ends); all zero when no sample is finite.
fn filled_linearly(t: &[f64], u: &[f64]) -> Vec<f64> {
    let finite: Vec<usize> = (0..u.len()).filter(|&k| u[k].is_finite()).collect();
    let (Some(&first), Some(&last)) = (finite.first(), finite.last()) else {
        return vec![0.0; u.len()];
    };
    let mut out = u.to_vec();
    out[..first].fill(u[first]);
    out[last + 1..].fill(u[last]);
    for w in finite.windows(2) {
        let (a, b) = (w[0], w[1]);
        for k in a + 1..b {
            let f = (t[k] - t[a]) / (t[b] - t[a]);
            out[k] = u[a] + f * (u[b] - u[a]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ramp_and_a_step_follow_the_closed_form_at_every_sample() {
        // u = 0 until 1 s, then a ramp of 500 N·m/s to 2 s, then held at 500, on uneven steps;
        // the closed form of τẏ = u − y from y(0) = 0 (steady state):
        // ramp phase y = r(t' − τ(1 − e^{−t'/τ})), t' = t − 1; after it the held value plus the
        // decaying error. Tolerance 1e-9 N·m: the recursion is exact, so only rounding remains.
        let tau = 0.1;
        let mut t = Vec::new();
        let mut x = 0.0;
        let mut k = 0;
        while x < 3.0 {
            t.push(x);
            x += if k % 3 == 0 { 0.013 } else { 0.007 };
            k += 1;
        }
        // the ramp's corners as samples, so that u is linear between samples
        t.extend([1.0, 2.0]);
        t.sort_by(f64::total_cmp);
        t.dedup();
        let r = 500.0;
        let u: Vec<f64> = t.iter().map(|&x| (r * (x - 1.0)).clamp(0.0, r)).collect();
        let y = first_order_lag(&t, &u, tau);
        let at_2 = r * (1.0 - tau * (1.0 - (-1.0 / tau).exp()));
        for (k, &x) in t.iter().enumerate() {
            let want = if x <= 1.0 {
                0.0
            } else if x <= 2.0 {
                let tp = x - 1.0;
                r * (tp - tau * (1.0 - (-tp / tau).exp()))
            } else {
                r + (at_2 - r) * (-(x - 2.0) / tau).exp()
            };
            assert!((y[k] - want).abs() < 1e-9, "t = {x}: {} vs {want}", y[k]);
        }
    }

    #[test]
    fn no_lag_is_the_input_and_gaps_stay_gaps() {
        let t = [0.0, 0.1, 0.2, 0.3, 0.4];
        let u = [100.0, f64::NAN, 300.0, 300.0, f64::NAN];
        assert_eq!(
            first_order_lag(&t, &u, 0.0)
                .iter()
                .map(|x| x.to_bits())
                .collect::<Vec<_>>(),
            u.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        let y = first_order_lag(&t, &u, 0.1);
        assert!(y[1].is_nan() && y[4].is_nan());
        // through the gap as through the line 100 → 300: the same as the filled input's lag
        let full = first_order_lag(&t, &[100.0, 200.0, 300.0, 300.0, 300.0], 0.1);
        for k in [0, 2, 3] {
            assert_eq!(y[k], full[k]);
        }
        assert!(y[2] > 100.0 && y[2] < 300.0);
    }
}
