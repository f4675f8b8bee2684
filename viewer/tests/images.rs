//! Offscreen renders of the demo scene against committed golden images, and steering a light
//! with the controls against a rig that puts it there.
//!
//! The goldens were rendered on Mesa's lavapipe (software Vulkan). Regenerate them, after a
//! deliberate change to what the viewer draws, with
//! `PRT_UPDATE_GOLDENS=1 cargo test --release -p prt-viewer --test images`, and look at them.

mod common;

use std::path::{Path, PathBuf};

use prt_baker::light::Rig;
use prt_viewer::controls::{Key, LIGHT_DEGREES_PER_SECOND};
use prt_viewer::lights::Lights;
use prt_viewer::{Bake, Camera, FrameInputs, Mode, View};

/// Golden images: 320×180, the demo scene from a fixed camera near the torus.
const GOLDEN_SIZE: (u32, u32) = (320, 180);
const GOLDEN_CAMERA: &str = "5,-5,3.5,135,-23";

/// Golden tolerance, in 8-bit sRGB codes. Rasterisers differ within the rules (which pixel an
/// edge shared by two triangles goes to, the order of attribute interpolation, LLVM's code
/// for the shaders on other CPUs and Mesa versions): edge pixels may take the neighbouring
/// triangle's colour and interpolated colours may move by a code. So: a mean absolute
/// difference of at most 2 codes, and at most 1 % of pixels off by more than 8 codes. The
/// sun turned by 5° moves 11–12 % of the pixels by more than 8 codes (measured by
/// `the_golden_tolerance_catches_a_light_turned_by_5_degrees`); a missing texture, swapped
/// channels or the other shading model move far more.
const GOLDEN_MEAN: f64 = 2.0;
const GOLDEN_OUTLIER_CODES: u8 = 8;
const GOLDEN_OUTLIER_FRACTION: f64 = 0.01;

/// Steered against placed lights: the coefficients agree to f64 rounding, so the only
/// differences left are f32 rounding that moves a value across an 8-bit boundary: 1 code.
const STEERING_CODES: u8 = 1;
/// f64 rounding of rotated coefficients (order 4, values ≲ 10).
const STEERING_COEFFICIENTS: f64 = 1e-9;

fn golden_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name)
}

fn golden_view(bake: &Bake, mode: Mode) -> View {
    let camera = Camera::parse(GOLDEN_CAMERA, 5.0).unwrap();
    let mut view = View::new(camera, Lights::load(None, bake.order()).unwrap());
    view.mode = mode;
    view
}

/// Whether `actual` is within the golden tolerance of `expected`.
fn within_golden_tolerance(
    actual: &image::RgbaImage,
    expected: &image::RgbaImage,
) -> (bool, common::Difference) {
    let d = common::difference(actual, expected, GOLDEN_OUTLIER_CODES);
    (
        d.mean <= GOLDEN_MEAN && d.outliers <= GOLDEN_OUTLIER_FRACTION,
        d,
    )
}

fn check_golden(name: &str, actual: &image::RgbaImage) {
    let path = golden_path(name);
    if std::env::var_os("PRT_UPDATE_GOLDENS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        actual.save(&path).unwrap();
        eprintln!("updated {}", path.display());
        return;
    }
    let expected = image::open(&path)
        .unwrap_or_else(|err| panic!("{}: {err} (PRT_UPDATE_GOLDENS=1 makes it)", path.display()))
        .to_rgba8();
    let (ok, d) = within_golden_tolerance(actual, &expected);
    eprintln!(
        "{name}: mean {:.3} codes, max {}, {:.3} % of pixels off by > {GOLDEN_OUTLIER_CODES}",
        d.mean,
        d.max,
        100.0 * d.outliers
    );
    if !ok {
        let failed = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("actual-{name}"));
        actual.save(&failed).unwrap();
        panic!(
            "{name} differs from its golden image beyond the tolerance: {d:?}; this run's image is {}",
            failed.display()
        );
    }
}

#[test]
fn demo_scene_matches_the_golden_images_in_both_modes() {
    let Some(gpu) = common::gpu() else { return };
    let bake = common::demo_bake(4);
    for (mode, name) in [(Mode::Prt, "demo-prt.png"), (Mode::Phong, "demo-phong.png")] {
        let view = golden_view(&bake, mode);
        let image = common::render(
            &gpu,
            &bake,
            &FrameInputs::from_view(&view, None),
            GOLDEN_SIZE,
        );
        check_golden(name, &image);
    }
}

/// The tolerance is not so loose that it would pass a wrong image.
#[test]
fn the_golden_tolerance_catches_a_light_turned_by_5_degrees() {
    let Some(gpu) = common::gpu() else { return };
    let bake = common::demo_bake(4);
    for mode in [Mode::Prt, Mode::Phong] {
        let view = golden_view(&bake, mode);
        let reference = common::render(
            &gpu,
            &bake,
            &FrameInputs::from_view(&view, None),
            GOLDEN_SIZE,
        );
        let mut turned = view.clone();
        turned.turn_light(5f64.to_radians(), 0.0);
        let image = common::render(
            &gpu,
            &bake,
            &FrameInputs::from_view(&turned, None),
            GOLDEN_SIZE,
        );
        let (ok, d) = within_golden_tolerance(&image, &reference);
        eprintln!("{}, sun 5° lower: {d:?}", mode.name());
        assert!(
            !ok,
            "{}: a light turned by 5° passes as the same image: {d:?}",
            mode.name()
        );
    }
}

/// A rig with the sun at (θ, φ) in degrees, a sky, and an environment map turned by ZYZ
/// angles `rotation` (degrees).
fn rig(folder: &Path, theta: f64, phi: f64, rotation: [f64; 3]) -> Rig {
    let text = format!(
        r#"
        [[light]]
        kind = "sun"
        theta = {theta}
        phi = {phi}
        intensity = 2.5
        [[light]]
        kind = "environment"
        path = "map.hdr"
        rotation = [{}, {}, {}]
        [[light]]
        kind = "hemisphere"
        color = [0.15, 0.2, 0.3]
        "#,
        rotation[0], rotation[1], rotation[2]
    );
    Rig::parse(&text, &folder.join("rig.toml")).unwrap()
}

/// An environment map with one bright warm patch, so that turning it shows.
fn write_map(folder: &Path) {
    let (w, h) = (32u32, 16u32);
    let map = image::Rgb32FImage::from_fn(w, h, |x, y| {
        if (4..8).contains(&x) && (3..6).contains(&y) {
            image::Rgb([8.0, 6.0, 3.0])
        } else {
            image::Rgb([0.05, 0.05, 0.06])
        }
    });
    image::DynamicImage::ImageRgb32F(map)
        .save(folder.join("map.hdr"))
        .unwrap();
}

/// Holding keys for `seconds` in steps of `dt`.
fn hold(view: &mut View, keys: &[Key], seconds: f64, dt: f64) {
    for &key in keys {
        view.key(key, true);
    }
    for _ in 0..(seconds / dt).round() as u32 {
        view.advance(dt);
    }
    for &key in keys {
        view.key(key, false);
    }
}

#[test]
fn steering_lights_with_the_controls_equals_a_rig_that_places_them() {
    let Some(gpu) = common::gpu() else { return };
    let folder = tempfile::tempdir().unwrap();
    write_map(folder.path());
    let bake = common::demo_bake(4);
    let order = bake.order();
    let camera = Camera::parse(GOLDEN_CAMERA, 5.0).unwrap();

    // Steer: the sun from (40°, −20°) by Q for 0.5 s and W for 1 s; the environment (light 2)
    // from its rig placement by Q for 1 s and E for 2 s.
    let (theta0, phi0) = (40.0, -20.0);
    let mut steered = View::new(
        camera,
        Lights::from_rig(&rig(folder.path(), theta0, phi0, [0.0; 3]), order),
    );
    hold(&mut steered, &[Key::Q], 0.5, 0.05);
    hold(&mut steered, &[Key::W], 1.0, 0.05);
    steered.key(Key::Digit(2), true);
    hold(&mut steered, &[Key::Q], 1.0, 0.1);
    hold(&mut steered, &[Key::E], 2.0, 0.1);

    // The rate is exact in degrees, so the rig can name where the lights went.
    let rate = LIGHT_DEGREES_PER_SECOND;
    let (sun_theta, sun_phi) = (theta0 + 0.5 * rate, phi0 + rate);
    let (map_theta, map_phi) = (rate, -2.0 * rate);
    let placed_rig = rig(folder.path(), sun_theta, sun_phi, [0.0, map_theta, map_phi]);
    let placed = View::new(camera, Lights::from_rig(&placed_rig, order));

    // The coefficients: the steered sum against the rig's own projection (which evaluates the
    // sun at its direction and turns the map by the rotation matrix, no steering involved).
    let steered_light = steered.lights.prt();
    let projected = placed_rig.project(order);
    for (a, b) in steered_light.rgb.iter().zip(&projected.rgb) {
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < STEERING_COEFFICIENTS, "{x} vs {y}");
        }
    }

    for mode in [Mode::Prt, Mode::Phong] {
        let mut a = steered.clone();
        a.mode = mode;
        let mut b = placed.clone();
        b.mode = mode;
        let mut placed_inputs = FrameInputs::from_view(&b, None);
        placed_inputs.prt_light = projected.clone();
        let image_a = common::render(&gpu, &bake, &FrameInputs::from_view(&a, None), GOLDEN_SIZE);
        let image_b = common::render(&gpu, &bake, &placed_inputs, GOLDEN_SIZE);
        let d = common::difference(&image_a, &image_b, STEERING_CODES);
        eprintln!("{}: steered vs placed {d:?}", mode.name());
        assert!(d.max <= STEERING_CODES, "{}: {d:?}", mode.name());
        // And the steering did something: the unsteered rig looks different.
        let unsteered = View::new(
            camera,
            Lights::from_rig(&rig(folder.path(), theta0, phi0, [0.0; 3]), order),
        );
        let mut c = unsteered;
        c.mode = mode;
        let image_c = common::render(&gpu, &bake, &FrameInputs::from_view(&c, None), GOLDEN_SIZE);
        let moved = common::difference(&image_a, &image_c, STEERING_CODES);
        assert!(
            moved.mean > 1.0,
            "{}: steering changed nothing: {moved:?}",
            mode.name()
        );
    }
}
