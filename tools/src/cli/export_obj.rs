//! `kdray export-obj MESH -o OUT.obj`: the flattened triangles as OBJ, for
//! tools that read only OBJ (`embree.sh` on a glTF scene).

use super::{CmdResult, MeshArgs};
use kdray_tools::io;
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
    super::check_apart_from_mesh(&a.output, &a.mesh)?;
    let tris = a.mesh_args.load(&a.mesh)?;
    let text = kdray_tools::mesh::obj_text(&tris);
    io::write_bytes(&a.output, &text)?;
    say!("wrote {} ({} triangles)", a.output.display(), tris.len());
    Ok(())
}
