//! `prt-bake bake OBJ --occluder [--spheres K] -o OBJ_OCC.prt`: a sphere set fitted to an
//! object, the stand-in that darkens a baked scene where the object moves
//! (docs/guides/occluders.md). Nothing is traced: the spheres' shadows are computed at run
//! time in closed form.

use std::path::Path;

use prt_baker::Error;
use prt_baker::scene::Scene;
use prt_baker::support::output::Output;

#[derive(clap::Args)]
pub struct OccluderArgs {
    /// Write an occluder file instead of a bake: spheres fitted to the scene's objects (in their own coordinates) for `relight --occluder` and `prt-view --mover` (docs/guides/occluders.md). Nothing is traced.
    #[arg(long, conflicts_with_all = ["lightmap", "probes", "shard", "checkpoint", "receivers", "clusters", "pcs"])]
    pub occluder: bool,
    /// With --occluder: how many spheres to fit (1 for a ball; more for long or flat objects).
    #[arg(long, value_name = "K", default_value_t = 1, requires = "occluder")]
    pub spheres: usize,
}

/// `prepare-lightmap` shares the bake's options, `--occluder` among them: it prepares a texel
/// bake, and an occluder is not one.
pub fn refuse_in_prepare(args: &OccluderArgs) -> Result<(), Error> {
    match args.occluder {
        true => Err(Error::InvalidOption(
            "--occluder is for `prt-bake bake OBJ --occluder`, not prepare-lightmap".into(),
        )),
        false => Ok(()),
    }
}

/// Fits and writes the occluder file.
pub fn run(scene_path: &Path, output: &Path, args: &OccluderArgs) -> Result<(), Error> {
    let output_policy = Output::new(output, &[scene_path.to_path_buf()])?;
    let scene = Scene::load(scene_path)?;
    let file = prt_baker::bake::occluder_fit::fit_spheres(&scene, args.spheres)
        .map_err(|message| Error::InvalidOption(format!("{}: {message}", scene_path.display())))?;
    let bytes = file.to_bytes();
    output_policy.write(&bytes)?;
    println!(
        "fitted {} sphere(s) to {} triangles of {}: {} -> {} ({} bytes)",
        file.spheres.len(),
        scene.triangles.len(),
        scene_path.display(),
        prt_baker::bake::occluder_fit::describe(&file),
        output.display(),
        bytes.len()
    );
    Ok(())
}
