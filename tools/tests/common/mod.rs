//! What the tools' integration tests share: running the `kdray` binary,
//! a temporary folder per test file, and reading what a run printed.
// Each test file uses some of these.
#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// Runs `kdray args`.
pub(crate) fn kdray(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .output()
        .expect("run kdray")
}

/// `name` in this process's temporary folder for the test file `test`.
pub(crate) fn tmp_in(test: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kdray-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// What a run wrote to standard error.
pub(crate) fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}
