//! Lights against closed forms (oracles.md, "Lights"): projections of constant, directional,
//! sun, sphere and hemisphere lights and of environment maps written by the test as `.hdr`
//! and `.exr`; the intensity convention through the irradiance of a floor; ringing control;
//! and `relight` of a baked floor against the analytic radiance, with the SH truncation error
//! of the order computed and stated.
//!
//! Independent references: `sh::eval_slow` (the thesis's trigonometric formulas) and the
//! quadratures of `prt_tests` — nothing here goes through the code under test twice.

use std::f64::consts::PI;
use std::path::Path;

use glam::{DMat3, DVec3};
use prt_baker::CoefficientFile;
use prt_baker::light::{EnvironmentMap, Light, LightCoefficients, Rig, Window};
use prt_baker::math::sh;
use prt_tests::*;

/// f64 rounding of sums of up to ~10⁴ terms of size ≲ 10 (map pixels, quadrature nodes):
/// ≲ 10⁴·10·2⁻⁵² ≈ 2e-11; twice that.
const ROUNDING: f64 = 5e-11;

fn direction(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// The largest difference of the RGB coefficients from `colour[c] · grey[j]`.
fn max_difference(c: &LightCoefficients, grey: &[f64], colour: DVec3) -> f64 {
    c.rgb
        .iter()
        .zip(colour.to_array())
        .flat_map(|(channel, k)| {
            channel
                .iter()
                .zip(grey)
                .map(move |(x, g)| (x - k * g).abs())
        })
        .fold(0.0, f64::max)
}

// ---------------------------------------------------------------------------------------------
// Environment maps

/// Writes a map as Radiance `.hdr` and OpenEXR `.exr` through the `image` crate.
fn write_maps(folder: &Path, width: usize, height: usize, pixels: &[[f32; 3]]) {
    let buffer = image::Rgb32FImage::from_fn(width as u32, height as u32, |x, y| {
        image::Rgb(pixels[y as usize * width + x as usize])
    });
    let image = image::DynamicImage::ImageRgb32F(buffer);
    image.save(folder.join("map.hdr")).expect("write map.hdr");
    image.save(folder.join("map.exr")).expect("write map.exr");
}

/// Loads both files back, checks they hold exactly `pixels`, and returns the .hdr's map.
fn load_maps(
    folder: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> [EnvironmentMap; 2] {
    ["map.hdr", "map.exr"].map(|name| {
        let map = EnvironmentMap::load(&folder.join(name)).expect("load the map");
        assert_eq!((map.width(), map.height()), (width, height), "{name}");
        // The values are dyadic with few bits, so RGBE's 8-bit mantissas and EXR's floats
        // store them exactly: any difference below comes from the projection alone.
        for y in 0..height {
            for x in 0..width {
                assert_eq!(map.pixel(x, y), pixels[y * width + x], "{name} ({x}, {y})");
            }
        }
        map
    })
}

#[test]
fn constant_environment_projects_to_the_dc_term_only() {
    let folder = tempfile::tempdir().unwrap();
    let radiance = [0.5f32, 1.25, 2.0];
    let (w, h) = (64, 32);
    let pixels = vec![radiance; w * h];
    write_maps(folder.path(), w, h, &pixels);
    let mut maps = load_maps(folder.path(), w, h, &pixels).to_vec();
    maps.push(EnvironmentMap::new(7, 3, vec![radiance; 21]));
    let order = 8;
    let mut dc_only = vec![0.0; sh::coeff_count(order)];
    dc_only[0] = (4.0 * PI).sqrt();
    for map in maps {
        let c = map.project(order);
        let d = max_difference(&c, &dc_only, DVec3::from(radiance.map(f64::from)));
        assert!(d < ROUNDING, "{}×{}: {d:e}", map.width(), map.height());
    }
}

/// A 16×8 map: sky above the horizon, ground below, and a bright window over
/// θ ∈ [45°, 90°], φ ∈ [0°, 90°] — columns 4..8, rows 2..4 by the documented orientation
/// (u = ½ − φ/2π, top row at +z). Its exact coefficients are sums of quadratures over those
/// regions; the projection treats pixels as constant over their rectangles, so the two agree
/// to rounding, and a mirrored or shifted orientation would not.
#[test]
fn hdr_and_exr_files_with_known_content_project_to_the_known_coefficients() {
    let (w, h) = (16, 8);
    let sky = [2.0f32, 1.0, 0.5];
    let ground = [0.25f32, 0.25, 0.25];
    let window = [8.0f32, 4.0, 2.0];
    let pixels: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            match (x, y) {
                (4..8, 2..4) => window,
                (_, 0..4) => sky,
                _ => ground,
            }
        })
        .collect();
    let folder = tempfile::tempdir().unwrap();
    write_maps(folder.path(), w, h, &pixels);

    let order = 8;
    // ∫∫ y sin θ dθ dφ over a θ–φ rectangle, by Gauss–Legendre in both (exact to rounding for
    // these smooth integrands of degree < 10 on intervals ≤ π).
    let rectangle = |theta: (f64, f64), phi: (f64, f64)| -> Vec<f64> {
        let (nodes, weights) = sh::gauss_legendre(30);
        let mut c = vec![0.0; sh::coeff_count(order)];
        for (a, wa) in nodes.iter().zip(&weights) {
            let t = theta.0 + 0.5 * (theta.1 - theta.0) * (a + 1.0);
            for (b, wb) in nodes.iter().zip(&weights) {
                let p = phi.0 + 0.5 * (phi.1 - phi.0) * (b + 1.0);
                let weight = wa * wb * 0.25 * (theta.1 - theta.0) * (phi.1 - phi.0) * t.sin();
                for (j, c) in c.iter_mut().enumerate() {
                    let (l, m) = sh::band_and_m(j);
                    *c += weight * sh::eval_slow(l, m, t, p);
                }
            }
        }
        c
    };
    let upper = rectangle((0.0, PI / 2.0), (-PI, PI));
    let lower = rectangle((PI / 2.0, PI), (-PI, PI));
    let pane = rectangle((PI / 4.0, PI / 2.0), (0.0, PI / 2.0));
    let expected: Vec<Vec<f64>> = (0..3)
        .map(|c| {
            let (s, g, wn) = (
                f64::from(sky[c]),
                f64::from(ground[c]),
                f64::from(window[c]),
            );
            (0..upper.len())
                .map(|j| s * upper[j] + g * lower[j] + (wn - s) * pane[j])
                .collect()
        })
        .collect();
    for map in load_maps(folder.path(), w, h, &pixels) {
        let got = map.project(order);
        let d = got
            .rgb
            .iter()
            .zip(&expected)
            .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
            .fold(0.0, f64::max);
        eprintln!("16×8 map with a window: max coefficient error {d:.2e}");
        assert!(d < ROUNDING, "{d:e}");
    }
}

#[test]
fn a_rotated_environment_is_the_rotated_projection() {
    // Constant sky above, black below: a hemisphere light about +z, through both paths.
    let (w, h) = (32, 16);
    let pixels: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            if i / w < h / 2 {
                [1.0, 2.0, 3.0]
            } else {
                [0.0; 3]
            }
        })
        .collect();
    let map = std::sync::Arc::new(EnvironmentMap::new(w, h, pixels));
    let r = DMat3::from_axis_angle(DVec3::new(1.0, -2.0, 0.5).normalize(), 1.1);
    let order = 6;
    let environment = Light::Environment {
        map,
        scale: DVec3::splat(0.5),
        rotation: r,
    }
    .project(order);
    let hemisphere = Light::Hemisphere {
        up: r * DVec3::Z,
        sky: DVec3::new(0.5, 1.0, 1.5),
        ground: DVec3::ZERO,
    }
    .project(order);
    for (a, b) in environment.rgb.iter().zip(&hemisphere.rgb) {
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < ROUNDING, "{x} vs {y}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Analytic lights

#[test]
fn directional_light_is_irradiance_times_the_basis() {
    let order = 8;
    let colour = DVec3::new(2.0, 1.0, 0.5);
    for (theta, phi) in [
        (0.0, 0.0),
        (0.7, -2.0),
        (PI / 2.0, 1.0),
        (2.5, 3.0),
        (PI, 0.0),
    ] {
        let c = Light::Directional {
            direction: direction(theta, phi),
            irradiance: colour,
        }
        .project(order);
        let y: Vec<f64> = (0..sh::coeff_count(order))
            .map(|j| {
                let (l, m) = sh::band_and_m(j);
                sh::eval_slow(l, m, theta, phi)
            })
            .collect();
        let d = max_difference(&c, &y, colour);
        assert!(d < ROUNDING, "({theta}, {phi}): {d:e}");
    }
}

/// Disk lights (sun, sphere) and the hemisphere sky against quadratures of their definitions,
/// about tilted axes: the closed-form zonal coefficients and their rotation.
#[test]
fn disk_and_hemisphere_lights_equal_quadratures_of_their_radiance() {
    let order = 8;
    let axis = DVec3::new(0.3, -0.2, 0.9).normalize();
    let colour = DVec3::new(1.0, 0.6, 0.3);
    for delta in [0.05f64, 0.5, 1.2] {
        // Sun: irradiance E on a facing surface, so radiance E/(π sin²δ) over the disk.
        let disk = band_projection(order, axis, delta.cos(), 1.0);
        let sun = Light::Sun {
            direction: axis,
            irradiance: colour,
            angular_radius: delta,
        }
        .project(order);
        let radiance = 1.0 / (PI * delta.sin().powi(2));
        let want: Vec<f64> = disk.iter().map(|c| c * radiance).collect();
        // Quadrature of a thin disk loses digits in 1 − cos δ; scale the bound with 1/sin²δ.
        let bound = ROUNDING * radiance.max(1.0);
        let d = max_difference(&sun, &want, colour);
        assert!(d < bound, "sun δ = {delta}: {d:e}");
        // Sphere: radiance L itself.
        let sphere = Light::Sphere {
            direction: axis,
            radiance: colour,
            angular_radius: delta,
        }
        .project(order);
        let d = max_difference(&sphere, &disk, colour);
        assert!(d < ROUNDING, "sphere δ = {delta}: {d:e}");
    }
    let (sky, ground) = (DVec3::new(0.4, 0.5, 0.9), DVec3::new(0.2, 0.15, 0.1));
    let hemisphere = Light::Hemisphere {
        up: axis,
        sky,
        ground,
    }
    .project(order);
    let upper = band_projection(order, axis, 0.0, 1.0);
    let lower = band_projection(order, axis, -1.0, 0.0);
    for (c, channel) in hemisphere.rgb.iter().enumerate() {
        for (j, x) in channel.iter().enumerate() {
            let want = sky[c] * upper[j] + ground[c] * lower[j];
            assert!(
                (x - want).abs() < ROUNDING,
                "hemisphere {c} {j}: {x} vs {want}"
            );
        }
    }
}

/// A sun's coefficients are the directional light's with band l scaled by g_l(δ). With
/// u = 1 − cos δ, g_l = 2P_l′(1 − u)/(l(l+1)) is a polynomial in u whose Taylor terms
/// alternate and shrink while u·(l+2)² < 1, so g_l = 1 − (l−1)(l+2)u/4 up to at most the next
/// term, (l+3)(l+2)(l−1)(l−2)u²/48 (from P_l^{(k)}(1) = (l+k)!/((l−k)! 2^k k!)); for l = 0,
/// g_0 = 2/(2 − u) = 1 + u/2 + …, within u²/2 for u ≤ 1. The test checks both the limit and
/// its leading-order rate, for δ from 0.1 down to 10⁻⁴ and at δ = 0 exactly.
#[test]
fn sun_of_vanishing_radius_approaches_the_directional_light() {
    let order = 8;
    let d = direction(0.8, 2.1);
    let colour = DVec3::new(1.0, 0.5, 0.25);
    let directional = Light::Directional {
        direction: d,
        irradiance: colour,
    }
    .project(order);
    for delta in [0.1f64, 0.01, 1e-3, 1e-4, 0.0] {
        let sun = Light::Sun {
            direction: d,
            irradiance: colour,
            angular_radius: delta,
        }
        .project(order);
        let u = 2.0 * (0.5 * delta).sin().powi(2);
        let mut worst = 0.0f64;
        for (sc, dc) in sun.rgb.iter().zip(&directional.rgb) {
            for (j, (s, x)) in sc.iter().zip(dc).enumerate() {
                let l = sh::band_and_m(j).0 as f64;
                let leading = -(l - 1.0) * (l + 2.0) * u / 4.0;
                let next = if l == 0.0 {
                    u * u / 2.0
                } else {
                    (l + 3.0) * (l + 2.0) * (l - 1.0) * (l - 2.0) * u * u / 48.0
                };
                let error = (s - x * (1.0 + leading)).abs();
                assert!(
                    error <= x.abs() * next.abs() + 1e-15,
                    "δ = {delta}, l = {l}: sun {s}, directional {x}, leading term {leading:e}"
                );
                worst = worst.max((s - x).abs());
            }
        }
        eprintln!("sun of radius {delta}: max |sun − directional| = {worst:.3e}");
        if delta == 0.0 {
            assert_eq!(worst, 0.0);
        }
    }
}

/// A light at the zenith over an unoccluded floor: the floor's irradiance through SH,
/// π·Σ_j T_j c_j with the clamped-cosine transfer T of oracles.md, against the analytic
/// irradiance — E for a sun (its intensity is defined as that), πL·sin²δ for a sphere.
///
/// Only the zonal terms meet, so the order-n result is Σ_{l<n} z_l·s_l (z_l the clamped
/// cosine's, s_l the light's zonal coefficients) and the truncation error is the rest of the
/// series, bounded by Cauchy–Schwarz and Parseval without summing it:
/// |Σ_{l≥n} z_l s_l| ≤ √(2π/3 − Σ_{l<n} z_l²) · √(‖L‖² − Σ_{l<n} s_l²), where 2π/3 = ∫ max(cos, 0)²
/// and ‖L‖² = L²·2π(1 − cos δ). The s_l come from quadrature, not from the code under test.
#[test]
fn light_at_the_zenith_gives_the_analytic_irradiance_of_a_floor() {
    for order in [4, 8] {
        let floor: Vec<f64> = (0..sh::coeff_count(order))
            .map(|j| {
                let (l, m) = sh::band_and_m(j);
                if m == 0 { clamped_cosine_zonal(l) } else { 0.0 }
            })
            .collect();
        let z2: f64 = (0..order).map(|l| clamped_cosine_zonal(l).powi(2)).sum();
        for delta in [0.1f64, 0.5, 1.0] {
            for (what, light, radiance, analytic) in [
                (
                    "sun",
                    Light::Sun {
                        direction: DVec3::Z,
                        irradiance: DVec3::splat(2.0),
                        angular_radius: delta,
                    },
                    2.0 / (PI * delta.sin().powi(2)),
                    2.0,
                ),
                (
                    "sphere",
                    Light::Sphere {
                        direction: DVec3::Z,
                        radiance: DVec3::splat(3.0),
                        angular_radius: delta,
                    },
                    3.0,
                    3.0 * PI * delta.sin().powi(2),
                ),
            ] {
                let c = light.project(order);
                let irradiance: f64 = floor.iter().zip(&c.rgb[0]).map(|(t, c)| t * c).sum();
                let disk = band_projection(order, DVec3::Z, delta.cos(), 1.0);
                let s2: f64 = (0..order)
                    .map(|l| (radiance * disk[sh::index(l, 0)]).powi(2))
                    .sum();
                let norm2 = radiance * radiance * disk_solid_angle(delta);
                let truncation = ((2.0 * PI / 3.0 - z2).max(0.0) * (norm2 - s2).max(0.0)).sqrt();
                let error = (irradiance - analytic).abs();
                eprintln!(
                    "{what} δ = {delta}, order {order}: irradiance {irradiance:.6} vs {analytic:.6}, \
                     error {error:.2e} ≤ truncation bound {truncation:.2e}"
                );
                assert!(
                    error <= truncation + ROUNDING,
                    "{what} δ = {delta}, order {order}"
                );
            }
        }
    }
}

/// 2π(1 − cos δ), the solid angle of a disk of angular radius δ, without cancellation.
fn disk_solid_angle(delta: f64) -> f64 {
    4.0 * PI * (0.5 * delta).sin().powi(2)
}

/// Windowing trades ringing for blur: a directional light reconstructed from its order-8
/// coefficients dips below zero away from the light; a Hanning or Lanczos window makes the
/// dip shallower, keeps the DC term, and lowers the peak.
#[test]
fn windows_reduce_the_ringing_of_a_directional_light() {
    let order = 8;
    let light = Light::Directional {
        direction: DVec3::Z,
        irradiance: DVec3::ONE,
    }
    .project(order);
    // The reconstruction along θ (it is zonal about +z).
    let profile = |c: &LightCoefficients| -> (f64, f64) {
        let (mut lowest, mut peak) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..=720 {
            let t = (PI * k as f64 / 720.0).cos();
            let value: f64 = (0..order)
                .map(|l| {
                    c.rgb[0][sh::index(l, 0)] * sh::normalization(l, 0) * sh::legendre(l, 0, t)
                })
                .sum();
            lowest = lowest.min(value);
            peak = peak.max(value);
        }
        (lowest, peak)
    };
    let (plain_low, plain_peak) = profile(&light);
    assert!(
        plain_low < 0.0,
        "the truncated delta rings below zero: {plain_low}"
    );
    for window in [
        Window::Hanning { width: None },
        Window::Lanczos { width: None },
    ] {
        let mut windowed = light.clone();
        windowed.scale_bands(&window.factors(order));
        let (low, peak) = profile(&windowed);
        eprintln!(
            "{}: lowest {low:.4} (plain {plain_low:.4}), peak {peak:.3} (plain {plain_peak:.3})",
            window.name()
        );
        assert!(low > plain_low && peak < plain_peak, "{window:?}");
        assert_eq!(windowed.rgb[0][0], light.rgb[0][0]);
    }
}

/// The example rig of docs/reference/lights.md parses as printed (its map is written beside it).
#[test]
fn the_documented_example_rig_parses() {
    let docs = include_str!("../docs/reference/lights.md");
    let start = docs.find("```toml\nwindow").expect("the example rig") + "```toml\n".len();
    let rig = &docs[start..start + docs[start..].find("```").unwrap()];
    let folder = tempfile::tempdir().unwrap();
    write_maps(folder.path(), 8, 4, &[[1.0, 1.0, 1.0]; 32]);
    std::fs::rename(
        folder.path().join("map.exr"),
        folder.path().join("studio.exr"),
    )
    .unwrap();
    let path = folder.path().join("rig.toml");
    std::fs::write(&path, rig).unwrap();
    let rig = Rig::load(&path).unwrap_or_else(|err| panic!("{err}"));
    assert_eq!(rig.lights.len(), 6);
    assert_eq!(rig.window, Window::Hanning { width: None });
}

// ---------------------------------------------------------------------------------------------
// Relighting a baked floor

/// `relight` of a baked, unoccluded floor under a directional light against the analytic
/// radiance ρ·E·max(cos θ, 0)/π.
///
/// Through SH the floor's exact transfer and the light meet band by band (Σ_m y_lm(n)y_lm(d)
/// = (2l+1)/(4π)·P_l(n·d)), so at order n the radiance is ρE/π·K_n(cos θ) with
/// K_n(t) = Σ_{l<n} z_l·N_l·P_l(t) (z_l the clamped cosine's zonal coefficients, N_l the
/// zonal normalisation). The truncation error ρE/π·|K_n − max(t, 0)| is computed per light
/// angle, printed, and allowed, plus the bake's Monte Carlo error.
///
/// The Monte Carlo error: with V = 1 the baked Σ_j T_j c_j is exactly an N-sample
/// cosine-weighted estimate of ∫ L_n(s) cos/π, L_n = Σ_j c_j y_j the light's truncated
/// reconstruction, so the radiance's per-sample variance is that of L_n under the cosine
/// lobe (computed by quadrature) and `prt_tests`' rule turns it into a tolerance; f32
/// storage adds at most [`FLOAT_SLACK`] per coefficient, weighted by |c_j|.
#[test]
fn relight_of_an_unoccluded_floor_matches_the_analytic_radiance() {
    let folder = tempfile::tempdir().unwrap();
    let obj = folder.path().join("floor.obj");
    std::fs::write(
        &obj,
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nv 0 0 0\nvn 0 0 1\n\
         f 1//1 2//1 5//1\nf 2//1 3//1 5//1\nf 3//1 4//1 5//1\nf 4//1 1//1 5//1\n",
    )
    .unwrap();
    let scene = prt_baker::Scene::load(&obj).unwrap();
    let albedo = f64::from(prt_baker::scene::DEFAULT_KD.x);
    let colour = DVec3::new(1.0, 0.5, 0.25);
    let irradiance = 2.0;
    // 2^18 rays: the sample table of an order-8 bake then takes 70 MB, and the Monte Carlo
    // bound (order 4: 4e-3 to 1.2e-2) falls below the truncation error at most order-4 angles,
    // so the comparison with the analytic radiance is not swamped by it.
    let samples = 1 << 18;
    for order in [4, 8] {
        let options = shadowed(order, samples);
        let tracer = prt_baker::trace::build(
            prt_baker::trace::Backend::DEFAULT,
            &scene,
            prt_baker::trace::TracerOptions::default(),
        )
        .unwrap();
        let transfer = prt_baker::bake(
            &scene,
            Some(tracer.as_ref()),
            &options,
            &prt_baker::support::progress::Silent,
        )
        .unwrap();
        let prt = folder.path().join("floor.prt");
        CoefficientFile::from_bake(&scene, &transfer)
            .write(&prt)
            .unwrap();
        for (theta_deg, phi_deg) in [
            (0.0, 0.0),
            (30.0, 40.0),
            (60.0, -100.0),
            (89.0, 10.0),
            (120.0, 200.0),
        ] {
            let rig = folder.path().join("rig.toml");
            std::fs::write(
                &rig,
                format!(
                    "[[light]]\nkind = \"directional\"\ntheta = {theta_deg}\nphi = {phi_deg}\n\
                     color = [{}, {}, {}]\nintensity = {irradiance}\n",
                    colour.x, colour.y, colour.z
                ),
            )
            .unwrap();
            let ply = folder.path().join("floor.ply");
            prt_baker::export::relight::relight(&obj, &prt, &rig, &ply, 0.0).unwrap();
            let radiance = read_ply_radiance(&std::fs::read(&ply).unwrap(), scene.vertex_count());

            let t = f64::to_radians(theta_deg).cos();
            let truncated: f64 = (0..order)
                .map(|l| clamped_cosine_zonal(l) * sh::normalization(l, 0) * sh::legendre(l, 0, t))
                .sum();
            let light = Rig::load(&rig).unwrap().project(order);
            let mut worst = 0.0f64;
            for c in 0..3 {
                let scale = albedo * irradiance * colour[c] / PI;
                let analytic = scale * t.max(0.0);
                let truncation = scale * (truncated - t.max(0.0)).abs();
                let (mut mean, mut second) = (0.0, 0.0);
                band_quadrature(order, DVec3::Z, 0.0, 1.0, |w, t, y| {
                    let value: f64 = y.iter().zip(&light.rgb[c]).map(|(y, c)| y * c).sum();
                    mean += w * t / PI * value;
                    second += w * t / PI * value * value;
                });
                assert!((albedo * mean - scale * truncated).abs() < ROUNDING);
                let sum_abs: f64 = light.rgb[c].iter().map(|x| x.abs()).sum();
                let monte_carlo = albedo
                    * (Z * (NET_VARIANCE_FACTOR * (second - mean * mean) / f64::from(samples))
                        .sqrt()
                        + FLOAT_SLACK * sum_abs);
                for (v, r) in radiance.iter().enumerate() {
                    let got = f64::from(r[c]);
                    assert!(
                        (got - scale * truncated).abs() <= monte_carlo,
                        "order {order}, θ = {theta_deg}°, vertex {v}, channel {c}: {got} vs truncated {} ± {monte_carlo:.2e}",
                        scale * truncated
                    );
                    assert!(
                        (got - analytic).abs() <= truncation + monte_carlo,
                        "order {order}, θ = {theta_deg}°, vertex {v}, channel {c}"
                    );
                    worst = worst.max((got - scale * truncated).abs() / monte_carlo);
                }
                if c == 0 {
                    eprintln!(
                        "order {order}, θ = {theta_deg:>5}°: analytic {analytic:.5}, SH {:.5}, \
                         truncation error {truncation:.2e}, Monte Carlo bound {monte_carlo:.2e}",
                        scale * truncated
                    );
                }
            }
            eprintln!("    worst vertex at {worst:.1e} of its Monte Carlo bound");
        }
    }
}
