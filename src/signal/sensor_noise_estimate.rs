//! Blind estimate of a recorded channel's sensor error on the log's grid
//! ([`estimate_sensor_noise`]): the measurement part of the diagnosis's noise floor
//! (docs/diagnosis/method.md, noise floor, part 1), and the error model the floor's Monte-Carlo
//! copies draw from ([`SensorNoise`]).
//!
//! CAN signals arrive at their own rate (10–50 Hz) and ingest puts them on the log's uniform
//! grid by linear interpolation (continuous columns) or zero-order hold (state-like columns,
//! `schemas/drive-log.toml`). Estimating noise on the grid would see interpolated, hence
//! smoothed and correlated, values; so the native samples are recovered first:
//! - *linear* columns: the knots are the rows where the second difference is non-zero (a
//!   line through the grid rows bends only at a knot). A knot on a row shows as one such row;
//!   a knot between rows `i` and `i+1` as two, and its time and value are recovered exactly
//!   as the intersection of the lines through rows `i−1, i` and `i+1, i+2`;
//! - *held* columns: the native samples start at the rows where the value changes;
//! - the native period `P` (rows) is the mean of the spacings between consecutive knots that
//!   are at most 1.5× their 10th percentile (spacings of 2P, 3P… are knots the data could not
//!   show: equal neighbouring values); gaps between knots longer than 1.5 P are filled with
//!   evenly spaced native samples read off the grid. When more than half of the rows are
//!   knots, or fewer than 8 knots exist, every row counts as a native sample (the channel is
//!   as fast as the grid, or it never changes);
//! - the noise σ is a robust spread of the native second differences,
//!   `σ = 1.4826·MAD(Δ²y)/√6` (`Var Δ²n = 6σ²` for white noise; the MAD ignores the sparse
//!   large values of real signal curvature, gear shifts, braking onsets). Samples at a
//!   physical bound (a brake at rest, whose sensor clamps its noise) are left out
//!   ([`estimate_sensor_noise_in`]);
//! - quantisation step `q`: [`crate::signal::quantization::estimate_quantization`] on the
//!   recorded native values (not the reconstructed ones), else a tolerant variant (the
//!   commonest small difference, 95 % of the values on its lattice); with a step the second differences lie on its lattice and
//!   the MAD is their median read as grouped data (`grouped_median_abs`: a plain median
//!   of lattice values is a lattice value and puts σ 10 % low for the 0.1 % slope sensor);
//! - coarse steps (the MAD-σ below `q`): the second differences take the discrete values
//!   0, ±q, ±2q of flicker and their MAD jumps between 0 and q. The flicker rate φ — the
//!   share of native samples off their recorded level (below) — gives the noise instead:
//!   for a true value spread evenly within a step `φ = 2σ/(q√(2π))`, so
//!   `σ_w = √(π/2)·q·φ` (while φ < 0.25; beyond, the noise dithers the rounding and the RMS
//!   of the second differences up to 2q is used, `σ_w² = σ² − q²/12`). Otherwise
//!   `σ_w² = max(0, σ² − q²/12)` (the second differences saw the rounding of dithered
//!   samples as noise);
//! - the persistent part of the quantisation error is uniform in `±h`,
//!   `h = (q/2)·exp(−2π²σ_w²/q²)`: without noise (`σ_w = 0`) the true value is anywhere
//!   within `±q/2` of the recorded one and stays there, while Gaussian noise dithers the
//!   rounding and the remaining bias `E[Q(s+n)] − s` has the amplitude of the first Fourier
//!   coefficient of the rounding error, damped by the noise's characteristic function
//!   `exp(−2π²σ²/q²)`. It is held constant over each run of equal *recorded level* — the
//!   running median of the native values over ±0.5 s, so that dither flicker does not cut
//!   the runs;
//! - rest states: a run whose level is within one step (or σ_w) of a physical bound, and
//!   samples in it within `3σ_w + q` of the bound, are the actuator at rest (brake, retarder,
//!   clutch off). A copy sets them to the bound (no persistent error): the recording of a
//!   brake at rest is clamped noise, |N(0, 0.2 kN)| rounded to 0.1 kN on the synthetic bus,
//!   +85 N on average, and a copy at rest differs from the recording as the recording differs
//!   from the truth. Measured on a clean 2 km city drive: that bias alone moves the simulated
//!   speed by 0.043 m/s RMS, the copies at rest by 0.036 m/s.
//!
//! Units: σ and steps in the channel's SI unit, periods in rows and s.

use super::quantization::estimate_quantization;
use super::sensor_noise::{SampleKind, SensorNoise, SensorNoiseError};
use super::stats::{median, median_unordered};
use std::collections::BTreeMap;

/// Minimum knots needed to estimate a native period.
const MIN_KNOTS: usize = 8;

/// The median of the absolute deviations `dev` of values recorded on a lattice of step `q`,
/// read as grouped data: a deviation `k·q` stands for the interval `[(k − ½)q, (k + ½)q]`
/// (`[0, q/2]` for `k = 0`) it was rounded from, and the median is interpolated linearly
/// inside its interval (the textbook median of grouped data). The plain median of such
/// values is itself a multiple of `q` and so jumps with the noise level: for white noise of
/// σ = 2q rounded to `q`, the plain MAD of the second differences is `3q` where the
/// continuous one is `3.3q`, which puts σ 10 % low on every drive with the 0.1 % slope
/// sensor of `fleetdyn prove` (σ 0.2 %). Measured on rounded Gaussian noise around a value
/// moving across the steps (30 000 samples, second differences, `σ_w² = σ_MAD² − q²/12`):
/// σ_w within 5 % of σ for σ/q from 0.5 to 5, where the plain median is 34 % low to 31 %
/// high; on a constant value at σ/q = 0.5 it is 10 % low, but there `σ_MAD < q` and the
/// coarse-step estimate is used instead. `NaN` when `dev` is empty.
fn grouped_median_abs(dev: &[f64], q: f64) -> f64 {
    if dev.is_empty() || !(q.is_finite() && q > 0.0) {
        return median_unordered(&mut dev.to_vec());
    }
    let mut counts: BTreeMap<u64, usize> = BTreeMap::new();
    for d in dev {
        *counts.entry((d / q).round().max(0.0) as u64).or_default() += 1;
    }
    let half = dev.len() as f64 / 2.0;
    let mut below = 0.0;
    for (&k, &c) in &counts {
        let c = c as f64;
        if below + c >= half {
            let lo = if k == 0 { 0.0 } else { (k as f64 - 0.5) * q };
            let hi = (k as f64 + 0.5) * q;
            return lo + (half - below) / c * (hi - lo);
        }
        below += c;
    }
    f64::NAN
}

/// Runs `[a, b)` of consecutive finite values.
fn finite_runs(x: &[f64]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < x.len() {
        if !x[i].is_finite() {
            i += 1;
            continue;
        }
        let a = i;
        while i < x.len() && x[i].is_finite() {
            i += 1;
        }
        out.push((a, i));
    }
    out
}

/// A knot found on the grid: position (rows, fractional) and value.
#[derive(Debug, Clone, Copy)]
struct Knot {
    pos: f64,
    val: f64,
    /// Index of the finite piece (32 bits, as the rows: a drive has far fewer than 2³² rows,
    /// and a knot takes 32 bytes instead of 40).
    piece: u32,
    /// Event rows behind the knot (1 or 2 for a knot; 3 or more: a channel as fast as the grid).
    rows: u32,
    /// The value is the recorded one (false: a knot between rows whose lines do not
    /// intersect inside, given the mean of its rows).
    exact: bool,
}

/// The knots of one finite piece `[a, b)` of `x`.
fn piece_knots(x: &[f64], a: usize, b: usize, kind: SampleKind, piece: u32) -> Vec<Knot> {
    let scale = x[a..b].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = 1e-9 * scale.max(f64::MIN_POSITIVE);
    let mut ev: Vec<usize> = Vec::new();
    match kind {
        SampleKind::Linear => {
            for i in a + 1..b.saturating_sub(1) {
                if (x[i + 1] - 2.0 * x[i] + x[i - 1]).abs() > tol {
                    ev.push(i);
                }
            }
        }
        SampleKind::Hold => {
            for i in a + 1..b {
                if (x[i] - x[i - 1]).abs() > tol {
                    ev.push(i);
                }
            }
        }
    }
    // clusters of adjacent event rows
    let mut knots = Vec::new();
    let mut k = 0;
    while k < ev.len() {
        let mut e = k;
        while e + 1 < ev.len() && ev[e + 1] == ev[e] + 1 {
            e += 1;
        }
        let i = ev[k];
        let size = e - k + 1;
        let knot = match (kind, size) {
            (SampleKind::Linear, 2) if i > a && i + 2 < b => {
                let sl = x[i] - x[i - 1];
                let sr = x[i + 2] - x[i + 1];
                let tau = if sl != sr {
                    (x[i + 1] - x[i] - sr) / (sl - sr)
                } else {
                    f64::NAN
                };
                if (0.0..=1.0).contains(&tau) {
                    Knot {
                        pos: i as f64 + tau,
                        val: x[i] + sl * tau,
                        piece,
                        rows: 2,
                        // nearly parallel lines amplify rounding: such a value may sit just
                        // off the quantisation lattice
                        exact: (sl - sr).abs() >= 0.25 * sl.abs().max(sr.abs()),
                    }
                } else {
                    Knot {
                        pos: i as f64 + 0.5,
                        val: 0.5 * (x[i] + x[i + 1]),
                        piece,
                        rows: 2,
                        exact: false,
                    }
                }
            }
            _ => Knot {
                pos: i as f64,
                val: x[i],
                piece,
                rows: size as u32,
                exact: true,
            },
        };
        knots.push(knot);
        k = e + 1;
    }
    knots
}

/// Value of `x` (finite piece `[a, b)`) at fractional row `p`, as the grid shows it.
fn grid_value(x: &[f64], a: usize, b: usize, p: f64, kind: SampleKind) -> f64 {
    let p = p.clamp(a as f64, (b - 1) as f64);
    match kind {
        SampleKind::Hold => x[(p.ceil() as usize).min(b - 1)],
        SampleKind::Linear => {
            let i = p.floor() as usize;
            if i + 1 >= b {
                return x[b - 1];
            }
            let w = p - i as f64;
            x[i] + w * (x[i + 1] - x[i])
        }
    }
}

/// Estimates the sensor error of one channel on the log's grid (see the module
/// documentation). `values` are on the grid with step `dt_s` (s), NaN in gaps.
///
/// # Errors
/// [`SensorNoiseError::Empty`] without a finite value; [`SensorNoiseError::BadConfig`] for a bad
/// `dt_s`.
pub fn estimate_sensor_noise(
    column: &str,
    unit: &str,
    values: &[f64],
    dt_s: f64,
    kind: SampleKind,
) -> Result<SensorNoise, SensorNoiseError> {
    estimate_sensor_noise_in(
        column,
        unit,
        values,
        dt_s,
        kind,
        (f64::NEG_INFINITY, f64::INFINITY),
    )
}

/// [`estimate_sensor_noise`] of a column whose physical range is `range` (min, max): native
/// samples at a bound (an actuator at rest, a sensor clamping its noise) are left out of the
/// noise statistics, which would otherwise see the clamped noise as smaller than it is.
///
/// # Errors
/// As [`estimate_sensor_noise`].
pub fn estimate_sensor_noise_in(
    column: &str,
    unit: &str,
    values: &[f64],
    dt_s: f64,
    kind: SampleKind,
    range: (f64, f64),
) -> Result<SensorNoise, SensorNoiseError> {
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(SensorNoiseError::BadConfig {
            parameter: "grid step dt_s",
            value: dt_s,
            requirement: "finite and > 0",
        });
    }
    let pieces = finite_runs(values);
    if pieces.is_empty() {
        return Err(SensorNoiseError::Empty {
            what: column.into(),
        });
    }
    let n_finite: usize = pieces.iter().map(|(a, b)| b - a).sum();
    let mut knots: Vec<Knot> = Vec::new();
    for (piece, &(a, b)) in (0u32..).zip(&pieces) {
        knots.extend(piece_knots(values, a, b, kind, piece));
    }
    // native period, rows
    let mut spacings: Vec<f64> = knots
        .windows(2)
        .filter(|w| w[0].piece == w[1].piece)
        .map(|w| w[1].pos - w[0].pos)
        .collect();
    let n_events: usize = knots.iter().map(|k| k.rows as usize).sum();
    let wide = knots.iter().filter(|k| k.rows >= 3).count();
    let every_row = n_events * 2 > n_finite
        || wide * 10 > knots.len()
        || knots.len() < MIN_KNOTS
        || spacings.is_empty();
    let period = if every_row {
        1.0
    } else {
        spacings.sort_by(f64::total_cmp);
        let p10 = spacings[spacings.len() / 10];
        let near: Vec<f64> = spacings
            .iter()
            .copied()
            .filter(|s| *s <= 1.5 * p10)
            .collect();
        let p = near.iter().sum::<f64>() / near.len() as f64;
        if p < 1.5 {
            1.0
        } else {
            p
        }
    };
    // native samples: every row, or the knots with the missing ones filled in. The spacings are
    // released once the period is known and the knots once nothing reads them (a 10-hour 50 Hz
    // column has 1.8 million knots of 32 bytes); a sample on every row is one exact allocation
    drop(spacings);
    let mut native: Vec<Knot>;
    if period == 1.0 {
        drop(knots);
        native = Vec::with_capacity(n_finite);
        for (piece, &(a, b)) in (0u32..).zip(&pieces) {
            for (i, &v) in values.iter().enumerate().take(b).skip(a) {
                native.push(Knot {
                    pos: i as f64,
                    val: v,
                    piece,
                    rows: 1,
                    exact: true,
                });
            }
        }
    } else {
        native = Vec::new();
        for (piece, &(a, b)) in (0u32..).zip(&pieces) {
            let ks: Vec<Knot> = knots.iter().copied().filter(|k| k.piece == piece).collect();
            let push_fill = |native: &mut Vec<Knot>, from: f64, to: f64| {
                // evenly spaced samples strictly between `from` and `to`
                let gap = to - from;
                let m = (gap / period).round() as usize;
                for j in 1..m {
                    let p = from + gap * j as f64 / m as f64;
                    native.push(Knot {
                        pos: p,
                        val: grid_value(values, a, b, p, kind),
                        piece,
                        rows: 0,
                        exact: false,
                    });
                }
            };
            if ks.is_empty() {
                let mut p = a as f64;
                while p <= (b - 1) as f64 {
                    native.push(Knot {
                        pos: p,
                        val: grid_value(values, a, b, p, kind),
                        piece,
                        rows: 0,
                        exact: false,
                    });
                    p += period;
                }
                continue;
            }
            // before the first knot
            let mut head = Vec::new();
            let mut p = ks[0].pos - period;
            while p >= a as f64 {
                head.push(Knot {
                    pos: p,
                    val: grid_value(values, a, b, p, kind),
                    piece,
                    rows: 0,
                    exact: false,
                });
                p -= period;
            }
            head.reverse();
            native.extend(head);
            for (j, k) in ks.iter().enumerate() {
                native.push(*k);
                if let Some(next) = ks.get(j + 1) {
                    if next.pos - k.pos > 1.5 * period {
                        push_fill(&mut native, k.pos, next.pos);
                    }
                }
            }
            let mut p = ks[ks.len() - 1].pos + period;
            while p <= (b - 1) as f64 {
                native.push(Knot {
                    pos: p,
                    val: grid_value(values, a, b, p, kind),
                    piece,
                    rows: 0,
                    exact: false,
                });
                p += period;
            }
        }
        drop(knots);
    }
    let vals: Vec<f64> = native.iter().map(|k| k.val).collect();
    // the step from the recorded values: not a piece's first and last sample (an interpolated
    // value at a gap's edge), not filled-in or ill-conditioned knots — one value off the lattice
    // breaks the smallest-gap step; `robust_step` tolerates a few more
    let interior: Vec<f64> = (0..native.len())
        .filter(|&j| {
            j > 0
                && j + 1 < native.len()
                && native[j].exact
                && native[j - 1].piece == native[j].piece
                && native[j + 1].piece == native[j].piece
        })
        .map(|j| native[j].val)
        .collect();
    let q = estimate_quantization(&interior)
        .map(|q| q.step)
        .or_else(|| robust_step(&interior));
    // recorded level: running median of the native values over ±0.5 s (same piece)
    let native_rate_hz = 1.0 / (period * dt_s);
    let hw = ((0.5 * native_rate_hz).round() as usize).max(1);
    let level: Vec<f64> = (0..native.len())
        .map(|j| {
            let lo = j.saturating_sub(hw);
            let hi = (j + hw + 1).min(native.len());
            let mut w: Vec<f64> = native[lo..hi]
                .iter()
                .filter(|k| k.piece == native[j].piece)
                .map(|k| k.val)
                .collect();
            median_unordered(&mut w)
        })
        .collect();
    let inside = |v: f64| v > range.0 && v < range.1;
    let mut d2: Vec<f64> = native
        .windows(3)
        .filter(|w| w[0].piece == w[2].piece && w.iter().all(|k| inside(k.val)))
        .map(|w| w[2].val - 2.0 * w[1].val + w[0].val)
        .collect();
    let sigma_mad = if d2.is_empty() {
        0.0
    } else {
        let m = median_unordered(&mut d2.clone());
        let mut dev: Vec<f64> = d2.iter_mut().map(|d| (*d - m).abs()).collect();
        let mad = match q {
            Some(q) => grouped_median_abs(&dev, q),
            None => median_unordered(&mut dev),
        };
        1.4826 * mad / 6f64.sqrt()
    };
    let (sigma_raw, sigma_white) = match q {
        // coarse steps (noise below a step): the second differences take the discrete values
        // 0, ±q, ±2q of flicker and their MAD jumps between 0 and q. The flicker rate φ (share
        // of native samples off their recorded level) gives σ instead: for truth spread evenly
        // within a step, φ = 2σ/(q√(2π)), so σ = √(π/2)·q·φ (valid while φ is small; at
        // φ ≥ 0.25 the noise dithers and the RMS of the small second differences is used)
        Some(q) if sigma_mad < q => {
            let (mut off, mut cnt) = (0usize, 0usize);
            for (k, l) in native.iter().zip(&level) {
                if inside(k.val) {
                    cnt += 1;
                    if (k.val - l).abs() > 1e-6 * q {
                        off += 1;
                    }
                }
            }
            let phi = if cnt == 0 {
                0.0
            } else {
                off as f64 / cnt as f64
            };
            if phi < 0.25 {
                let s = (std::f64::consts::PI / 2.0).sqrt() * q * phi;
                (s, s)
            } else {
                let small: Vec<f64> = d2
                    .iter()
                    .copied()
                    .filter(|d| d.abs() <= 2.0 * q * (1.0 + 1e-6))
                    .collect();
                let raw = if small.is_empty() {
                    0.0
                } else {
                    (small.iter().map(|d| d * d).sum::<f64>() / small.len() as f64 / 6.0).sqrt()
                };
                (raw, (raw * raw - q * q / 12.0).max(0.0).sqrt())
            }
        }
        Some(q) => (
            sigma_mad,
            (sigma_mad.powi(2) - q * q / 12.0).max(0.0).sqrt(),
        ),
        None => (sigma_mad, sigma_mad),
    };
    let half = q.map_or(0.0, |q| {
        let damp = (-2.0 * std::f64::consts::PI.powi(2) * sigma_white.powi(2) / (q * q)).exp();
        0.5 * q * damp
    });
    // runs of equal recorded level
    let mut run = Vec::with_capacity(native.len());
    let mut run_level = Vec::new();
    let mut last: Option<(u32, f64)> = None;
    let mut id = 0usize;
    for (k, &l) in native.iter().zip(&level) {
        match last {
            Some((piece, lv)) if piece == k.piece && lv == l => {}
            Some(_) => {
                id += 1;
                run_level.push(l);
            }
            None => run_level.push(l),
        }
        last = Some((k.piece, l));
        // a run per native sample at most: a drive has far fewer than 2³² samples
        run.push(id as u32);
    }
    Ok(SensorNoise {
        column: column.into(),
        unit: unit.into(),
        kind,
        grid_dt_s: dt_s,
        native_rate_hz,
        n_native: native.len(),
        sigma_raw,
        quantization_step: q,
        sigma_white,
        persistent_half_width: half,
        positions: native.iter().map(|k| k.pos).collect(),
        run,
        run_level,
        native_values: vals,
    })
}

/// The quantisation step of `v` when a few values are off the lattice (reconstructed knots that
/// rounding moved): the smallest non-zero difference between consecutive values that makes up
/// at least 5 % of them, accepted when at least 95 % of the values lie within 2 % of a step of
/// the lattice through the median value and values repeat (as
/// [`estimate_quantization`]: at most one distinct value per 2 samples).
fn robust_step(v: &[f64]) -> Option<f64> {
    if v.len() < 8 {
        return None;
    }
    let scale = v
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()))
        .max(f64::MIN_POSITIVE);
    let tol = 1e-9 * scale;
    let mut d: Vec<f64> = v
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|x| *x > tol)
        .collect();
    if d.len() < 8 {
        return None;
    }
    d.sort_by(f64::total_cmp);
    let need = (d.len() / 20).max(2);
    let mut q = None;
    let mut i = 0;
    while i < d.len() {
        let mut j = i;
        while j + 1 < d.len() && d[j + 1] - d[i] <= 0.02 * d[i] {
            j += 1;
        }
        if j - i + 1 >= need {
            q = Some(d[i..=j].iter().sum::<f64>() / (j - i + 1) as f64);
            break;
        }
        i = j + 1;
    }
    let q = q?;
    let mut sorted = v.to_vec();
    let v0 = median(&mut sorted);
    let on = v
        .iter()
        .filter(|x| {
            let k = (*x - v0) / q;
            (k - k.round()).abs() <= 0.02
        })
        .count();
    let mut distinct = sorted.clone();
    distinct.dedup_by(|a, b| (*a - *b).abs() <= 0.02 * q);
    (on * 100 >= 95 * v.len() && distinct.len() * 2 <= v.len()).then_some(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro256StarStar;

    /// A 10 Hz channel with noise σ on a 50 Hz grid (linear), its knots at phase 0.3 rows.
    fn linear_10hz(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = Xoshiro256StarStar::seed_from_u64(seed);
        let knots: Vec<(f64, f64)> = (0..n / 5 + 2)
            .map(|k| {
                let p = 0.3 + 5.0 * k as f64;
                (p, 10.0 + (p * 0.002).sin() + sigma * rng.standard_normal())
            })
            .collect();
        (0..n)
            .map(|i| {
                let x = i as f64;
                let k = knots.partition_point(|kn| kn.0 <= x);
                if k == 0 {
                    return knots[0].1;
                }
                let (a, b) = (knots[k - 1], knots[k]);
                a.1 + (x - a.0) / (b.0 - a.0) * (b.1 - a.1)
            })
            .collect()
    }

    #[test]
    fn native_rate_and_sigma_of_an_interpolated_channel() {
        let x = linear_10hz(20_000, 0.05, 1);
        let s =
            estimate_sensor_noise("vehicle_speed", "m/s", &x, 0.02, SampleKind::Linear).unwrap();
        assert!((s.native_rate_hz - 10.0).abs() < 0.05, "{s:?}");
        assert!((s.sigma_raw / 0.05 - 1.0).abs() < 0.08, "{}", s.sigma_raw);
        assert_eq!(s.quantization_step, None);
    }

    #[test]
    fn held_quantised_channel_without_noise_gets_the_persistent_half_step() {
        // slope 10 Hz held on a 50 Hz grid, whole percent, no noise
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                let k = i / 5;
                ((0.03 * (k as f64 * 0.003).sin()) * 100.0).round() / 100.0
            })
            .collect();
        let s = estimate_sensor_noise("road_slope", "1", &x, 0.02, SampleKind::Hold).unwrap();
        assert_eq!(s.quantization_step.map(|q| (q * 1e4).round()), Some(100.0));
        assert!(s.sigma_white < 0.002, "{s:?}");
        assert!(s.persistent_half_width > 0.004, "{s:?}");
    }

    #[test]
    fn noise_of_twice_the_step_is_not_read_off_the_lattice() {
        // the proof's slope sensor: 10 Hz held on a 50 Hz grid, σ 0.2 % rounded to 0.1 %
        let mut rng = Xoshiro256StarStar::seed_from_u64(7);
        let (q, sigma) = (0.001, 0.002);
        let native: Vec<f64> = (0..10_000)
            .map(|k| {
                let s = 0.03 * (k as f64 * 0.003).sin() + sigma * rng.standard_normal();
                (s / q).round() * q
            })
            .collect();
        let x: Vec<f64> = (0..50_000).map(|i| native[i / 5]).collect();
        let s = estimate_sensor_noise("road_slope", "1", &x, 0.02, SampleKind::Hold).unwrap();
        assert_eq!(s.quantization_step.map(|v| (v / q).round()), Some(1.0));
        // 10 000 samples: the MAD's own spread is about 1 %; the plain median gives 0.90 σ
        assert!(
            (s.sigma_white / sigma - 1.0).abs() < 0.04,
            "σ_w {} against {sigma}",
            s.sigma_white
        );
    }

    #[test]
    fn empty_and_bad_inputs_are_errors() {
        assert!(matches!(
            estimate_sensor_noise("x", "1", &[], 0.02, SampleKind::Linear),
            Err(SensorNoiseError::Empty { .. })
        ));
        assert!(matches!(
            estimate_sensor_noise("x", "1", &[f64::NAN; 10], 0.02, SampleKind::Linear),
            Err(SensorNoiseError::Empty { .. })
        ));
        assert!(estimate_sensor_noise("x", "1", &[1.0; 10], f64::NAN, SampleKind::Linear).is_err());
        // constant series: zero noise, no error
        let s = estimate_sensor_noise("x", "1", &[1.0; 50], 0.02, SampleKind::Linear).unwrap();
        assert_eq!(s.sigma_raw, 0.0);
    }
}
