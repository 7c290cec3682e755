#![no_main]
//! See `kdray_fuzz::checks::tree_vs_brute`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| kdray_fuzz::checks::tree_vs_brute(data));
