//! `prt-bake relight`: a bake lit by a rig on the CPU, the reference a viewer must match.

use std::path::PathBuf;

use prt_baker::Error;
use prt_baker::support::output::Output;

#[derive(clap::Args)]
pub struct RelightArgs {
    /// The scene the coefficient file was baked from; for an LDPRT file (`bake --transfer
    /// ldprt`), its mesh in any pose (same vertices and triangles).
    scene: PathBuf,
    /// The .prt file, or an LDPRT file.
    file: PathBuf,
    /// The light rig (TOML).
    #[arg(long)]
    lights: PathBuf,
    /// Output .ply file; for a lightmap bake a .png (tone-mapped) or .exr (linear) image.
    #[arg(short, long)]
    output: PathBuf,
    /// With an LDPRT file and a glTF mesh: the pose its skins and animations are read in,
    /// `rest` (the nodes' own transforms), `ANIM@SECONDS` or `ANIM#KEYFRAME` (ANIM an
    /// animation's name or index; docs/guides/characters.md).
    #[arg(long, default_value = "rest")]
    pose: prt_baker::scene::Pose,
    /// Exposure of the 8-bit colour in stops: radiance × 2^EV before clamping to [0, 1]
    /// (the float radiance is written unscaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f64,
    /// Camera position X,Y,Z in the scene's coordinates: a transfer-matrix bake is then
    /// rendered with its materials' glossy layers (docs/guides/glossy.md). Without it a matrix bake
    /// is rendered diffuse; vector bakes take no view.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_view, allow_hyphen_values = true)]
    view: Option<glam::Vec3>,
    /// A probe bake (`bake --probes grid:…`) of the scene a rigid object moves through: the
    /// object (SCENE, FILE: baked alone, in its own frame) is lit by the probes' incident
    /// radiance at --at, turned into its frame by --turn (docs/guides/probes.md). With an
    /// LDPRT file: a character in --pose, lit at the centre of its posed bounds (or --at)
    /// (docs/guides/characters.md).
    #[arg(long, conflicts_with_all = ["view", "occluder"])]
    probes: Option<PathBuf>,
    /// With --probes: the object's position X,Y,Z in the probes' scene; with --occluder: the
    /// occluder's, one --at per --occluder.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_view, allow_hyphen_values = true)]
    at: Vec<glam::Vec3>,
    /// With --probes: the object's rotation, about the axis X,Y,Z by DEGREES (default none);
    /// with --occluder: the rotation of the --occluder before it (default none).
    #[arg(long, value_name = "X,Y,Z,DEGREES", value_parser = parse_turn, allow_hyphen_values = true)]
    turn: Vec<glam::DQuat>,
    #[command(flatten)]
    occluders: super::relight_occluders::OccluderGroups,
}

/// An axis and an angle in degrees, `X,Y,Z,DEGREES`, as a unit quaternion.
fn parse_turn(text: &str) -> Result<glam::DQuat, String> {
    let numbers: Vec<f64> = text
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("`{text}` is not four numbers X,Y,Z,DEGREES"))?;
    match numbers[..] {
        [x, y, z, degrees] if numbers.iter().all(|v| v.is_finite()) => {
            let axis = glam::DVec3::new(x, y, z)
                .try_normalize()
                .ok_or_else(|| format!("`{text}`: the axis must not be zero"))?;
            Ok(glam::DQuat::from_axis_angle(axis, degrees.to_radians()))
        }
        _ => Err(format!("`{text}` is not four finite numbers X,Y,Z,DEGREES")),
    }
}

/// Three finite numbers separated by commas.
fn parse_view(text: &str) -> Result<glam::Vec3, String> {
    let numbers: Vec<f32> = text
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("`{text}` is not three numbers X,Y,Z"))?;
    match numbers[..] {
        [x, y, z] if numbers.iter().all(|v| v.is_finite()) => Ok(glam::Vec3::new(x, y, z)),
        [_, _, _] => Err(format!("`{text}`: the position must be finite")),
        _ => Err(format!("`{text}` is not three numbers X,Y,Z")),
    }
}

pub fn run(args: RelightArgs) -> Result<(), Error> {
    if !args.exposure.is_finite() {
        return Err(Error::InvalidOption("--exposure must be finite".into()));
    }
    let inputs = [args.scene.clone(), args.file.clone(), args.lights.clone()];
    Output::new(&args.output, &inputs)?;
    if !args.occluders.is_empty() {
        let files = (
            args.scene.as_path(),
            args.file.as_path(),
            args.lights.as_path(),
        );
        let placed = args.occluders.placed(&args.at, &args.turn)?;
        return super::relight_occluders::run(files, &placed, &args.output, args.exposure);
    }
    let ldprt = super::relight_ldprt::LdprtRelight {
        mesh: (&args.scene, &args.pose),
        files: (&args.file, &args.lights),
        probes: args.probes.as_deref(),
        at: &args.at,
        turns: args.turn.len(),
    };
    if super::relight_ldprt::run_if_ldprt(&ldprt, &args.output, args.exposure)? {
        return Ok(());
    }
    super::relight_occluders::check_placement(args.probes.is_some(), &args.at, &args.turn)?;
    if let (Some(probes), Some(&position)) = (&args.probes, args.at.first()) {
        let placement = prt_baker::export::relight_rigid::Placement {
            probes,
            position,
            rotation: args.turn.first().copied().unwrap_or_default(),
        };
        let relit = prt_baker::export::relight_rigid::relight_rigid(
            (&args.scene, &args.file),
            &args.lights,
            &placement,
            &args.output,
            args.exposure,
        )?;
        println!(
            "relit {} vertices of a rigid object at ({}, {}, {}) through the probes {} with {} \
             light(s) at order {}, largest radiance {:.4} -> {}",
            relit.vertex_count,
            position.x,
            position.y,
            position.z,
            probes.display(),
            relit.light_count,
            relit.order,
            relit.max_radiance,
            args.output.display()
        );
        return Ok(());
    }
    let relit = prt_baker::export::relight::relight_from(
        &args.scene,
        &args.file,
        &args.lights,
        &args.output,
        args.exposure,
        args.view,
    )?;
    let how = match (relit.matrix, args.view) {
        (true, Some(_)) => " (transfer matrices, glossy)",
        (true, None) => " (transfer matrices, diffuse)",
        _ => "",
    };
    println!(
        "relit {} {}{how} with {} light(s) at order {}, largest radiance {:.4} -> {}",
        relit.vertex_count,
        if relit.lightmap { "texels" } else { "vertices" },
        relit.light_count,
        relit.order,
        relit.max_radiance,
        args.output.display()
    );
    Ok(())
}
