//! `prt-bake relight MESH FILE` where FILE is an LDPRT bake: the lobes lit on MESH's pose, by
//! the rig, or through a scene's probes (`--probes`, a character walking through a room).

use std::io::Read;
use std::path::Path;

use glam::Vec3;
use prt_baker::Error;
use prt_baker::export::relight_ldprt_probes::{CharacterPlacement, relight_ldprt_probes};
use prt_baker::formats::ldprt_file::{MAGIC, is_ldprt};
use prt_baker::scene::Pose;

/// What `relight` was given, as far as an LDPRT file uses it.
pub struct LdprtRelight<'a> {
    /// The mesh and its pose.
    pub mesh: (&'a Path, &'a Pose),
    /// The coefficient file and the rig.
    pub files: (&'a Path, &'a Path),
    pub probes: Option<&'a Path>,
    pub at: &'a [Vec3],
    /// How many --turn were given (a character is placed by its pose: none).
    pub turns: usize,
}

/// Relights the file on the mesh in its pose if it is an LDPRT file (and says so); `false`
/// for any other file, which must then be lit in the rest pose (its transfer is in world
/// space).
pub fn run_if_ldprt(args: &LdprtRelight, output: &Path, exposure: f64) -> Result<bool, Error> {
    let ((mesh, pose), (file, lights)) = (args.mesh, args.files);
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
    if let Some(probes) = args.probes {
        if args.turns > 0 || args.at.len() > 1 {
            return Err(Error::InvalidOption(
                "an LDPRT character is placed by its pose: at most one --at, no --turn".into(),
            ));
        }
        let placement = CharacterPlacement {
            probes,
            position: args.at.first().copied(),
        };
        let (relit, at) =
            relight_ldprt_probes((mesh, pose), (file, lights), &placement, output, exposure)?;
        println!(
            "relit {} vertices of an LDPRT bake posed as {} ({pose}) through the probes {} at \
             ({:.4}, {:.4}, {:.4}) with {} light(s) at order {} -> {}",
            relit.vertex_count,
            mesh.display(),
            probes.display(),
            at.x,
            at.y,
            at.z,
            relit.light_count,
            relit.order,
            output.display()
        );
        return Ok(true);
    }
    if !args.at.is_empty() || args.turns > 0 {
        return Err(Error::InvalidOption(
            "--at and --turn place an object: give --probes or --occluder".into(),
        ));
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
