//! The properties the fuzz targets check, as plain functions that panic
//! on a violation. `tests/fuzz_regressions.rs` in the root package
//! includes `checks.rs` too, so every crash replays under `cargo test`.

pub mod checks;
