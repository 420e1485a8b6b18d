//! MDF4 bytes through the raw CAN reader (blocks, links, data lists, zipped data, sorted and
//! unsorted records, VLSD payloads), then through a session ingest decoded with the parked
//! truck's J1939 DBC (decode, multi-rate alignment, splitting at pauses, checks). Must never
//! panic.
#![no_main]
mod common;
use fleetdyn::ingest::can::{ingest_session_recording, mdf4::parse_mdf4};
use fleetdyn::ingest::IngestOptions;
use std::path::{Path, PathBuf};

const DBC: &str = "fixtures/real/css-j1939-parked/CSS-Electronics-SAE-J1939-DEMO.dbc";

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.MF4");
    if parse_mdf4(data, path).is_err() {
        return;
    }
    let file = common::scratch("MF4");
    std::fs::write(&file, data).expect("scratch file");
    let _ = ingest_session_recording(
        &[file],
        &[PathBuf::from(DBC)],
        &IngestOptions::default(),
    );
});
