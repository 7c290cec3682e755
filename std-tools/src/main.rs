//! The `kdray` command-line tool: build, inspect and trace k-d trees.
#![forbid(unsafe_code)]

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
