//! Concealed effects in synthetic drives: every catalogue effect is injected into the truth of the
//! same 2 km city drive (seed 3) with a set magnitude and compared with the drive without it. Each
//! test checks the effect's physics in what it changed — the sensors' signals, the truth
//! trajectories or the energy balance — and that nothing leaks: the vehicle file written is the
//! nominal one, the drive's files do not name the effect, and the answer file alone holds it.

use crate::common::fixture;
use fleetdyn::synth::drive::{synth_drive, DriveConfig, HiddenEffect, SynthDrive};
use fleetdyn::synth::effects::{Effect, EffectChoice};
use std::path::Path;

const VEHICLE: &str = "fixtures/vehicles/seed002-6x2-diesel.toml";
const SEED: u64 = 3;

fn drive(dir: &Path, choice: Option<EffectChoice>) -> SynthDrive {
    let hidden = choice.map(|choice| HiddenEffect {
        choice,
        answer_path: dir.join("answer.json"),
    });
    synth_drive(
        &fixture(VEHICLE),
        "city-se",
        2.0,
        SEED,
        &dir.join("drive"),
        &DriveConfig::default(),
        hidden.as_ref(),
    )
    .unwrap()
}

fn with(dir: &Path, e: Effect, value: f64) -> SynthDrive {
    drive(dir, Some(EffectChoice::Given(e, Some(value))))
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn corr(a: &[f64], b: &[f64]) -> f64 {
    let (ma, mb) = (mean(a), mean(b));
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// Centred moving average over `w` samples (shorter at the ends).
fn smooth(v: &[f64], w: usize) -> Vec<f64> {
    (0..v.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(w / 2), (i + w / 2 + 1).min(v.len()));
            mean(&v[a..b])
        })
        .collect()
}

/// Engine work minus service-brake and retarder work over the drive,
/// ∫ (M_e ω_e − (F_b + T_aux/r_w) v) dt (truth, J): what the driver spends against the
/// resistances, up to the driveline's losses.
fn net_work(d: &SynthDrive) -> f64 {
    let (t, r) = (&d.drive.t_s, &d.drive);
    let r_w = d.truth.vehicle.driveline.wheel_radius_m;
    let aux = |i: usize| r.aux_brake_wheel_nm.get(i).copied().unwrap_or(0.0) / r_w;
    (1..t.len())
        .map(|i| {
            (r.engine_torque_nm[i] * r.engine_speed_rad_s[i]
                - (r.brake_n[i] + aux(i)) * r.speed_mps[i])
                * (t[i] - t[i - 1])
        })
        .sum()
}

/// (log signal of `a`, log signal of `b`) on the rows where both are finite. Same seed and bus:
/// the logs share their time stamps as long as the drives last equally long.
fn paired(a: &SynthDrive, b: &SynthDrive, col: &str) -> (Vec<f64>, Vec<f64>) {
    let (sa, sb) = (a.log.signal(col).unwrap(), b.log.signal(col).unwrap());
    let n = a.log.len().min(b.log.len());
    assert_eq!(a.log.timestamp_ns[..n], b.log.timestamp_ns[..n]);
    (0..n)
        .filter(|&i| sa[i].is_finite() && sb[i].is_finite())
        .map(|i| (sa[i], sb[i]))
        .unzip()
}

#[test]
fn a_hidden_effect_never_leaks_into_the_drive_and_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, none, a1, a2) = (
        dir.path().join("plain"),
        dir.path().join("none"),
        dir.path().join("a1"),
        dir.path().join("a2"),
    );
    let rp = drive(&plain, None);
    let rn = drive(&none, Some(EffectChoice::None));
    let r1 = drive(&a1, Some(EffectChoice::Given(Effect::AeroDrag, None)));
    drive(&a2, Some(EffectChoice::Given(Effect::AeroDrag, None)));
    let read = |p: &Path| std::fs::read(p).unwrap();
    // "none" is the plain drive, byte for byte (the Parquet metadata names its own source
    // path, so the logs are compared as tables), plus an answer saying so
    assert!(read(&plain.join("drive/drive.mcap")) == read(&none.join("drive/drive.mcap")));
    assert!(rp.log.timestamp_ns == rn.log.timestamp_ns);
    for c in [
        "vehicle_speed",
        "engine_speed",
        "engine_torque",
        "road_slope",
    ] {
        let (a, b) = (rp.log.signal(c).unwrap(), rn.log.signal(c).unwrap());
        assert!(
            a.iter()
                .zip(b.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits()),
            "{c}"
        );
    }
    let answer: serde_json::Value =
        serde_json::from_slice(&read(&none.join("answer.json"))).unwrap();
    assert!(answer["effect"].is_null());
    assert!(!plain.join("answer.json").exists());
    // same seed and effect: same drawn magnitude, same bytes
    for f in ["drive/drive.mcap", "answer.json"] {
        assert!(read(&a1.join(f)) == read(&a2.join(f)), "{f} differs");
    }
    let answer: serde_json::Value = serde_json::from_slice(&read(&a1.join("answer.json"))).unwrap();
    let inj = r1.injection.unwrap();
    assert_eq!(answer["effect"]["id"], "aero_drag");
    assert_eq!(answer["effect"]["parameter"], "c_w_a_f_m2");
    assert_eq!(answer["effect"]["truth"].as_f64().unwrap(), inj.truth);
    let rel = (inj.truth / inj.nominal - 1.0).abs();
    assert!((0.15..=0.40).contains(&rel), "drawn change {rel}");
    // the drive differs from the nominal one, yet names nothing: the vehicle file is the
    // nominal one and neither log file contains the effect's id or parameter
    assert!(read(&a1.join("drive/drive.mcap")) != read(&none.join("drive/drive.mcap")));
    assert_eq!(
        read(&a1.join("drive/vehicle.toml")),
        read(&fixture(VEHICLE))
    );
    for f in ["drive/drive.mcap", "drive/drive.parquet"] {
        let bytes = read(&a1.join(f));
        for needle in ["aero_drag", "c_w_a_f", "answer", "effect"] {
            assert!(
                !bytes.windows(needle.len()).any(|w| w == needle.as_bytes()),
                "{f} contains `{needle}`"
            );
        }
    }
}

#[test]
fn random_choice_covers_the_catalogue_and_none_deterministically() {
    use fleetdyn::synth::effects::{resolve, TruthModel};
    let vf = fleetdyn::model::vehicle::VehicleFile::load(&fixture(VEHICLE)).unwrap();
    let nominal = TruthModel::nominal(vf.driveline.as_ref().unwrap(), vf.axles.as_ref());
    let mut seen = std::collections::BTreeSet::new();
    let mut nones = 0;
    for seed in 0..400 {
        let (inj, _) = resolve(EffectChoice::Random, &nominal, 0.01, seed).unwrap();
        let (again, _) = resolve(EffectChoice::Random, &nominal, 0.01, seed).unwrap();
        assert_eq!(inj, again);
        match inj {
            Some(i) => {
                seen.insert(i.effect);
            }
            None => nones += 1,
        }
    }
    // 17 equally likely outcomes in 400 draws: each expected 23.5 times; missing one has
    // probability < 17·(16/17)^400 ≈ 5e-10
    assert_eq!(seen.len(), Effect::ALL.len());
    assert!(nones > 0);
}

#[test]
fn drag_and_rolling_resistance_cost_the_engine_their_extra_work() {
    let dir = tempfile::tempdir().unwrap();
    let none = drive(&dir.path().join("none"), None);
    let p = none.truth.vehicle.driveline.clone();
    let aero = with(
        &dir.path().join("aero"),
        Effect::AeroDrag,
        1.4 * p.c_w_a_f_m2,
    );
    let roll = with(
        &dir.path().join("roll"),
        Effect::RollingResistance,
        1.5 * p.c_r1,
    );
    assert!((roll.truth.vehicle.driveline.c_r2_s_per_m / p.c_r2_s_per_m - 1.5).abs() < 1e-12);
    // the extra resistance's work along the effect drive's own trajectory
    let extra = |d: &SynthDrive, f: &dyn Fn(f64, f64) -> f64| -> f64 {
        let (t, v, s) = (&d.drive.t_s, &d.drive.speed_mps, &d.drive.slope);
        (1..t.len())
            .map(|i| f(v[i], s[i]) * v[i] * (t[i] - t[i - 1]))
            .sum()
    };
    let g = p.gravity_m_per_s2;
    let d_aero = extra(&aero, &|v, _| {
        0.4 * 0.5 * p.rho_air_kg_per_m3 * p.c_w_a_f_m2 * v * v
    });
    let d_roll = extra(&roll, &|v, s| {
        0.5 * p.mass_kg * g * s.atan().cos() * (p.c_r1 + p.c_r2_s_per_m * v)
    });
    for (name, d, expected) in [("aero", &aero, d_aero), ("roll", &roll, d_roll)] {
        let got = net_work(d) - net_work(&none);
        eprintln!(
            "{name}: engine − brake work +{:.0} kJ, extra resistance work {:.0} kJ",
            got / 1e3,
            expected / 1e3
        );
        // the driver pays the extra work with more engine work and less braking; what else
        // differs between the drives — the driveline's viscous losses along slightly different
        // speeds — is small (measured: within 1.3 %): within ±5 % of it
        assert!(
            got > 0.95 * expected && got < 1.05 * expected,
            "{name}: engine − brake +{got} J for {expected} J"
        );
    }
}

#[test]
fn payload_loads_every_axle_and_the_truth_weighs_what_the_answer_says() {
    let dir = tempfile::tempdir().unwrap();
    let none = drive(&dir.path().join("none"), None);
    let m0 = none.truth.vehicle.driveline.mass_kg;
    let heavy = with(&dir.path().join("m"), Effect::VehicleMass, 1.2 * m0);
    let a = heavy.truth.vehicle.axles.as_ref().unwrap();
    assert!((a.mass_kg() - 1.2 * m0).abs() < 1e-6 * m0);
    let st = a.static_state();
    let g = a.gravity_m_per_s2;
    assert!((st.normal_n.iter().sum::<f64>() - 1.2 * m0 * g).abs() < 1e-6 * m0 * g);
    // at rest before the start: every bellow pressure higher (payload at the CG)
    for i in 0..3 {
        let (p0, p1) = (
            none.axles.as_ref().unwrap().pressure_pa[i][10],
            heavy.axles.as_ref().unwrap().pressure_pa[i][10],
        );
        assert!(p1 > p0 * 1.05, "axle {i}: {p0} -> {p1} Pa");
    }
}

#[test]
fn sensor_faults_change_only_the_sensor_by_their_magnitude() {
    let dir = tempfile::tempdir().unwrap();
    let none = drive(&dir.path().join("none"), None);
    // grade offset: the slope sensor reads tan(α + δ); same noise, same quantisation, so the
    // mean difference is tan-shift δ within a quantisation step over √N
    let off = with(&dir.path().join("g"), Effect::GradeOffset, 0.015);
    assert_eq!(off.drive, none.drive, "the plant is untouched");
    let (a, b) = paired(&off, &none, "road_slope");
    let d = mean(&a) - mean(&b);
    assert!((d - 0.015).abs() < 0.002, "mean slope shift {d}");
    // torque offset: +100 N·m reported, in whole percent of 2600 N·m steps
    let tq = with(&dir.path().join("t"), Effect::EngineTorqueOffset, 100.0);
    let (a, b) = paired(&tq, &none, "engine_torque");
    let d = mean(&a) - mean(&b);
    assert!((d - 100.0).abs() < 5.0, "mean torque shift {d} N·m");
    // quantisation: every slope value a multiple of the 4 % step
    let q = with(&dir.path().join("q"), Effect::SlopeQuantization, 0.04);
    let s = q.log.signal("road_slope").unwrap();
    let n = s.iter().filter(|x| x.is_finite()).count();
    assert!(n > 1000);
    for x in s.iter().filter(|x| x.is_finite()) {
        let k = x / 0.04;
        assert!((k - k.round()).abs() < 1e-6, "slope {x}");
    }
    assert!(s.iter().any(|x| x.is_finite() && *x != 0.0));
    // delay: the torque channel's cross-correlation with the nominal one peaks at 0.3 s
    let del = with(&dir.path().join("d"), Effect::SignalDelay, 0.3);
    let (a, b) = paired(&del, &none, "engine_torque");
    let rows_per_s = none.log.len() as f64 / none.log.duration_s();
    let best = (0..60)
        .map(|lag| {
            let c = corr(&a[lag..], &b[..b.len() - lag]);
            (lag, c)
        })
        .fold((0, f64::MIN), |m, x| if x.1 > m.1 { x } else { m });
    let lag_s = best.0 as f64 / rows_per_s;
    eprintln!(
        "delay: peak at {} rows = {lag_s:.3} s (r {:.4}), {rows_per_s:.1} rows/s",
        best.0, best.1
    );
    assert!((lag_s - 0.3).abs() < 0.03, "lag {lag_s} s");
}

#[test]
fn driveline_effects_show_in_shaft_torque_launches_and_engine_speed() {
    let dir = tempfile::tempdir().unwrap();
    let none = drive(&dir.path().join("none"), None);
    let p = none.truth.vehicle.driveline.clone();
    // backlash: the shaft carries no torque while crossing its play, which the nominal shaft
    // never does while moving
    let lash = with(&dir.path().join("b"), Effect::DrivelineBacklash, 0.04);
    let gap = |d: &SynthDrive| {
        d.drive
            .drive_torque_nm
            .iter()
            .zip(&d.drive.speed_mps)
            .filter(|(m, v)| **m == 0.0 && **v > 0.5)
            .count()
    };
    eprintln!(
        "samples in the lash gap while moving: {} (nominal {})",
        gap(&lash),
        gap(&none)
    );
    assert_eq!(gap(&none), 0);
    assert!(gap(&lash) > 10);
    // compliance: a 40 % softer shaft changes the engine speed the logger sees by more than its
    // noise (1 rpm σ, 0.125 rpm steps)
    let soft = with(
        &dir.path().join("c"),
        Effect::DrivelineCompliance,
        0.6 * p.k_d_nm_per_rad,
    );
    let (a, b) = paired(&soft, &none, "engine_speed");
    let rms = (a.iter().zip(&b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
    eprintln!(
        "engine speed RMS difference, softer shaft: {:.2} rpm",
        rms * 30.0 / std::f64::consts::PI
    );
    assert!(rms > 2.0 * std::f64::consts::PI / 30.0);
    // clutch slip: a clutch at 65 % of its capacity makes the launches slip longer
    let slip = with(
        &dir.path().join("s"),
        Effect::ClutchSlip,
        0.65 * p.clutch_max_torque_nm,
    );
    let total = |d: &SynthDrive| d.drive.launches.iter().map(|(a, b)| b - a).sum::<f64>();
    eprintln!(
        "launch slip time {:.2} s -> {:.2} s",
        total(&none),
        total(&slip)
    );
    assert_eq!(slip.drive.launches.len(), none.drive.launches.len());
    assert!(total(&slip) > total(&none) + 0.2);
}

#[test]
fn axle_effects_leave_the_driveline_alone_and_follow_their_fingerprint() {
    let dir = tempfile::tempdir().unwrap();
    let none = drive(&dir.path().join("none"), None);
    let a0 = none.truth.vehicle.axles.clone().unwrap();
    let run = |name: &str, e: Effect, v: f64| {
        let d = with(&dir.path().join(name), e, v);
        assert_eq!(d.drive, none.drive, "{name}: the driveline is untouched");
        d
    };
    let dp = |d: &SynthDrive, i: usize| -> Vec<f64> {
        d.axles.as_ref().unwrap().pressure_pa[i]
            .iter()
            .zip(&none.axles.as_ref().unwrap().pressure_pa[i])
            .map(|(a, b)| a - b)
            .collect()
    };
    let t = &none.drive.t_s;
    let accel: Vec<f64> = (0..t.len())
        .map(|i| {
            let (j0, j1) = (i.saturating_sub(5), (i + 5).min(t.len() - 1));
            (none.drive.speed_mps[j1] - none.drive.speed_mps[j0]) / (t[j1] - t[j0])
        })
        .collect();
    // torque reaction: the driven bellow's pressure change follows the driven-axle torque
    let tr = run("tr", Effect::BogieTorqueReaction, 0.5);
    let r_w = a0.wheel_radius_m;
    let t_axle: Vec<f64> = (0..t.len())
        .map(|i| {
            none.drive.drive_torque_nm[i]
                - none.drive.aux_brake_wheel_nm.get(i).copied().unwrap_or(0.0)
                - a0.service_brake_share_rear * none.drive.brake_n[i] * r_w
        })
        .collect();
    // the suspension answers a torque step with its pitch/bounce modes (1–2 Hz): compare the
    // 1 s moving averages
    let r = corr(&smooth(&dp(&tr, 1), 100), &smooth(&t_axle, 100));
    eprintln!("torque reaction: corr(Δp_rear, T_axle), 1 s averages = {r:.3}");
    assert!(r > 0.9, "{r}");
    // CG height: the load transfer change follows the d'Alembert and grade load a + g sin α
    // (1 s averages, as above)
    let h = run(
        "h",
        Effect::LoadTransferHeight,
        a0.chassis_cg_height_m + 0.3,
    );
    let g = a0.gravity_m_per_s2;
    let load: Vec<f64> = accel
        .iter()
        .zip(&none.drive.slope)
        .map(|(a, s)| a + g * s.atan().sin())
        .collect();
    let r = corr(&smooth(&dp(&h, 0), 100), &smooth(&load, 100)).abs();
    eprintln!("CG height: |corr(Δp_front, a + g sin α)|, 1 s averages = {r:.3}");
    assert!(r > 0.8, "{r}");
    // progressive bellows: in the effect drive the rear bellow's force follows the exponential
    // law B = B_0 + k_b (e^{2γc} − 1)/(2γ) (c = −(l_b/l_a)·travel at the axle: both are the
    // arm's rotation relative to the chassis at their levers), and its excess over the linear
    // law, the fingerprint, follows c²
    let gamma = 4.0;
    let nl = run("nl", Effect::AirSpringNonlinearity, gamma);
    let (_, la, lb, _, _) = a0.arm(fleetdyn::model::axle::Axle::Rear).unwrap();
    let area = a0.bellow_area(fleetdyn::model::axle::Axle::Rear);
    let (b0, k) = (
        a0.static_state().bellow_n[1],
        a0.bellow_stiffness_rear_n_per_m,
    );
    let c: Vec<f64> = nl.axles.as_ref().unwrap().travel_m[1]
        .iter()
        .map(|x| -lb / la * x)
        .collect();
    for (p, c) in nl.axles.as_ref().unwrap().pressure_pa[1].iter().zip(&c) {
        let law = b0 + k * (2.0 * gamma * c).exp_m1() / (2.0 * gamma);
        // rounding of travel and pressure only
        assert!(
            (p * area - law).abs() < 1e-6 * b0,
            "c {c}: {} vs {law} N",
            p * area
        );
    }
    let extra: Vec<f64> = nl.axles.as_ref().unwrap().pressure_pa[1]
        .iter()
        .zip(&c)
        .map(|(p, c)| p * area - b0 - k * c)
        .collect();
    let c2: Vec<f64> = c.iter().map(|x| x * x).collect();
    let r = corr(&extra, &c2);
    let c_max = c.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    eprintln!(
        "air spring: corr(B − B0 − k c, c²) = {r:.4}, |c| ≤ {:.1} mm",
        c_max * 1e3
    );
    assert!(r > 0.95, "{r}");
    // grade transfer: Δp follows sin α
    let gl = run("gl", Effect::GradeLoadTransfer, 0.8);
    let sin: Vec<f64> = none.drive.slope.iter().map(|s| s.atan().sin()).collect();
    let r = corr(&dp(&gl, 1), &sin).abs();
    eprintln!("grade transfer: |corr(Δp_rear, sin α)| = {r:.3}");
    assert!(r > 0.9, "{r}");
    // CG position: at rest the front unloads and the bogie loads (opposite signs)
    let cg = run("cg", Effect::CgPosition, 0.25);
    let (f, rr, tg) = (dp(&cg, 0)[10], dp(&cg, 1)[10], dp(&cg, 2)[10]);
    eprintln!("CG shift: static Δp front {f:.0}, rear {rr:.0}, tag {tg:.0} Pa");
    assert!(f < -1e3 && rr > 1e3 && tg > 1e3);
    // tyre stiffness: no static change, a dynamic one
    let ty = run("ty", Effect::TyreStiffness, 0.7);
    let d = dp(&ty, 1);
    // (the drive starts at rest on a grade: the steady start's deflections differ with the
    // tyres, by little)
    assert!(
        d[10].abs() < 0.01 * none.axles.as_ref().unwrap().pressure_pa[1][10],
        "static Δp {}",
        d[10]
    );
    assert!(d.iter().any(|x| x.abs() > 100.0));
}

#[test]
fn out_of_catalogue_resistance_stretch_costs_its_work_and_is_answered_apart() {
    use fleetdyn::synth::effects::EffectChoice;
    let dir = tempfile::tempdir().unwrap();
    let none = drive(&dir.path().join("none"), None);
    let st = drive(
        &dir.path().join("st"),
        Some(EffectChoice::LocalRollingResistance),
    );
    let stretch = st.truth.stretch.expect("a stretch was drawn");
    let answer: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("st/answer.json")).unwrap()).unwrap();
    assert!(answer["effect"].is_null());
    assert_eq!(
        answer["out_of_catalogue"]["kind"],
        "local_rolling_resistance"
    );
    assert_eq!(
        answer["out_of_catalogue"]["stretch"]["start_m"]
            .as_f64()
            .unwrap(),
        stretch.start_m
    );
    // the stretch lies where the rule says (20–60 % in, 15–30 % long, 1–2 × c_r1)
    let l = 2000.0;
    let c_r1 = none.truth.vehicle.driveline.c_r1;
    assert!(stretch.start_m >= 0.2 * l && stretch.start_m <= 0.6 * l);
    let len = stretch.end_m - stretch.start_m;
    assert!(len >= 0.15 * l - 1e-9 && len <= 0.30 * l + 1e-9);
    assert!(stretch.c_r_extra >= c_r1 && stretch.c_r_extra <= 2.0 * c_r1);
    // the vehicle file stays nominal; the engine pays the stretch's work (±5 %, as for drag)
    let p = &st.truth.vehicle.driveline;
    let (t, v, s, x) = (
        &st.drive.t_s,
        &st.drive.speed_mps,
        &st.drive.slope,
        &st.drive.distance_m,
    );
    let expected: f64 = (1..t.len())
        .map(|i| {
            stretch.force_n(x[i], p.mass_kg, p.gravity_m_per_s2, s[i]) * v[i] * (t[i] - t[i - 1])
        })
        .sum();
    let got = net_work(&st) - net_work(&none);
    eprintln!(
        "stretch {:.0}–{:.0} m, Δc_r {:.4}: engine − brake work +{:.0} kJ for {:.0} kJ",
        stretch.start_m,
        stretch.end_m,
        stretch.c_r_extra,
        got / 1e3,
        expected / 1e3
    );
    assert!(
        got > 0.95 * expected && got < 1.05 * expected,
        "{got} for {expected}"
    );
}
