//! The driven tyres' longitudinal slip: model structure the lumped driveline leaves out.
//!
//! The nominal model turns the wheels at the vehicle's speed, `v = r_w ω_w`. A driven tyre
//! transmits its force `F_x` by slipping, `κ = (ω_w r_w − v)/v = F_x / C_κ` in its linear range
//! (Pacejka, "Tire and Vehicle Dynamics", 3rd ed., Elsevier 2012, §1.2), `C_κ` the slip
//! stiffness of the driven tyres together (N per unit slip). A vehicle speed from the free
//! rolling wheels (or GNSS) misses it, so under traction the engine turns `ω_e κ` faster
//! than the rigid model puts it against the recorded speed, and at a torque reversal the
//! engine-against-wheel speed swings by `ω_e Δκ`, as a lash would.
//!
//! # Structure, estimated per drive
//! [`estimate`] fits the slip per newton `b = 1/C_κ` from the recorded speeds alone: on rows
//! with the clutch closed, a gear held, at least [`MIN_SPEED_MPS`] and a traction force
//! within [`MAX_TRACTION_SHARE`] of the tyres' friction limit (the linear range) and a
//! relative slip no larger than the bound below allows plus [`RADIUS_MARGIN`],
//! `ω_e / (G v) − 1 = a + b·F_x` with `G = i_t i_f / r_w` and `F_x = M_e i_t i_f / r_w`
//! from the recorded engine torque. The intercept `a` takes the rolling radius's deviation
//! from the file's (the speed-consistency test, [`super::speed_consistency`], uses it); `b` is
//! kept within `[0, 1/(`[`SLIP_STIFFNESS_MIN`]`· F_z,min)]`,
//! `F_z,min = `[`DRIVEN_LOAD_SHARE_MIN`]` · m g`. The fit is least squares trimmed twice at 3 × 1.4826 × the median absolute residual (a slipping clutch, a stuck
//! speed channel or a shift's transient is not tyre slip). The longitudinal model then
//! reports the engine speed as `ω_e (1 + κ)` with `κ = b M_d / r_w` from its own drive-shaft
//! torque, and starts each window's engine side from the recorded engine speed divided by
//! `1 + κ` (`κ` there from the corrected recorded torque, [`slip_of_rows`];
//! [`super::extended::LongitudinalModel::simulate`]): the vehicle, whose inertia dominates
//! the wheels', keeps the model's speed, and the driveline turns faster than it by the slip,
//! continuously through clutch slip and torque steps.
//!
//! [`tyre_slip_variance`] bounds what the slip leaves in the engine speed when it is not
//! modelled; the located floor keeps it (a bound, conservative once the slip is modelled).

use crate::model::driveline::DrivelineParams;
use crate::table::{DriveLog, LogView};

/// Smallest normalised longitudinal slip stiffness `C_κ / F_z` of a driven heavy-truck axle
/// on a dry road, 1 (per unit slip): truck tyres measure about 8–15 (Pacejka, "Tire and
/// Vehicle Dynamics", Elsevier); the lower end gives the larger slip.
pub const SLIP_STIFFNESS_MIN: f64 = 8.0;
/// Smallest share of the vehicle's weight on its driven axle, 1: a 40 t tractor-semitrailer's
/// drive axle carries about 11.5 t (29 %); rigid trucks more.
pub const DRIVEN_LOAD_SHARE_MIN: f64 = 0.25;
/// Friction coefficient of the driven tyres on the road, 1: dry asphalt under a truck tyre
/// (0.7–0.9); sets the force their slip and tangent stiffness are limited by.
pub const TYRE_FRICTION: f64 = 0.8;
/// Typical share of the vehicle's weight on its driven axle, 1: a 40 t tractor-semitrailer's
/// drive axle at its EU limit of 11.5 t (Directive 96/53/EC). Sets the driven tyres' load
/// and, as a share of `J_w`, their inertia ([`super::modal::tyre_mode`]); the normalisation
/// of [`SlipEstimate::normalised_stiffness`].
pub const DRIVEN_LOAD_SHARE: f64 = 0.29;
/// Lowest recorded speed of a row [`estimate`] uses, m/s: below it the relative slip
/// `ω_e/(G v) − 1` divides by a small speed and the speed sensor's resolution dominates.
pub const MIN_SPEED_MPS: f64 = 3.0;
/// Largest traction force [`estimate`] uses, as a share of the tyres' friction limit
/// `µ F_z,min` (µ = [`TYRE_FRICTION`]): the linear range of the force–slip curve.
pub const MAX_TRACTION_SHARE: f64 = 0.4;
/// Largest relative slip beyond the bound `|F_x| / (C_κ,min)` a row [`estimate`] uses may show,
/// 1: the rolling radius's deviation from the file's (tread wear and inflation, ±1–2 %) plus
/// the speed channels' resolution.
pub const RADIUS_MARGIN: f64 = 0.02;
/// Fewest rows [`estimate`] needs.
pub const MIN_ROWS: usize = 200;

/// The drive's slip estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipEstimate {
    /// Slip per newton of traction force `b = 1/C_κ`, 1/N (0: the rigid nominal model).
    pub slip_per_newton: f64,
    /// Normalised slip stiffness `C_κ / (`[`DRIVEN_LOAD_SHARE`]` · m g)` it corresponds to
    /// (infinite at 0).
    pub normalised_stiffness: f64,
    /// Rows used after trimming.
    pub rows: usize,
    /// Intercept `a` of the fit at the kept `b`, 1: the rolling radius's relative deviation
    /// from the file's, seen through the speed channels (0 for the rigid model).
    pub intercept: f64,
}

impl SlipEstimate {
    /// No slip: the rigid nominal model.
    pub const RIGID: SlipEstimate = SlipEstimate {
        slip_per_newton: 0.0,
        normalised_stiffness: f64::INFINITY,
        rows: 0,
        intercept: 0.0,
    };
}

/// `(F_x, G)` of row `i`: traction force from the recorded torque and gear, N, and the
/// overall ratio per metre `i_t i_f / r_w`, 1/m; `None` without a finite torque or gear.
pub(crate) fn traction(
    torque: &[f64],
    gear: &[f64],
    i: usize,
    p: &DrivelineParams,
    ratios: &[f64],
) -> Option<(f64, f64)> {
    let g = gear[i].round();
    if !(torque[i].is_finite() && g >= 1.0) {
        return None;
    }
    let i_t = *ratios.get(g as usize - 1)?;
    let big_g = i_t * p.final_drive_ratio / p.wheel_radius_m;
    Some((torque[i] * big_g, big_g))
}

/// Fits the drive's slip per newton (module documentation). The rigid model (`b = 0`) without
/// the columns it needs or with fewer than [`MIN_ROWS`] usable rows.
pub fn estimate(log: &DriveLog, p: &DrivelineParams, ratios: &[f64]) -> SlipEstimate {
    let rigid = SlipEstimate::RIGID;
    let (Some(torque), Some(gear), Some(w), Some(v), Some(clutch)) = (
        log.signal("engine_torque"),
        log.signal("gear"),
        log.signal("engine_speed"),
        log.signal("vehicle_speed"),
        log.signal("clutch_position"),
    ) else {
        return rigid;
    };
    let weight = p.mass_kg * p.gravity_m_per_s2;
    let f_max = TYRE_FRICTION * DRIVEN_LOAD_SHARE_MIN * weight;
    let b_max = 1.0 / (SLIP_STIFFNESS_MIN * DRIVEN_LOAD_SHARE_MIN * weight);
    let mut pts: Vec<(f64, f64)> = (0..log.len())
        .filter_map(|i| {
            let (f_x, big_g) = traction(torque, gear, i, p, ratios)?;
            let held = (i == 0 || gear[i - 1] == gear[i]) && clutch[i] <= 0.02;
            (held
                && w[i].is_finite()
                && v[i] >= MIN_SPEED_MPS
                && f_x.abs() <= MAX_TRACTION_SHARE * f_max)
                .then(|| (f_x, w[i] / (big_g * v[i]) - 1.0))
        })
        // a relative slip no tyre can reach at that force (beyond the bound by more than
        // RADIUS_MARGIN) is a slipping clutch, a spinning wheel or a faulty channel
        .filter(|(f, k)| k.is_finite() && k.abs() <= b_max * f.abs() + RADIUS_MARGIN)
        .collect();
    let fit = |pts: &[(f64, f64)]| -> Option<(f64, f64)> {
        let n = pts.len() as f64;
        let (mf, mk) = pts
            .iter()
            .fold((0.0, 0.0), |(a, b), (f, k)| (a + f / n, b + k / n));
        let (sff, sfk) = pts.iter().fold((0.0, 0.0), |(a, b), (f, k)| {
            (a + (f - mf) * (f - mf), b + (f - mf) * (k - mk))
        });
        (sff > 0.0).then(|| {
            let b = sfk / sff;
            (mk - b * mf, b)
        })
    };
    for _ in 0..2 {
        if pts.len() < MIN_ROWS {
            return rigid;
        }
        let Some((a, b)) = fit(&pts) else {
            return rigid;
        };
        let mut res: Vec<f64> = pts.iter().map(|(f, k)| (k - a - b * f).abs()).collect();
        res.sort_by(f64::total_cmp);
        let cut = 3.0 * 1.4826 * res[res.len() / 2];
        pts.retain(|(f, k)| (k - a - b * f).abs() <= cut);
    }
    if pts.len() < MIN_ROWS {
        return rigid;
    }
    let Some((_, b)) = fit(&pts) else {
        return rigid;
    };
    let b = b.clamp(0.0, b_max);
    let n = pts.len() as f64;
    let intercept = pts.iter().map(|(f, k)| (k - b * f) / n).sum();
    SlipEstimate {
        slip_per_newton: b,
        normalised_stiffness: if b > 0.0 {
            1.0 / (b * DRIVEN_LOAD_SHARE * weight)
        } else {
            f64::INFINITY
        },
        rows: pts.len(),
        intercept,
    }
}

/// The slip `κ = b F_x` on every row of `log` for the slip per newton `slip_per_newton`, `F_x`
/// from the torque the engine produces (the recorded one through `p`'s
/// `engine_torque_lag_s`): 0 where the torque or gear is not finite or the clutch is not closed
/// (position above 0.02; the engine then does not follow the wheels).
pub fn slip_of_rows(
    log: LogView<'_>,
    p: &DrivelineParams,
    ratios: &[f64],
    slip_per_newton: f64,
) -> Vec<f64> {
    let (Some(torque), Some(gear)) = (log.signal("engine_torque"), log.signal("gear")) else {
        return vec![0.0; log.len()];
    };
    if slip_per_newton == 0.0 {
        return vec![0.0; log.len()];
    }
    // the torque the engine produces: the reported one through the engine's lag
    let produced;
    let torque = if p.engine_torque_lag_s > 0.0 {
        let t = log.log.seconds_from_start();
        produced = crate::signal::first_order_lag(&t, torque, p.engine_torque_lag_s);
        produced.as_slice()
    } else {
        torque
    };
    let clutch = log.signal("clutch_position");
    (0..log.len())
        .map(|i| {
            let closed = clutch.is_none_or(|c| c[i] <= 0.02);
            traction(torque, gear, i, p, ratios)
                .filter(|_| closed)
                .map_or(0.0, |(f_x, _)| (slip_per_newton * f_x).clamp(-0.2, 0.2))
        })
        .collect()
}

/// Per row, the variance of the engine speed that the driven tyres' longitudinal slip allows
/// about a model without it: a wheel-based speed from free-rolling wheels misses the slip
/// `κ = |F_x| / (C_κ F_z)` of the driven tyres, so the engine turns `ω_e κ` faster (drive) or
/// slower (engine braking) than a rigid model predicts. The located floor keeps this bound
/// although the longitudinal model carries the slip ([`estimate`]): the estimate's own error
/// and the slip's transients stay inside it. `F_x = M_e i_t i_f / r_w`
/// from the recorded torque and gear, `C_κ / F_z ≥` [`SLIP_STIFFNESS_MIN`] and
/// `F_z ≥` [`DRIVEN_LOAD_SHARE_MIN`]` · m g` bound `κ` from above; `κ` is taken as spread
/// uniformly up to that bound's magnitude about the model, variance `(ω_e κ_max)²/3`, as the
/// tolerances are. `None` without the channels it needs. NaN-free: rows without a finite
/// torque, gear or speed get 0.
pub fn tyre_slip_variance(log: &DriveLog, p: &DrivelineParams, ratios: &[f64]) -> Option<Vec<f64>> {
    let torque = log.signal("engine_torque")?;
    let gear = log.signal("gear")?;
    let w = log.signal("engine_speed")?;
    let f_z = DRIVEN_LOAD_SHARE_MIN * p.mass_kg * p.gravity_m_per_s2;
    Some(
        (0..log.len())
            .map(|i| {
                let Some((f_x, _)) = traction(torque, gear, i, p, ratios) else {
                    return 0.0;
                };
                if !w[i].is_finite() {
                    return 0.0;
                }
                let kappa = f_x.abs() / (SLIP_STIFFNESS_MIN * f_z);
                let d = w[i] * kappa;
                d * d / 3.0
            })
            .collect(),
    )
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The bundled 40 t truck's driveline and gear ratios.
    pub(crate) fn truck() -> (DrivelineParams, Vec<f64>) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures/vehicles/truck-40t.toml");
        let vf = crate::model::vehicle::VehicleFile::load(&path).unwrap();
        (vf.driveline.unwrap(), vf.gearbox.ratios)
    }

    /// A drive in gears 8–12 at 12–22 m/s under torques of −300…+1200 N·m whose engine turns
    /// at `G v (1 + a + b F_x)` plus a deterministic ±0.5 rad/s ripple, with a few rows of a
    /// slipping clutch (engine 30 rad/s fast) that the trimmed fit must leave out.
    fn drive(p: &DrivelineParams, ratios: &[f64], a: f64, b: f64) -> DriveLog {
        let n = 3000;
        let (mut tq, mut gear, mut w, mut v, mut clutch) = (vec![], vec![], vec![], vec![], vec![]);
        for i in 0..n {
            let g = 8 + (i / 600) % 5;
            let speed = 12.0 + 10.0 * (i as f64 / n as f64);
            let m_e = -300.0 + 1500.0 * ((i * 37) % 101) as f64 / 100.0;
            let big_g = ratios[g - 1] * p.final_drive_ratio / p.wheel_radius_m;
            let ripple = 0.5 * ((i * 7919) % 13) as f64 / 6.0 - 0.5;
            let slipping = i % 500 == 7;
            w.push(
                big_g * speed * (1.0 + a + b * m_e * big_g)
                    + ripple
                    + if slipping { 30.0 } else { 0.0 },
            );
            tq.push(m_e);
            gear.push(g as f64);
            v.push(speed);
            clutch.push(0.0);
        }
        DriveLog::from_columns(
            20_000_000,
            vec![
                ("engine_torque", "N.m", tq),
                ("gear", "1", gear),
                ("engine_speed", "rad/s", w),
                ("vehicle_speed", "m/s", v),
                ("clutch_position", "1", clutch),
            ],
        )
    }

    #[test]
    fn the_slip_stiffness_is_recovered_and_a_rigid_drive_has_none() {
        let (p, ratios) = truck();
        // C_κ/F_z = 10 on 29 % of the weight; a rolling radius 1 % off the file's
        let c = 10.0 * DRIVEN_LOAD_SHARE * p.mass_kg * p.gravity_m_per_s2;
        let e = estimate(&drive(&p, &ratios, 0.01, 1.0 / c), &p, &ratios);
        assert!((e.normalised_stiffness / 10.0 - 1.0).abs() < 0.05, "{e:?}");
        assert!(e.rows > 2500, "{e:?}");
        // the nominal model's kinematics: no slip
        let r = estimate(&drive(&p, &ratios, 0.0, 0.0), &p, &ratios);
        assert!(r.slip_per_newton < 0.02 / c, "{r:?}");
        // a slip beyond any truck tyre's is held at the bound C_κ/F_z,min = 8
        let soft = estimate(&drive(&p, &ratios, 0.0, 10.0 / c), &p, &ratios);
        let b_max =
            1.0 / (SLIP_STIFFNESS_MIN * DRIVEN_LOAD_SHARE_MIN * p.mass_kg * p.gravity_m_per_s2);
        assert!(
            (soft.slip_per_newton - b_max).abs() < 1e-12 * b_max,
            "{soft:?}"
        );
        // the rows' slip follows the torque the engine produces (the recorded one through the
        // file's lag) and is 0 without one
        let log = drive(&p, &ratios, 0.0, 0.0);
        let k = slip_of_rows(LogView::of(&log), &p, &ratios, 1.0 / c);
        let tq = crate::signal::first_order_lag(
            &log.seconds_from_start(),
            log.signal("engine_torque").unwrap(),
            p.engine_torque_lag_s,
        );
        let g = log.signal("gear").unwrap();
        let expect = tq[5] * ratios[g[5] as usize - 1] * p.final_drive_ratio / p.wheel_radius_m / c;
        assert!((k[5] - expect).abs() < 1e-15);
        assert!(slip_of_rows(LogView::of(&log), &p, &ratios, 0.0)
            .iter()
            .all(|x| *x == 0.0));
    }
}
