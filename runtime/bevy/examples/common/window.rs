//! day_night's window (`--features window`): the Cornell room's texel bake (or `--scene`),
//! loaded through the asset server, with the sun crossing the sky and the PRT light (and, with
//! `--specular`, Bevy's own sun) following it every frame.

use std::path::PathBuf;

use bevy::math::DMat3;
use bevy::prelude::*;
use bevy_prt::{PrtExport, PrtLight, PrtPlugin, PrtStyle, TexelTransfer, spawn_prt};

use super::{Args, Pending, all_loaded, asset_path, bounds, fail, headless, specular_of, sun_at};

/// The window: the sun crosses the sky, the sky's colours follow its height.
pub fn interactive(args: Args) {
    let (scene, exr) = demo_scene(&args);
    App::new()
        .add_plugins((DefaultPlugins.set(headless::file_assets()), PrtPlugin))
        .add_systems(
            Startup,
            move |mut commands: Commands, server: Res<AssetServer>| {
                commands.insert_resource(Pending {
                    scene: server.load(asset_path(&scene)),
                    texel: (exr.as_ref())
                        .map(|d| server.load(asset_path(&d.join("manifest.json")))),
                    reference: None,
                    args: args.clone(),
                });
            },
        )
        .add_systems(
            Update,
            (
                spawn_window_scene.run_if(not(resource_exists::<Shown>)),
                move_sun.run_if(resource_exists::<Shown>),
            ),
        )
        .run();
}

/// The window's scene is up; its transfer's order.
#[derive(Resource)]
struct Shown(usize);

#[allow(clippy::too_many_arguments)] // a Bevy system: one argument per resource
fn spawn_window_scene(
    mut commands: Commands,
    pending: Res<Pending>,
    server: Res<AssetServer>,
    exports: Res<Assets<PrtExport>>,
    texels: Res<Assets<TexelTransfer>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut images: ResMut<Assets<Image>>,
    mut materials: ResMut<Assets<bevy_prt::PrtMaterial>>,
) {
    if !all_loaded(&server, &pending) {
        return;
    }
    let Some(export) = exports.get(&pending.scene) else {
        return;
    };
    let texel = pending.texel.as_ref().and_then(|h| texels.get(h));
    let args = &pending.args;
    let style = PrtStyle {
        clamp_shading: false,
        specular: args.specular.then_some(specular_of(args)),
    };
    spawn_prt(
        &mut commands,
        export,
        texel,
        style,
        &mut meshes,
        &mut images,
        &mut materials,
    )
    .unwrap_or_else(|e| fail(&e));
    let (lo, hi) = bounds(export);
    let centre = 0.5 * (lo + hi);
    let eye = centre + args.view.normalize() * 0.5 * (hi - lo).length() * 2.4;
    commands.spawn((
        Camera3d::default(),
        bevy::core_pipeline::tonemapping::Tonemapping::None,
        // An exposure of 1: Bevy's specular in T·L's units.
        bevy::camera::Exposure {
            ev100: -(1.2f32).log2(),
        },
        Transform::from_translation(eye).looking_at(centre, Vec3::Y),
    ));
    if args.specular {
        commands.spawn(
            sun_at(0.0, export.order)
                .1
                .directional_light(DMat3::IDENTITY),
        );
    }
    info!(
        "day_night: {} parts loaded and relit by PRT{}",
        export.parts.len(),
        if args.specular {
            " with Bevy's specular"
        } else {
            ""
        }
    );
    commands.insert_resource(Shown(export.order));
}

/// The sun crosses the sky: the PRT light and Bevy's sun (its specular) follow it.
fn move_sun(
    time: Res<Time>,
    shown: Res<Shown>,
    mut light: ResMut<PrtLight>,
    mut suns: Query<(&mut DirectionalLight, &mut Transform)>,
) {
    let (prt, sun) = sun_at(time.elapsed_secs_f64(), shown.0);
    *light = prt;
    for (mut bevy_light, mut transform) in &mut suns {
        (*bevy_light, *transform) = sun.directional_light(DMat3::IDENTITY);
    }
}

/// The interactive scene: --scene, or the Cornell room's texel bake, made by make if missing.
fn demo_scene(args: &Args) -> (PathBuf, Option<PathBuf>) {
    if let Some(s) = &args.scene {
        return (s.clone(), args.exr.clone());
    }
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let glb = dir.join("target/bevy/demo/cornell-lm.glb");
    if !glb.exists() {
        let status = std::process::Command::new("make")
            .arg("-C")
            .arg(&dir)
            .arg("bevy-demo-data")
            .status();
        if !status.is_ok_and(|s| s.success()) {
            fail("make bevy-demo-data failed");
        }
    }
    (glb, Some(dir.join("target/bevy/demo/cornell-lm-exr")))
}
