//! Causal filtering with a cascade of second-order sections.
//!
//! * [`sosfilt`] = `scipy.signal.sosfilt(sos, x, zi=zi)`: each section is a
//!   direct form II transposed recursion
//!   `y = b0·x + z0; z0 ← b1·x − a1·y + z1; z1 ← b2·x − a2·y`,
//!   evaluated in scipy's operation order, sections applied first to last.
//! * [`sosfilt_in_place`]: the same without allocating (the signal is
//!   overwritten, the state updated), for long signals.
//! * [`sosfilt_zi`] = `scipy.signal.sosfilt_zi(sos)`: steady-state state for
//!   a unit step, to be scaled by the first input sample.
//!
//! State layout: one `[z0, z1]` per section, first section first (scipy's
//! `zi` of shape `(n_sections, 2)`).

use super::butterworth::Sos;

/// Steady-state initial conditions for a unit-step input, one `[z0, z1]`
/// per section (= `scipy.signal.sosfilt_zi`).
///
/// Section `s` gets `lfilter_zi(b_s, a_s)` — the state of that section after
/// an infinitely long input of 1 — multiplied by the DC gain of the
/// sections before it (their steady output, which is this section's input).
/// Multiply every entry by `x[0]` to start a filter in steady state on a
/// signal that starts at `x[0]`.
pub fn sosfilt_zi(sos: &Sos) -> Vec<[f64; 2]> {
    let mut scale = 1.0;
    sos.sections()
        .iter()
        .map(|s| {
            let zi = lfilter_zi2(s);
            let out = [scale * zi[0], scale * zi[1]];
            scale *= (s[0] + s[1] + s[2]) / (s[3] + s[4] + s[5]);
            out
        })
        .collect()
}

/// `scipy.signal.lfilter_zi` for one section with `a0 == 1`: solves
/// `(I − Aᵀ)·zi = B` with `B = b[1:] − a[1:]·b0`; for the 2×2 companion
/// system this is `z0 = (B0 + B1)/(1 + a1 + a2)`, `z1 = B1 − a2·z0`.
fn lfilter_zi2(s: &[f64; 6]) -> [f64; 2] {
    let (b0, b1, b2, a1, a2) = (s[0], s[1], s[2], s[4], s[5]);
    let big_b0 = b1 - a1 * b0;
    let big_b1 = b2 - a2 * b0;
    let z0 = (big_b0 + big_b1) / (1.0 + a1 + a2);
    let z1 = big_b1 - a2 * z0;
    [z0, z1]
}

/// Filters `x` with the cascade (= `scipy.signal.sosfilt(sos, x, zi=zi)`).
///
/// `zi` is the initial state, one `[z0, z1]` per section (`None` = zeros,
/// i.e. the filter at rest). Returns the output `y` (same length as `x`) and
/// the final state `zf` (returned also when `zi` is `None`, unlike scipy).
///
/// # Panics
/// If `zi` is given with a length other than `sos.n_sections()`.
pub fn sosfilt(sos: &Sos, x: &[f64], zi: Option<&[[f64; 2]]>) -> (Vec<f64>, Vec<[f64; 2]>) {
    let mut y = x.to_vec();
    let mut state = match zi {
        Some(z) => z.to_vec(),
        None => vec![[0.0; 2]; sos.n_sections()],
    };
    sosfilt_in_place(sos, &mut y, &mut state);
    (y, state)
}

/// In-place [`sosfilt`]: `x` is replaced by the filter output and `state`
/// (initial `zi` on entry, final `zf` on return) is updated; no allocation.
///
/// The cascade is evaluated section by section over the whole signal, which
/// performs exactly the same floating-point operations as scipy's
/// sample-by-sample loop (each section only sees the previous section's
/// output) but is friendlier to the cache.
///
/// # Panics
/// If `state.len() != sos.n_sections()`.
pub fn sosfilt_in_place(sos: &Sos, x: &mut [f64], state: &mut [[f64; 2]]) {
    assert_eq!(
        state.len(),
        sos.n_sections(),
        "sosfilt: need one [z0, z1] state per section"
    );
    for (s, z) in sos.sections().iter().zip(state.iter_mut()) {
        let (b0, b1, b2, a1, a2) = (s[0], s[1], s[2], s[4], s[5]);
        let (mut z0, mut z1) = (z[0], z[1]);
        for v in x.iter_mut() {
            let xc = *v;
            let y = b0 * xc + z0;
            z0 = b1 * xc - a1 * y + z1;
            z1 = b2 * xc - a2 * y;
            *v = y;
        }
        *z = [z0, z1];
    }
}
