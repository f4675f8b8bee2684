//! Transfer-probe oracles: `bake --probes` through the real estimator and Embree,
//! at order 4 with 16,384 rays per probe, within 0.01 per matrix entry.
//!
//! * the held-out oracle: probes on the axis of a one-sided disk, above and below it, see the
//!   disk as a cone of directions taken from the sphere: M = I − C, C the cap's matrix
//!   ∫_cap y_i y_j, here in closed form: about +z it is diagonal in m, C = δ_mm′ · 2π K_l^m
//!   K_l′^m ∫_{cos α}^1 P_l^m P_l′^m dt (a polynomial integral, done exactly), and about −z
//!   it is (−1)^(l+l′) times that (y_lm(−s) = (−1)^l y_lm(s));
//! * an unblocked probe sees the sphere: M = I;
//! * a tilted disk (the cap straddles the two hemispheres a probe is baked as): I − C by
//!   quadrature about the tilted axis;
//! * interreflected, the one-sided disk (albedo ρ, facing −z): from above (its back) nothing
//!   comes back, M = I − C; from below the cap brings ρ·T(h), T the disk's own transfer, the
//!   clamped cosine about −z over π: M = I − C + ρ·(∫_cap y_i)·ĉ_j/π.

use glam::{DVec3, Vec3};
use prt_baker::bake::options::TransferKind;
use prt_baker::bake::probes;
use prt_baker::math::sh;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, Mode, Scene};
use prt_tests::*;

const ORDER: usize = 4;
const SAMPLES: u32 = 16_384;
/// The required tolerance per matrix entry.
const TOLERANCE: f64 = 0.01;

/// The probes' matrices (per probe, per channel: n⁴, row-major) through Embree.
fn bake_probes(scene: &Scene, mode: Mode, positions: &[Vec3]) -> Vec<Vec<Vec<f64>>> {
    let options = BakeOptions {
        transfer: TransferKind::Matrix,
        mode,
        bounces: u32::from(mode == Mode::Interreflected),
        ..shadowed(ORDER, SAMPLES)
    };
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("embree scene");
    let transfer =
        probes::bake(scene, Some(&tracer), &options, positions, &Silent).expect("probe bake");
    let n = sh::coeff_count(ORDER);
    let per_probe = transfer.channels * n * n;
    assert_eq!(transfer.coefficients.len(), positions.len() * per_probe);
    transfer
        .coefficients
        .chunks_exact(per_probe)
        .map(|p| {
            p.chunks_exact(n * n)
                .map(|c| c.iter().map(|&x| f64::from(x)).collect())
                .collect()
        })
        .collect()
}

/// P_l^m(t) for m ≥ 0, without the Condon–Shortley phase (it cancels in C's products).
fn legendre(l: usize, m: usize, t: f64) -> f64 {
    let mut pmm =
        (1..=m).fold(1.0, |p, k| p * (2 * k - 1) as f64) * (1.0 - t * t).powf(m as f64 / 2.0);
    if l == m {
        return pmm;
    }
    let mut pm1 = t * (2 * m + 1) as f64 * pmm;
    for k in m + 2..=l {
        let next = ((2 * k - 1) as f64 * t * pm1 - (k + m - 1) as f64 * pmm) / (k - m) as f64;
        pmm = pm1;
        pm1 = next;
    }
    pm1
}

fn factorial(k: usize) -> f64 {
    (1..=k).map(|x| x as f64).product()
}

/// K_l^m = √((2l+1)/(4π) · (l−m)!/(l+m)!).
fn k_lm(l: usize, m: usize) -> f64 {
    ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * factorial(l - m) / factorial(l + m)).sqrt()
}

/// ∫_a^b f by composite Simpson's rule on 4096 panels: P_l^m P_l′^m (polynomials of degree
/// ≤ 6 at order 4) to about 1e−14.
fn integrate(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    let panels = 4096;
    let h = (b - a) / panels as f64;
    (0..panels)
        .map(|k| {
            let x = a + h * k as f64;
            h / 6.0 * (f(x) + 4.0 * f(x + 0.5 * h) + f(x + h))
        })
        .sum()
}

/// The cap's matrix ∫ y_i y_j over the directions within α of +z (`up`) or of −z, in closed
/// form (the module doc), from cos α.
fn cap_matrix(cos_alpha: f64, up: bool) -> Vec<f64> {
    let n = sh::coeff_count(ORDER);
    let mut c = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            let ((l, m), (l2, m2)) = (sh::band_and_m(i), sh::band_and_m(j));
            if m != m2 {
                continue;
            }
            let a = m.unsigned_abs() as usize;
            let integral = integrate(cos_alpha, 1.0, |t| legendre(l, a, t) * legendre(l2, a, t));
            let sign = if up || (l + l2) % 2 == 0 { 1.0 } else { -1.0 };
            c[i * n + j] = sign * std::f64::consts::TAU * k_lm(l, a) * k_lm(l2, a) * integral;
        }
    }
    c
}

/// I − `c`.
fn identity_minus(c: &[f64]) -> Vec<f64> {
    let n = sh::coeff_count(ORDER);
    (0..n * n)
        .map(|k| f64::from(u8::from(k / n == k % n)) - c[k])
        .collect()
}

/// The largest |got − expected| entry, printed; fails beyond [`TOLERANCE`].
fn assert_close(what: &str, got: &[f64], expected: &[f64]) {
    assert_entries_close(what, got, expected, sh::coeff_count(ORDER), TOLERANCE);
}

/// A one-sided disk of radius 1 at z = 0, facing −z (`disk`'s winding and normals).
fn disk_scene(kd: Option<Vec3>) -> Scene {
    let mut mesh = disk(Vec3::ZERO, 1.0, 512);
    if let Some(kd) = kd {
        mesh.material = prt_baker::scene::Material {
            name: "disk".into(),
            kd,
            ..Default::default()
        };
    }
    scene(vec![mesh])
}

/// cos α of the disk of radius 1 seen from distance h on its axis.
fn cos_alpha(h: f64) -> f64 {
    h / (1.0 + h * h).sqrt()
}

#[test]
fn the_closed_form_cap_is_the_quadratures() {
    // The closed form against the test crate's quadrature (both independent of the baker).
    let n = sh::coeff_count(ORDER);
    for (c, up) in [(0.3, true), (std::f64::consts::FRAC_1_SQRT_2, false)] {
        let closed = cap_matrix(c, up);
        let axis = if up { DVec3::Z } else { DVec3::NEG_Z };
        let mut quadrature = vec![0.0; n * n];
        band_quadrature(ORDER, axis, c, 1.0, |w, _, y| {
            for i in 0..n {
                for j in 0..n {
                    quadrature[i * n + j] += w * y[i] * y[j];
                }
            }
        });
        let worst = closed
            .iter()
            .zip(&quadrature)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-9, "cos α {c}, up {up}: off by {worst}");
    }
    // The whole sphere is the identity.
    let sphere = cap_matrix(-1.0, true);
    assert!(identity_minus(&sphere).iter().all(|x| x.abs() < 1e-9));
}

#[test]
fn probes_on_the_axis_of_a_disk_see_the_sphere_less_the_cap() {
    let heights = [1.0f32, 0.5, 2.0];
    let positions: Vec<Vec3> = heights
        .iter()
        .flat_map(|&h| [Vec3::new(0.0, 0.0, h), Vec3::new(0.0, 0.0, -h)])
        .collect();
    let baked = bake_probes(&disk_scene(None), Mode::Shadowed, &positions);
    for (p, position) in positions.iter().enumerate() {
        let above = position.z > 0.0;
        // Above the disk the hidden cone is about −z, below it about +z.
        let expected = identity_minus(&cap_matrix(cos_alpha(position.z.abs().into()), !above));
        assert_close(&format!("probe at {position}"), &baked[p][0], &expected);
    }
}

#[test]
fn an_open_probe_sees_the_whole_sphere_and_a_tilted_disk_its_cap() {
    let axis = DVec3::new(0.4, -0.3, 0.85).normalize();
    let normal = axis.as_vec3();
    // A disk of radius 1 about `axis`, the probe at distance 1 on the axis: a 45° cone.
    let mut mesh = disk(Vec3::ZERO, 1.0, 512);
    let turn = glam::Quat::from_rotation_arc(Vec3::NEG_Z, normal);
    for p in &mut mesh.positions {
        *p = turn * *p;
    }
    for n in mesh.normals.iter_mut().flatten() {
        *n = turn * *n;
    }
    let scene = scene(vec![mesh]);
    let positions = [-normal, Vec3::new(30.0, 20.0, -10.0)];
    let baked = bake_probes(&scene, Mode::Shadowed, &positions);
    let n = sh::coeff_count(ORDER);
    let mut cap = vec![0.0; n * n];
    band_quadrature(
        ORDER,
        axis,
        std::f64::consts::FRAC_1_SQRT_2,
        1.0,
        |w, _, y| {
            for i in 0..n {
                for j in 0..n {
                    cap[i * n + j] += w * y[i] * y[j];
                }
            }
        },
    );
    assert_close("tilted disk", &baked[0][0], &identity_minus(&cap));
    assert_close(
        "open probe",
        &baked[1][0],
        &identity_minus(&vec![0.0; n * n]),
    );
}

#[test]
fn a_one_sided_disk_reflects_towards_its_front_only() {
    let rho = Vec3::new(0.8, 0.4, 0.1);
    let positions = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0)];
    let baked = bake_probes(&disk_scene(Some(rho)), Mode::Interreflected, &positions);
    let n = sh::coeff_count(ORDER);
    let c = std::f64::consts::FRAC_1_SQRT_2;
    // Above: the disk's back, which reflects nothing.
    let above = identity_minus(&cap_matrix(c, false));
    // Below: the cap about +z brings ρ·T_j(h), T the lone disk's transfer, the clamped cosine
    // about −z over π: zonal, (1/π)·z_l·(−1)^l in band l, m = 0.
    let below = identity_minus(&cap_matrix(c, true));
    let mut cap_integral = vec![0.0; n];
    band_quadrature(ORDER, DVec3::Z, c, 1.0, |w, _, y| {
        for (s, y) in cap_integral.iter_mut().zip(y) {
            *s += w * y;
        }
    });
    let transfer: Vec<f64> = (0..n)
        .map(|j| match sh::band_and_m(j) {
            (l, 0) => {
                clamped_cosine_zonal(l) * if l % 2 == 0 { 1.0 } else { -1.0 } / std::f64::consts::PI
            }
            _ => 0.0,
        })
        .collect();
    assert_eq!(baked[0].len(), 3, "a coloured disk gives RGB probes");
    for (channel, rho) in rho.to_array().iter().enumerate() {
        assert_close(
            &format!("above, channel {channel}"),
            &baked[0][channel],
            &above,
        );
        let expected: Vec<f64> = (0..n * n)
            .map(|k| below[k] + f64::from(*rho) * cap_integral[k / n] * transfer[k % n])
            .collect();
        assert_close(
            &format!("below, channel {channel}"),
            &baked[1][channel],
            &expected,
        );
    }
}
