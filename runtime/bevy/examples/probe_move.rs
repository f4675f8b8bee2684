//! A rigid PRT object lit from transfer probes where it stands (bevy_prt's `ProbeLit`), against
//! `prt-bake relight --probes --at --turn` from a probe baked exactly at that position
//! (scripts/bevy/test.sh; docs/guides/bevy.md). Headless:
//!
//!   probe_move --object BALL.glb --probes GRID.prt --lights RIG.toml --at X,Y,Z
//!              --turn AX,AY,AZ,DEG --radiance EXACT.ply --screenshot OUT.png
//!
//! Positions, axes and the rig are in the probe scene's frame (z up for OBJ scenes), as
//! relight takes them; the object is placed in Bevy's world (glTF's +Y up) turned to it. The
//! comparison is the browser test's for a moving object: ≥ 95 % of the object's pixels within
//! 4 codes (interpolated probes against an exact one).

#[path = "common/headless.rs"]
mod headless;

use std::path::PathBuf;

use bevy::camera::visibility::RenderLayers;
use bevy::math::{DMat3, DQuat, DVec3};
use bevy::prelude::*;
use bevy_prt::probes::{ProbeLit, PrtProbes};
use bevy_prt::{PrtExtension, PrtLight, PrtMaterial, PrtPlugin, load_export, sh};
use headless::{Captures, beside, camera, compare, fail, headless_app, save};

struct Args {
    object: PathBuf,
    probes: PathBuf,
    lights: PathBuf,
    at: DVec3,
    turn: DMat3,
    radiance: PathBuf,
    screenshot: PathBuf,
}

fn numbers(s: &str, n: usize) -> Vec<f64> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse()
                .unwrap_or_else(|_| fail(&format!("not a number in {s}")))
        })
        .collect();
    if v.len() != n {
        fail(&format!("{s}: expected {n} numbers"));
    }
    v
}

fn parse_args() -> Args {
    let list: Vec<String> = std::env::args().skip(1).collect();
    let get = |name: &str| -> String {
        let i = list
            .iter()
            .position(|a| a == name)
            .unwrap_or_else(|| fail(&format!("{name} is required")));
        list.get(i + 1)
            .cloned()
            .unwrap_or_else(|| fail(&format!("{name} needs a value")))
    };
    let at = numbers(&get("--at"), 3);
    let turn = numbers(&get("--turn"), 4);
    Args {
        object: get("--object").into(),
        probes: get("--probes").into(),
        lights: get("--lights").into(),
        at: DVec3::new(at[0], at[1], at[2]),
        turn: DMat3::from_axis_angle(
            DVec3::new(turn[0], turn[1], turn[2]).normalize(),
            turn[3].to_radians(),
        ),
        radiance: get("--radiance").into(),
        screenshot: get("--screenshot").into(),
    }
}

/// The linear radiance per vertex of relight's binary PLY (x y z nx ny nz float, red green
/// blue uchar, then the radiance floats).
fn read_radiance(path: &PathBuf) -> Vec<[f32; 4]> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| fail(&format!("{}: {e}", path.display())));
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap_or_else(|| fail("not a PLY"))
        + 11;
    let header = String::from_utf8_lossy(&bytes[..end]);
    let count: usize = header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| fail("PLY without vertices"));
    let f = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    (0..count)
        .map(|v| {
            let o = end + v * 39 + 27;
            [f(o), f(o + 4), f(o + 8), 1.0]
        })
        .collect()
}

#[derive(Resource)]
struct Run {
    targets: Vec<Handle<Image>>,
    frame: u32,
    screenshot: PathBuf,
}

/// The exit status is the app's: 1 when a comparison fails.
fn main() -> AppExit {
    let args = parse_args();
    let export = load_export(&args.object).unwrap_or_else(|e| fail(&e.to_string()));
    let probes = PrtProbes::load(&args.probes).unwrap_or_else(|e| fail(&e.to_string()));
    let light = PrtLight::from_rig_file(&args.lights, probes.order)
        .unwrap_or_else(|e| fail(&e.to_string()));
    let radiance = read_radiance(&args.radiance);
    // The probe scene's frame to Bevy's world.
    let to_world = if probes.y_up {
        DMat3::IDENTITY
    } else {
        sh::z_up_to_gltf()
    };
    let position = (to_world * args.at).as_vec3();
    let rotation = DQuat::from_mat3(&(to_world * args.turn * to_world.transpose())).as_quat();
    let mut app = headless_app();
    app.add_plugins(PrtPlugin)
        .insert_resource(light)
        .insert_resource(probes)
        .insert_resource(Captures::default());
    let screenshot = args.screenshot.clone();
    app.add_systems(
        Startup,
        move |mut commands: Commands,
              mut meshes: ResMut<Assets<Mesh>>,
              mut images: ResMut<Assets<Image>>,
              mut prt_materials: ResMut<Assets<PrtMaterial>>,
              mut materials: ResMut<Assets<StandardMaterial>>| {
            let part = export
                .parts
                .first()
                .unwrap_or_else(|| fail("the object has no mesh"));
            if export.parts.len() != 1 || !part.vertex_transfer {
                fail("the object must be one mesh with vertex transfer");
            }
            let placed = Transform::from_translation(position).with_rotation(rotation);
            let base = StandardMaterial {
                base_color: Color::LinearRgba(part.base_color),
                unlit: true,
                ..default()
            };
            let material = prt_materials.add(PrtMaterial {
                base: base.clone(),
                extension: PrtExtension::new(
                    export.order,
                    export.channels == 3,
                    None,
                    false,
                    false,
                ),
            });
            commands.spawn((
                Mesh3d(meshes.add(part.mesh.clone())),
                MeshMaterial3d(material),
                placed,
                ProbeLit,
                RenderLayers::layer(1),
            ));
            let mut coloured = part.mesh.clone();
            if coloured.count_vertices() != radiance.len() {
                fail("the PLY's vertices are not the object's");
            }
            coloured.insert_attribute(Mesh::ATTRIBUTE_COLOR, radiance.clone());
            let white = materials.add(StandardMaterial {
                base_color: Color::WHITE,
                unlit: true,
                ..default()
            });
            commands.spawn((
                Mesh3d(meshes.add(coloured)),
                MeshMaterial3d(white),
                placed,
                RenderLayers::layer(2),
            ));
            // The browser test's camera: 0.15 above and 0.5 in front (+z) of the object.
            let projection = PerspectiveProjection {
                fov: 30f32.to_radians(),
                aspect_ratio: 1.0,
                near: 0.01,
                far: 10.0,
                ..default()
            };
            let eye = Transform::from_translation(position + Vec3::new(0.0, 0.15, 0.5))
                .looking_at(position, Vec3::Y);
            let targets = (1..=2)
                .map(|layer| {
                    camera(
                        &mut commands,
                        &mut images,
                        256,
                        layer,
                        projection.clone(),
                        eye,
                    )
                })
                .collect();
            commands.insert_resource(Run {
                targets,
                frame: 0,
                screenshot: screenshot.clone(),
            });
        },
    );
    app.add_systems(Update, step);
    app.run()
}

fn step(
    mut commands: Commands,
    mut run: ResMut<Run>,
    captures: Res<Captures>,
    mut exit: MessageWriter<AppExit>,
) {
    run.frame += 1;
    if run.frame == 5 {
        captures.request(&mut commands, &run.targets);
    }
    if run.frame > 5
        && let Some(shots) = captures.pixels()
    {
        save(&shots[0], 256, &run.screenshot);
        let reference = beside(&run.screenshot, "relight");
        save(&shots[1], 256, &reference);
        let c = compare(&shots[0], &shots[1], 4);
        let ok = c.covered > 1000 && c.share >= 0.95;
        println!(
            "probe_move: {} {:.2} % of {} pixels within 4 codes of relight at an exact probe (worst {}); {}",
            if ok { "ok  " } else { "FAIL" },
            100.0 * c.share,
            c.covered,
            c.worst,
            reference.display()
        );
        exit.write(if ok {
            AppExit::Success
        } else {
            AppExit::error()
        });
    } else if run.frame > 300 {
        fail("no screenshot after 300 frames");
    }
}
