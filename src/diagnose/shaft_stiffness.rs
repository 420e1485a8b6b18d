//! The drive-shaft stiffness `k_d` (`driveline_compliance`) that makes the nominal driveline's
//! linearised shuffle modes ([`super::linearised_mode`]) match the modes measured after a
//! drive's clutch engagements ([`super::modal`]; docs/models/driveline.md,
//! docs/diagnosis/method.md): least squares of the log-frequency differences in `ln k_d` by
//! Levenberg–Marquardt, with a Student-t confidence interval.
//!
//! Stiffness in N·m/rad; frequencies in Hz.

use super::linearised_mode::locked_mode;
use super::modal::EngagementModes;
use super::modal_config::ModalConfig;
use crate::model::driveline::DrivelineParams;
use crate::optim::{minimise, Damping, ScalarResiduals, Scaling, Settings, Silent};
use serde::Serialize;

/// The drive-shaft stiffness that makes the linearised modes match the measured ones.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StiffnessFit {
    /// Fitted `k_d`, N·m/rad.
    pub k_d_nm_per_rad: f64,
    /// 95 % confidence interval of `k_d` (Student t on the fit's `ln k_d` standard error,
    /// `n − 1` degrees of freedom), N·m/rad.
    pub ci95_nm_per_rad: (f64, f64),
    /// Engagements used.
    pub n: usize,
    /// RMS of the remaining `ln f_measured − ln f_linearised`.
    pub rms_log_residual: f64,
}

/// Fits the drive-shaft stiffness `k_d` (`driveline_compliance`) to the accepted measured modes
/// of `fits`: least squares of `ln f_measured − ln f_linearised(k_d)` over the engagements
/// (each at its gear and measured speed, [`locked_mode`] on `p` with `k_d` replaced), in
/// `x = ln(k_d / k_d,nominal)` by Levenberg–Marquardt from `x = 0`
/// ([`crate::optim::minimise`], Gauss–Newton steps while they lower the cost) with a
/// central-difference derivative (20 steps at most, to a step below 10⁻⁶, `x` kept within ±2). Engagements whose measured mode is not within a
/// factor [`ModalConfig::max_mode_ratio`] of the nominal linearised one are left out. `None`
/// below two engagements.
pub fn fit_shaft_stiffness(
    fits: &[EngagementModes],
    p: &DrivelineParams,
    ratios: &[f64],
    cfg: &ModalConfig,
) -> Option<StiffnessFit> {
    let obs: Vec<(usize, f64, f64)> = fits
        .iter()
        .filter_map(|e| {
            let m = e.measured.as_ref().ok()?;
            let (g, v) = (e.engagement.gear, e.engagement.speed_mps);
            let ratio = m.frequency_hz / locked_mode(p, ratios, g, v)?.frequency_hz;
            (v.is_finite() && ratio <= cfg.max_mode_ratio && ratio * cfg.max_mode_ratio >= 1.0)
                .then_some((g, v, m.frequency_hz.ln()))
        })
        .collect();
    let n = obs.len();
    if n < 2 {
        return None;
    }
    let k0 = p.k_d_nm_per_rad;
    let residuals = |x: f64| -> Option<Vec<f64>> {
        let mut q = p.clone();
        q.k_d_nm_per_rad = k0 * x.exp();
        obs.iter()
            .map(|&(g, v, lf)| Some(lf - locked_mode(&q, ratios, g, v)?.frequency_hz.ln()))
            .collect()
    };
    let mut problem = ScalarResiduals::new(residuals, 0.01);
    let start_cost = problem.start(0.0)?;
    let settings = Settings {
        bounds: vec![(-2.0, 2.0)],
        step_tolerance: 1e-6,
        ..Settings::new(Damping::GAUSS_NEWTON_FIRST, Scaling::Marquardt, 20)
    };
    let x = minimise(&mut problem, &[0.0], start_cost, &settings, &mut Silent).params[0];
    let r = problem.residuals(x)?;
    let rss: f64 = r.iter().map(|v| v * v).sum();
    let jtj: f64 = problem.derivative(x)?.iter().map(|j| j * j).sum();
    if jtj <= 0.0 {
        return None;
    }
    let se = (rss / (n - 1) as f64 / jtj).sqrt();
    let tq = crate::signal::stats::t_quantile(0.975, (n - 1) as f64);
    if tq.is_nan() {
        return None;
    }
    Some(StiffnessFit {
        k_d_nm_per_rad: k0 * x.exp(),
        ci95_nm_per_rad: (k0 * (x - tq * se).exp(), k0 * (x + tq * se).exp()),
        n,
        rms_log_residual: (rss / n as f64).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::clutch_engagements::Engagement;
    use crate::diagnose::linearised_mode::tests::vehicle;
    use crate::diagnose::modal_fit::{ModalFit, ModalReject};

    #[test]
    fn the_stiffness_fit_inverts_the_linearised_modes() {
        let (p, ratios) = vehicle();
        let mut truth = p.clone();
        truth.k_d_nm_per_rad *= 0.7;
        let fit = |f: f64| ModalFit {
            frequency_hz: f,
            frequency_se_hz: 0.05,
            decay_per_s: 5.0,
            decay_se_per_s: 0.5,
            amplitude: 1.0,
            phase_rad: 0.0,
            r2: 0.9,
            residual_rms: 0.1,
        };
        // measured modes of a drive whose shaft is 30 % softer, each off by ±0.03 Hz
        let fits: Vec<EngagementModes> = [(1, 3.0), (7, 14.0), (8, 16.0), (9, 18.0), (12, 24.0)]
            .iter()
            .enumerate()
            .map(|(k, &(gear, v))| {
                let f = locked_mode(&truth, &ratios, gear, v).unwrap().frequency_hz;
                let jitter = if k % 2 == 0 { 0.03 } else { -0.03 };
                EngagementModes {
                    engagement: Engagement {
                        t_close_s: 0.0,
                        gear,
                        rows: 0..1,
                        speed_mps: v,
                        engine_torque_nm: 0.0,
                    },
                    measured: Ok(fit(f + jitter)),
                    simulated: Err(ModalReject::TooShort),
                    linearised: None,
                }
            })
            .collect();
        let k = fit_shaft_stiffness(&fits, &p, &ratios, &ModalConfig::default())
            .expect("five engagements");
        let t = truth.k_d_nm_per_rad;
        // a 0.03 Hz jitter on 1.5–8 Hz modes is < 2 % of ln f; with d ln f / d ln k ≈ 0.2–0.5
        // the fitted k_d lands within a few per cent, and the interval holds the truth
        assert!((k.k_d_nm_per_rad / t - 1.0).abs() < 0.05, "{k:?} vs {t}");
        assert!(
            k.ci95_nm_per_rad.0 < t && t < k.ci95_nm_per_rad.1,
            "{k:?} vs {t}"
        );
        assert_eq!(k.n, 5);
        // without jitter it is exact
        let exact: Vec<EngagementModes> = fits
            .into_iter()
            .map(|mut e| {
                let f = locked_mode(&truth, &ratios, e.engagement.gear, e.engagement.speed_mps)
                    .unwrap()
                    .frequency_hz;
                e.measured = Ok(fit(f));
                e
            })
            .collect();
        let k = fit_shaft_stiffness(&exact, &p, &ratios, &ModalConfig::default())
            .expect("five engagements");
        assert!((k.k_d_nm_per_rad / t - 1.0).abs() < 1e-4, "{k:?} vs {t}");
    }
}
