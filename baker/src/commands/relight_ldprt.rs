//! `prt-bake relight MESH FILE` where FILE is an LDPRT bake: the lobes lit on MESH's pose.

use std::io::Read;
use std::path::Path;

use prt_baker::Error;
use prt_baker::formats::ldprt_file::{MAGIC, is_ldprt};
use prt_baker::scene::Pose;

/// Relights `file` on `mesh` in `pose` if it is an LDPRT file (and says so); `false` for any
/// other file, which must then be lit in the rest pose (its transfer is in world space).
pub fn run_if_ldprt(
    (mesh, pose): (&Path, &Pose),
    file: &Path,
    lights: &Path,
    output: &Path,
    exposure: f64,
) -> Result<bool, Error> {
    let mut head = [0u8; MAGIC.len()];
    let read = std::fs::File::open(file).and_then(|mut f| f.read(&mut head));
    if !matches!(read, Ok(n) if n == MAGIC.len()) || !is_ldprt(&head) {
        if !pose.is_rest() {
            return Err(Error::InvalidOption(
                "--pose is for LDPRT files (bake --transfer ldprt): other bakes are in world \
                 space"
                    .into(),
            ));
        }
        return Ok(false);
    }
    let relit = prt_baker::export::relight_ldprt::relight_ldprt(
        mesh, pose, file, lights, output, exposure,
    )?;
    println!(
        "relit {} vertices of an LDPRT bake posed as {} ({pose}) with {} light(s) at order {}, largest \
         radiance {:.4} -> {}",
        relit.vertex_count,
        mesh.display(),
        relit.light_count,
        relit.order,
        relit.max_radiance,
        output.display()
    );
    Ok(true)
}
