//! Precomputed radiance transfer in Bevy: prt-bake's exports relit every frame by any light.
//!
//! * [`PrtExport`] (a `.glb` export: vertex transfer, `--quantize`d or CPCA-compressed) and
//!   [`TexelTransfer`] (a texel bake's `export --exr` manifest) are assets, loaded by
//!   `asset_server.load::<PrtExport>("x.glb")` and
//!   `asset_server.load::<TexelTransfer>("x-exr/manifest.json")` ([`PrtExportLoader`],
//!   [`TexelTransferLoader`]), or outside Bevy by [`load_export`] and [`load_texel_transfer`];
//! * [`PrtMaterial`] is a [`StandardMaterial`] whose lighting is T·L, per vertex or per texel;
//! * [`PrtLight`] (a resource) is the light, in SH, turned by its `rotation` every frame;
//! * [`PrtProbes`] and [`ProbeLit`] light moving meshes from transfer probes.
//!
//! Conventions are the project's (docs/reference/gltf.md): real SH, index l(l+1)+m, θ from
//! +z, Condon–Shortley phase, the light in the export's glTF frame (+Y up).

pub mod assets;
pub mod export;
pub mod light;
pub mod material;
pub mod probes;
mod rig;
pub mod scene;
pub mod sh;
pub mod texel;

use bevy::asset::embedded_asset;
use bevy::prelude::*;

pub use assets::{PrtAssetsPlugin, PrtExportLoader, TexelTransferLoader};
pub use export::{ExportError, PrtExport, PrtPart, load_export};
pub use light::PrtLight;
pub use material::{PrtExtension, PrtMaterial};
pub use probes::{ProbeLit, PrtProbes};
pub use rig::RigSun;
pub use scene::{PrtStyle, Specular, spawn_exported, spawn_prt};
pub use texel::{TexelError, TexelTransfer, load_texel_transfer};

/// Registers [`PrtMaterial`], the export assets and their loaders ([`PrtAssetsPlugin`]), the
/// [`PrtLight`] resource (order 3, dark, until set) and the systems that write the turned
/// light into every PRT material each frame.
pub struct PrtPlugin;

impl Plugin for PrtPlugin {
    fn build(&self, app: &mut App) {
        embedded_asset!(app, "prt.wgsl");
        app.add_plugins((MaterialPlugin::<PrtMaterial>::default(), PrtAssetsPlugin))
            .init_resource::<PrtLight>()
            .add_systems(
                PostUpdate,
                (
                    relight,
                    probes::light_probe_lit.after(bevy::transform::TransformSystems::Propagate),
                ),
            );
    }
}

impl Default for PrtLight {
    fn default() -> PrtLight {
        PrtLight::zero(3)
    }
}

/// Writes [`PrtLight`], turned, into every [`PrtMaterial`]: in the glTF frame, or turned back
/// to z-up for texel transfer baked z-up.
fn relight(light: Res<PrtLight>, mut materials: ResMut<Assets<PrtMaterial>>) {
    let gltf = light.turned(light.order);
    let z_up = PrtLight {
        rotation: sh::z_up_to_gltf().transpose() * light.rotation,
        ..light.clone()
    }
    .turned(light.order);
    for (_, material) in materials.iter_mut() {
        let e = &mut material.extension;
        if e.probe_lit {
            continue;
        }
        e.set_light(if e.z_up { &z_up } else { &gltf });
    }
}
