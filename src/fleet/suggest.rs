//! A suggested vehicle-file update from a vehicle's evidence ([`suggestion`]): the parameters
//! whose current estimate lies outside the file's tolerance, as TOML with the evidence in
//! comments, for a person to review — fleetdyn never edits a vehicle file itself.

use super::evidence::{sig, VehicleEvidence};
use crate::model::catalogue::Effect;

/// The vehicle-file section and key of an effect's parameter, for the effects the vehicle file
/// holds (the others are faults or sensor errors: offsets, delays, lash, slip of a worn clutch
/// is its capacity).
pub fn file_key(e: Effect) -> Option<(&'static str, &'static str)> {
    match e {
        Effect::AeroDrag => Some(("driveline", "c_w_a_f_m2")),
        Effect::RollingResistance => Some(("driveline", "c_r1")),
        Effect::DrivelineCompliance => Some(("driveline", "k_d_nm_per_rad")),
        Effect::ClutchSlip => Some(("driveline", "clutch_max_torque_nm")),
        Effect::LoadTransferHeight => Some(("axles", "chassis_cg_height_m")),
        _ => None,
    }
}

/// The suggested update of `v`'s vehicle file `file` (as the pipeline names it), `None` when
/// nothing lies outside its tolerance. Values with three significant digits.
pub fn suggestion(v: &VehicleEvidence, file: &str) -> Option<String> {
    let outside: Vec<_> = v.flagged().collect();
    if outside.is_empty() {
        return None;
    }
    let mut s = format!(
        "# Suggested update of {file} for vehicle {}, from its {} drives (fleetdyn {}).\n\
         # Review before use: each value is the pooled estimate of the drives since its last\n\
         # change, with its 95 % interval.\n",
        v.vehicle_id,
        v.drives.len(),
        env!("CARGO_PKG_VERSION")
    );
    let mut sections: Vec<&str> = Vec::new();
    for p in &outside {
        if let Some((section, _)) = file_key(p.effect) {
            if !sections.contains(&section) {
                sections.push(section);
            }
        }
    }
    for section in sections {
        s.push_str(&format!("\n[{section}]\n"));
        for p in outside
            .iter()
            .filter(|p| file_key(p.effect).is_some_and(|k| k.0 == section))
        {
            let (_, key) = file_key(p.effect).expect("filtered");
            s.push_str(&format!(
                "{key} = {}  # file: {}; {}\n",
                sig(p.current().pooled.value),
                sig(p.nominal),
                p.sentence()
            ));
        }
    }
    let faults: Vec<_> = outside
        .iter()
        .filter(|p| file_key(p.effect).is_none())
        .collect();
    if !faults.is_empty() {
        s.push_str("\n# Outside tolerance but not vehicle-file parameters (check the vehicle):\n");
        for p in faults {
            s.push_str(&format!("# {}\n", p.sentence()));
        }
    }
    Some(s)
}
