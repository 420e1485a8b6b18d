//! Pipeline-file text through parse and plan validation. The inputs are overridden with an
//! empty list so a fuzzed `inputs = ["/"]` cannot walk the file system; vehicle files, vehicle
//! folders and mappings the text names are read (relative to the fuzzer's working folder, the
//! repository top). Must never panic.
#![no_main]
use fleetdyn::pipeline::spec::PipelineSpec;
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(spec) = PipelineSpec::parse(text, "fuzz.toml") {
        let _ = spec.plan("fuzz.toml", Some(&[]));
    }
});
