#![no_main]
//! See `kdray_fuzz::checks::distance`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| kdray_fuzz::checks::distance(data));
