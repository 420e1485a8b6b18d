//! Shuffle modes per clutch engagement, measured against simulated (docs/diagnosis/method.md, steps
//! 2 and 3 for the driveline effects): after a clutch closes, the locked driveline rings at its
//! first torsional ("shuffle") mode, whose frequency is set by the drive-shaft stiffness `k_d` and
//! the inertias of the engaged gear (docs/models/driveline.md). A change of `k_d`
//! (`driveline_compliance`) moves that frequency; it hides in the time-domain engine-speed residual
//! (whose floor is input-driven, 0.33–0.43 rad/s on the proof drives) but not in the frequency of
//! the ringing.
//!
//! # Method
//! 1. [`engagements`] ([`super::clutch_engagements`]): every clutch closing after which the
//!    clutch stays closed, the gear stays engaged and unchanged, and the engine speed has no gap
//!    over the analysis window.
//! 2. [`fit_damped_sinusoid`] ([`super::modal_fit`]): a damped sinusoid on a quadratic trend,
//!    fitted to the window's engine speed.
//! 3. [`compare_modes`]: the same fit on the nominal model's simulated engine speed
//!    ([`super::extended::LongitudinalModel::simulate`], the comparison of step 1) on the same
//!    rows, so that the window and the method's bias cancel in `Δf = f_measured − f_simulated`.
//!    The nominal driveline's linearised mode ([`super::linearised_mode`]) is the other
//!    reference ([`Reference`]).
//! 4. Significance ([`DriveModalTest`]): the relative shift `r = Δf / f_simulated` of every
//!    engagement with both fits accepted, one-sample two-sided Student t-test of `mean r = 0`
//!    over the drive's engagements (one test per drive, false-alarm rate
//!    [`ModalConfig::alpha`] when the engagements' shifts are independent with zero mean), and
//!    a practical margin [`ModalConfig::min_relative_shift`] the mean must also exceed. Per gear
//!    the mean and spread of `Δf` and `Δσ` are reported, with Holm-corrected per-gear t-tests
//!    where a gear has at least two engagements.
//!
//! Settings: [`ModalConfig`] ([`super::modal_config`]). Conventions of frequency, decay rate and
//! amplitude: [`super::modal_fit`]. The drive-shaft stiffness that matches the measured modes:
//! [`super::shaft_stiffness`]. This module holds steps 3 and 4 and re-exports the parts they are
//! built from.
//!
//! ## Reference
//! Holm, Scand. J. Statist. 6 (1979) — the step-down correction.

use crate::model::driveline::DrivelineParams;
use crate::table::DriveLog;
use serde::Serialize;

pub use super::clutch_engagements::{engagements, Engagement};
pub use super::linearised_mode::{
    driven_tyres, locked_mode, tolerance_shift, tyre_mode, LockedMode,
};
pub use super::modal_config::ModalConfig;
pub use super::modal_fit::{fit_damped_sinusoid, ModalFit, ModalReject};

/// What the measured modes are compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Reference {
    /// The same fit on the nominal model's simulated engine speed on the same rows.
    Simulated,
    /// The first torsional mode of the nominal driveline linearised in the engagement's gear at
    /// its measured speed ([`locked_mode`]).
    Linearised,
}

/// The modes of one engagement: measured, simulated and linearised.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EngagementModes {
    /// The engagement.
    pub engagement: Engagement,
    /// Fit on the measured engine speed.
    pub measured: Result<ModalFit, ModalReject>,
    /// Fit on the simulated engine speed.
    pub simulated: Result<ModalFit, ModalReject>,
    /// The nominal linearised mode (`None` without driveline parameters or without a mode).
    pub linearised: Option<LockedMode>,
}

impl EngagementModes {
    /// The reference mode of `reference`, when there is one (an accepted simulated fit, a
    /// linearised mode).
    pub fn reference(&self, reference: Reference) -> Option<LockedMode> {
        match reference {
            Reference::Simulated => self.simulated.as_ref().ok().map(|s| LockedMode {
                frequency_hz: s.frequency_hz,
                decay_per_s: s.decay_per_s,
            }),
            Reference::Linearised => self.linearised,
        }
    }

    /// The accepted measured fit with the reference mode of `reference`, when both exist and
    /// their frequencies are within a factor `max_mode_ratio` of each other
    /// ([`ModalConfig::max_mode_ratio`]).
    pub fn pair(
        &self,
        reference: Reference,
        max_mode_ratio: f64,
    ) -> Option<(&ModalFit, LockedMode)> {
        let m = self.measured.as_ref().ok()?;
        let r = self.reference(reference)?;
        let ratio = m.frequency_hz / r.frequency_hz;
        (ratio <= max_mode_ratio && ratio * max_mode_ratio >= 1.0).then_some((m, r))
    }
}

/// Measured minus reference modes of one gear.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GearModes {
    /// Gear (1-based).
    pub gear: usize,
    /// Engagements with both fits accepted.
    pub n: usize,
    /// Mean measured frequency, Hz.
    pub measured_hz: f64,
    /// Mean reference frequency, Hz.
    pub reference_hz: f64,
    /// Mean `Δf = f_measured − f_reference`, Hz.
    pub delta_f_hz: f64,
    /// Sample standard deviation of `Δf` (NaN for one engagement), Hz.
    pub delta_f_sd_hz: f64,
    /// Mean `Δσ = σ_measured − σ_reference`, 1/s.
    pub delta_decay_per_s: f64,
    /// Sample standard deviation of `Δσ` (NaN for one engagement), 1/s.
    pub delta_decay_sd_per_s: f64,
    /// Two-sided t-test p-value of `mean Δf = 0`, Holm-adjusted over the gears tested (NaN for
    /// one engagement).
    pub p_holm: f64,
}

/// The drive-level test on the relative frequency shifts `r = Δf / f_reference`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DriveModalTest {
    /// Engagements in the test.
    pub n: usize,
    /// Mean relative shift, fraction.
    pub mean_shift: f64,
    /// Its standard error, fraction.
    pub shift_se: f64,
    /// Student t statistic, `n − 1` degrees of freedom.
    pub t: f64,
    /// Two-sided p-value.
    pub p_value: f64,
    /// `p_value < alpha` and `|mean_shift| ≥ min_relative_shift`.
    pub flagged: bool,
}

/// The modal comparison of one drive.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModalComparison {
    /// What the measured modes were compared with.
    pub reference: Reference,
    /// Every usable engagement with its two fits.
    pub engagements: Vec<EngagementModes>,
    /// Per gear, gears ascending, gears with at least one accepted pair.
    pub gears: Vec<GearModes>,
    /// The drive-level test (`None` with fewer than [`ModalConfig::min_engagements`] pairs).
    pub test: Option<DriveModalTest>,
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let sd = if x.len() > 1 {
        (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        f64::NAN
    };
    (m, sd)
}

/// Two-sided one-sample t-test p-value of mean 0 (`None` below two samples; a zero spread with
/// a non-zero mean gives 0).
fn t_test(x: &[f64]) -> Option<(f64, f64, f64)> {
    if x.len() < 2 {
        return None;
    }
    let (m, sd) = mean_sd(x);
    let se = sd / (x.len() as f64).sqrt();
    if se == 0.0 {
        return Some((m, se, if m == 0.0 { 1.0 } else { 0.0 }));
    }
    let t = m / se;
    let tail = crate::signal::stats::t_cdf(-t.abs(), (x.len() - 1) as f64);
    (!tail.is_nan()).then_some((t, se, 2.0 * tail))
}

/// Fits the mode of every usable engagement of `log` ([`engagements`]) on the measured engine
/// speed `measured` and the simulated `simulated` (rad/s on the log's rows; the same rows for
/// both), adds the nominal linearised mode when `nominal` (driveline parameters, gear ratios
/// and the drive's tyre share of the main flexibility, [`tyre_mode`]) is given, and compares the measured modes with `reference` per gear and for the
/// drive (see the module documentation).
pub fn compare_modes(
    log: &DriveLog,
    measured: &[f64],
    simulated: &[f64],
    nominal: Option<(&DrivelineParams, &[f64], f64)>,
    reference: Reference,
    cfg: &ModalConfig,
) -> ModalComparison {
    let t = log.seconds_from_start();
    let fits: Vec<EngagementModes> = engagements(log, cfg)
        .into_iter()
        .map(|e| {
            let r = e.rows.clone();
            EngagementModes {
                measured: fit_damped_sinusoid(&t[r.clone()], &measured[r.clone()], cfg),
                simulated: fit_damped_sinusoid(&t[r.clone()], &simulated[r], cfg),
                linearised: nominal.and_then(|(p, ratios, share)| {
                    (e.gear <= ratios.len() && e.speed_mps.is_finite())
                        .then(|| {
                            tyre_mode(p, ratios, e.gear, e.speed_mps, e.engine_torque_nm, share)
                        })
                        .flatten()
                }),
                engagement: e,
            }
        })
        .collect();
    summarise(fits, reference, cfg)
}

/// Per-gear figures and the drive-level test of already fitted engagements.
pub fn summarise(
    fits: Vec<EngagementModes>,
    reference: Reference,
    cfg: &ModalConfig,
) -> ModalComparison {
    let mut by_gear: std::collections::BTreeMap<usize, Vec<(&ModalFit, LockedMode)>> =
        std::collections::BTreeMap::new();
    for e in &fits {
        if let Some(p) = e.pair(reference, cfg.max_mode_ratio) {
            by_gear.entry(e.engagement.gear).or_default().push(p);
        }
    }
    let mut gears = Vec::new();
    let mut raw_p = Vec::new();
    for (&gear, pairs) in &by_gear {
        let df: Vec<f64> = pairs
            .iter()
            .map(|(m, s)| m.frequency_hz - s.frequency_hz)
            .collect();
        let dd: Vec<f64> = pairs
            .iter()
            .map(|(m, s)| m.decay_per_s - s.decay_per_s)
            .collect();
        let (delta_f_hz, delta_f_sd_hz) = mean_sd(&df);
        let (delta_decay_per_s, delta_decay_sd_per_s) = mean_sd(&dd);
        let fm: Vec<f64> = pairs.iter().map(|(m, _)| m.frequency_hz).collect();
        let fs: Vec<f64> = pairs.iter().map(|(_, s)| s.frequency_hz).collect();
        raw_p.push(t_test(&df).map_or(f64::NAN, |(_, _, p)| p));
        gears.push(GearModes {
            gear,
            n: pairs.len(),
            measured_hz: mean_sd(&fm).0,
            reference_hz: mean_sd(&fs).0,
            delta_f_hz,
            delta_f_sd_hz,
            delta_decay_per_s,
            delta_decay_sd_per_s,
            p_holm: f64::NAN,
        });
    }
    let tested: Vec<usize> = (0..raw_p.len()).filter(|&i| raw_p[i].is_finite()).collect();
    let adjusted = super::locate::holm(&tested.iter().map(|&i| raw_p[i]).collect::<Vec<_>>());
    for (k, &i) in tested.iter().enumerate() {
        gears[i].p_holm = adjusted[k];
    }
    let shifts: Vec<f64> = fits
        .iter()
        .filter_map(|e| e.pair(reference, cfg.max_mode_ratio))
        .map(|(m, s)| (m.frequency_hz - s.frequency_hz) / s.frequency_hz)
        .collect();
    let test = if shifts.len() >= cfg.min_engagements.max(2) {
        t_test(&shifts).map(|(t, se, p)| {
            let mean_shift = mean_sd(&shifts).0;
            DriveModalTest {
                n: shifts.len(),
                mean_shift,
                shift_se: se,
                t,
                p_value: p,
                flagged: p < cfg.alpha && mean_shift.abs() >= cfg.min_relative_shift,
            }
        })
    } else {
        None
    };
    ModalComparison {
        reference,
        engagements: fits,
        gears,
        test,
    }
}

impl ModalComparison {
    /// The drive's modal mismatch as a located stretch of the engine speed, when the drive-level
    /// test flags it (`None` otherwise): from the first to the last analysis window compared,
    /// `band_hz` the range of the measured mode frequencies, the gears and the mean shift in
    /// words, `rms_residual` the RMS of `measured − simulated` engine speed (rad/s) over those
    /// windows, `significance` the test's p-value (its own test at [`ModalConfig::alpha`], not
    /// in the Holm family of the window tests), `floor_rms` the mean RMS left around the fitted
    /// modes, `windows` the engagements. `t_s`, `distance_m` (empty: NaN), `measured` and
    /// `simulated` are on the log's rows.
    pub fn mismatch(
        &self,
        cfg: &ModalConfig,
        t_s: &[f64],
        distance_m: &[f64],
        measured: &[f64],
        simulated: &[f64],
    ) -> Option<super::locate::Mismatch> {
        let test = self.test.filter(|t| t.flagged)?;
        let used: Vec<(&Engagement, &ModalFit)> = self
            .engagements
            .iter()
            .filter_map(|e| {
                e.pair(self.reference, cfg.max_mode_ratio)
                    .map(|(m, _)| (&e.engagement, m))
            })
            .collect();
        let (first, last) = (used.first()?.0, used.last()?.0);
        let (a, b) = (first.rows.start, last.rows.end - 1);
        let dist = |i: usize| distance_m.get(i).copied().unwrap_or(f64::NAN);
        let f_lo = used
            .iter()
            .map(|(_, m)| m.frequency_hz)
            .fold(f64::INFINITY, f64::min);
        let f_hi = used.iter().map(|(_, m)| m.frequency_hz).fold(0.0, f64::max);
        let (mut ss, mut n) = (0.0, 0usize);
        for (e, _) in &used {
            for i in e.rows.clone() {
                let r = measured[i] - simulated[i];
                if r.is_finite() {
                    ss += r * r;
                    n += 1;
                }
            }
        }
        let mut gears: Vec<usize> = used.iter().map(|(e, _)| e.gear).collect();
        gears.dedup();
        gears.sort_unstable();
        gears.dedup();
        let gears: Vec<String> = gears.iter().map(|g| g.to_string()).collect();
        let what = match self.reference {
            Reference::Simulated => "the nominal model's simulated ringing",
            Reference::Linearised => "the nominal driveline's linearised mode",
        };
        Some(super::locate::Mismatch {
            signal: "engine_speed".into(),
            start_s: t_s[a],
            end_s: t_s[b],
            start_m: dist(a),
            end_m: dist(b),
            band_hz: [f_lo, f_hi],
            condition: format!(
                "after clutch engagements in gear {}: the driveline shuffle rings {:+.1} % off {what} ({} engagements)",
                gears.join(", "),
                100.0 * test.mean_shift,
                test.n
            ),
            rms_residual: if n > 0 { (ss / n as f64).sqrt() } else { f64::NAN },
            significance: test.p_value,
            floor_rms: used.iter().map(|(_, m)| m.residual_rms).sum::<f64>() / used.len() as f64,
            windows: used.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::clutch_engagements::tests::{engagement_log, log_with};

    #[test]
    fn finds_a_closing_with_its_window() {
        let (c, g, w) = engagement_log();
        let log = log_with(c, g, w.clone());
        let cfg = ModalConfig::default();
        let e = engagements(&log, &cfg);
        assert_eq!(e.len(), 1, "{e:?}");
        assert!((e[0].t_close_s - 3.0).abs() < 1e-9);
        assert_eq!(e[0].gear, 7);
        // rows 3.2 s … 5.5 s at 50 Hz
        assert_eq!(e[0].rows, 160..276);
        assert_eq!(e[0].speed_mps, 10.0);
        let cmp = compare_modes(&log, &w, &w, None, Reference::Simulated, &cfg);
        let (m, s) = cmp.engagements[0]
            .pair(Reference::Simulated, cfg.max_mode_ratio)
            .expect("noise-free ringing accepted");
        assert!((m.frequency_hz - 4.3).abs() < 1e-3);
        assert_eq!(m.frequency_hz, s.frequency_hz);
        assert!(cmp.engagements[0]
            .pair(Reference::Linearised, cfg.max_mode_ratio)
            .is_none());
    }

    #[test]
    fn the_drive_test_flags_a_consistent_shift_and_not_noise() {
        let cfg = ModalConfig::default();
        let fit = |f: f64| ModalFit {
            frequency_hz: f,
            frequency_se_hz: 0.01,
            decay_per_s: 5.0,
            decay_se_per_s: 0.1,
            amplitude: 1.0,
            phase_rad: 0.0,
            r2: 0.9,
            residual_rms: 0.1,
        };
        let e = |gear: usize, fm: f64, fs: f64| EngagementModes {
            engagement: Engagement {
                t_close_s: 0.0,
                gear,
                rows: 0..1,
                speed_mps: 10.0,
                engine_torque_nm: 0.0,
            },
            measured: Ok(fit(fm)),
            simulated: Ok(fit(fs)),
            linearised: None,
        };
        // +10 % in every gear, ±0.05 Hz scatter: flagged
        let shifted = vec![
            e(7, 4.78, 4.32),
            e(7, 4.72, 4.32),
            e(8, 5.80, 5.25),
            e(8, 5.75, 5.25),
            e(1, 1.90, 1.71),
        ];
        let s = summarise(shifted, Reference::Simulated, &cfg);
        let t = s.test.expect("five pairs");
        assert!(t.flagged && t.mean_shift > 0.09, "{t:?}");
        assert_eq!(s.gears.len(), 3);
        assert!(s.gears[0].p_holm.is_nan(), "gear 1 has one engagement");
        // the flagged drive is a located engine-speed mismatch over its engagements
        let m = s
            .mismatch(&cfg, &[0.0], &[0.0], &[1.0], &[0.5])
            .expect("flagged");
        assert_eq!((m.signal.as_str(), m.windows), ("engine_speed", 5));
        assert_eq!(m.band_hz, [1.90, 5.80]);
        assert_eq!(m.significance, t.p_value);
        assert!((m.rms_residual - 0.5).abs() < 1e-12);
        assert!(m.condition.contains("gear 1, 7, 8"), "{}", m.condition);
        // ±0.05 Hz scatter around no shift: not flagged
        let clean = vec![
            e(7, 4.37, 4.32),
            e(7, 4.27, 4.32),
            e(8, 5.30, 5.25),
            e(8, 5.20, 5.25),
            e(1, 1.72, 1.71),
        ];
        // a slow drift fitted in gear 12 (0.95 Hz against an 8.3 Hz shuffle) is not the mode:
        // left out of the comparison, so it cannot swing the test
        let mut clean = clean;
        clean.push(e(12, 0.95, 8.30));
        assert!(clean[5]
            .pair(Reference::Simulated, cfg.max_mode_ratio)
            .is_none());
        let c = summarise(clean, Reference::Simulated, &cfg);
        assert!(!c.test.expect("five pairs").flagged);
        assert!(c.mismatch(&cfg, &[0.0], &[0.0], &[1.0], &[0.5]).is_none());
        // a significant but tiny shift (1 %) stays below the practical margin
        let tiny = vec![
            e(7, 4.363, 4.32),
            e(7, 4.364, 4.32),
            e(8, 5.302, 5.25),
            e(8, 5.303, 5.25),
        ];
        let t = summarise(tiny, Reference::Simulated, &cfg)
            .test
            .expect("four pairs");
        assert!(t.p_value < cfg.alpha && !t.flagged, "{t:?}");
    }
}
