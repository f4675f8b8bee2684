//! `prt-view`: shows a baked scene in real time, PRT against Blinn-Phong, with the thesis's
//! controls; renders screenshots without a display; measures frame rates.
//! Everything it does is a library call; this file parses arguments and reports.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use prt_baker::formats::occluder_file::OccluderFile;
use prt_baker::light::Rig;
use prt_baker::support::output::Output;
use prt_viewer::bench::{self, BenchOptions};
use prt_viewer::lights::{Lights, MAX_LIGHTS};
use prt_viewer::moving::{self, Mover, Probes};
use prt_viewer::occluders::MoverShadow;
use prt_viewer::offscreen;
use prt_viewer::skinned::Skinned;
use prt_viewer::window::{self, WindowOptions};
use prt_viewer::{Bake, Camera, Error, FrameInputs, Gpu, Key, Mode, Renderer, View};

/// Exit codes, as `prt-bake`'s: 0 success, 1 failure, 2 bad command line, 3 bad input files.
const EXIT_FAILURE: u8 = 1;
const EXIT_BAD_COMMAND_LINE: u8 = 2;
const EXIT_BAD_INPUT: u8 = 3;

#[derive(Parser)]
#[command(
    name = "prt-view",
    version,
    about = "Real-time viewer of PRT bakes: PRT against Blinn-Phong, with the thesis's controls",
    after_help = "Controls: arrows move, left-drag turns, 1-8 select a light, Q/A its theta, W/E its phi, \
                  T textures, N normals, L light vectors, P probes, F1 Blinn-Phong, F2 PRT, Escape quits.\n\n\
                  Moving objects (docs/guides/probes.md): --probes PROBES.prt (a grid bake of the scene, \
                  `prt-bake bake SCENE --probes grid:NX,NY,NZ`) draws the probes as spheres showing \
                  their incident radiance; --mover OBJECT --mover-prt OBJECT.prt --path \"x,y,z;x,y,z\" \
                  moves an object baked alone along the path, lit through the probes; --character \
                  SKINNED.glb --character-ldprt FILE.ldprt plays a skinned character's animation through \
                  them (docs/guides/characters.md)."
)]
struct Cli {
    /// The scene the coefficient file was baked from.
    scene: PathBuf,
    /// The .prt coefficient file.
    file: PathBuf,
    /// Light rig (TOML, docs/reference/lights.md); a sun and a sky if not given.
    #[arg(long, value_name = "RIG.toml")]
    lights: Option<PathBuf>,
    /// Render one frame without a display (needs --screenshot).
    #[arg(long, requires = "screenshot")]
    headless: bool,
    /// With --headless: write the frame here as PNG.
    #[arg(long, value_name = "OUT.png", requires = "headless")]
    screenshot: Option<PathBuf>,
    /// Print a frame-rate table of Blinn-Phong and PRT with 1 and 8 lights (offscreen).
    #[arg(long, conflicts_with_all = ["headless", "frames", "keys"])]
    bench: bool,
    /// Image or initial window size.
    #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Shading model of the first frame.
    #[arg(long, value_enum, default_value_t = ModeArg::Prt)]
    mode: ModeArg,
    /// Camera position and direction, angles in degrees (yaw from +x towards +y, pitch up);
    /// a view of the whole scene if not given.
    #[arg(long, value_name = "X,Y,Z,YAW,PITCH", allow_hyphen_values = true)]
    camera: Option<String>,
    /// Exposure in stops (radiance × 2^EV before clamping), as `prt-bake relight --exposure`.
    #[arg(
        long,
        value_name = "EV",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    exposure: f32,
    /// Start with textures off (T toggles).
    #[arg(long)]
    no_textures: bool,
    /// Start with normals drawn (N toggles).
    #[arg(long)]
    normals: bool,
    /// Start with light vectors drawn (L toggles).
    #[arg(long)]
    light_vectors: bool,
    /// Window: quit after N frames.
    #[arg(long, value_name = "N")]
    frames: Option<u64>,
    /// Window: keys pressed one per frame from the first, e.g. F1,Q,Q,2,F2,Escape.
    #[arg(long, value_name = "KEYS", value_delimiter = ',', value_parser = parse_key)]
    keys: Vec<Key>,
    /// Bench: timed frames per configuration.
    #[arg(long, value_name = "N", default_value_t = 240)]
    bench_frames: u32,
    /// With --bench: another coefficient file of the same scene (e.g. a transfer-matrix bake,
    /// uncompressed or compressed, shown as glossy PRT) whose PRT rows join the same run.
    #[arg(long, value_name = "FILE.prt", requires = "bench")]
    bench_also: Vec<PathBuf>,
    /// With --bench: an occluder file (`prt-bake bake OBJECT --occluder`) whose copies move
    /// over the scene and shadow it in further PRT rows (docs/guides/occluders.md).
    #[arg(long, value_name = "OCC", requires = "bench")]
    bench_occluder: Option<PathBuf>,
    /// With --bench-occluder: how many copies move at once.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 4,
        requires = "bench_occluder"
    )]
    bench_occluders: usize,
    /// Transfer probes of the scene (a grid bake: `prt-bake bake SCENE --probes grid:…`),
    /// drawn as spheres shaded by their incident radiance as a white diffuse ball there (P toggles), and lighting --mover.
    #[arg(long, value_name = "PROBES.prt", conflicts_with = "bench")]
    probes: Option<PathBuf>,
    /// An object baked alone (its own vector bake: --mover-prt) that moves along --path
    /// through the scene, lit by the probes at its position.
    #[arg(long, value_name = "OBJECT", requires_all = ["probes", "mover_prt", "path"])]
    mover: Option<PathBuf>,
    /// The moving object's coefficient file.
    #[arg(long, value_name = "OBJECT.prt", requires = "mover")]
    mover_prt: Option<PathBuf>,
    /// The moving object's path in the scene's frame: points x,y,z separated by ';'. It
    /// goes there and back, facing along the path (its +x turned about +z).
    #[arg(
        long,
        value_name = "X,Y,Z;X,Y,Z;…",
        requires = "mover",
        allow_hyphen_values = true,
        value_parser = parse_path
    )]
    path: Option<PathPoints>,
    /// The moving object's speed in scene units per second.
    #[arg(long, value_name = "UNITS", default_value_t = 0.5, requires = "mover")]
    speed: f32,
    /// Where the moving object is in a screenshot, as a fraction of the path (0 its start,
    /// 1 its end).
    #[arg(
        long,
        value_name = "FRACTION",
        default_value_t = 0.0,
        requires = "mover"
    )]
    mover_at: f32,
    /// With --mover: an occluder file (`prt-bake bake OBJECT --occluder`) that moves with it
    /// and shadows the scene's vector bake, per vertex or per lightmap texel
    /// (docs/guides/occluders.md).
    #[arg(long, value_name = "OCC", requires = "mover")]
    mover_occluder: Option<PathBuf>,
    /// Start with the probes hidden (P shows them).
    #[arg(long, requires = "probes")]
    hide_probes: bool,
    /// A skinned glTF character (with --character-ldprt, its LDPRT bake) that plays its
    /// first animation through the scene, lit each frame by the probes at its posed position
    /// (docs/guides/characters.md).
    #[arg(long, value_name = "SKINNED.glb", requires_all = ["probes", "character_ldprt"], conflicts_with = "mover")]
    character: Option<PathBuf>,
    /// The character's LDPRT bake (`prt-bake bake SKINNED.glb --transfer ldprt`).
    #[arg(long, value_name = "FILE.ldprt", requires = "character")]
    character_ldprt: Option<PathBuf>,
    /// With an LDPRT file (`prt-bake bake SKINNED.glb --transfer ldprt`) or --character: show
    /// this pose (rest, ANIM@SECONDS, ANIM#KEYFRAME) instead of playing the glTF's first
    /// animation.
    #[arg(long, value_name = "POSE", conflicts_with = "bench")]
    pose: Option<prt_baker::scene::Pose>,
}

#[derive(Clone, Copy, ValueEnum)]
enum ModeArg {
    Prt,
    Phong,
}

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH, e.g. 1280x720, not {text}"))?;
    let parse = |s: &str| match s.trim().parse::<u32>() {
        Ok(n @ 1..=16384) => Ok(n),
        _ => Err(format!("{s} is not a size from 1 to 16384")),
    };
    Ok((parse(w)?, parse(h)?))
}

/// `--path`'s points.
#[derive(Clone)]
struct PathPoints(Vec<glam::Vec3>);

fn parse_path(text: &str) -> Result<PathPoints, String> {
    moving::parse_path(text)
        .map(PathPoints)
        .map_err(|err| err.to_string())
}

fn parse_key(text: &str) -> Result<Key, String> {
    Key::parse(text).ok_or_else(|| {
        format!(
            "unknown key {text} (Up, Down, Left, Right, 1-8, Q, A, W, E, T, N, L, P, F1, F2, Escape)"
        )
    })
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // A panic is a bug, but still ends with one clear line and exit code 1; a screenshot's
    // temporary file is removed as the panic unwinds (prt_baker::support::output).
    prt_baker::support::output::install_panic_hook("prt-view");
    let Ok(result) = std::panic::catch_unwind(|| run(cli)) else {
        return ExitCode::from(EXIT_FAILURE);
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("prt-view: error: {err}");
            ExitCode::from(
                if matches!(err, Error::Baker(prt_baker::Error::Output { .. })) {
                    EXIT_BAD_COMMAND_LINE
                } else if err.is_bad_input() {
                    EXIT_BAD_INPUT
                } else {
                    EXIT_FAILURE
                },
            )
        }
    }
}

fn run(cli: Cli) -> Result<(), Error> {
    let named_inputs: Vec<PathBuf> = [
        Some(&cli.scene),
        Some(&cli.file),
        cli.lights.as_ref(),
        cli.probes.as_ref(),
        cli.mover.as_ref(),
        cli.mover_prt.as_ref(),
        cli.mover_occluder.as_ref(),
        cli.bench_occluder.as_ref(),
        cli.character.as_ref(),
        cli.character_ldprt.as_ref(),
    ]
    .into_iter()
    .flatten()
    .cloned()
    .collect();
    if let Some(path) = &cli.screenshot {
        // Refused before the scene is loaded and the GPU started.
        Output::new(path, &named_inputs)?;
    }
    let (bake, skinned) = if is_ldprt(&cli.file) {
        let (skinned, bake) = Skinned::load(&cli.scene, &cli.file, cli.pose.clone())?;
        (bake, Some(skinned))
    } else if cli.pose.is_some() && cli.character.is_none() {
        return Err(Error::InvalidOption(
            "--pose is for LDPRT files (bake --transfer ldprt)".into(),
        ));
    } else {
        (Bake::load(&cli.scene, &cli.file)?, None)
    };
    if skinned.is_some() && (cli.bench || cli.probes.is_some()) {
        return Err(Error::InvalidOption(
            "an LDPRT file is shown on its own (no --bench, --probes)".into(),
        ));
    }
    let rig = match &cli.lights {
        Some(path) => Rig::load(path)?,
        None => Lights::default_rig(),
    };
    let view = initial_view(&cli, &bake, &rig)?;
    let probes = probe_scene(&cli)?;
    let shadow = match &cli.mover_occluder {
        Some(path) => Some(MoverShadow::new(&bake, OccluderFile::read(path)?)?),
        None => None,
    };
    let walker = match (&cli.character, &cli.character_ldprt) {
        (Some(mesh), Some(ldprt)) => Some(Skinned::open(mesh, ldprt, cli.pose.clone())?),
        _ => None,
    };

    if cli.bench {
        let gpu = Gpu::headless()?;
        let options = BenchOptions {
            size: cli.size,
            frames: cli.bench_frames,
        };
        let also = cli
            .bench_also
            .iter()
            .map(|file| Bake::load(&cli.scene, file))
            .collect::<Result<Vec<_>, _>>()?;
        let occluders = match &cli.bench_occluder {
            Some(path) => Some(bench::BenchOccluders {
                occluder: OccluderFile::read(path)?,
                count: cli.bench_occluders,
            }),
            None => None,
        };
        let report = bench::run_occluded(&gpu, (&bake, &also), occluders.as_ref(), options)?;
        println!("{}", report.table());
        return Ok(());
    }
    if let Some(path) = &cli.screenshot {
        return screenshot(
            &cli,
            path,
            (&bake, probes, shadow, walker),
            &view,
            &rig,
            named_inputs,
        );
    }
    let options = WindowOptions {
        size: cli.size,
        frames: cli.frames,
        keys: cli.keys,
        probes,
        shadow,
        skinned,
        walker,
    };
    let stats = window::run(bake, view, options)?;
    println!(
        "prt-view: {} frames in {:.2} s ({:.1} fps{})",
        stats.frames,
        stats.seconds,
        stats.frames as f64 / stats.seconds.max(1e-9),
        stats.backend.map_or(String::new(), |b| format!(", {b:?}"))
    );
    Ok(())
}

/// The view the command line asks for: the rig's lights turned to the scene's up, the
/// camera given or framing the scene, and the display options. Warns when Blinn-Phong mode
/// cannot show every light.
fn initial_view(cli: &Cli, bake: &Bake, rig: &Rig) -> Result<View, Error> {
    let lights = Lights::from_rig(rig, bake.order()).for_up(bake.up());
    let dropped = lights.phong().dropped;
    if dropped > 0 {
        eprintln!(
            "prt-view: Blinn-Phong mode shows the first {MAX_LIGHTS} directional and hemisphere lights; {dropped} more are left out (PRT shows them all)"
        );
    }
    let framing = Camera::framing(&bake.scene.positions, cli.size.0 as f32 / cli.size.1 as f32);
    let camera = match &cli.camera {
        Some(text) => Camera::parse(text, framing.scale)?,
        None => framing,
    };
    let mut view = View::new(camera, lights);
    view.mode = match cli.mode {
        ModeArg::Prt => Mode::Prt,
        ModeArg::Phong => Mode::Phong,
    };
    view.textures = !cli.no_textures;
    view.normals = cli.normals;
    view.light_vectors = cli.light_vectors;
    view.exposure = cli.exposure;
    Ok(view)
}

/// The probes and the moving object the command line names, loaded.
fn probe_scene(cli: &Cli) -> Result<Option<(Probes, Option<Mover>)>, Error> {
    let Some(path) = &cli.probes else {
        return Ok(None);
    };
    let probes = Probes::load(path)?;
    let mover = match (&cli.mover, &cli.mover_prt, &cli.path) {
        (Some(object), Some(file), Some(points)) => {
            Some(Mover::load(object, file, points.0.clone(), cli.speed)?)
        }
        _ => None,
    };
    Ok(Some((probes, mover)))
}

/// Whether `path` starts with the LDPRT magic (an unreadable file is left to the loader's
/// message).
fn is_ldprt(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; prt_baker::formats::ldprt_file::MAGIC.len()];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && prt_baker::formats::ldprt_file::is_ldprt(&head)
}

/// `--probes` and `--mover`, loaded.
type ProbesAndMover = Option<(Probes, Option<Mover>)>;

/// Renders one frame offscreen to `path`, which must not overwrite any input (the scene's
/// files, those named on the command line, the rig's).
fn screenshot(
    cli: &Cli,
    path: &Path,
    (bake, probes, shadow, walker): (&Bake, ProbesAndMover, Option<MoverShadow>, Option<Skinned>),
    view: &View,
    rig: &Rig,
    named_inputs: Vec<PathBuf>,
) -> Result<(), Error> {
    let mut inputs = bake.scene.input_files();
    inputs.extend(named_inputs);
    if cli.lights.is_some() {
        inputs.extend(rig.input_files());
    }
    let output = Output::new(path, &inputs)?;
    let gpu = Gpu::headless()?;
    let mut renderer = Renderer::new(&gpu.device, &gpu.queue, bake, offscreen::FORMAT, cli.size)?;
    if let Some((probes, mover)) = probes {
        renderer.set_probe_scene(&gpu.device, probes, mover)?;
        let scene = renderer.probe_scene_mut().expect("just set");
        scene.show_probes = !cli.hide_probes;
        scene.distance = cli.mover_at.clamp(0.0, 1.0) * scene.mover().map_or(0.0, |m| m.length());
    }
    if let Some(walker) = walker {
        renderer.set_walker(&gpu.device, walker)?;
    }
    if let Some(shadow) = shadow {
        renderer.set_mover_shadow(&gpu.device, bake, shadow)?;
    }
    let inputs = FrameInputs::from_view(view, None);
    let image = offscreen::render_image(&gpu.device, &gpu.queue, &mut renderer, &inputs)?;
    offscreen::save_png_to(&image, &output)?;
    println!(
        "prt-view: wrote {} ({}×{}, {}, camera {}; {})",
        path.display(),
        cli.size.0,
        cli.size.1,
        view.mode.name(),
        view.camera.to_argument(),
        gpu.description()
    );
    Ok(())
}
