//! Vehicle-file text through parse and validation, then what `fleetdyn bode` does with a
//! driveline: the linear model and its resonances in every gear. Must never panic.
#![no_main]
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::report::bode::BodeTable;
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(v) = VehicleFile::parse(text, "fuzz.toml") else {
        return;
    };
    let _ = v.gear_range();
    let _ = v.final_drive_ratio();
    let _ = v.axles("fuzz.toml");
    if let Ok(p) = v.driveline("fuzz.toml") {
        let _ = BodeTable::new(&v.vehicle_id, p, &v.gearbox.ratios);
    }
});
