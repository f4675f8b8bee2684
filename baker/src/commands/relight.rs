//! `prt-bake relight`: a bake lit by a rig on the CPU, the reference a viewer must match.

use std::path::PathBuf;

use prt_baker::Error;
use prt_baker::support::output::Output;

#[derive(clap::Args)]
pub struct RelightArgs {
    /// The scene the coefficient file was baked from.
    scene: PathBuf,
    /// The .prt file.
    file: PathBuf,
    /// The light rig (TOML).
    #[arg(long)]
    lights: PathBuf,
    /// Output .ply file; for a lightmap bake a .png (tone-mapped) or .exr (linear) image.
    #[arg(short, long)]
    output: PathBuf,
    /// Exposure of the 8-bit colour in stops: radiance × 2^EV before clamping to [0, 1]
    /// (the float radiance is written unscaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f64,
}

pub fn run(args: RelightArgs) -> Result<(), Error> {
    if !args.exposure.is_finite() {
        return Err(Error::InvalidOption("--exposure must be finite".into()));
    }
    let inputs = [args.scene.clone(), args.file.clone(), args.lights.clone()];
    Output::new(&args.output, &inputs)?;
    let relit = prt_baker::export::relight::relight(
        &args.scene,
        &args.file,
        &args.lights,
        &args.output,
        args.exposure,
    )?;
    println!(
        "relit {} {} with {} light(s) at order {}, largest radiance {:.4} -> {}",
        relit.vertex_count,
        if relit.lightmap { "texels" } else { "vertices" },
        relit.light_count,
        relit.order,
        relit.max_radiance,
        args.output.display()
    );
    Ok(())
}
