//! `kdray sort-rays IN.rays -o OUT.rays [--key origin|origin-direction]`:
//! the same rays in the order of the Morton code of their origins (or of
//! their origins and directions; `kdray_tools::morton`), as an engine
//! gives the shadow or bounce rays of neighbouring pixels, for `trace` to
//! measure that order beside the file's own. The output may not be the
//! input (as for every command): the unsorted file is kept.

use super::CmdResult;
use kdray_kernel::{Ray, RayKey};
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
    /// What the Morton code is made of.
    #[arg(long, value_enum, default_value_t = Key::Origin)]
    key: Key,
}

/// `--key`: the kernel's [`RayKey`] by name.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum Key {
    /// The origin (shadow rays: what `trace` sorts any-hit batches by).
    Origin,
    /// The origin and the direction (bounce and random rays: what `trace`
    /// sorts closest-hit batches by).
    OriginDirection,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    io::check_output_apart(&a.output, &[&a.rays])?;
    let mut rays: Vec<Ray> = io::read_records(&a.rays, "ray")?;
    let (by, of) = match a.key {
        Key::Origin => (RayKey::Origin, "origins"),
        Key::OriginDirection => (RayKey::OriginDirection, "origins and directions"),
    };
    morton::sort_by(&mut rays, by);
    io::write_records(&a.output, &rays)?;
    say!(
        "wrote {} rays in Morton order of their {of} to {}",
        rays.len(),
        a.output.display()
    );
    Ok(())
}
