//! The tyres' warm-up: cold tyres roll harder, and their rolling resistance falls towards the
//! vehicle file's (warm) coefficients as the drive heats them.
//!
//! # Model
//! A tyre's rolling loss is hysteresis in its rubber, which falls as the rubber warms; the loss
//! itself heats the tyre, and the air cools it, so the temperature settles after some tens of
//! kilometres (Mars and Luchini, "An Analytical Model for the Transient Rolling Resistance
//! Behavior of Tires", Tire Science and Technology 27(3), 1999: a first-order heat balance;
//! Hyttinen, Ussner, Österlöf, Jerrelind and Drugge, International Journal of Automotive
//! Technology 23(6), 1651–1661, 2022, doi:10.1007/s12239-022-0143-6: a truck tyre's rolling
//! resistance measured from −30 to +25 °C in a climate wind tunnel). At a steady speed
//! the heat balance is a first-order lag in the distance rolled, so the models take the
//! rolling-resistance coefficients as
//!
//! `c_ri(s) = c_ri · φ(s)`, `φ(s) = 1 + β·exp(−s/L)`   (i = 1, 2)
//!
//! with `s` the distance rolled since the log's first row (m), `β` the cold tyres' extra
//! rolling resistance over warm ones (`tyre_cold_excess`, 1) and `L` the distance over which
//! the excess falls by e (`tyre_warm_up_distance_m`, m). `c_ri` are the vehicle file's
//! coefficients, which hold for warm tyres (tyre labels are measured warm, ISO 28580). The
//! extra force `(φ(s) − 1)·(c_r1 + c_r2|v|)·m·g` opposes the motion like the rolling
//! resistance it belongs to, and at a standstill adds to what holds the truck.
//!
//! What the model leaves out: the speed and load dependence of the heating (a city drive warms
//! its tyres less per kilometre than a motorway drive), the ambient temperature, and a drive
//! that starts on tyres still warm from the last one. `β = 0` (the default) switches the
//! warm-up off: every drive starts on warm tyres.

use super::driveline::DrivelineParams;

/// The tyres' warm-up of a vehicle file (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TyreWarmUp {
    /// Extra rolling resistance of cold tyres over warm ones, β (1, ≥ 0).
    pub cold_excess: f64,
    /// Distance over which the excess falls by e, L (m, > 0).
    pub distance_m: f64,
}

impl TyreWarmUp {
    /// The warm-up `p` states; `None` when its cold excess is 0 (or not a positive finite
    /// number, or its distance is not), which leaves the rolling resistance at the file's.
    pub fn of(p: &DrivelineParams) -> Option<Self> {
        let w = Self {
            cold_excess: p.tyre_cold_excess,
            distance_m: p.tyre_warm_up_distance_m,
        };
        (w.cold_excess.is_finite()
            && w.cold_excess > 0.0
            && w.distance_m.is_finite()
            && w.distance_m > 0.0)
            .then_some(w)
    }

    /// `φ(s) − 1 = β·exp(−s/L)` after `distance_m` rolled (negative distances count as 0).
    pub fn excess(&self, distance_m: f64) -> f64 {
        self.cold_excess * (-distance_m.max(0.0) / self.distance_m).exp()
    }

    /// The extra rolling-resistance force of the cold tyres on every row, N (≥ 0):
    /// `(φ(s_k) − 1)·(c_r1 + c_r2|v_k|)·m·g`, with `s_k` the distance the speeds `v`
    /// (m/s) at times `t` (s) roll from the first row ([`distance_rolled_m`]).
    pub fn extra_force_n(&self, p: &DrivelineParams, t: &[f64], v: &[f64]) -> Vec<f64> {
        let mg = p.mass_kg * p.gravity_m_per_s2;
        distance_rolled_m(t, v)
            .iter()
            .zip(v)
            .map(|(&s, &vk)| {
                let speed = if vk.is_finite() { vk.abs() } else { 0.0 };
                self.excess(s) * (p.c_r1 + p.c_r2_s_per_m * speed) * mg
            })
            .collect()
    }
}

/// Distance rolled from the first row at each row, m: the trapezoidal integral of `|v|` over
/// `t` (a non-finite speed counts as 0, as does a step back in time).
pub fn distance_rolled_m(t: &[f64], v: &[f64]) -> Vec<f64> {
    let speed = |x: f64| if x.is_finite() { x.abs() } else { 0.0 };
    let mut s = 0.0;
    let mut out = Vec::with_capacity(t.len().min(v.len()));
    for k in 0..t.len().min(v.len()) {
        if k > 0 {
            let dt = (t[k] - t[k - 1]).max(0.0);
            s += 0.5 * (speed(v[k]) + speed(v[k - 1])) * dt;
        }
        out.push(s);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truck(excess: f64, distance_m: f64) -> DrivelineParams {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/vehicles/truck-40t.toml"
        ))
        .unwrap();
        let v = crate::model::vehicle::VehicleFile::parse(&text, "truck-40t.toml").unwrap();
        let mut p = v.driveline("truck-40t.toml").unwrap().clone();
        p.tyre_cold_excess = excess;
        p.tyre_warm_up_distance_m = distance_m;
        p
    }

    #[test]
    fn no_excess_or_a_bad_distance_switches_the_warm_up_off() {
        assert_eq!(TyreWarmUp::of(&truck(0.0, 20_000.0)), None);
        assert_eq!(TyreWarmUp::of(&truck(0.15, 0.0)), None);
        assert_eq!(TyreWarmUp::of(&truck(f64::NAN, 20_000.0)), None);
        assert!(TyreWarmUp::of(&truck(0.15, 20_000.0)).is_some());
    }

    #[test]
    fn the_excess_falls_by_e_over_the_warm_up_distance() {
        let w = TyreWarmUp {
            cold_excess: 0.15,
            distance_m: 20_000.0,
        };
        assert_eq!(w.excess(0.0), 0.15);
        assert_eq!(w.excess(-5.0), 0.15);
        // exp(−1) at L, exp(−2) at 2L: the closed form to the last bits of a few operations
        assert!((w.excess(20_000.0) - 0.15 * (-1.0f64).exp()).abs() < 1e-15);
        assert!((w.excess(40_000.0) / w.excess(20_000.0) - (-1.0f64).exp()).abs() < 1e-12);
    }

    #[test]
    fn the_extra_force_at_constant_speed_is_the_closed_form() {
        // 20 m/s for 1000 s at 10 Hz: s = 20 t exactly (the trapezoid is exact on a constant)
        let p = truck(0.15, 20_000.0);
        let w = TyreWarmUp::of(&p).unwrap();
        let t: Vec<f64> = (0..=10_000).map(|k| k as f64 * 0.1).collect();
        let v = vec![20.0; t.len()];
        let f = w.extra_force_n(&p, &t, &v);
        let mg = p.mass_kg * p.gravity_m_per_s2;
        for (k, &fk) in f.iter().enumerate() {
            let s = 20.0 * t[k];
            let want = 0.15 * (-s / 20_000.0).exp() * (p.c_r1 + p.c_r2_s_per_m * 20.0) * mg;
            // relative 1e-9: the summed distance's rounding over 10⁴ steps
            assert!((fk - want).abs() <= 1e-9 * want, "row {k}: {fk} vs {want}");
        }
        // the start: 15 % of the warm rolling resistance
        assert!((f[0] / ((p.c_r1 + p.c_r2_s_per_m * 20.0) * mg) - 0.15).abs() < 1e-12);
    }

    #[test]
    fn distance_ignores_gaps_and_direction() {
        let t = [0.0, 1.0, 2.0, 3.0, 3.0];
        let v = [2.0, -2.0, f64::NAN, 4.0, 4.0];
        // |v| trapezoid: 2, then (2 + 0)/2 = 1, then (0 + 4)/2 = 2, then a zero step
        assert_eq!(distance_rolled_m(&t, &v), vec![0.0, 2.0, 3.0, 5.0, 5.0]);
    }
}
