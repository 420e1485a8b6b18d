//! DBC text through the parser and its checks (signal sizes and layouts, value types, J1939
//! attributes), then every signal of every message decoded from payloads of 0, 8 and 64 bytes
//! (all zeros, all ones) and the automatic mapping chosen for it. Must never panic.
#![no_main]
use fleetdyn::ingest::can::dbc::Database;
use fleetdyn::ingest::can::session::auto_can_mapping;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(db) = Database::parse(text, "fuzz.dbc") else {
        return;
    };
    for m in &db.messages {
        for k in 0..m.signals.len() {
            for payload in [&[][..], &[0u8; 8][..], &[0xFFu8; 8][..], &[0xA5u8; 64][..]] {
                let _ = m.signal_value(k, payload);
                let _ = m.is_present(k, payload);
            }
        }
    }
    let _ = auto_can_mapping(std::slice::from_ref(&db));
});
