//! Loading a bake's scene, with `--instances`: which glTF mesh nodes are traced through
//! instances rather than flattened (docs/guides/production-assets.md, "Instancing").

use std::path::Path;

use clap::ValueEnum;
use prt_baker::bake::receiver_names::receives;
use prt_baker::scene::{AUTO_MIN_TRIANGLES, Instancing, Pose, Scene};
use prt_baker::support::error::Result;

/// `--instances`: when non-receiving glTF mesh nodes that share a mesh are traced as instances.
#[derive(Clone, Copy, Debug, Default, PartialEq, ValueEnum)]
pub enum InstancesArg {
    /// When that keeps at least a million triangles out of the flattened scene.
    #[default]
    Auto,
    /// Whenever a non-receiving mesh is placed at two nodes or more.
    On,
    /// Never: every node is flattened.
    Off,
}

/// `--double-sided`: whether glTF `doubleSided` objects get a back sheet of receivers
/// (docs/guides/production-assets.md, "Two-sided surfaces").
#[derive(Clone, Copy, Debug, Default, PartialEq, ValueEnum)]
pub enum DoubleSidedArg {
    /// Where the material says `doubleSided`: the bake adds a back sheet, lit from behind.
    #[default]
    Auto,
    /// Never: the front side's transfer only (bakes before the flag was read).
    Off,
}

/// Loads `path` (warnings to stderr), with instances where `arg` asks for them and the bake
/// can use them (`possible`: a shadowed or unshadowed whole vertex bake; the receivers are
/// chosen by `globs` as `--receivers` chooses them), back sheets where `sides` asks, a
/// glTF file in `pose`.
pub fn load(
    path: &Path,
    (arg, sides, pose): (InstancesArg, DoubleSidedArg, &Pose),
    globs: &[String],
    possible: bool,
) -> Result<Scene> {
    let receives = receives(globs);
    let min_triangles = match arg {
        InstancesArg::Auto => AUTO_MIN_TRIANGLES,
        InstancesArg::On => 0,
        InstancesArg::Off => u64::MAX,
    };
    let instancing = Instancing {
        receives: &receives,
        min_triangles,
    };
    let chosen = (possible && arg != InstancesArg::Off).then_some(&instancing);
    let (mut scene, warnings) = Scene::load_posed(path, chosen, pose)?;
    if sides == DoubleSidedArg::Off {
        scene.drop_back_sheets();
    }
    for warning in warnings {
        eprintln!("warning: {}: {warning}", path.display());
    }
    if !scene.instances.is_empty() {
        eprintln!(
            "{}: {} placements of {} meshes traced as instances ({} triangles not flattened)",
            path.display(),
            scene.instances.placements.len(),
            scene.instances.meshes.len(),
            scene.instances.flattened_triangle_count()
        );
    }
    Ok(scene)
}
