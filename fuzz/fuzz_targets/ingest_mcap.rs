//! MCAP bytes through ingest (magic, records, chunk CRCs, decompression, JSON topic mapping,
//! multi-rate alignment), then resample and slope filter. Must never panic.
#![no_main]
mod common;
libfuzzer_sys::fuzz_target!(|data: &[u8]| common::ingest_bytes(data, "mcap"));
