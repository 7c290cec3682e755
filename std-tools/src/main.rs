//! The `kdray` command-line tool: build, inspect and trace k-d trees.
#![deny(unsafe_code)]

/// The build makes and frees a few small lists per cell (hundreds of
/// thousands of cells): glibc's malloc was 11% of a bunny build. mimalloc
/// v2 takes 12-18% off `kdray build` of the bunny (SAH, binned) and 5% off
/// the 1M-triangle one; v3 (the crate's default) was as fast on the bunny
/// but 5-10% slower than glibc on the 1M mesh (it returned and re-faulted
/// memory: page clearing was 23% of the build).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
