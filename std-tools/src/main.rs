//! The `kdray` command-line tool: build, inspect and trace k-d trees.
#![forbid(unsafe_code)]

/// The build makes and frees a few small lists per cell (hundreds of
/// thousands of cells): glibc's malloc was 11% of a bunny build, mimalloc
/// takes 10-15% off the whole `kdray build` (SAH and binned).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
