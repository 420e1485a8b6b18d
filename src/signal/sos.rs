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
/// The cascade is evaluated sample by sample through every section, as scipy
/// does — the same floating-point operations in the same order — with the
/// states of up to [`FUSED_SECTIONS`] sections held in registers: the
/// sections' recursions are independent chains the CPU overlaps (section 2 of
/// sample `i` alongside section 1 of sample `i + 1`), and the signal crosses
/// memory once. Longer cascades run section by section over cache-sized
/// blocks of [`SOSFILT_BLOCK`] samples.
///
/// # Panics
/// If `state.len() != sos.n_sections()`.
pub fn sosfilt_in_place(sos: &Sos, x: &mut [f64], state: &mut [[f64; 2]]) {
    run(sos, x, state, false);
}

/// [`sosfilt_in_place`] run backwards in time: `x` read from its last sample to
/// its first, each output written where its input was — the same values, bit
/// for bit, as reversing `x`, filtering and reversing back, without the two
/// reversal passes over memory (the backward half of `sosfiltfilt`).
///
/// # Panics
/// If `state.len() != sos.n_sections()`.
pub fn sosfilt_in_place_rev(sos: &Sos, x: &mut [f64], state: &mut [[f64; 2]]) {
    run(sos, x, state, true);
}

/// Most sections evaluated fused (states in registers).
pub const FUSED_SECTIONS: usize = 4;

/// Samples per block of the section-by-section path (32 KiB of f64).
pub const SOSFILT_BLOCK: usize = 4096;

fn run(sos: &Sos, x: &mut [f64], state: &mut [[f64; 2]], rev: bool) {
    assert_eq!(
        state.len(),
        sos.n_sections(),
        "sosfilt: need one [z0, z1] state per section"
    );
    match state.len() {
        0 => {}
        1 => fused::<1>(sos, x, state, rev),
        2 => fused::<2>(sos, x, state, rev),
        3 => fused::<3>(sos, x, state, rev),
        4 => fused::<4>(sos, x, state, rev),
        _ => blocked(sos, x, state, rev),
    }
}

#[inline(always)]
fn step<const N: usize>(c: &[[f64; 5]; N], z: &mut [[f64; 2]; N], v: &mut f64) {
    let mut xc = *v;
    for k in 0..N {
        let [b0, b1, b2, a1, a2] = c[k];
        let y = b0 * xc + z[k][0];
        z[k][0] = b1 * xc - a1 * y + z[k][1];
        z[k][1] = b2 * xc - a2 * y;
        xc = y;
    }
    *v = xc;
}

fn fused<const N: usize>(sos: &Sos, x: &mut [f64], state: &mut [[f64; 2]], rev: bool) {
    let mut c = [[0.0; 5]; N];
    let mut z = [[0.0; 2]; N];
    for k in 0..N {
        let s = sos.sections()[k];
        c[k] = [s[0], s[1], s[2], s[4], s[5]];
        z[k] = state[k];
    }
    if rev {
        for v in x.iter_mut().rev() {
            step(&c, &mut z, v);
        }
    } else {
        for v in x.iter_mut() {
            step(&c, &mut z, v);
        }
    }
    state.copy_from_slice(&z);
}

fn blocked(sos: &Sos, x: &mut [f64], state: &mut [[f64; 2]], rev: bool) {
    let mut section = |block: &mut [f64]| {
        for (s, z) in sos.sections().iter().zip(state.iter_mut()) {
            let (b0, b1, b2, a1, a2) = (s[0], s[1], s[2], s[4], s[5]);
            let (mut z0, mut z1) = (z[0], z[1]);
            let mut one = |v: &mut f64| {
                let xc = *v;
                let y = b0 * xc + z0;
                z0 = b1 * xc - a1 * y + z1;
                z1 = b2 * xc - a2 * y;
                *v = y;
            };
            if rev {
                block.iter_mut().rev().for_each(&mut one);
            } else {
                block.iter_mut().for_each(&mut one);
            }
            *z = [z0, z1];
        }
    };
    if rev {
        x.rchunks_mut(SOSFILT_BLOCK).for_each(&mut section);
    } else {
        x.chunks_mut(SOSFILT_BLOCK).for_each(&mut section);
    }
}
