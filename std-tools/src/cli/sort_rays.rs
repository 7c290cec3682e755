//! `kdray sort-rays IN.rays -o OUT.rays`: the same rays in the order of the
//! Morton code of their origins (`kdray_tools::morton`), as an engine gives
//! the shadow or bounce rays of neighbouring pixels, for `trace` to measure
//! that order beside the file's own. In and out may be the same file.

use super::CmdResult;
use kdray_kernel::Ray;
use kdray_tools::{io, morton};
use std::path::PathBuf;

/// Arguments of `kdray sort-rays`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The ray file (32-byte records, docs/formats.md).
    rays: PathBuf,
    /// Where to write the sorted rays (replaced only once complete).
    #[arg(short, long)]
    output: PathBuf,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    io::check_output(&a.output)?;
    let mut rays: Vec<Ray> = io::read_records(&a.rays, "ray")?;
    morton::sort_by_origin(&mut rays);
    io::write_records(&a.output, &rays)?;
    say!(
        "wrote {} rays in Morton order of their origins to {}",
        rays.len(),
        a.output.display()
    );
    Ok(())
}
