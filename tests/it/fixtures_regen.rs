//! The bundled fixture drives come from fleetdyn's own generator: `fixtures/gen/make_drives.sh`,
//! run with this build's `fleetdyn`, makes every one of them and its truth table again, byte for
//! byte. A change to the generator that alters them fails here until the fixtures are
//! regenerated (`fixtures/gen/make_drives.sh`) and the figures measured on them re-checked.

use crate::common::fixture;

const FILES: [&str; 8] = [
    "truck-0001.mcap",
    "truck-0002-lz4.mcap",
    "truck-0003-export.parquet",
    "truck-0004-long.parquet",
    "truth/truck-0001-truth.parquet",
    "truth/truck-0002-truth.parquet",
    "truth/truck-0003-truth.parquet",
    "truth/truck-0004-truth.parquet",
];

#[test]
// The committed files are made by the release build; other optimisation levels may round the
// simulation's last bits differently.
#[cfg_attr(
    debug_assertions,
    ignore = "the fixtures are made by the release build"
)]
fn make_drives_sh_regenerates_every_fixture_drive_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let o = std::process::Command::new("bash")
        .arg(fixture("fixtures/gen/make_drives.sh"))
        .arg("--out")
        .arg(dir.path())
        .env("FLEETDYN", env!("CARGO_BIN_EXE_fleetdyn"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    for f in FILES {
        let made = std::fs::read(dir.path().join(f)).unwrap();
        let committed = std::fs::read(fixture(&format!("fixtures/drives/{f}"))).unwrap();
        assert!(
            made == committed,
            "fixtures/drives/{f}: regenerated {} bytes differ from the committed {} bytes; run \
             fixtures/gen/make_drives.sh and re-check the figures measured on the fixtures",
            made.len(),
            committed.len()
        );
        // small, as bundled fixtures must be
        assert!(made.len() < 1_600_000, "{f}: {} bytes", made.len());
    }
}
