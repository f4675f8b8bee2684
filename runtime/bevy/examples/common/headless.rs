//! What the examples' headless checks share: an app without a window, cameras rendering
//! render layers into sRGB images, their screenshots, and the browser test's comparison
//! (scripts/browser/harness.mjs): the share of covered pixels within a number of codes.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use bevy::app::ScheduleRunnerPlugin;
use bevy::asset::RenderAssetUsages;
use bevy::camera::{Exposure, RenderTarget, visibility::RenderLayers};
use bevy::core_pipeline::tonemapping::{DebandDither, Tonemapping};
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages};
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::window::ExitCondition;

/// An app that renders headless (no window, no ambient light) as fast as it can.
pub fn headless_app() -> App {
    let mut app = App::new();
    let plugins = DefaultPlugins.build();
    // Built with the interactive window too (make bevy builds every target once, with
    // `--features window`): headless, no event loop is opened.
    #[cfg(feature = "window")]
    let plugins = plugins.disable::<bevy::winit::WinitPlugin>();
    app.add_plugins(
        plugins
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                ..default()
            })
            .set(file_assets())
            .set(bevy::render::RenderPlugin {
                synchronous_pipeline_compilation: true,
                ..default()
            }),
    )
    .add_plugins(ScheduleRunnerPlugin::run_loop(Duration::ZERO))
    .insert_resource(GlobalAmbientLight {
        brightness: 0.0,
        ..default()
    });
    app
}

/// The asset server reading files given on the command line: relative to the working
/// directory, wherever they are (`..` allowed), without `.meta` files.
pub fn file_assets() -> AssetPlugin {
    AssetPlugin {
        file_path: std::env::current_dir()
            .map(|d| d.display().to_string())
            .unwrap_or_else(|_| ".".into()),
        unapproved_path_mode: bevy::asset::UnapprovedPathMode::Allow,
        meta_check: bevy::asset::AssetMetaCheck::Never,
        ..default()
    }
}

pub fn fail(message: &str) -> ! {
    eprintln!("bevy_prt: {message}");
    std::process::exit(1);
}

/// A camera rendering render layer `layer` into a new `size`² sRGB image: colours as they
/// are (no tonemapping, dithering or MSAA) and an exposure of 1 for Bevy's lit path
/// (exp2(−ev100)/1.2 = 1), clear transparent (alpha is coverage).
pub fn camera(
    commands: &mut Commands,
    images: &mut Assets<Image>,
    size: u32,
    layer: usize,
    projection: PerspectiveProjection,
    transform: Transform,
) -> Handle<Image> {
    let mut image = Image::new_uninit(
        Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::all(),
    );
    image.texture_descriptor.usage |= TextureUsages::RENDER_ATTACHMENT | TextureUsages::COPY_SRC;
    let handle = images.add(image);
    commands.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::NONE),
            order: layer as isize,
            ..default()
        },
        RenderTarget::Image(handle.clone().into()),
        Projection::Perspective(projection),
        transform,
        Tonemapping::None,
        DebandDither::Disabled,
        Msaa::Off,
        Exposure {
            ev100: -(1.2f32).log2(),
        },
        RenderLayers::layer(layer),
    ));
    handle
}

/// Screenshots of render targets, filled in as they arrive.
#[derive(Resource, Clone, Default)]
pub struct Captures(pub Arc<Mutex<Vec<Option<Image>>>>);

impl Captures {
    /// Asks for a screenshot of each target.
    pub fn request(&self, commands: &mut Commands, targets: &[Handle<Image>]) {
        *self.0.lock().unwrap() = vec![None; targets.len()];
        for (i, target) in targets.iter().enumerate() {
            let store = self.0.clone();
            commands.spawn(Screenshot::image(target.clone())).observe(
                move |captured: On<ScreenshotCaptured>| {
                    store.lock().unwrap()[i] = Some(captured.image.clone());
                },
            );
        }
    }

    /// The RGBA8 pixels of every screenshot, once all have arrived.
    pub fn pixels(&self) -> Option<Vec<Vec<u8>>> {
        let shots = self.0.lock().unwrap();
        if shots.is_empty() || shots.iter().any(Option::is_none) {
            return None;
        }
        Some(
            shots
                .iter()
                .map(|s| {
                    s.as_ref()
                        .and_then(|i| i.data.clone())
                        .expect("screenshot data")
                })
                .collect(),
        )
    }
}

/// Saves RGBA8 pixels as a PNG (alpha kept: it is coverage).
pub fn save(data: &[u8], size: u32, path: &Path) {
    let image = image::RgbaImage::from_raw(size, size, data.to_vec()).expect("screenshot size");
    image
        .save(path)
        .unwrap_or_else(|e| fail(&format!("{}: {e}", path.display())));
}

/// `out` with `-suffix` before its extension.
pub fn beside(out: &Path, suffix: &str) -> PathBuf {
    out.with_file_name(format!(
        "{}-{suffix}.png",
        out.file_stem().unwrap_or_default().to_string_lossy()
    ))
}

/// The comparison of two renders: pixels covered in either, those within `tolerance` codes in
/// every channel and alpha, the worst difference.
pub struct Comparison {
    pub covered: usize,
    pub share: f64,
    pub worst: u8,
}

pub fn compare(a: &[u8], b: &[u8], tolerance: u8) -> Comparison {
    let (mut covered, mut close, mut worst) = (0usize, 0usize, 0u8);
    for (p, q) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        if p[3] == 0 && q[3] == 0 {
            continue;
        }
        covered += 1;
        let d = (0..4).map(|i| p[i].abs_diff(q[i])).max().unwrap_or(0);
        worst = worst.max(d);
        if d <= tolerance {
            close += 1;
        }
    }
    Comparison {
        covered,
        share: close as f64 / covered.max(1) as f64,
        worst,
    }
}
