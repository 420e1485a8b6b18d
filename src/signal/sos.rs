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
/// does — the same floating-point operations in the same order (signals of
/// [`LOCKSTEP_MIN`] samples and more: in [`LANES`] chunks side by side, equal
/// up to rounding, see `lockstep`) — with the
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

/// [`sosfilt_in_place`] from `src` into `dst` (of the same length), forwards: `dst` ends as
/// the output, `state` as the final state, in one pass over memory for long signals (the
/// input is read where the in-place filter would read its own copy). Returns whether every
/// sample of `src` is finite; if not, `dst` and `state` hold non-finite values and the
/// caller must discard them.
///
/// # Panics
/// If `state.len() != sos.n_sections()` or `src.len() != dst.len()`.
pub(crate) fn sosfilt_from(
    sos: &Sos,
    src: &[f64],
    dst: &mut [f64],
    state: &mut [[f64; 2]],
) -> bool {
    assert_eq!(
        src.len(),
        dst.len(),
        "sosfilt_from: src and dst lengths differ"
    );
    fn lanes<const N: usize>(
        sos: &Sos,
        src: &[f64],
        dst: &mut [f64],
        state: &mut [[f64; 2]],
    ) -> bool {
        let (c, mut z) = fused_coefficients::<N>(sos, state);
        let finite = lanes_dispatch::<N, true>(&c, &mut z, src, dst, false);
        state.copy_from_slice(&z);
        finite
    }
    if src.len() >= LOCKSTEP_MIN {
        assert_eq!(
            state.len(),
            sos.n_sections(),
            "sosfilt: need one [z0, z1] state per section"
        );
        match state.len() {
            1 => return lanes::<1>(sos, src, dst, state),
            2 => return lanes::<2>(sos, src, dst, state),
            3 => return lanes::<3>(sos, src, dst, state),
            4 => return lanes::<4>(sos, src, dst, state),
            _ => {}
        }
    }
    dst.copy_from_slice(src);
    let finite = src.iter().all(|v| v.is_finite());
    sosfilt_in_place(sos, dst, state);
    finite
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

/// The first `N` sections' coefficients `[b0, b1, b2, a1, a2]` and states, as arrays.
fn fused_coefficients<const N: usize>(
    sos: &Sos,
    state: &[[f64; 2]],
) -> ([[f64; 5]; N], [[f64; 2]; N]) {
    let mut c = [[0.0; 5]; N];
    let mut z = [[0.0; 2]; N];
    for k in 0..N {
        let s = sos.sections()[k];
        c[k] = [s[0], s[1], s[2], s[4], s[5]];
        z[k] = state[k];
    }
    (c, z)
}

fn fused<const N: usize>(sos: &Sos, x: &mut [f64], state: &mut [[f64; 2]], rev: bool) {
    let (c, mut z) = fused_coefficients::<N>(sos, state);
    if x.len() >= LOCKSTEP_MIN {
        lockstep(&c, &mut z, x, rev);
    } else if rev {
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

/// Independent chunks filtered side by side for signals of [`LOCKSTEP_MIN`] samples or more.
pub const LANES: usize = 4;
/// Shortest signal filtered in [`LANES`] chunks side by side.
pub const LOCKSTEP_MIN: usize = 1 << 16;
/// A chunk's free response is followed until its state falls below this fraction of its
/// start (then the rest is below double precision's resolution of any output it adds to).
pub const FREE_RESPONSE_FLOOR: f64 = 1e-30;

fn max_abs<const N: usize>(z: &[[f64; 2]; N]) -> f64 {
    z.iter().flatten().fold(0.0, |m, v| m.max(v.abs()))
}

/// The cascade over `x` in [`LANES`] contiguous chunks at once: every chunk but the first
/// starts from the zero state, so the chunks' recursions are independent chains the CPU runs
/// side by side; then, chunk by chunk, the free response of the true start state (the
/// previous chunk's corrected end state) is added — the filter is linear, so the sum is the
/// sequential result up to rounding (a few ulp) and the free response's tail below
/// [`FREE_RESPONSE_FLOOR`] of its start. `rev` runs backwards in time.
///
/// The lanes' states are stored lane-innermost (`z[section][0 or 1][lane]`), so one
/// arithmetic instruction can advance all four chains: on x86-64 CPUs with AVX (checked at
/// run time) the chains run in one 256-bit register each step. The operations per lane are
/// the scalar recursion's, in its order, without fused multiply-adds, so every CPU gives
/// the same bits.
fn lockstep<const N: usize>(c: &[[f64; 5]; N], z0: &mut [[f64; 2]; N], x: &mut [f64], rev: bool) {
    lanes_dispatch::<N, false>(c, z0, &[], x, rev);
}

/// Runs [`lockstep_lanes`] with AVX where the CPU has it; returns its finiteness flag.
fn lanes_dispatch<const N: usize, const COPY: bool>(
    c: &[[f64; 5]; N],
    z0: &mut [[f64; 2]; N],
    src: &[f64],
    x: &mut [f64],
    rev: bool,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: `lockstep_avx` only requires AVX, which the CPU was just found to have.
        return unsafe { lockstep_avx::<N, COPY>(c, z0, src, x, rev) };
    }
    lockstep_lanes::<N, COPY>(c, z0, src, x, rev)
}

/// [`lockstep_lanes`] compiled with AVX enabled (256-bit registers hold the four lanes).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn lockstep_avx<const N: usize, const COPY: bool>(
    c: &[[f64; 5]; N],
    z0: &mut [[f64; 2]; N],
    src: &[f64],
    x: &mut [f64],
    rev: bool,
) -> bool {
    lockstep_lanes::<N, COPY>(c, z0, src, x, rev)
}

/// One sample of each lane through the cascade: [`step`] with the lane loop innermost.
#[inline(always)]
fn step_lanes<const N: usize>(
    c: &[[f64; 5]; N],
    z: &mut [[[f64; LANES]; 2]; N],
    v: &mut [f64; LANES],
) {
    for k in 0..N {
        let [b0, b1, b2, a1, a2] = c[k];
        let [z0, z1] = &mut z[k];
        let mut y = [0.0; LANES];
        for q in 0..LANES {
            y[q] = b0 * v[q] + z0[q];
        }
        for q in 0..LANES {
            z0[q] = b1 * v[q] - a1 * y[q] + z1[q];
        }
        for q in 0..LANES {
            z1[q] = b2 * v[q] - a2 * y[q];
        }
        *v = y;
    }
}

/// The first `l` steps of every lane, sample `j` of lane `q` at `x[index(q, j)]` (read from
/// `src` with `COPY`, which also sums `v·0` into `nan_probe`).
#[inline(always)]
fn lane_pass<const N: usize, const COPY: bool>(
    c: &[[f64; 5]; N],
    z: &mut [[[f64; LANES]; 2]; N],
    nan_probe: &mut [f64; LANES],
    src: &[f64],
    x: &mut [f64],
    l: usize,
    index: impl Fn(usize, usize) -> usize,
) {
    for j in 0..l {
        let mut v = [0.0; LANES];
        for q in 0..LANES {
            v[q] = if COPY {
                src[index(q, j)]
            } else {
                x[index(q, j)]
            };
        }
        if COPY {
            for q in 0..LANES {
                nan_probe[q] += v[q] * 0.0;
            }
        }
        step_lanes(c, z, &mut v);
        for q in 0..LANES {
            x[index(q, j)] = v[q];
        }
    }
}

/// The lanes of [`lockstep`]. With `COPY` the input is read from `src` (as long as `x`) and
/// the output written to `x`, and the return value says whether every input sample was
/// finite (`v·0` is NaN exactly for infinite and NaN `v`, and NaN persists in a sum); in
/// place (`COPY = false`, `src` unused) it returns `true`.
#[inline(always)]
fn lockstep_lanes<const N: usize, const COPY: bool>(
    c: &[[f64; 5]; N],
    z0: &mut [[f64; 2]; N],
    src: &[f64],
    x: &mut [f64],
    rev: bool,
) -> bool {
    let n = x.len();
    let l = n / LANES;
    let mut z = [[[0.0f64; LANES]; 2]; N];
    for (zk, s) in z.iter_mut().zip(z0.iter()) {
        zk[0][0] = s[0];
        zk[1][0] = s[1];
    }
    let mut nan_probe = [0.0f64; LANES];
    // Lane q covers positions q·l … (q+1)·l − 1 in filtering order (position p is x[p], or
    // x[n − 1 − p] backwards); the positions from LANES·l on continue the last lane after.
    if rev {
        lane_pass::<N, COPY>(c, &mut z, &mut nan_probe, src, x, l, |q, j| {
            n - 1 - (q * l + j)
        });
    } else {
        lane_pass::<N, COPY>(c, &mut z, &mut nan_probe, src, x, l, |q, j| q * l + j);
    }
    let lane_state = |q: usize| -> [[f64; 2]; N] {
        let mut s = [[0.0; 2]; N];
        for (sk, zk) in s.iter_mut().zip(&z) {
            *sk = [zk[0][q], zk[1][q]];
        }
        s
    };
    let at = |p: usize| if rev { n - 1 - p } else { p };
    let mut tail_state = lane_state(LANES - 1);
    let mut finite = nan_probe.iter().all(|v| *v == 0.0);
    for p in LANES * l..n {
        if COPY {
            x[at(p)] = src[at(p)];
            finite &= x[at(p)].is_finite();
        }
        step(c, &mut tail_state, &mut x[at(p)]);
    }
    let mut end_prev = lane_state(0);
    for k in 1..LANES {
        let (start, end) = (k * l, if k == LANES - 1 { n } else { (k + 1) * l });
        let mut f = end_prev;
        let scale = max_abs(&f);
        let mut decayed = scale == 0.0;
        let mut p = start;
        while !decayed && p < end {
            let mut v = 0.0;
            step(c, &mut f, &mut v);
            x[at(p)] += v;
            p += 1;
            if (p - start) % 64 == 0 && max_abs(&f) <= FREE_RESPONSE_FLOOR * scale {
                decayed = true;
            }
        }
        let mut e = if k == LANES - 1 {
            tail_state
        } else {
            lane_state(k)
        };
        if !decayed {
            for (es, fs) in e.iter_mut().zip(&f) {
                es[0] += fs[0];
                es[1] += fs[1];
            }
        }
        end_prev = e;
    }
    *z0 = end_prev;
    finite
}

fn blocked(sos: &Sos, x: &mut [f64], state: &mut [[f64; 2]], rev: bool) {
    let mut section = |block: &mut [f64]| {
        for (s, z) in sos.sections().iter().zip(state.iter_mut()) {
            let c = [[s[0], s[1], s[2], s[4], s[5]]];
            let mut zs = [*z];
            if rev {
                block.iter_mut().rev().for_each(|v| step(&c, &mut zs, v));
            } else {
                block.iter_mut().for_each(|v| step(&c, &mut zs, v));
            }
            *z = zs[0];
        }
    };
    if rev {
        x.rchunks_mut(SOSFILT_BLOCK).for_each(&mut section);
    } else {
        x.chunks_mut(SOSFILT_BLOCK).for_each(&mut section);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::{butter, BandType};

    /// A deterministic test signal: slow waves, steps and an LCG's noise.
    fn signal(n: usize) -> Vec<f64> {
        let mut s: u64 = 7;
        (0..n)
            .map(|i| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                (i as f64 / 3000.0).sin() + if (i / 40_000) % 2 == 0 { 0.3 } else { -0.2 } + 0.1 * u
            })
            .collect()
    }

    /// The chunked evaluation equals the sequential recursion (the blocked path, which runs
    /// scipy's operations in scipy's order) to rounding: outputs within 1e-12 of the signal's
    /// range, end states within 1e-12 of their size. Covers a fast-decaying free response
    /// (cut-off 0.004) and one that outlives the chunk (cut-off 2e-6, order 8: four sections),
    /// forwards and backwards.
    #[test]
    fn lockstep_equals_the_sequential_recursion() {
        let n = LOCKSTEP_MIN * 3 + 17;
        let x = signal(n);
        for (order, wn) in [(3, 4e-3), (8, 2e-6), (2, 0.2)] {
            let sos = butter(order, wn, 1.0, BandType::Lowpass).unwrap();
            for rev in [false, true] {
                let zi: Vec<[f64; 2]> = (0..sos.n_sections())
                    .map(|k| [0.1 * k as f64, -0.05])
                    .collect();
                let (mut a, mut b) = (x.clone(), x.clone());
                let (mut za, mut zb) = (zi.clone(), zi.clone());
                run(&sos, &mut a, &mut za, rev);
                blocked(&sos, &mut b, &mut zb, rev);
                let range = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let d = a
                    .iter()
                    .zip(&b)
                    .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
                assert!(d <= 1e-12 * range, "order {order} wn {wn} rev {rev}: {d}");
                for (p, q) in za.iter().flatten().zip(zb.iter().flatten()) {
                    assert!(
                        (p - q).abs() <= 1e-12 * q.abs().max(1.0),
                        "state {p} vs {q} (order {order} wn {wn} rev {rev})"
                    );
                }
            }
        }
    }

    /// The AVX-compiled lanes and the portable ones give the same bits (no fused
    /// multiply-add, the same operation order), so results do not depend on the CPU.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_lanes_equal_the_portable_lanes_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let x = signal(LOCKSTEP_MIN + 1003);
        let sos = butter(3, 4e-3, 1.0, BandType::Lowpass).unwrap();
        let c = [0, 1].map(|k| {
            let s = sos.sections()[k];
            [s[0], s[1], s[2], s[4], s[5]]
        });
        for rev in [false, true] {
            let (mut a, mut b) = (x.clone(), x.clone());
            let (mut za, mut zb) = ([[0.3, -0.1], [0.2, 0.05]], [[0.3, -0.1], [0.2, 0.05]]);
            // SAFETY: AVX was detected above.
            unsafe { lockstep_avx::<2, false>(&c, &mut za, &[], &mut a, rev) };
            lockstep_lanes::<2, false>(&c, &mut zb, &[], &mut b, rev);
            assert!(a.iter().zip(&b).all(|(p, q)| p.to_bits() == q.to_bits()));
            assert_eq!(za, zb);
        }
    }

    /// Filtering from a source into a destination is the in-place filter, bit for bit, and
    /// its finiteness flag is exact: for the four-lane path (two sections), and for short
    /// signals and long cascades (copy, then in place).
    #[test]
    fn sosfilt_from_equals_in_place_filtering() {
        for (order, n) in [(3, LOCKSTEP_MIN + 5), (3, 1000), (10, LOCKSTEP_MIN + 5)] {
            let sos = butter(order, 4e-3, 1.0, BandType::Lowpass).unwrap();
            let x = signal(n);
            let zi: Vec<[f64; 2]> = (0..sos.n_sections())
                .map(|k| [0.01 * k as f64, 0.2])
                .collect();
            let (mut a, mut za) = (vec![0.0; n], zi.clone());
            let (mut b, mut zb) = (x.clone(), zi);
            assert!(sosfilt_from(&sos, &x, &mut a, &mut za));
            sosfilt_in_place(&sos, &mut b, &mut zb);
            assert!(
                a.iter().zip(&b).all(|(p, q)| p.to_bits() == q.to_bits()),
                "order {order} n {n}"
            );
            assert_eq!(za, zb);
            let mut bad = x.clone();
            bad[n / 2] = f64::INFINITY;
            assert!(
                !sosfilt_from(&sos, &bad, &mut a, &mut za),
                "order {order} n {n}"
            );
        }
    }
}
