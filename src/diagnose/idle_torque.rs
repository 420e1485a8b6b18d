//! The engine-torque channel's offset measured while the engine turns only itself
//! (docs/diagnosis/method.md, "The torque channel on the free engine").
//!
//! With the clutch released or no gear engaged the engine drives nothing but its own inertia
//! `J_e`, so its net torque is `M_e = J_e·ω̇_e`. The reported torque is `M_rep = (1 + ε)·M_e + o`
//! (`o` the catalogue's `engine_torque_offset_nm`, `ε` a map gain error), so on a free engine
//!
//! `o = M_rep − (1 + ε)·J_e·ω̇_e ≈ M_rep − J_e·ω̇_e`,
//!
//! and at a steady idle, where `ω̇_e ≈ 0`, the reported torque reads the offset itself: neither
//! the gain error nor the engine's inertia matters there. What the engine drives besides itself
//! while declutched (alternator, air and air-conditioning compressors, fan) is in `o` as it is
//! while driving, which is what the catalogue's effect means by "friction, auxiliaries"; a load
//! that differs between idling and driving (a compressor that cycles) shows as a scatter between
//! the idle episodes and widens the interval. An offset that varies with engine speed is read
//! at idle speed.
//!
//! # Rows
//! A row is free when the engine speed and torque are finite, the engine turns (at least
//! [`MIN_ENGINE_SPEED_RAD_S`]) and nothing connects it to the wheels: `gear` 0 (neutral) or
//! `clutch_position` at least [`RELEASED`] (0 = engaged, 1 = released). A run of consecutive
//! free rows is trimmed by [`SETTLE_S`] at its start (the shift or the stop that opened it) and
//! by [`LEAD_S`] at its end (the speed match before the clutch closes), and its rows whose
//! engine speed changes by more than [`MAX_SPEED_CHANGE_RAD_S`] over the [`STEADY_SPAN_S`] about
//! them are dropped (a rev, a governor's swing). What is left, in pieces of at least
//! [`MIN_EPISODE_S`], are the episodes. The engine's speed change over each episode gives its
//! mean `J_e·ω̇_e` exactly (`J_e·Δω/Δt`, the file's engine inertia), which is taken off.
//!
//! # Estimate and interval
//! The estimate is the mean over the episodes' rows of `M_rep − J_e·Δω/Δt`. Its standard error
//! is the larger of two:
//! - Newey–West's on the rows about their episode's mean, Bartlett kernel of [`HAC_LAG_S`]
//!   within an episode (the governor and the bus's noise are correlated over a fraction of a
//!   second, episodes are apart);
//! - with two or more episodes, the cluster-robust one over episodes,
//!   `√(n/(n−1) · Σ_i N_i²(x_i − x̄)²) / N`, read with Student t on `n − 1` degrees of freedom
//!   (few episodes estimate their scatter badly).
//!
//! The channel's resolution adds a bias the noise may not dither away: a channel of step `q`
//! (the smallest difference between distinct readings of the episodes) whose noise before
//! the quantiser is `σ_n` (from the rows' variance about their episode's mean less `q²/12`) has a
//! mean biased by at most `min(q/2, Σ_k (q/(πk))·exp(−2π²k²σ_n²/q²))` (the harmonics of the
//! quantiser's mean error; Widrow and Kollár, *Quantization Noise*, Cambridge University Press,
//! 2008). That bound is added to each side of the 95 % interval.
//!
//! # When there is no measurement
//! No `engine_torque`, `engine_speed` or `gear` column, less than [`MIN_TOTAL_S`] of episodes,
//! a torque channel that does not vary at all over them (a frozen channel), or an offset beyond
//! [`MAX_OFFSET_NM`] (the catalogue's fit domain: another quantity in the channel). The reason
//! is reported.

use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::signal::stats::t_quantile;
use crate::table::DriveLog;
use serde::Serialize;

/// Clutch travel from which the clutch is released (0 engaged, 1 released).
pub const RELEASED: f64 = 0.95;
/// Least engine speed of a free row, rad/s (300 rpm: below it the engine is off or stalling).
pub const MIN_ENGINE_SPEED_RAD_S: f64 = 31.4;
/// Time trimmed from the start of a run of free rows, s.
pub const SETTLE_S: f64 = 2.0;
/// Time trimmed from the end of a run of free rows, s.
pub const LEAD_S: f64 = 1.0;
/// Span over which a row's engine speed change is read, s.
pub const STEADY_SPAN_S: f64 = 1.0;
/// Largest engine speed change over [`STEADY_SPAN_S`] of a steady row, rad/s (about 19 rpm).
pub const MAX_SPEED_CHANGE_RAD_S: f64 = 2.0;
/// Shortest episode, s.
pub const MIN_EPISODE_S: f64 = 2.0;
/// Least time in episodes, s.
pub const MIN_TOTAL_S: f64 = 10.0;
/// Bartlett kernel half-width of the Newey–West standard error, s.
pub const HAC_LAG_S: f64 = 2.0;
/// Largest offset taken as a measurement, N·m (the catalogue's fit domain).
pub const MAX_OFFSET_NM: f64 = 500.0;
/// A gap between rows that ends a run, s.
const MAX_GAP_S: f64 = 0.5;
/// The 95 % two-sided normal quantile.
const Z95: f64 = 1.959_963_984_540_054;

/// The measured offset.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IdleTorqueOffset {
    /// Offset of the reported torque, N·m (reported = delivered + offset; the catalogue's
    /// `engine_torque_offset_nm`).
    pub value_nm: f64,
    /// Standard error, N·m (module doc, "Estimate and interval").
    pub std_error_nm: f64,
    /// Bound of the quantiser's bias added to each side of the interval, N·m.
    pub resolution_bias_nm: f64,
    /// 95 % interval, lower end, N·m.
    pub ci_low_nm: f64,
    /// 95 % interval, upper end, N·m.
    pub ci_high_nm: f64,
    /// Episodes used.
    pub episodes: usize,
    /// Rows used.
    pub rows: usize,
    /// Time in episodes, s.
    pub duration_s: f64,
    /// Mean engine speed over the rows used, rad/s.
    pub engine_speed_rad_s: f64,
    /// Step of the torque channel read off its values, N·m.
    pub channel_step_nm: f64,
}

/// The measurement, or why there is none.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum IdleTorqueOutcome {
    /// Measured.
    Measured(IdleTorqueOffset),
    /// Not measured, and why.
    NotMeasured(String),
}

impl IdleTorqueOutcome {
    /// The measurement, if any.
    pub fn measured(&self) -> Option<&IdleTorqueOffset> {
        match self {
            IdleTorqueOutcome::Measured(m) => Some(m),
            IdleTorqueOutcome::NotMeasured(_) => None,
        }
    }
}

/// Bound of the bias of the mean of a quantiser of step `q` fed a value with Gaussian noise of
/// σ `sigma`: the amplitudes of the harmonics of its mean error, `Σ_k q/(πk)·exp(−2π²k²σ²/q²)`,
/// at most `q/2` (what an undithered quantiser can be off by).
fn quantiser_bias_bound(q: f64, sigma: f64) -> f64 {
    let r = 2.0 * (std::f64::consts::PI * sigma / q).powi(2);
    let sum: f64 = (1..=64)
        .map(|k| {
            let k = f64::from(k);
            q / (std::f64::consts::PI * k) * (-r * k * k).exp()
        })
        .sum();
    sum.min(0.5 * q)
}

/// Measures the torque channel's offset of `log` on its free-engine rows (module doc), with
/// the engine's inertia `j_e_kg_m2` (engine and flywheel, the vehicle file's).
pub fn idle_torque_offset(log: &DriveLog, j_e_kg_m2: f64) -> IdleTorqueOutcome {
    let no = |why: String| IdleTorqueOutcome::NotMeasured(why);
    let (Some(torque), Some(speed)) = (log.signal("engine_torque"), log.signal("engine_speed"))
    else {
        return no("the log lacks engine_torque or engine_speed".into());
    };
    let Some(gear) = log
        .signal("gear")
        .and_then(|g| fill_gaps(g, Interpolation::Hold))
    else {
        return no("the log has no gear".into());
    };
    let clutch = log
        .signal("clutch_position")
        .and_then(|c| fill_gaps(c, Interpolation::Linear));
    let t = log.seconds_from_start();
    let n = t.len();
    let free = |i: usize| {
        torque[i].is_finite()
            && speed[i].is_finite()
            && speed[i] >= MIN_ENGINE_SPEED_RAD_S
            && (gear[i] == 0.0 || clutch.as_ref().is_some_and(|c| c[i] >= RELEASED))
    };
    // runs of free rows, trimmed
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut i = 0;
    while i < n {
        if !free(i) {
            i += 1;
            continue;
        }
        let mut j = i;
        while j + 1 < n && free(j + 1) && t[j + 1] - t[j] <= MAX_GAP_S {
            j += 1;
        }
        let a = (i..=j).find(|&k| t[k] - t[i] >= SETTLE_S);
        let b = (i..=j).rev().find(|&k| t[j] - t[k] >= LEAD_S);
        if let (Some(a), Some(b)) = (a, b) {
            if a <= b {
                runs.push((a, b));
            }
        }
        i = j + 1;
    }
    // steady rows of each run, in episodes of at least MIN_EPISODE_S
    let half = 0.5 * STEADY_SPAN_S;
    let mut episodes: Vec<(usize, usize)> = Vec::new();
    for &(a, b) in &runs {
        let (mut lo, mut hi) = (a, a);
        let mut start: Option<usize> = None;
        let close = |s: usize, e: usize, eps: &mut Vec<(usize, usize)>| {
            if t[e] - t[s] >= MIN_EPISODE_S {
                eps.push((s, e));
            }
        };
        for k in a..=b {
            while t[k] - t[lo] > half {
                lo += 1;
            }
            while hi < b && t[hi + 1] - t[k] <= half {
                hi += 1;
            }
            let steady = (speed[hi] - speed[lo]).abs() <= MAX_SPEED_CHANGE_RAD_S;
            match (steady, start) {
                (true, None) => start = Some(k),
                (false, Some(s)) => {
                    close(s, k - 1, &mut episodes);
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(s) = start {
            close(s, b, &mut episodes);
        }
    }
    let duration_s: f64 = episodes.iter().map(|&(a, b)| t[b] - t[a]).sum();
    if duration_s < MIN_TOTAL_S {
        return no(format!(
            "{duration_s:.1} s of steady engine with no gear or the clutch released; at least \
             {MIN_TOTAL_S} s are needed"
        ));
    }
    // each episode's offset x_i, the rows' residuals about it
    let mut xs = Vec::with_capacity(episodes.len());
    let mut means = Vec::with_capacity(episodes.len());
    let mut counts = Vec::with_capacity(episodes.len());
    let (mut sum, mut rows, mut speed_sum) = (0.0, 0usize, 0.0);
    for &(a, b) in &episodes {
        let inertia = j_e_kg_m2 * (speed[b] - speed[a]) / (t[b] - t[a]);
        let m = torque[a..=b].iter().sum::<f64>() / (b - a + 1) as f64;
        xs.push(m - inertia);
        means.push(m);
        counts.push(b - a + 1);
        sum += (m - inertia) * (b - a + 1) as f64;
        rows += b - a + 1;
        speed_sum += speed[a..=b].iter().sum::<f64>();
    }
    let value = sum / rows as f64;
    if value.abs() > MAX_OFFSET_NM {
        return no(format!(
            "the free engine's reported torque is {value:.0} N·m, more than an offset can be \
             (at most {MAX_OFFSET_NM} N·m)"
        ));
    }
    // Newey–West within episodes
    let (mut s, mut ss) = (0.0, 0.0);
    for (&(a, b), &m) in episodes.iter().zip(&means) {
        for k in a..=b {
            let r = torque[k] - m;
            ss += r * r;
            s += r * r;
            for l in k + 1..=b {
                let lag = t[l] - t[k];
                if lag >= HAC_LAG_S {
                    break;
                }
                s += 2.0 * (1.0 - lag / HAC_LAG_S) * r * (torque[l] - m);
            }
        }
    }
    let nw = s.max(0.0).sqrt() / rows as f64;
    let mut half_width = Z95 * nw;
    let mut std_error_nm = nw;
    let k = xs.len();
    if k >= 2 {
        let cr = (k as f64 / (k - 1) as f64
            * xs.iter()
                .zip(&counts)
                .map(|(x, &c)| (c as f64 * (x - value)).powi(2))
                .sum::<f64>())
        .sqrt()
            / rows as f64;
        let q = t_quantile(0.975, (k - 1) as f64);
        if q * cr > half_width {
            half_width = q * cr;
            std_error_nm = cr;
        }
    }
    // the channel's step and the quantiser's bias
    let mut values: Vec<f64> = episodes
        .iter()
        .flat_map(|&(a, b)| torque[a..=b].iter().copied())
        .collect();
    values.sort_by(f64::total_cmp);
    values.dedup();
    let Some(step) = values
        .windows(2)
        .map(|w| w[1] - w[0])
        .min_by(f64::total_cmp)
    else {
        return no(format!(
            "the torque channel reads {} N·m on every free-engine row: frozen",
            values.first().copied().unwrap_or(f64::NAN)
        ));
    };
    let noise_var = (ss / rows as f64 - step * step / 12.0).max(0.0);
    let resolution_bias_nm = quantiser_bias_bound(step, noise_var.sqrt());
    half_width += resolution_bias_nm;
    IdleTorqueOutcome::Measured(IdleTorqueOffset {
        value_nm: value,
        std_error_nm,
        resolution_bias_nm,
        ci_low_nm: value - half_width,
        ci_high_nm: value + half_width,
        episodes: k,
        rows,
        duration_s,
        engine_speed_rad_s: speed_sum / rows as f64,
        channel_step_nm: step,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro256StarStar;

    const J_E: f64 = 3.5;

    /// A 50 Hz drive of `stops` cycles: 60 s driving in 6th gear at 1400 rpm and 1 200 N·m,
    /// then 30 s at standstill, clutch released, the engine at 600 rpm, its reported torque
    /// `offset` plus noise of σ `noise` quantised to `step` (`step` 0: not quantised).
    fn drive(stops: usize, offset: f64, noise: f64, step: f64, seed: u64) -> DriveLog {
        let mut rng = Xoshiro256StarStar::seed_from_u64(seed);
        let (mut tq, mut w, mut g, mut c) = (vec![], vec![], vec![], vec![]);
        let q = |x: f64| {
            if step > 0.0 {
                (x / step).round() * step
            } else {
                x
            }
        };
        for _ in 0..stops {
            for _ in 0..3000 {
                tq.push(q(1200.0 + offset + noise * rng.standard_normal()));
                w.push(146.6 + 0.1 * rng.standard_normal());
                g.push(6.0);
                c.push(0.0);
            }
            for _ in 0..1500 {
                tq.push(q(offset + noise * rng.standard_normal()));
                w.push(62.8 + 0.1 * rng.standard_normal());
                g.push(1.0);
                c.push(1.0);
            }
        }
        DriveLog::from_columns(
            20_000_000,
            vec![
                ("engine_torque", "N*m", tq),
                ("engine_speed", "rad/s", w),
                ("gear", "1", g),
                ("clutch_position", "1", c),
            ],
        )
    }

    #[test]
    fn the_free_engine_reads_the_offset_and_a_healthy_channel_none() {
        // the synthetic bus's torque channel: 1 % of 2 600 N·m, noise 0.5 % (13 N·m)
        for (k, offset) in [0.0, 65.5, -47.4, -142.5, 12.0].into_iter().enumerate() {
            let m = idle_torque_offset(&drive(4, offset, 13.0, 26.0, k as u64), J_E);
            let m = *m.measured().expect("measured");
            assert_eq!(m.episodes, 4);
            // 4 × 27 s at 50 Hz of 13 N·m noise: a standard error of about 0.2 N·m before
            // the correlation, the cluster-robust one on 3 degrees of freedom about as much
            assert!((m.value_nm - offset).abs() < 1.5, "{offset}: {m:?}");
            assert!(
                m.ci_low_nm < offset && offset < m.ci_high_nm,
                "{offset}: {m:?}"
            );
            assert!(m.ci_high_nm - m.ci_low_nm < 10.0, "{offset}: {m:?}");
            assert!((m.channel_step_nm - 26.0).abs() < 1e-9);
            // noise of half a step dithers the quantiser: its bias bound is negligible
            assert!(m.resolution_bias_nm < 0.1, "{m:?}");
            assert!((m.engine_speed_rad_s - 62.8).abs() < 0.01);
        }
    }

    #[test]
    fn a_coarse_channel_with_little_noise_widens_the_interval_by_its_bias() {
        // no noise: every idle row reads the offset rounded to the step, 10 N·m off at most
        let m = idle_torque_offset(&drive(4, 60.0, 0.0, 26.0, 1), J_E);
        // a frozen reading at idle has one value: no step to read, no measurement
        assert!(m.measured().is_none(), "{m:?}");
        // a little noise (σ 4 N·m) reads 78 instead of 52 on a tenth of the rows: the mean is
        // about 5 N·m short of 60, and the bias bound (from σ_n read off the readings' spread)
        // covers it where the standard error (0.1 N·m) does not
        let m = idle_torque_offset(&drive(4, 60.0, 4.0, 26.0, 1), J_E);
        let m = *m.measured().expect("measured");
        assert!(60.0 - m.value_nm > 3.0, "{m:?}");
        assert!(m.resolution_bias_nm > 60.0 - m.value_nm, "{m:?}");
        assert!(m.resolution_bias_nm <= 13.0, "{m:?}");
        assert!(m.ci_low_nm < 60.0 && 60.0 < m.ci_high_nm, "{m:?}");
    }

    #[test]
    fn a_slow_drift_of_the_free_engine_is_taken_off_through_its_inertia() {
        // the free engine rises at 1.5 rad/s² (within the steady rows' 2 rad/s per second):
        // its net torque J_e·ω̇ = 5.25 N·m is not offset
        let n = 2000;
        let w: Vec<f64> = (0..n).map(|k| 60.0 + 1.5 * k as f64 * 0.02).collect();
        let tq = vec![40.0 + J_E * 1.5; n];
        let mut tq = tq;
        for (k, v) in tq.iter_mut().enumerate() {
            *v += if k % 2 == 0 { 0.5 } else { -0.5 };
        }
        let log = DriveLog::from_columns(
            20_000_000,
            vec![
                ("engine_torque", "N*m", tq),
                ("engine_speed", "rad/s", w),
                ("gear", "1", vec![0.0; n]),
            ],
        );
        let m = *idle_torque_offset(&log, J_E).measured().expect("measured");
        assert!((m.value_nm - 40.0).abs() < 1e-3, "{m:?}");
        assert_eq!(m.episodes, 1);
        // trimmed: 2 s after the run opens, 1 s before it ends
        assert!((m.duration_s - (40.0 - 0.02 - 3.0)).abs() < 0.05, "{m:?}");
    }

    #[test]
    fn revs_and_engaged_rows_are_not_read_and_a_log_without_free_rows_says_why() {
        // a stop where the engine revs: swings of 10 rad/s every 2 s are not steady
        let n = 3000;
        let w: Vec<f64> = (0..n)
            .map(|k| 62.8 + 10.0 * (std::f64::consts::PI * k as f64 * 0.02).sin())
            .collect();
        let log = DriveLog::from_columns(
            20_000_000,
            vec![
                ("engine_torque", "N*m", vec![300.0; n]),
                ("engine_speed", "rad/s", w),
                ("gear", "1", vec![0.0; n]),
            ],
        );
        assert!(matches!(
            idle_torque_offset(&log, J_E),
            IdleTorqueOutcome::NotMeasured(ref why) if why.contains("steady")
        ));
        // always in gear with the clutch engaged: nothing is free
        let log = DriveLog::from_columns(
            20_000_000,
            vec![
                ("engine_torque", "N*m", vec![300.0; n]),
                ("engine_speed", "rad/s", vec![120.0; n]),
                ("gear", "1", vec![5.0; n]),
                ("clutch_position", "1", vec![0.0; n]),
            ],
        );
        assert!(idle_torque_offset(&log, J_E).measured().is_none());
        // without a gear column there is no telling a free engine
        let log = DriveLog::from_columns(
            20_000_000,
            vec![
                ("engine_torque", "N*m", vec![0.0; n]),
                ("engine_speed", "rad/s", vec![62.8; n]),
            ],
        );
        assert!(matches!(
            idle_torque_offset(&log, J_E),
            IdleTorqueOutcome::NotMeasured(ref why) if why.contains("gear")
        ));
    }
}
