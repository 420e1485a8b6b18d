//! Residual statistics of step 3 of the diagnosis, explain (docs/diagnosis/method.md): the
//! whiteness of a residual ([`whiteness`], [`event_whiteness`]), which rule 2 of the acceptance
//! rule compares, and the effective number of independent samples of a residual
//! ([`effective_samples`]), which sets the fit's interval.
//!
//! The statistics themselves are in [`crate::signal::whiteness`]; this module applies them to a
//! diagnosis channel's residual on its train or held-out rows.
//!
//! Lags in s (of events for an events channel); residuals standardised by each row's own weight
//! ([`Channel::weight`]); the non-white power in the units of the weighted mean square
//! (dimensionless).

use super::channel::Channel;
use super::split::Part;
use crate::signal::stats::run_positions;
use crate::signal::whiteness::{
    effective_samples as signal_effective_samples, mean_squared_autocorrelation,
};
use serde::Serialize;
use std::ops::Index;

/// Lags (s) of the whiteness statistic: 0.1 s to 2 s in 0.1 s steps — from the driveline's
/// shuffle band (a few Hz) to the seconds over which a missing force drifts the speed.
pub const WHITENESS_LAG_STEP_S: f64 = 0.1;
/// Number of lags of the whiteness statistic.
pub const WHITENESS_LAGS: usize = 20;

/// Whiteness of a residual (see [`whiteness`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Whiteness {
    /// Mean over channels of the Ljung–Box statistic per sample, `Q/n`: the mean squared
    /// non-centred autocorrelation at the lags; 0 for white noise, 1 for a constant.
    pub q_per_n: f64,
    /// Non-white (autocorrelated) power: mean over channels of `√(Q/n)` times the channel's
    /// weighted mean square `MS_c / σ_c²` — the RMS of the weighted autocovariance at the
    /// lags. White noise of any level scores 0 (up to the autocorrelation's sampling noise).
    pub nonwhite_power: f64,
}

/// Whiteness of `outputs`' residual on `part` over the channels `chans` (weights `sigmas`).
///
/// For each channel, the squared *non-centred* autocorrelation `ρ(k) = Σ r_i r_{i+k} / Σ r_i²`
/// (pairs within contiguous valid runs) at the lags `k·0.1 s`, k = 1…20 — from the driveline's
/// shuffle band (a few Hz) to the seconds over which a missing force drifts the speed — is
/// averaged: the Ljung–Box statistic per sample `Q/n` on a 10 Hz lag grid; a bias counts as
/// non-white (the model's residual should be zero-mean noise). The acceptance rule compares the
/// non-white power, `√(Q/n)` scaled by the residual's weighted mean square (the RMS of the
/// autocovariance at the lags): the normalised `Q/n` alone rises whenever a fit removes a fast
/// structured error and leaves a smaller but slower one (the whole-percent slope sensor's
/// drift), although less of the residual is structure, and `Q/n` scaled by the mean square
/// still rises when the error removed is white at the lags (`super::explain`, rule 2).
///
/// An events channel ([`Channel::events`]; engagements tens of seconds apart, no time lags
/// between them) is scored on its standardised residuals `z_i = r_i √w_i` in event order, at
/// the lags of 1 … min(20, n − 1) events ([`event_whiteness`]): a shift common to the events
/// (a wrong shaft stiffness moves every engagement's frequency) is non-white as a bias is.
pub fn whiteness<Y: Index<usize, Output = f64>>(
    channels: &[Channel],
    chans: &[usize],
    sigmas: &[f64],
    outputs: &[Y],
    part: Part,
    dt_s: f64,
) -> Whiteness {
    let step = ((WHITENESS_LAG_STEP_S / dt_s.max(1e-9)).round() as usize).max(1);
    let (mut qn, mut pw) = (0.0, 0.0);
    for ((&c, y), sg) in chans.iter().zip(outputs).zip(sigmas) {
        let ch = &channels[c];
        let rows = ch.rows(part);
        if ch.events.is_some() {
            let z: Vec<f64> = rows
                .iter()
                .map(|&i| (ch.measured[i] - y[i]) * ch.weight(i).sqrt())
                .collect();
            let q = event_whiteness(&z);
            let ms = z.iter().map(|x| x * x).sum::<f64>() / z.len().max(1) as f64;
            qn += q;
            pw += q.sqrt() * ms / (sg * sg);
            continue;
        }
        // standardised by the row's own weight (1 but for a row-weighted channel)
        let r: Vec<f64> = rows
            .iter()
            .map(|&i| (ch.measured[i] - y[i]) * ch.weight(i).sqrt())
            .collect();
        let Some(q) = mean_squared_autocorrelation(&r, &run_positions(rows), step, WHITENESS_LAGS)
        else {
            continue;
        };
        let e0: f64 = r.iter().map(|x| x * x).sum();
        qn += q;
        pw += q.sqrt() * e0 / (r.len() as f64 * sg * sg);
    }
    let n = chans.len().max(1) as f64;
    Whiteness {
        q_per_n: qn / n,
        nonwhite_power: pw / n,
    }
}

/// `Q/n` of a sequence of event residuals `z` ([`whiteness`] for an events channel): the mean
/// over the lags `k` = 1 … min([`WHITENESS_LAGS`], n − 1) of the squared non-centred
/// autocorrelation `(Σ z_i z_{i+k} / Σ z_i²)²`; 0 for fewer than 2 events or a zero residual.
pub fn event_whiteness(z: &[f64]) -> f64 {
    let lags = WHITENESS_LAGS.min(z.len().saturating_sub(1));
    mean_squared_autocorrelation(z, std::slice::from_ref(&(0..z.len())), 1, lags).unwrap_or(0.0)
}

/// Effective number of independent samples of the residual of one channel on `part`:
/// `N / τ` with `τ = 1 + 2 Σ_{k=1}^{M} ρ(k)` the integrated autocorrelation time of the
/// (centred) residual, `ρ` pooled over the contiguous valid runs (computed by FFT), and `M`
/// Sokal's automatic window (the smallest `M ≥ 5 τ(M)`), `τ ≥ 1`. The samples of an events
/// channel ([`Channel::events`]: engagements tens of seconds apart, each from its own fit)
/// count as independent: `N`.
pub fn effective_samples<Y: Index<usize, Output = f64> + ?Sized>(
    ch: &Channel,
    sim: &Y,
    part: Part,
) -> f64 {
    let rows = ch.rows(part);
    if ch.events.is_some() {
        return rows.len() as f64;
    }
    let r: Vec<f64> = rows
        .iter()
        .map(|&i| (ch.measured[i] - sim[i]) * ch.weight(i).sqrt())
        .collect();
    signal_effective_samples(&r, &run_positions(rows))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::channel::tests::channel;
    use crate::diagnose::channel::{weighted_ms, EventWeights};
    use crate::diagnose::row_column::RowColumn;
    use crate::rng::Xoshiro256StarStar;

    fn gauss(rng: &mut Xoshiro256StarStar) -> f64 {
        // Box–Muller
        let (u, v) = (rng.next_f64().max(1e-300), rng.next_f64());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    #[test]
    fn whiteness_is_zero_for_noise_and_one_for_a_bias() {
        let mut rng = Xoshiro256StarStar::seed_from_u64(1);
        let noise: Vec<f64> = (0..20_000).map(|_| gauss(&mut rng)).collect();
        let zero = vec![vec![0.0; noise.len()]];
        let w = whiteness(&[channel(noise)], &[0], &[1.0], &zero, Part::Train, 0.02);
        assert!(w.q_per_n < 1e-3, "{w:?}");
        let w = whiteness(
            &[channel(vec![0.5; 20_000])],
            &[0],
            &[1.0],
            &[vec![0.0; 20_000]],
            Part::Train,
            0.02,
        );
        assert!((w.q_per_n - 1.0).abs() < 0.05 && (w.nonwhite_power - 0.25).abs() < 0.02);
    }

    #[test]
    fn white_error_on_top_of_slow_structure_leaves_the_non_white_power_alone() {
        // a fit that removes a fast error leaves the sensors' slow drift: slow structure (a
        // 0.05 Hz sine, power 0.125) with and without white noise of power 1. The non-white
        // power is the autocovariance at the lags, which the white part does not change; the
        // other form, (Q/n)·MS = mean c_k² / c_0, rises about 9-fold when it is removed
        let n = 50_000;
        let mut rng = Xoshiro256StarStar::seed_from_u64(3);
        let slow: Vec<f64> = (0..n)
            .map(|i| 0.5 * (std::f64::consts::TAU * 0.05 * i as f64 * 0.02).sin())
            .collect();
        let mixed: Vec<f64> = slow.iter().map(|s| s + gauss(&mut rng)).collect();
        let zero = vec![vec![0.0; n]];
        let w = |r: Vec<f64>| whiteness(&[channel(r)], &[0], &[1.0], &zero, Part::Train, 0.02);
        let ms = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64;
        let (ms_mixed, ms_slow) = (ms(&mixed), ms(&slow));
        let (with, without) = (w(mixed), w(slow));
        let ratio = without.nonwhite_power / with.nonwhite_power;
        // the lag sums' sampling noise with the white part: a few per cent at 50 000 rows
        assert!((ratio - 1.0).abs() < 0.08, "{with:?} -> {without:?}");
        let old = (without.q_per_n * ms_slow) / (with.q_per_n * ms_mixed);
        assert!(old > 5.0, "(Q/n)·MS rose only {old}×");
    }

    #[test]
    fn an_events_channel_is_weighted_per_sample_and_its_whiteness_is_over_events() {
        // 6 events on rows 0, 10, …, 50 of 60; weights 1/s² with s = 0.01 and 0.02
        let n = 60;
        let mut measured = vec![0.0; n];
        let mut valid = vec![false; n];
        let mut w = vec![0.0; n];
        for k in 0..6 {
            let i = 10 * k;
            measured[i] = 0.05; // a common shift of 5 %
            valid[i] = true;
            w[i] = if k % 2 == 0 { 1e4 } else { 2.5e3 };
        }
        let mut ch = channel(measured);
        ch.valid = valid;
        ch.train_idx = (0..6).map(|k| 10 * k).collect();
        ch.events = Some(EventWeights(RowColumn::dense(w)));
        let zero = vec![vec![0.0; n]];
        // mean of w r²: (3·1e4 + 3·2.5e3)·0.0025 / 6 = 15.625
        let ms = weighted_ms(std::slice::from_ref(&ch), &[0], &[1.0], &zero, Part::Train);
        assert!((ms - 15.625).abs() < 1e-9, "{ms}");
        // a common shift is non-white: lag-k autocorrelation of z = (5, 2.5, 5, 2.5, 5, 2.5)
        let z = [5.0, 2.5, 5.0, 2.5, 5.0, 2.5];
        let e0: f64 = z.iter().map(|x| x * x).sum();
        let expect: f64 = (1..=5)
            .map(|k| {
                let s: f64 = z[..6 - k].iter().zip(&z[k..]).map(|(a, b)| a * b).sum();
                (s / e0).powi(2)
            })
            .sum::<f64>()
            / 5.0;
        let wh = whiteness(
            std::slice::from_ref(&ch),
            &[0],
            &[1.0],
            &zero,
            Part::Train,
            0.02,
        );
        assert!(
            (wh.q_per_n - expect).abs() < 1e-12 && wh.q_per_n > 0.2,
            "{wh:?}"
        );
        assert!((wh.nonwhite_power - expect.sqrt() * 15.625).abs() < 1e-9);
        // a single event has no lag at all, a zero residual no structure
        assert_eq!(event_whiteness(&[3.0]), 0.0);
        assert_eq!(event_whiteness(&[0.0, 0.0]), 0.0);
        // events are independent samples
        assert_eq!(effective_samples(&ch, &zero[0], Part::Train), 6.0);
    }
}
