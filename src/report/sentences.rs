//! The plain sentences of a diagnosis (docs/diagnosis/method.md, explain and locate): a
//! finding's sentence (what is wrong by how much, its fingerprint, and the held-out error of the
//! signal it improves most), the sentence of an estimate consistent with the vehicle file, and a
//! located residual's shape in words.
//!
//! Numbers are written with three significant figures ([`crate::number_fmt::sig3`]); parameters in the catalogue's
//! SI units (angles in degrees and grades in % where the text says so).

use crate::diagnose::explain::{ConsistentEstimate, Finding};
use crate::diagnose::location::Statement;
use crate::model::catalogue::{Domain, Effect};
use crate::number_fmt::sig3 as num;

fn signal_words(name: &str) -> &str {
    match name {
        "vehicle_speed" => "speed",
        "engine_speed" => "engine speed",
        "shuffle_frequency" => "shuffle frequency (after clutch engagements)",
        "reversal_relative_speed" => "engine-against-wheel speed at torque reversals",
        "bellow_pressure_front" => "front bellow pressure",
        "bellow_pressure_rear" => "rear bellow pressure",
        "bellow_pressure_tag" => "tag bellow pressure",
        other => other,
    }
}

/// The plain sentence of an estimate within the vehicle file's tolerance: "mass_kg = 40800 kg
/// (95 % CI 40500 to 41100 kg), within the vehicle file's 40000 kg ± 3 %".
pub fn consistent_sentence(c: &ConsistentEstimate) -> String {
    use crate::model::catalogue::Tolerance;
    let e = Effect::from_id(c.effect).expect("catalogue id");
    let (nominal, est, tol) = (c.nominal, &c.estimate, c.file_tolerance);
    let unit = if e.unit() == "1" {
        String::new()
    } else {
        format!(" {}", e.unit())
    };
    let width = |t: Tolerance| match t {
        Tolerance::Relative(r) => format!("± {} %", num(100.0 * r)),
        Tolerance::Absolute(a) => format!("± {}{unit}", num(a)),
        Tolerance::None => String::new(),
    };
    let band = match tol {
        Tolerance::None => format!("{}{unit}", num(nominal)),
        t => format!("{}{unit} {}", num(nominal), width(t)),
    };
    // the model's own allowance widens the band the estimate is judged against
    let mf = c.model_form;
    let side = |t: Tolerance, sign: char| match t {
        Tolerance::Relative(r) => Some(format!("{sign} {} %", num(100.0 * r))),
        Tolerance::Absolute(x) => Some(format!("{sign} {}{unit}", num(x))),
        Tolerance::None => None,
    };
    let model = match (side(mf.below, '−'), side(mf.above, '+')) {
        _ if c.measured_by.is_some() => String::new(),
        (Some(_), Some(_)) if mf.below == mf.above => {
            format!(" and the model's own {}", width(mf.above))
        }
        (Some(b), Some(a)) => format!(" and the model's own {b} / {a}"),
        (Some(b), None) => format!(" and the model's own {b} below"),
        (None, Some(a)) => format!(" and the model's own {a} above"),
        (None, None) => String::new(),
    };
    let how = match c.measured_by {
        Some("free engine") => ", measured on the free engine".to_string(),
        Some(source) => format!(", measured against the {source}"),
        None => String::new(),
    };
    format!(
        "{} = {}{unit} (95 % CI {} to {}{unit}{how}), within the vehicle file's {band}{model}: \
         consistent with the file, not named",
        e.parameter(),
        num(est.value),
        num(est.ci_low),
        num(est.ci_high)
    )
}

/// The plain sentence of a finding: what is wrong by how much, its fingerprint, and the
/// held-out RMSE of the signal it improves most.
pub fn finding_sentence(f: &Finding) -> String {
    use Effect::*;
    let e = Effect::from_id(f.effect).expect("catalogue id");
    let nominal = f.evidence.nominal;
    let est = &f.parameters[e.parameter()];
    let (met, ambiguous) = (&f.metrics, &f.ambiguous_with);
    let v = est.value;
    let unit = if e.unit() == "1" {
        String::new()
    } else {
        format!(" {}", e.unit())
    };
    let ci = format!(
        "{} = {}{unit} (95 % CI {} to {}{unit})",
        e.parameter(),
        num(v),
        num(est.ci_low),
        num(est.ci_high)
    );
    let pct = if nominal != 0.0 {
        100.0 * (v / nominal - 1.0)
    } else {
        0.0
    };
    let more = |hi: &'static str, lo: &'static str| if pct >= 0.0 { hi } else { lo };
    let head = match e {
        AeroDrag => format!(
            "aerodynamic drag is {:.0} % {} than the vehicle file says, {ci}: residual force grows with v²",
            pct.abs(),
            more("higher", "lower")
        ),
        RollingResistance => format!(
            "rolling resistance is {:.0} % {} than the vehicle file says, {ci}: residual force is constant plus ∝ v, with load",
            pct.abs(),
            more("higher", "lower")
        ),
        VehicleMass => format!(
            "the vehicle is {:.0} kg ({:.0} %) {} than the vehicle file says, {ci}: residual force ∝ a + g·sin α",
            (v - nominal).abs(),
            pct.abs(),
            more("heavier", "lighter")
        ),
        GradeOffset => format!(
            "the slope sensor reads {:.2}° too {} (mounting angle), {ci}: {}",
            v.abs().to_degrees(),
            if v >= 0.0 { "nose-up" } else { "nose-down" },
            match f.evidence.measured_by {
                Some(source) => format!(
                    "measured against the {source}: the height the slope readings integrate to \
                     departs from it by the angle times the distance travelled"
                ),
                None => "residual force ∝ m·g, constant along the road".to_string(),
            }
        ),
        SlopeQuantization => format!(
            "the slope sensor resolves only {:.2} % steps, coarser than the model assumes ({:.2} %), {ci}: fed the sensor's steps the model sees grade the road does not have (and shuffle the steps excite); the slope reconstructed within the sensor's cells, widened by its noise, fits better",
            100.0 * v,
            100.0 * nominal
        ),
        SignalDelay => format!(
            "the engine-torque channel lags the driveline by {:.2} s, {ci}: input–residual cross-correlation peaks at a non-zero lag",
            v
        ),
        DrivelineBacklash => format!(
            "the driveline has {:.1}° of lash, {ci}: mismatch concentrated at torque sign changes",
            v.to_degrees()
        ),
        DrivelineCompliance => format!(
            "the drive shaft is {:.0} % {} than the vehicle file says, {ci}: the shuffle rings {} after clutch engagements than the nominal driveline's mode",
            pct.abs(),
            more("stiffer", "softer"),
            more("faster", "slower")
        ),
        EngineTorqueOffset => format!(
            "the reported engine torque is {:.0} N·m {} the delivered torque, {ci}: {}",
            v.abs(),
            if v >= 0.0 { "above" } else { "below" },
            match f.evidence.measured_by {
                Some(_) => "measured on the free engine: declutched at a steady speed its net \
                            torque is nil, yet the channel reports one"
                    .to_string(),
                None => "residual force ∝ gear ratio, constant in torque".to_string(),
            }
        ),
        ClutchSlip => format!(
            "the clutch transmits at most {:.0} N·m, {:.0} % {} than the vehicle file says, {ci}: the engine speed runs away from the gearbox's where the clutch slips (engagements, full load)",
            v,
            pct.abs(),
            more("more", "less")
        ),
        BogieTorqueReaction => format!(
            "a fraction {:.2} of the driven axle's torque reacts through the trailing arms, {ci}: driven-axle pressure residual ∝ axle torque, mirrored in braking",
            v
        ),
        LoadTransferHeight => format!(
            "the centre of gravity is {:.2} m {} than the vehicle file says, {ci}: pressure residual ∝ longitudinal acceleration",
            (v - nominal).abs(),
            if v >= nominal { "higher" } else { "lower" }
        ),
        AirSpringNonlinearity => format!(
            "the air springs are progressive, {ci}: pressure residual ∝ travel², asymmetric"
        ),
        CgPosition => format!(
            "the static centre of gravity sits {:.2} m {} of where the vehicle file puts it, {ci}: constant pressure offset front vs rear and tag, opposite signs",
            v.abs(),
            if v >= 0.0 { "rearwards" } else { "forwards" }
        ),
        TyreStiffness => format!(
            "the tyres are {:.0} % {} than the vehicle file says, {ci}: axle-hop band phase and amplitude mismatch",
            pct.abs(),
            more("stiffer", "softer")
        ),
        GradeLoadTransfer => format!(
            "the gravity component on grades acts {:.2} m {} the centre of gravity, {ci}: pressure residual ∝ sin α",
            v.abs(),
            if v >= 0.0 { "above" } else { "below" }
        ),
    };
    // the signal of the effect's own model improved most (relative held-out RMSE)
    let own = |name: &str| (e.domain() == Domain::Axle) == name.starts_with("bellow_pressure");
    let best = met
        .iter()
        .filter(|(name, m)| own(name) && m.rmse.heldout_before > 0.0)
        .max_by(|a, b| {
            let ga = 1.0 - a.1.rmse.heldout_after / a.1.rmse.heldout_before;
            let gb = 1.0 - b.1.rmse.heldout_after / b.1.rmse.heldout_before;
            ga.total_cmp(&gb)
        });
    let mut s = head;
    if let Some((name, m)) = best {
        if m.unit == "1" {
            // a relative error (the shuffle frequency's ln f residual), in per cent
            s.push_str(&format!(
                "; held-out {} RMS error {:.1} % → {:.1} %",
                signal_words(name),
                100.0 * m.rmse.heldout_before,
                100.0 * m.rmse.heldout_after,
            ));
        } else {
            s.push_str(&format!(
                "; held-out {} RMSE {} → {} {}",
                signal_words(name),
                num(m.rmse.heldout_before),
                num(m.rmse.heldout_after),
                m.unit
            ));
        }
    }
    if !ambiguous.is_empty() {
        s.push_str(&format!(
            " (not isolable from {} with the recorded signals)",
            ambiguous.join(", ")
        ));
    }
    s
}

/// A located residual's shape in words, with the share of the energy it explains: "grows with
/// speed² (explains 64 % of the residual energy)"; indicators ("only while braking") speak of
/// the excess energy above the noise floor.
pub fn statement_text(s: &Statement) -> String {
    let words = match s.shape.as_str() {
        "constant" => "constant offset",
        "speed" => "grows with speed",
        "speed_squared" => "grows with speed²",
        "acceleration" => "proportional to acceleration",
        "grade" => "proportional to grade",
        "engine_torque" => "proportional to engine torque",
        "gear_ratio" => "proportional to the gear ratio",
        "torque_sign_change" => "only at torque sign changes",
        "clutch_actuated" => "only while the clutch is actuated",
        "braking" => "only while braking",
        "gear_shift" => "only at gear shifts",
        other => other,
    };
    let what = if s.coefficient.is_nan() {
        "of the excess residual energy"
    } else {
        "of the residual energy"
    };
    format!("{words} (explains {:.0} % {what})", 100.0 * s.share)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_one_sided_allowance_is_named_with_its_side() {
        use crate::diagnose::explanation::{ConsistentEstimate, ParameterEstimate};
        use crate::model::catalogue::Tolerance;
        let c = |effect: &'static str, value: f64, nominal: f64, unit: &'static str| {
            ConsistentEstimate {
                effect,
                estimate: ParameterEstimate {
                    value,
                    ci_low: 0.98 * value,
                    ci_high: 1.02 * value,
                    unit,
                },
                nominal,
                band_low: 0.0,
                band_high: 2.0 * nominal,
                band_from_file: false,
                round: 0,
                ambiguous_with: Vec::new(),
                file_tolerance: Tolerance::Relative(0.1),
                model_form: crate::model::catalogue::Effect::from_id(effect)
                    .unwrap()
                    .spec()
                    .model_form,
                measured_by: None,
            }
        };
        // the clutch's estimates on healthy trucks missed upwards only
        let s = consistent_sentence(&c("clutch_slip", 4000.0, 3500.0, "N.m"));
        assert!(
            s.contains(
                "within the vehicle file's 3500 N.m ± 10.0 % and the model's own + 7.40 % above:"
            ),
            "{s}"
        );
        // both sides measured
        let s = consistent_sentence(&c("vehicle_mass", 41_000.0, 40_000.0, "kg"));
        assert!(
            s.contains("and the model's own − 0.410 % / + 3.00 %:"),
            "{s}"
        );
        // a measured parameter says so and is judged against the file's own band
        let measured = ConsistentEstimate {
            file_tolerance: Tolerance::Absolute(0.002),
            model_form: crate::model::catalogue::ModelForm::NONE,
            measured_by: Some("altitude"),
            ..c("grade_offset", 0.0004, 0.0, "rad")
        };
        let s = consistent_sentence(&measured);
        assert!(
            s.ends_with(
                "measured against the altitude), within the vehicle file's 0 rad ± 0.00200 rad: \
                 consistent with the file, not named"
            ),
            "{s}"
        );
        // the torque channel's offset measured on the free engine
        let measured = ConsistentEstimate {
            file_tolerance: Tolerance::Absolute(25.0),
            model_form: crate::model::catalogue::ModelForm::NONE,
            measured_by: Some("free engine"),
            ..c("engine_torque_offset", 4.0, 0.0, "N.m")
        };
        let s = consistent_sentence(&measured);
        assert!(
            s.contains(", measured on the free engine), within the vehicle file's 0 N.m ± 25"),
            "{s}"
        );
        assert!(!s.contains("model's own"), "{s}");
    }

    #[test]
    fn a_torque_offset_finding_says_how_it_was_found() {
        use crate::diagnose::explanation::{Evidence, ParameterEstimate};
        use crate::diagnose::whiteness::Whiteness;
        use std::collections::BTreeMap;
        let finding = |value: f64, measured_by: Option<&'static str>| {
            let white = Whiteness {
                q_per_n: 0.0,
                nonwhite_power: 0.0,
            };
            let mut parameters = BTreeMap::new();
            parameters.insert(
                "engine_torque_offset_nm".to_string(),
                ParameterEstimate {
                    value,
                    ci_low: value - 1.5,
                    ci_high: value + 1.5,
                    unit: "N.m",
                },
            );
            Finding {
                effect: "engine_torque_offset",
                ambiguous_with: Vec::new(),
                parameters,
                fit: BTreeMap::new(),
                metrics: BTreeMap::new(),
                evidence: Evidence {
                    round: 0,
                    domain: Domain::Longitudinal,
                    nominal: 0.0,
                    start: 0.0,
                    models: Vec::new(),
                    heldout_gain: 0.0,
                    explained: 0.0,
                    whiteness_before: white,
                    whiteness_after: white,
                    n_eff: 0.0,
                    deviance_threshold: 0.0,
                    deviance_at_start: 0.0,
                    deviance_heldout_at_start: None,
                    ambiguity_correlation: BTreeMap::new(),
                    evaluations: 1,
                    measured_by,
                },
            }
        };
        // measured on the free engine: the sentence names the measurement, not a residual shape
        let s = finding_sentence(&finding(66.2, Some("free engine")));
        assert_eq!(
            s,
            "the reported engine torque is 66 N·m above the delivered torque, \
             engine_torque_offset_nm = 66.2 N.m (95 % CI 64.7 to 67.7 N.m): measured on the \
             free engine: declutched at a steady speed its net torque is nil, yet the channel \
             reports one"
        );
        // fitted from the driving signals: the residual's shape
        let s = finding_sentence(&finding(-143.1, None));
        assert!(
            s.starts_with("the reported engine torque is 143 N·m below the delivered torque"),
            "{s}"
        );
        assert!(
            s.ends_with(": residual force ∝ gear ratio, constant in torque"),
            "{s}"
        );
    }

    #[test]
    fn statements_read_as_words_with_their_share() {
        let st = |shape: &str, coefficient: f64| Statement {
            shape: shape.into(),
            share: 0.642,
            coefficient,
            p_value: 1e-6,
            best: true,
        };
        assert_eq!(
            statement_text(&st("speed_squared", 0.01)),
            "grows with speed² (explains 64 % of the residual energy)"
        );
        assert_eq!(
            statement_text(&st("braking", f64::NAN)),
            "only while braking (explains 64 % of the excess residual energy)"
        );
    }
}
