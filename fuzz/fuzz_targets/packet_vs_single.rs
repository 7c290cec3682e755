#![no_main]
//! See `kdray_fuzz::checks::packet_vs_single`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| kdray_fuzz::checks::packet_vs_single(data));
