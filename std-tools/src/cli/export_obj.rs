//! `kdray export-obj MESH -o OUT.obj`: the flattened triangles as OBJ, for
//! tools that read only OBJ (`embree.sh` on a glTF scene).

use super::{CmdResult, MeshArgs};
use kdray_tools::io;
use std::io::Write as _;
use std::path::PathBuf;

/// Arguments of `kdray export-obj`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The mesh (.obj, .ply, .gltf, .glb).
    mesh: PathBuf,
    /// Where to write the OBJ file.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    mesh_args: MeshArgs,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    io::check_output(&a.output)?;
    let tris = a.mesh_args.load(&a.mesh)?;
    // Three vertices per triangle, so triangle i is face i, in the order
    // `kdray build` numbers them; `{:?}` prints the shortest decimal that
    // reads back as the same f32.
    let mut text = Vec::with_capacity(tris.len() * 100);
    writeln!(text, "# {} triangles from {}", tris.len(), a.mesh.display())?;
    for t in &tris {
        for p in &t.v {
            writeln!(text, "v {:?} {:?} {:?}", p[0], p[1], p[2])?;
        }
    }
    for i in 0..tris.len() {
        writeln!(text, "f {} {} {}", 3 * i + 1, 3 * i + 2, 3 * i + 3)?;
    }
    io::write_bytes(&a.output, &text)?;
    say!("wrote {} ({} triangles)", a.output.display(), tris.len());
    Ok(())
}
