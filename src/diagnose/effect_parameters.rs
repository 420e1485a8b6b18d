//! One parameter per catalogue effect (docs/diagnosis/method.md, step 3): [`Theta`], whose
//! component per [`Effect`] is that effect's parameter, in the same SI quantity the catalogue
//! names (`c_w_a_f_m2`, `mass_kg`, `slope_offset_rad`, …; [`Effect::parameter`]), in
//! [`Effect::ALL`] order. At the nominal values ([`Theta::nominal`]) the extended models
//! ([`super::extended`]) are the nominal ones.

use crate::model::catalogue::Effect;
use crate::model::extended_vehicle::ExtendedVehicle;

/// One parameter per catalogue effect, in [`Effect::ALL`] order, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Theta(pub [f64; 16]);

impl Theta {
    /// The value of `e`'s parameter.
    pub fn get(&self, e: Effect) -> f64 {
        self.0[index(e)]
    }

    /// Sets `e`'s parameter.
    pub fn set(&mut self, e: Effect, v: f64) {
        self.0[index(e)] = v;
    }

    /// The nominal parameter values of `truth` (the vehicle file's, or "absent"), with the
    /// recording's slope resolution `slope_resolution` (tan α per step) as `slope_quantization`'s.
    /// Axle effects of a vehicle without axles get 0.
    pub fn nominal(truth: &ExtendedVehicle, slope_resolution: f64) -> Theta {
        let mut t = [0.0; 16];
        for (i, e) in Effect::ALL.iter().enumerate() {
            t[i] = truth.value_of(*e, slope_resolution).unwrap_or(0.0);
        }
        Theta(t)
    }

    /// Effects whose value differs from `nominal`.
    pub fn changed(&self, nominal: &Theta) -> Vec<Effect> {
        Effect::ALL
            .into_iter()
            .filter(|e| self.get(*e) != nominal.get(*e))
            .collect()
    }
}

/// Position of `e` in [`Effect::ALL`].
pub fn index(e: Effect) -> usize {
    Effect::ALL
        .iter()
        .position(|x| *x == e)
        .expect("every effect is in the catalogue")
}
