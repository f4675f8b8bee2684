//! The day–night example and the render check of bevy_prt (docs/guides/bevy.md).
//!
//! Interactive (`--features window`): the Cornell room's texel bake (baked by make when
//! missing) or any export, with the sun crossing the sky and the light following it every
//! frame. Headless, for any bake:
//!
//!   day_night --scene FILE.glb [--exr DIR] [--lights RIG.toml | --light LIGHT.json]
//!             [--turn DEG | --time SECONDS] --screenshot OUT.png [--compare [EXPORT.glb]] [--view X,Y,Z]
//!   day_night --scene FILE.glb [--exr DIR] --bench prt|lightmap [--frames N]
//!
//! `--specular [--roughness R]` adds Bevy's own specular (reflectance 0.5) from a Bevy
//! DirectionalLight per sun of the rig (or the sun of `--time`), turned with the light. With
//! `--compare` it then checks the specular instead: against T·L alone away from the highlight,
//! and against T·L plus Bevy's own StandardMaterial specular (base colour black) everywhere.
//!
//! `--compare` renders the same view a second time as exported (COLOR_0 unlit, or the relit
//! lightmap through Bevy's own `Lightmap`), from EXPORT.glb (default: the scene; pass the
//! export of the rig turned the same way with `--turn`), and prints the share of lit pixels
//! within `--tolerance` codes (default 2); it exits 1 below `--min-share` (default 0.99).

#[path = "common/headless.rs"]
mod headless;
#[path = "common/specular.rs"]
mod specular;
#[cfg(feature = "window")]
#[path = "common/window.rs"]
mod window;

use std::path::PathBuf;
use std::time::Instant;

use bevy::asset::{AssetLoadError, LoadState};
use bevy::camera::visibility::RenderLayers;
use bevy::math::{DMat3, DVec3};
use bevy::prelude::*;
use bevy_prt::{
    ExportError, PrtExport, PrtLight, PrtPlugin, PrtStyle, RigSun, Specular, TexelError,
    TexelTransfer, spawn_exported, spawn_prt,
};
use headless::{Captures, beside, camera, compare, fail, headless_app, save};
use specular::check_specular;

#[derive(Clone, Debug)]
struct Args {
    scene: Option<PathBuf>,
    exr: Option<PathBuf>,
    lights: Option<PathBuf>,
    light_json: Option<PathBuf>,
    turn: f64,
    time: Option<f64>,
    screenshot: Option<PathBuf>,
    compare: Option<Option<PathBuf>>,
    view: Vec3,
    size: u32,
    tolerance: u8,
    min_share: f64,
    bench: Option<String>,
    frames: u32,
    specular: bool,
    roughness: f32,
}

fn usage(message: &str) -> ! {
    eprintln!(
        "day_night: {message}\nusage: day_night [--scene FILE.glb [--exr DIR]] [--lights RIG.toml | --light LIGHT.json] [--turn DEG] [--time SECONDS] [--screenshot OUT.png [--compare [EXPORT.glb]]] [--view X,Y,Z] [--size N] [--tolerance CODES] [--min-share F] [--bench prt|lightmap [--frames N]] [--specular [--roughness R]]"
    );
    std::process::exit(2);
}

fn parse_args() -> Args {
    let mut a = Args {
        scene: None,
        exr: None,
        lights: None,
        light_json: None,
        turn: 0.0,
        time: None,
        screenshot: None,
        compare: None,
        view: Vec3::new(0.15, 0.2, 1.0),
        size: 256,
        tolerance: 2,
        min_share: 0.99,
        bench: None,
        frames: 200,
        specular: false,
        roughness: 0.35,
    };
    let list: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    let value = |i: &mut usize, name: &str| -> String {
        *i += 1;
        list.get(*i)
            .cloned()
            .unwrap_or_else(|| usage(&format!("{name} needs a value")))
    };
    while i < list.len() {
        let flag = list[i].clone();
        let number = |s: String| {
            s.parse::<f64>()
                .unwrap_or_else(|_| usage(&format!("{flag}: not a number: {s}")))
        };
        match flag.as_str() {
            "--scene" => a.scene = Some(value(&mut i, &flag).into()),
            "--exr" => a.exr = Some(value(&mut i, &flag).into()),
            "--lights" => a.lights = Some(value(&mut i, &flag).into()),
            "--light" => a.light_json = Some(value(&mut i, &flag).into()),
            "--turn" => a.turn = number(value(&mut i, &flag)),
            "--time" => a.time = Some(number(value(&mut i, &flag))),
            "--screenshot" => a.screenshot = Some(value(&mut i, &flag).into()),
            "--compare" => {
                let next = list.get(i + 1).filter(|s| !s.starts_with("--")).cloned();
                if next.is_some() {
                    i += 1;
                }
                a.compare = Some(next.map(PathBuf::from));
            }
            "--view" => {
                let v: Vec<f32> = value(&mut i, &flag)
                    .split(',')
                    .map(|s| s.trim().parse().unwrap_or_else(|_| usage("--view X,Y,Z")))
                    .collect();
                if v.len() != 3 {
                    usage("--view X,Y,Z");
                }
                a.view = Vec3::new(v[0], v[1], v[2]);
            }
            "--size" => a.size = number(value(&mut i, &flag)) as u32,
            "--tolerance" => a.tolerance = number(value(&mut i, &flag)) as u8,
            "--min-share" => a.min_share = number(value(&mut i, &flag)),
            "--bench" => a.bench = Some(value(&mut i, &flag)),
            "--frames" => a.frames = number(value(&mut i, &flag)) as u32,
            "--specular" => a.specular = true,
            "--roughness" => a.roughness = number(value(&mut i, &flag)) as f32,
            "-h" | "--help" => usage("help"),
            other => usage(&format!("unknown argument {other}")),
        }
        i += 1;
    }
    if a.compare.is_some() && a.screenshot.is_none() {
        usage("--compare needs --screenshot");
    }
    a
}

/// The light the scene is lit by: a rig projected here, a light JSON, or the export's own.
fn scene_light(args: &Args, export: &PrtExport) -> Result<PrtLight, String> {
    let mut light = if let Some(t) = args.time {
        sun_at(t, export.order).0
    } else if let Some(rig) = &args.lights {
        PrtLight::from_rig_file(rig, export.order.max(3)).map_err(|e| e.to_string())?
    } else if let Some(json) = &args.light_json {
        PrtLight::from_json_file(json).map_err(|e| e.to_string())?
    } else if let Some(l) = &export.light {
        l.clone()
    } else {
        return Err("the export carries no light: pass --lights RIG.toml".into());
    };
    // --turn: about glTF's up axis, +Y (a rig turned about its z-up world's +z).
    light.rotation = DMat3::from_rotation_y(args.turn.to_radians());
    Ok(light)
}

#[derive(Resource)]
struct Run {
    args: Args,
    targets: Vec<Handle<Image>>,
    frame: u32,
    started: Option<Instant>,
}

/// The files as the asset server loads them ([`bevy_prt::PrtExportLoader`],
/// [`bevy_prt::TexelTransferLoader`]), until they have loaded.
#[derive(Resource)]
struct Pending {
    args: Args,
    scene: Handle<PrtExport>,
    texel: Option<Handle<TexelTransfer>>,
    reference: Option<Handle<PrtExport>>,
}

/// The exit status is the app's: 1 when a comparison fails.
fn main() -> AppExit {
    let args = parse_args();
    let Some(scene) = args.scene.clone() else {
        #[cfg(feature = "window")]
        window::interactive(args);
        #[cfg(not(feature = "window"))]
        interactive(args);
        return AppExit::Success;
    };
    if args.screenshot.is_none() && args.bench.is_none() {
        usage("a --scene is checked headless: give --screenshot OUT.png or --bench");
    }
    if args.specular && args.time.is_none() && args.lights.is_none() {
        usage("--specular needs the suns of --lights RIG.toml or of --time");
    }
    let mut app = headless_app();
    app.add_plugins(PrtPlugin)
        .insert_resource(Captures::default());
    app.add_systems(
        Startup,
        move |mut commands: Commands, server: Res<AssetServer>| {
            let reference = match &args.compare {
                Some(Some(path)) => Some(path.clone()),
                Some(None) => Some(scene.clone()),
                None => None,
            };
            commands.insert_resource(Pending {
                scene: server.load(asset_path(&scene)),
                texel: (args.exr.as_ref())
                    .map(|d| server.load(asset_path(&d.join("manifest.json")))),
                reference: reference.map(|p| server.load(asset_path(&p))),
                args: args.clone(),
            });
        },
    );
    app.add_systems(
        Update,
        (
            spawn_when_loaded.run_if(not(resource_exists::<Run>)),
            step.run_if(resource_exists::<Run>),
        ),
    );
    app.run()
}

/// `path` relative to the working directory, which is the asset root of the headless app.
fn asset_path(path: &std::path::Path) -> String {
    let canonical = |p: &std::path::Path| {
        std::fs::canonicalize(p).unwrap_or_else(|e| fail(&format!("{}: {e}", p.display())))
    };
    let (full, base) = (canonical(path), canonical(std::path::Path::new(".")));
    let common = full
        .components()
        .zip(base.components())
        .take_while(|(a, b)| a == b)
        .count();
    let mut relative = PathBuf::new();
    base.components()
        .skip(common)
        .for_each(|_| relative.push(".."));
    full.components()
        .skip(common)
        .for_each(|c| relative.push(c));
    relative.to_string_lossy().into_owned()
}

/// Whether every pending file has loaded; a file that failed ends the run with its error.
fn all_loaded(server: &AssetServer, pending: &Pending) -> bool {
    let ids = [
        Some(pending.scene.id().untyped()),
        pending.texel.as_ref().map(|h| h.id().untyped()),
        pending.reference.as_ref().map(|h| h.id().untyped()),
    ];
    for id in ids.into_iter().flatten() {
        match server.load_state(id) {
            LoadState::Loaded => {}
            LoadState::Failed(e) => fail(&match e.as_ref() {
                // The loader's own error (it names the file), without Bevy's backtrace.
                AssetLoadError::AssetLoaderError(e) => {
                    let error = e.error();
                    (error.downcast_ref::<ExportError>().map(|e| e.to_string()))
                        .or_else(|| error.downcast_ref::<TexelError>().map(|e| e.to_string()))
                        .unwrap_or_else(|| error.to_string())
                }
                other => other.to_string(),
            }),
            _ => return false,
        }
    }
    true
}

/// Once the files have loaded: the light, the scene relit by PRT and what it is compared
/// with, each seen by its own camera.
#[allow(clippy::too_many_arguments)] // a Bevy system: one argument per resource
fn spawn_when_loaded(
    mut commands: Commands,
    pending: Res<Pending>,
    server: Res<AssetServer>,
    exports: Res<Assets<PrtExport>>,
    texels: Res<Assets<TexelTransfer>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut images: ResMut<Assets<Image>>,
    mut prt_materials: ResMut<Assets<bevy_prt::PrtMaterial>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    if !all_loaded(&server, &pending) {
        return;
    }
    let args = &pending.args;
    let (Some(export), texel) = (
        exports.get(&pending.scene),
        pending.texel.as_ref().and_then(|h| texels.get(h)),
    ) else {
        return;
    };
    let reference = pending.reference.as_ref().and_then(|h| exports.get(h));
    let light = scene_light(args, export).unwrap_or_else(|e| fail(&e));
    let suns = if !args.specular {
        Vec::new()
    } else if let Some(t) = args.time {
        vec![sun_at(t, export.order).1]
    } else if let Some(rig) = &args.lights {
        PrtLight::rig_suns(rig).unwrap_or_else(|e| fail(&e.to_string()))
    } else {
        Vec::new()
    };
    let rotation = light.rotation;
    commands.insert_resource(light);
    let style = PrtStyle {
        clamp_shading: true,
        specular: args.specular.then_some(specular_of(args)),
    };
    let mut targets = Vec::new();
    let lightmap_only = args.bench.as_deref() == Some("lightmap");
    for sun in &suns {
        commands.spawn((
            sun.directional_light(rotation),
            RenderLayers::from_layers(&[0, 1, 2, 3]),
        ));
    }
    if !lightmap_only {
        let parts = spawn_prt(
            &mut commands,
            export,
            texel,
            style,
            &mut meshes,
            &mut images,
            &mut prt_materials,
        )
        .unwrap_or_else(|e| fail(&e));
        targets.push(view_camera(
            &mut commands,
            &mut images,
            export,
            args,
            1,
            &parts,
        ));
    }
    let exported = if lightmap_only {
        Some(export)
    } else {
        reference
    };
    if args.specular && args.compare.is_some() {
        // T·L alone, and Bevy's own specular on black.
        let plain = PrtStyle {
            specular: None,
            ..style
        };
        let parts = spawn_prt(
            &mut commands,
            export,
            texel,
            plain,
            &mut meshes,
            &mut images,
            &mut prt_materials,
        )
        .unwrap_or_else(|e| fail(&e));
        targets.push(view_camera(
            &mut commands,
            &mut images,
            export,
            args,
            2,
            &parts,
        ));
        let parts = spawn_bevy_specular(
            &mut commands,
            export,
            specular_of(args),
            &mut meshes,
            &mut images,
            &mut materials,
        );
        targets.push(view_camera(
            &mut commands,
            &mut images,
            export,
            args,
            3,
            &parts,
        ));
    } else if let Some(r) = exported {
        let parts = spawn_exported(&mut commands, r, &mut meshes, &mut images, &mut materials)
            .unwrap_or_else(|e| fail(&e));
        targets.push(view_camera(&mut commands, &mut images, r, args, 2, &parts));
    }
    commands.insert_resource(Run {
        args: args.clone(),
        targets,
        frame: 0,
        started: None,
    });
}

/// The StandardMaterial parameters of --specular.
fn specular_of(args: &Args) -> Specular {
    Specular {
        perceptual_roughness: args.roughness,
        metallic: 0.0,
        reflectance: 0.5,
    }
}

/// The export as Bevy's own lit StandardMaterial with a black base colour: its diffuse is
/// zero, so it draws Bevy's specular alone (the oracle of --specular --compare).
fn spawn_bevy_specular(
    commands: &mut Commands,
    export: &PrtExport,
    specular: Specular,
    meshes: &mut Assets<Mesh>,
    images: &mut Assets<Image>,
    materials: &mut Assets<StandardMaterial>,
) -> Vec<Entity> {
    let handles = bevy_prt::scene::add_images(export, images);
    export
        .parts
        .iter()
        .map(|part| {
            let material = StandardMaterial {
                base_color: Color::BLACK,
                base_color_texture: None,
                perceptual_roughness: specular.perceptual_roughness,
                metallic: specular.metallic,
                reflectance: specular.reflectance,
                ..bevy_prt::scene::standard_material(part, &handles, false)
            };
            commands
                .spawn((
                    Mesh3d(meshes.add(part.mesh.clone())),
                    MeshMaterial3d(materials.add(material)),
                ))
                .id()
        })
        .collect()
}

/// The scene's bounding box.
fn bounds(export: &PrtExport) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for part in &export.parts {
        if let Some(bevy::mesh::VertexAttributeValues::Float32x3(p)) =
            part.mesh.attribute(Mesh::ATTRIBUTE_POSITION)
        {
            for q in p {
                lo = lo.min(Vec3::from(*q));
                hi = hi.max(Vec3::from(*q));
            }
        }
    }
    (lo, hi)
}

/// The browser test's view of a scene: from the bounding box's centre along `--view`, 2.4
/// radii away, a 40° field; the parts go to render layer `layer`.
fn view_camera(
    commands: &mut Commands,
    images: &mut Assets<Image>,
    export: &PrtExport,
    args: &Args,
    layer: usize,
    parts: &[Entity],
) -> Handle<Image> {
    let (lo, hi) = bounds(export);
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    for &p in parts {
        commands.entity(p).insert(RenderLayers::layer(layer));
    }
    let projection = PerspectiveProjection {
        fov: 40f32.to_radians(),
        aspect_ratio: 1.0,
        near: radius / 100.0,
        far: radius * 10.0,
        ..default()
    };
    let eye = centre + args.view.normalize() * radius * 2.4;
    camera(
        commands,
        images,
        args.size,
        layer,
        projection,
        Transform::from_translation(eye).looking_at(centre, Vec3::Y),
    )
}

/// Headless frames: a few to settle, then the screenshots (and the comparison), or the timed
/// frames of --bench.
fn step(
    mut commands: Commands,
    mut run: ResMut<Run>,
    captures: Res<Captures>,
    mut exit: MessageWriter<AppExit>,
) {
    run.frame += 1;
    let frame = run.frame;
    if let Some(which) = run.args.bench.clone() {
        if frame == 10 {
            run.started = Some(Instant::now());
        } else if frame == 10 + run.args.frames {
            let ms = run
                .started
                .map_or(0.0, |s| s.elapsed().as_secs_f64() * 1000.0)
                / run.args.frames as f64;
            println!(
                "day_night: {which}: {ms:.2} ms a frame over {} frames at {}²",
                run.args.frames, run.args.size
            );
            exit.write(AppExit::Success);
        }
        return;
    }
    if frame == 5 {
        captures.request(&mut commands, &run.targets);
    }
    if frame > 5
        && let Some(shots) = captures.pixels()
    {
        let code = finish(&run.args, &shots);
        exit.write(if code == 0 {
            AppExit::Success
        } else {
            AppExit::error()
        });
    } else if frame > 300 {
        eprintln!("day_night: no screenshot after 300 frames");
        exit.write(AppExit::error());
    }
}

/// Writes the screenshots and compares them; returns the exit code.
fn finish(args: &Args, shots: &[Vec<u8>]) -> i32 {
    let out = args.screenshot.as_ref().expect("--screenshot");
    save(&shots[0], args.size, out);
    println!("day_night: wrote {}", out.display());
    if args.compare.is_none() {
        return 0;
    }
    if args.specular {
        save(&shots[1], args.size, &beside(out, "diffuse"));
        save(&shots[2], args.size, &beside(out, "bevy-specular"));
        let c = check_specular(&shots[0], &shots[1], &shots[2], args.tolerance);
        let ok = c.away > 1000
            && c.away_share >= args.min_share
            && c.highlight >= 20
            && c.sum_share >= args.min_share;
        println!(
            "day_night: {} specular: {:.2} % of {} pixels away from the highlight within {} codes of T·L alone; highlight of {} pixels centred at ({:.1}, {:.1}); {:.2} % of {} lit pixels within {} codes of T·L + Bevy's own specular (worst {})",
            if ok { "ok  " } else { "FAIL" },
            100.0 * c.away_share,
            c.away,
            args.tolerance,
            c.highlight,
            c.centre[0],
            c.centre[1],
            100.0 * c.sum_share,
            c.covered,
            args.tolerance,
            c.worst
        );
        return if ok { 0 } else { 1 };
    }
    let ref_path = beside(out, "exported");
    save(&shots[1], args.size, &ref_path);
    let c = compare(&shots[0], &shots[1], args.tolerance);
    let ok = c.covered > 1000 && c.share >= args.min_share;
    println!(
        "day_night: {} {:.2} % of {} lit pixels within {} codes of the export (worst {}); as exported: {}",
        if ok { "ok  " } else { "FAIL" },
        100.0 * c.share,
        c.covered,
        args.tolerance,
        c.worst,
        ref_path.display()
    );
    if ok { 0 } else { 1 }
}

/// The light of time t (seconds): a day of 20 s, the sun rising in the east (+x), crossing
/// the sky tilted 30° towards −z, setting in the west; sky and sun warmer and dimmer low. Also
/// the sun alone, for Bevy's own DirectionalLight (its specular).
pub fn sun_at(t: f64, order: usize) -> (PrtLight, RigSun) {
    let angle = (t / 20.0) * std::f64::consts::TAU;
    let d = DVec3::new(angle.cos(), angle.sin(), -0.5 * angle.sin()).normalize();
    let height = d.y.max(0.0);
    let day = height.powf(0.5);
    let sun = DVec3::new(1.0, 0.55 + 0.4 * day, 0.3 + 0.6 * day) * (3.0 * day);
    let sky = DVec3::new(0.1, 0.14, 0.25) * (0.2 + day);
    let ground = DVec3::new(0.05, 0.045, 0.04) * (0.3 + day);
    (
        PrtLight::sun_and_sky(order, d, sun, sky, ground, DVec3::Y),
        RigSun {
            direction: d,
            irradiance: sun,
        },
    )
}

#[cfg(not(feature = "window"))]
fn interactive(_args: Args) {
    fail(
        "the window needs `--features window`; headless, give --scene FILE.glb --screenshot OUT.png",
    );
}
