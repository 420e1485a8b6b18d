//! The drive-hour the stage benchmarks share (`benches/diagnose.rs`, `benches/peers/peer_side.rs`):
//! one synthetic drive of about an hour — 65 km of Swedish main road (`highway-se`, seed 3), the
//! diesel variant of the axle-load thesis 6x2 truck, multi-rate quantised CAN with dropouts (start
//! probability 0.001 per sample, mean 0.3 s), a stop every 5 km, a hidden aerodynamic-drag change
//! (c_w·A 6.6 m² instead of 5.5 m²) so a diagnosis has something to find. Written as `drive.mcap`
//! (the JSON topics at their CAN rates) and `drive.parquet` (canonical) under the given folder.

use fleetdyn::model::catalogue::Effect;
use fleetdyn::synth::can::Dropouts;
use fleetdyn::synth::drive::{synth_drive, DriveConfig, HiddenEffect, SynthDrive};
use fleetdyn::synth::effects::EffectChoice;
use std::path::Path;

/// Length of the bench road, km.
pub const HOUR_DRIVE_KM: f64 = 65.0;

/// Generates the drive-hour into `dir` (`drive/` and `answer.json` under it).
pub fn hour_drive(dir: &Path) -> SynthDrive {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut cfg = DriveConfig {
        slope_resolution: 0.001,
        dropouts: Some(Dropouts {
            start_probability: 0.001,
            mean_length_s: 0.3,
        }),
        ..DriveConfig::default()
    };
    cfg.driver.stop_every_m = Some(5000.0);
    synth_drive(
        &root.join("fixtures/vehicles/seed002-6x2-diesel.toml"),
        "highway-se",
        HOUR_DRIVE_KM,
        3,
        &dir.join("drive"),
        &cfg,
        Some(&HiddenEffect {
            choice: EffectChoice::Given(Effect::AeroDrag, Some(6.6)),
            answer_path: dir.join("answer.json"),
        }),
    )
    .expect("the bench drive generates")
}
