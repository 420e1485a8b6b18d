//! The proof's plan: which drive hides which effect, on which road, with which driver.

use crate::model::catalogue::{Domain, Effect};
use crate::rng::Xoshiro256StarStar;
use crate::synth::can::Dropouts;
use crate::synth::driver::{DriverConfig, LiftOffs};
use serde::Serialize;

/// Settings of a proof run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ProofConfig {
    /// Number of drives.
    pub drives: usize,
    /// Seed of the plan (drive `i` uses `seed + i`).
    pub seed: u64,
    /// Drive length range, km.
    pub length_km: (f64, f64),
    /// CAN dropouts of every message.
    pub dropouts: Dropouts,
    /// Drives without an effect in each cycle of the plan.
    pub clean_per_cycle: usize,
    /// Drives with the out-of-catalogue effect in each cycle of the plan.
    pub out_of_catalogue_per_cycle: usize,
    /// How the drives' driving is chosen.
    pub driving: Driving,
    /// Plan indices to run (each drive exactly as in the whole plan); empty: all `drives`.
    /// An index at or past `drives` matches no case and runs nothing (`fleetdyn prove --cases`
    /// rejects it with exit 2).
    pub only: Vec<usize>,
    /// Where the drives' truth comes from.
    pub truth: TruthSource,
    /// Wind on the independent truth's drives (true, the proof) or calm (false: a study of
    /// what the wind costs the diagnosis, not the proof). The model truth has no wind.
    pub wind: bool,
    /// The independent truth's tyres start warm (true: a study of what their warm-up costs the
    /// diagnosis, not the proof) or cold (false, the proof).
    pub warm_tyres: bool,
}

impl Default for ProofConfig {
    /// [`ProofConfig::independent`].
    fn default() -> Self {
        Self::independent()
    }
}

impl ProofConfig {
    /// Checks the plan: at least one drive, drive lengths finite with 0.5 km ≤ min ≤ max, and
    /// every index of `only` inside the plan.
    pub fn validate(&self) -> Result<(), crate::settings::InvalidSetting> {
        use crate::settings::require;
        let (lo, hi) = self.length_km;
        require(
            self.drives >= 1,
            "drives",
            self.drives,
            "must be at least 1",
        )?;
        require(
            lo.is_finite() && lo >= 0.5,
            "min_km",
            lo,
            "must be finite and at least 0.5",
        )?;
        require(
            hi.is_finite() && hi >= lo,
            "max_km",
            hi,
            "must be finite and at least min_km",
        )?;
        require(
            self.wind || self.truth == TruthSource::Independent,
            "calm",
            true,
            "applies to the independent truth only (the model truth has no wind)",
        )?;
        require(
            !self.warm_tyres || self.truth == TruthSource::Independent,
            "warm_tyres",
            true,
            "applies to the independent truth only (the model truth has no tyre temperature)",
        )?;
        match self.only.iter().find(|&&c| c >= self.drives) {
            Some(c) => Err(crate::settings::InvalidSetting::new(
                "cases",
                c,
                "is not an index of the plan (0 to drives - 1)",
            )),
            None => Ok(()),
        }
    }

    /// The proof on the independent truth ([`crate::truth`]): 66 drives in cycles of the ten
    /// longitudinal catalogue effects, four clean drives and three out-of-catalogue ones (one
    /// of each kind in turn), so 16 of 66 drives (24 %) hide nothing; seed 1, 3–6 km, dropouts
    /// starting with probability 0.001 per message, 0.3 s long on average.
    pub fn independent() -> Self {
        Self {
            drives: 66,
            seed: 1,
            length_km: (3.0, 6.0),
            dropouts: Dropouts {
                start_probability: 0.001,
                mean_length_s: 0.3,
            },
            clean_per_cycle: 4,
            out_of_catalogue_per_cycle: 3,
            driving: Driving::Drawn,
            only: Vec::new(),
            truth: TruthSource::Independent,
            wind: true,
            warm_tyres: false,
        }
    }

    /// The inversion check on the diagnosis's own extended model ([`crate::synth::effects`]):
    /// 66 drives, three cycles of all sixteen effects, four clean drives and two with the
    /// out-of-catalogue stretch of extra rolling resistance (48 + 12 + 6), otherwise as
    /// [`ProofConfig::independent`].
    pub fn model() -> Self {
        Self {
            out_of_catalogue_per_cycle: 2,
            truth: TruthSource::Model,
            ..Self::independent()
        }
    }

    /// The catalogue effects the plan cycles through: all sixteen on the model truth, the ten
    /// longitudinal ones on the independent truth (it simulates no axle loads).
    pub fn effects(&self) -> Vec<Effect> {
        match self.truth {
            TruthSource::Model => Effect::ALL.to_vec(),
            TruthSource::Independent => Effect::ALL
                .into_iter()
                .filter(|e| e.domain() == Domain::Longitudinal)
                .collect(),
        }
    }
}

/// Where a proof's drives come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TruthSource {
    /// The independent truth plant ([`crate::truth`]): its own driveline, tyres, clutch,
    /// engine, driver and gearbox, with the truck's parameters drawn around the vehicle file
    /// within tolerances on every drive. The proof.
    Independent,
    /// The diagnosis's own extended model ([`crate::synth::effects`]): an inversion check.
    Model,
}

impl TruthSource {
    /// The `--truth` value.
    pub fn label(self) -> &'static str {
        match self {
            TruthSource::Independent => "independent",
            TruthSource::Model => "model",
        }
    }
}

/// An effect outside the catalogue.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outside {
    /// Model truth: extra rolling resistance on one stretch of road.
    LocalRollingResistance,
    /// Independent truth: a wet or broken surface (extra rolling resistance) on one stretch.
    WetSurface,
    /// Independent truth: the wheel-speed channel stuck on one stretch, then jumping back.
    StuckSpeedSensor,
    /// Independent truth: a retarder the logs do not report, dragging on one stretch.
    HiddenRetarder,
}

impl Outside {
    /// The kinds the independent truth conceals, in the plan's turn.
    pub const INDEPENDENT: [Outside; 3] = [
        Outside::WetSurface,
        Outside::StuckSpeedSensor,
        Outside::HiddenRetarder,
    ];

    /// Identifier in answers and case tables.
    pub fn id(self) -> &'static str {
        match self {
            Outside::LocalRollingResistance => "local_rolling_resistance",
            Outside::WetSurface => "wet_surface",
            Outside::StuckSpeedSensor => "stuck_speed_sensor",
            Outside::HiddenRetarder => "hidden_retarder",
        }
    }
}

/// How a proof's drives are driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Driving {
    /// One driver for every drive: the generator's default [`DriverConfig`] (0.8 m/s² up,
    /// 1.2 m/s² down, k_v = 0.5 1/s, ±5 % tips, 8 s at a stop, no lift-offs) — the proofs of
    /// the README's tables dated before the drawn driving (`fleetdyn prove --driving fixed`).
    Fixed,
    /// A driver drawn per case from its drive seed ([`drawn_driver`]).
    Drawn,
}

impl Driving {
    /// The `--driving` value.
    pub fn label(self) -> &'static str {
        match self {
            Driving::Fixed => "fixed",
            Driving::Drawn => "drawn",
        }
    }
}

/// PRNG stream of the drawn driving (xored into the drive seed).
const DRIVING_STREAM: u64 = 0x6472_6976_696E_6721;

/// The driver of a proof drive with seed `seed` under [`Driving::Drawn`]: the generator's
/// default driver with, drawn uniformly from the drive seed's own stream,
/// - comfortable acceleration 0.5–1.2 m/s² (a loaded truck's gentle start to a brisk one;
///   at 1.2 m/s² the 18.7 t truck of the axle-load thesis reaches cruise in its top gear at
///   full torque on a drive of `fleetdyn prove --seed 1`) and deceleration 0.9–1.5 m/s²;
/// - speed-error gain 0.3–0.8 1/s;
/// - tip amplitude ±3 % to ±20 % of the torque demand;
/// - lift-offs ([`LiftOffs`]) every 20–120 s on average (each interval 0.5–1.5 times the
///   drive's mean), 1–4 s long, above 5 m/s;
/// - 5–20 s standing at each stop.
///
/// Only the driver changes: roads, stops, effects and their magnitudes, the sensors and their
/// noise draw from their own streams and are the same under either [`Driving`].
pub fn drawn_driver(seed: u64) -> DriverConfig {
    let mut rng = Xoshiro256StarStar::seed_from_u64(seed ^ DRIVING_STREAM);
    let mean_lift_s = rng.uniform(20.0, 120.0);
    DriverConfig {
        accel_mps2: rng.uniform(0.5, 1.2),
        decel_mps2: rng.uniform(0.9, 1.5),
        speed_gain_per_s: rng.uniform(0.3, 0.8),
        tip_fraction: rng.uniform(0.03, 0.2),
        stop_dwell_s: rng.uniform(5.0, 20.0),
        lift_offs: Some(LiftOffs {
            interval_s: (0.5 * mean_lift_s, 1.5 * mean_lift_s),
            duration_s: (1.0, 4.0),
            min_speed_mps: 5.0,
        }),
        ..DriverConfig::default()
    }
}

/// What a proof drive hides.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Hidden {
    /// Nothing.
    Nothing,
    /// A catalogue effect.
    Effect(Effect),
    /// An effect outside the catalogue, on one stretch of the road.
    OutOfCatalogue(Outside),
}

impl Hidden {
    /// Label in the confusion table.
    pub fn label(&self) -> &'static str {
        match self {
            Hidden::Nothing => "none",
            Hidden::Effect(e) => e.id(),
            Hidden::OutOfCatalogue(_) => "out_of_catalogue",
        }
    }
}

/// One planned drive.
#[derive(Debug, Clone, PartialEq)]
pub struct ProofCase {
    /// Index in the plan.
    pub index: usize,
    /// Drive seed.
    pub seed: u64,
    /// Road rule set.
    pub rules: &'static str,
    /// Road length, km (whole hundreds of metres).
    pub length_km: f64,
    /// What it hides.
    pub hidden: Hidden,
}

/// The deterministic plan of a proof (see the module documentation).
pub fn plan(cfg: &ProofConfig) -> Vec<ProofCase> {
    let mut rng = Xoshiro256StarStar::seed_from_u64(cfg.seed ^ 0x9E00_F00D);
    let effects = cfg.effects();
    let mut outside_turn = 0;
    (0..cfg.drives)
        .map(|i| {
            let cycle = effects.len() + cfg.clean_per_cycle + cfg.out_of_catalogue_per_cycle;
            let slot = i % cycle.max(1);
            let hidden = match effects.get(slot) {
                Some(e) => Hidden::Effect(*e),
                None if slot < effects.len() + cfg.clean_per_cycle => Hidden::Nothing,
                None => Hidden::OutOfCatalogue(match cfg.truth {
                    TruthSource::Model => Outside::LocalRollingResistance,
                    TruthSource::Independent => {
                        outside_turn += 1;
                        Outside::INDEPENDENT[(outside_turn - 1) % Outside::INDEPENDENT.len()]
                    }
                }),
            };
            let r = rng.next_u64() % 10;
            let rules = match r {
                0..=2 => "highway-se",
                3..=5 => "freeway-us",
                6..=7 => "city-se",
                _ => "urban-us",
            };
            let km = rng.uniform(cfg.length_km.0, cfg.length_km.1);
            ProofCase {
                index: i,
                seed: cfg.seed + i as u64,
                rules,
                length_km: (km * 10.0).round() / 10.0,
                hidden,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proof::drive_config;

    #[test]
    fn drawn_drivers_are_the_seeds_own_and_within_their_ranges() {
        let drivers: Vec<DriverConfig> = (1..200).map(drawn_driver).collect();
        assert_eq!(drivers[0], drawn_driver(1));
        for d in &drivers {
            assert!((0.5..=1.2).contains(&d.accel_mps2));
            assert!((0.9..=1.5).contains(&d.decel_mps2));
            assert!((0.3..=0.8).contains(&d.speed_gain_per_s));
            assert!((0.03..=0.2).contains(&d.tip_fraction));
            assert!((5.0..=20.0).contains(&d.stop_dwell_s));
            let l = d.lift_offs.unwrap();
            assert!(l.interval_s.0 >= 10.0 && l.interval_s.1 <= 180.0);
            assert_eq!(l.interval_s.1, 3.0 * l.interval_s.0);
            // everything else is the generator's default driver
            assert_eq!(d.stop_every_m, DriverConfig::default().stop_every_m);
            assert_eq!(d.retarder, DriverConfig::default().retarder);
        }
        // the drives differ: brisk and gentle, nervous and steady feet
        let (lo, hi) = drivers.iter().fold((f64::MAX, 0.0_f64), |(lo, hi), d| {
            (lo.min(d.accel_mps2), hi.max(d.accel_mps2))
        });
        assert!(lo < 0.6 && hi > 1.1, "{lo}…{hi}");
        // the fixed driving is the default driver, whatever the seed
        let case = plan(&ProofConfig::default())[5].clone();
        let fixed = ProofConfig {
            driving: Driving::Fixed,
            ..ProofConfig::default()
        };
        assert_eq!(drive_config(&case, &fixed).driver.accel_mps2, 0.8);
        assert_eq!(drive_config(&case, &fixed).driver.lift_offs, None);
        assert_eq!(
            drive_config(&case, &ProofConfig::default())
                .driver
                .stop_every_m,
            drive_config(&case, &fixed).driver.stop_every_m
        );
    }

    #[test]
    fn the_study_flags_apply_to_the_independent_truth_only_and_leave_the_plan_alone() {
        let study = ProofConfig {
            wind: false,
            warm_tyres: true,
            ..ProofConfig::independent()
        };
        assert!(study.validate().is_ok());
        // the same drives hide the same effects: only the plant's physics differs
        assert_eq!(plan(&study), plan(&ProofConfig::independent()));
        for (name, cfg) in [
            (
                "calm",
                ProofConfig {
                    wind: false,
                    ..ProofConfig::model()
                },
            ),
            (
                "warm_tyres",
                ProofConfig {
                    warm_tyres: true,
                    ..ProofConfig::model()
                },
            ),
        ] {
            let e = cfg.validate().unwrap_err().to_string();
            assert!(
                e.contains(name) && e.contains("independent truth only"),
                "{e}"
            );
        }
    }

    #[test]
    fn plan_cycles_the_catalogue_and_is_deterministic() {
        let cfg = ProofConfig::model();
        let p = plan(&cfg);
        assert_eq!(p, plan(&cfg));
        assert_eq!(p.len(), 66);
        for e in Effect::ALL {
            assert_eq!(
                p.iter().filter(|c| c.hidden == Hidden::Effect(e)).count(),
                3
            );
        }
        assert_eq!(p.iter().filter(|c| c.hidden == Hidden::Nothing).count(), 12);
        assert_eq!(
            p.iter()
                .filter(|c| matches!(c.hidden, Hidden::OutOfCatalogue(_)))
                .count(),
            6
        );
        assert!(p.iter().all(|c| c.length_km >= 3.0 && c.length_km <= 6.0));
    }

    #[test]
    fn the_independent_plan_cycles_the_longitudinal_effects_with_a_fifth_of_clean_drives() {
        let cfg = ProofConfig::default();
        assert_eq!(cfg.truth, TruthSource::Independent);
        let p = plan(&cfg);
        assert_eq!(p, plan(&cfg));
        let longitudinal: Vec<Effect> = Effect::ALL
            .into_iter()
            .filter(|e| e.domain() == Domain::Longitudinal)
            .collect();
        assert_eq!(longitudinal.len(), 10);
        for e in Effect::ALL {
            let n = p.iter().filter(|c| c.hidden == Hidden::Effect(e)).count();
            // 66 = 3 cycles of 17 + 15: each longitudinal effect 4 times, no axle effect
            assert_eq!(
                n,
                if longitudinal.contains(&e) { 4 } else { 0 },
                "{}",
                e.id()
            );
        }
        let clean = p.iter().filter(|c| c.hidden == Hidden::Nothing).count();
        assert_eq!(clean, 16);
        assert!(clean as f64 >= 0.2 * p.len() as f64);
        for kind in Outside::INDEPENDENT {
            let n = p
                .iter()
                .filter(|c| c.hidden == Hidden::OutOfCatalogue(kind))
                .count();
            assert!(n >= 3, "{}: {n}", kind.id());
        }
        // the model plan's roads, lengths and seeds are the same drive for drive
        let m = plan(&ProofConfig::model());
        for (a, b) in p.iter().zip(&m) {
            assert_eq!(
                (a.seed, a.rules, a.length_km),
                (b.seed, b.rules, b.length_km)
            );
        }
    }
}
