//! Parquet bytes through ingest (footer, schema, dtypes, units, mapping detection, wide and
//! long layouts, time order, range and NaN-run checks), then resample and slope filter. Must
//! never panic.
#![no_main]
mod common;
libfuzzer_sys::fuzz_target!(|data: &[u8]| common::ingest_bytes(data, "parquet"));
