#![no_main]
//! See `kdray_fuzz::checks::point_blob`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| kdray_fuzz::checks::point_blob(data));
