//! Fixtures for the cross-crate tests: analytic geometry, the closed-form oracles of
//! `../shared/docs/oracles.md`, and the rule that turns a Monte Carlo standard error into a
//! tolerance.
//!
//! # Tolerances
//!
//! A coefficient estimated from N samples whose per-sample values have variance σ² is
//! compared with its exact value under
//!
//! ```text
//!     |estimate − exact| ≤ Z · sqrt(e · σ² / N) + FLOAT_SLACK
//! ```
//!
//! * σ² is computed exactly for each oracle (by quadrature over the visible region), never
//!   estimated from the run under test;
//! * the factor e ≈ 2.72 is Owen's (1997) bound on the variance of a scrambled (0,m,2)-net in
//!   base 2 relative to independent samples (N is a power of two in every test);
//! * Z = [`Z`] standard errors; the seed is fixed, so a passing test stays passing;
//! * [`FLOAT_SLACK`] covers f32 storage and accumulation.

pub mod ray_sets;
pub mod referee;

use glam::{DVec3, Vec2, Vec3};
use prt_baker::bake::transfer::{Estimator, Scratch, Visibility};
use prt_baker::math::sampling::{Frame, Pcg32};
use prt_baker::math::sh;
use prt_baker::scene::{Material, Mesh, Scene};
use prt_baker::trace::{EmbreeMode, EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, Mode};

/// Standard errors allowed.
pub const Z: f64 = 5.0;
/// Absolute slack for f32 storage and summation of coefficients of size ≲ 1.
pub const FLOAT_SLACK: f64 = 2e-6;
/// Owen's variance bound for scrambled (0,m,2)-nets in base 2.
pub const NET_VARIANCE_FACTOR: f64 = std::f64::consts::E;

/// The tolerance for an estimate from `samples` samples of per-sample variance `variance`.
pub fn tolerance(variance: f64, samples: u32) -> f64 {
    Z * (NET_VARIANCE_FACTOR * variance.max(0.0) / f64::from(samples)).sqrt() + FLOAT_SLACK
}

// ---------------------------------------------------------------------------------------------
// Oracles

/// Exact moments of the transfer estimator's per-sample values over a region of directions.
///
/// With cosine-weighted sampling around the normal, a sample's value for coefficient j is
/// V(s)·y_j(s). Over the region {s : t_lo ≤ n·s ≤ t_hi} (V = 1 inside, 0 outside):
/// `mean[j]` = (1/π) ∫ y_j (n·s) ds = the exact transfer coefficient, and `second[j]` =
/// (1/π) ∫ y_j² (n·s) ds, so the per-sample variance is `second − mean²`.
pub struct Moments {
    pub mean: Vec<f64>,
    pub second: Vec<f64>,
}

impl Moments {
    pub fn variance(&self, j: usize) -> f64 {
        self.second[j] - self.mean[j] * self.mean[j]
    }
}

/// Visits a quadrature of the band of directions around `axis` with axis·s in [t_lo, t_hi]:
/// Gauss–Legendre in t and the trapezoid rule in azimuth, both exact for the polynomial
/// integrands of SH products up to order 8. `visit(weight, t, y)` gets each node's weight
/// (solid angle), its t and every basis value there, from the slow, trigonometric SH of the
/// thesis.
pub fn band_quadrature(
    order: usize,
    axis: DVec3,
    t_lo: f64,
    t_hi: f64,
    mut visit: impl FnMut(f64, f64, &[f64]),
) {
    let n = sh::coeff_count(order);
    let axis = axis.normalize();
    let (tangent, bitangent) = axis.any_orthonormal_pair();
    let (nodes, weights) = sh::gauss_legendre(24);
    let azimuths = 48;
    let mut y = vec![0.0; n];
    for (x, w) in nodes.iter().zip(&weights) {
        let t = 0.5 * (t_hi - t_lo) * x + 0.5 * (t_hi + t_lo);
        let w = w * 0.5 * (t_hi - t_lo);
        let r = (1.0 - t * t).max(0.0).sqrt();
        for k in 0..azimuths {
            let phi = std::f64::consts::TAU * k as f64 / azimuths as f64;
            let d = tangent * (r * phi.cos()) + bitangent * (r * phi.sin()) + axis * t;
            let (theta, az) = sh::angles(d);
            for (j, value) in y.iter_mut().enumerate() {
                let (l, m) = sh::band_and_m(j);
                *value = sh::eval_slow(l, m, theta, az);
            }
            visit(w * std::f64::consts::TAU / azimuths as f64, t, &y);
        }
    }
}

/// [`Moments`] of the band of directions around `normal` with n·s in [t_lo, t_hi], by
/// [`band_quadrature`].
pub fn band_moments(order: usize, normal: DVec3, t_lo: f64, t_hi: f64) -> Moments {
    let n = sh::coeff_count(order);
    let mut moments = Moments {
        mean: vec![0.0; n],
        second: vec![0.0; n],
    };
    band_quadrature(order, normal, t_lo, t_hi, |w, t, y| {
        let weight = w * t / std::f64::consts::PI;
        for (j, y) in y.iter().enumerate() {
            moments.mean[j] += weight * y;
            moments.second[j] += weight * y * y;
        }
    });
    moments
}

/// [`Moments`] of the quarter of the sphere {n·s > 0, c·s > 0} (`cut` ⊥ `normal`): a point
/// on a plane with an infinite perpendicular plane through it blocking the other half.
pub fn quarter_moments(order: usize, normal: DVec3, cut: DVec3) -> Moments {
    let n = sh::coeff_count(order);
    let mut moments = Moments {
        mean: vec![0.0; n],
        second: vec![0.0; n],
    };
    quarter_quadrature(order, normal, cut, |solid_angle, t, y| {
        let weight = solid_angle * t / std::f64::consts::PI;
        for (j, &y) in y.iter().enumerate() {
            moments.mean[j] += weight * y;
            moments.second[j] += weight * y * y;
        }
    });
    moments
}

/// Visits a Gauss–Legendre quadrature (in n·s and in azimuth over the half-turn) of the
/// quarter of the sphere {n·s > 0, c·s > 0} (`cut` ⊥ `normal`): `visit(solid angle, s·n, y)`
/// with y_j(s) for the `order`'s coefficients.
pub fn quarter_quadrature(
    order: usize,
    normal: DVec3,
    cut: DVec3,
    mut visit: impl FnMut(f64, f64, &[f64]),
) {
    let n = sh::coeff_count(order);
    let (normal, cut) = (normal.normalize(), cut.normalize());
    let side = normal.cross(cut);
    let (nodes, weights) = sh::gauss_legendre(32);
    let mut y = vec![0.0; n];
    for (xt, wt) in nodes.iter().zip(&weights) {
        let t = 0.5 * (xt + 1.0);
        let r = (1.0 - t * t).sqrt();
        for (xp, wp) in nodes.iter().zip(&weights) {
            // Azimuth in (−π/2, π/2) around `cut`.
            let phi = 0.5 * std::f64::consts::PI * xp;
            let d = cut * (r * phi.cos()) + side * (r * phi.sin()) + normal * t;
            let (theta, az) = sh::angles(d);
            for (j, value) in y.iter_mut().enumerate() {
                let (l, m) = sh::band_and_m(j);
                *value = sh::eval_slow(l, m, theta, az);
            }
            visit(0.5 * wt * 0.5 * std::f64::consts::PI * wp, t, &y);
        }
    }
}

/// Coordinates from 0 to `far` for a grid meeting a corner: 0, then 0.05 growing by `ratio`
/// each step, then `far` (fine near the corner, coarse far away).
pub fn graded(far: f32, ratio: f32) -> Vec<f32> {
    let mut xs = vec![0.0f32];
    let mut x = 0.05f32;
    while x < far {
        xs.push(x);
        x *= ratio;
    }
    xs.push(far);
    xs
}

/// ∫ y_j over the band of directions around `axis` with axis·s in [t_lo, t_hi]: the
/// coefficients of unit radiance there (a disk light, a hemisphere), by [`band_quadrature`].
pub fn band_projection(order: usize, axis: DVec3, t_lo: f64, t_hi: f64) -> Vec<f64> {
    let mut c = vec![0.0; sh::coeff_count(order)];
    band_quadrature(order, axis, t_lo, t_hi, |w, _, y| {
        for (c, y) in c.iter_mut().zip(y) {
            *c += w * y;
        }
    });
    c
}

/// The oracles' zonal coefficient ∫ V max(cos θ, 0) y_l^0 over a visible cone of half-angle
/// α about the normal: 2π·N_l·∫_{cos α}^1 t·P_l(t) dt (not divided by π).
pub fn visible_cone_zonal(l: usize, cos_alpha: f64) -> f64 {
    let (nodes, weights) = sh::gauss_legendre(l / 2 + 2);
    let integral: f64 = nodes
        .iter()
        .zip(&weights)
        .map(|(x, w)| {
            let t = 0.5 * (1.0 - cos_alpha) * x + 0.5 * (1.0 + cos_alpha);
            w * 0.5 * (1.0 - cos_alpha) * t * sh::legendre(l, 0, t)
        })
        .sum();
    std::f64::consts::TAU * sh::normalization(l, 0) * integral
}

/// The clamped-cosine zonal coefficient z_l (an unoccluded point, normal +z).
pub fn clamped_cosine_zonal(l: usize) -> f64 {
    visible_cone_zonal(l, 0.0)
}

// ---------------------------------------------------------------------------------------------
// Geometry

/// A mesh with explicit normals (so shading normals are exactly what the oracle assumes).
pub fn mesh(
    name: &str,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
) -> Mesh {
    Mesh {
        name: name.into(),
        uvs: Some(vec![Vec2::ZERO; positions.len()]),
        positions,
        normals: Some(normals),
        triangles,
        material: Material::default(),
    }
}

/// A small triangle lying in the plane through `corner` with normal `normal`; vertex 0 is
/// `corner`, the face is wound so its geometric normal is `normal`.
pub fn patch(corner: Vec3, normal: Vec3, size: f32) -> Mesh {
    let frame = Frame::from_normal(normal);
    let a = corner + (frame.tangent - frame.bitangent) * size;
    let b = corner + (frame.tangent + frame.bitangent) * size;
    mesh(
        "patch",
        vec![corner, a, b],
        vec![normal; 3],
        vec![[0, 1, 2]],
    )
}

/// A rectangle `origin + u·edge_u + v·edge_v` split into `cells`² quads (normal
/// edge_u × edge_v).
pub fn grid(name: &str, origin: Vec3, edge_u: Vec3, edge_v: Vec3, cells: u32) -> Mesh {
    let normal = edge_u.cross(edge_v).normalize();
    let mut positions = Vec::new();
    for j in 0..=cells {
        for i in 0..=cells {
            positions.push(
                origin + edge_u * (i as f32 / cells as f32) + edge_v * (j as f32 / cells as f32),
            );
        }
    }
    let at = |i: u32, j: u32| j * (cells + 1) + i;
    let mut triangles = Vec::new();
    for j in 0..cells {
        for i in 0..cells {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let count = positions.len();
    mesh(name, positions, vec![normal; count], triangles)
}

/// A rectangle over the tensor grid of coordinates `us` × `vs` along `edge_u`, `edge_v`
/// (unit directions) from `origin`: fine where the coordinates are dense.
pub fn graded_grid(
    name: &str,
    origin: Vec3,
    edge_u: Vec3,
    edge_v: Vec3,
    us: &[f32],
    vs: &[f32],
) -> Mesh {
    let normal = edge_u.cross(edge_v).normalize();
    let positions: Vec<Vec3> = vs
        .iter()
        .flat_map(|&v| us.iter().map(move |&u| origin + edge_u * u + edge_v * v))
        .collect();
    let (nu, nv) = (us.len() as u32, vs.len() as u32);
    let at = |i: u32, j: u32| j * nu + i;
    let mut triangles = Vec::new();
    for j in 0..nv - 1 {
        for i in 0..nu - 1 {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let count = positions.len();
    mesh(name, positions, vec![normal; count], triangles)
}

/// A horizontal disk of `radius` centred at `centre`, as a fan of `segments` triangles.
pub fn disk(centre: Vec3, radius: f32, segments: u32) -> Mesh {
    let mut positions = vec![centre];
    for k in 0..segments {
        let phi = std::f32::consts::TAU * k as f32 / segments as f32;
        positions.push(centre + Vec3::new(phi.cos(), phi.sin(), 0.0) * radius);
    }
    let triangles = (0..segments)
        .map(|k| [0, 1 + (k + 1) % segments, 1 + k])
        .collect();
    let count = positions.len();
    mesh("disk", positions, vec![-Vec3::Z; count], triangles)
}

/// A sphere of `radius` around `centre` restricted to polar angles (from −z) up to
/// `max_polar`, with `rings` × `segments` cells. Normals point `outward` or inward. Vertex 0
/// is the bottom pole.
pub fn spherical_cap(
    centre: Vec3,
    radius: f32,
    max_polar: f32,
    rings: u32,
    segments: u32,
    outward: bool,
) -> Mesh {
    let sign = if outward { 1.0 } else { -1.0 };
    let point = |polar: f32, phi: f32| {
        Vec3::new(
            polar.sin() * phi.cos(),
            polar.sin() * phi.sin(),
            -polar.cos(),
        )
    };
    let mut positions = vec![centre + radius * Vec3::NEG_Z];
    let mut normals = vec![sign * Vec3::NEG_Z];
    for ring in 1..=rings {
        let polar = max_polar * ring as f32 / rings as f32;
        for k in 0..segments {
            let d = point(polar, std::f32::consts::TAU * k as f32 / segments as f32);
            positions.push(centre + radius * d);
            normals.push(sign * d);
        }
    }
    let at = |ring: u32, k: u32| 1 + (ring - 1) * segments + k % segments;
    let mut triangles = Vec::new();
    for k in 0..segments {
        triangles.push([0, at(1, k + 1), at(1, k)]);
    }
    for ring in 1..rings {
        for k in 0..segments {
            triangles.push([at(ring, k), at(ring, k + 1), at(ring + 1, k + 1)]);
            triangles.push([at(ring, k), at(ring + 1, k + 1), at(ring + 1, k)]);
        }
    }
    // As built the faces are wound outwards; flip them for a bowl seen from inside.
    if !outward {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    mesh("cap", positions, normals, triangles)
}

/// A closed UV sphere (outward normals); convex, so no vertex can see any of it.
pub fn sphere(centre: Vec3, radius: f32, rings: u32, segments: u32) -> Mesh {
    let mut mesh = spherical_cap(centre, radius, std::f32::consts::PI, rings, segments, true);
    // The last ring sits at the top pole: weld it into one vertex.
    let top = mesh.positions.len() as u32 - segments;
    mesh.positions.truncate(top as usize + 1);
    mesh.normals
        .as_mut()
        .expect("normals")
        .truncate(top as usize + 1);
    mesh.uvs = Some(vec![Vec2::ZERO; mesh.positions.len()]);
    for t in &mut mesh.triangles {
        for i in t.iter_mut() {
            *i = (*i).min(top);
        }
    }
    mesh.triangles
        .retain(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
    mesh
}

/// `count` triangles with corners drawn independently in a box of side `size` around a random
/// point of the unit cube: a soup of every orientation, aspect and overlap.
pub fn triangle_soup(count: u32, size: f32, rng: &mut Pcg32) -> Mesh {
    let mut point = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let mut positions = Vec::with_capacity(3 * count as usize);
    for _ in 0..count {
        let centre = point();
        for _ in 0..3 {
            positions.push(centre + (point() - 0.5) * size);
        }
    }
    let triangles = (0..count).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
    let normals = vec![Vec3::Z; positions.len()];
    mesh("soup", positions, normals, triangles)
}

/// `count` needle triangles in the unit cube: length about 1, width `width` (aspect 1/width),
/// in random orientations.
pub fn slivers(count: u32, width: f32, rng: &mut Pcg32) -> Mesh {
    let mut positions = Vec::with_capacity(3 * count as usize);
    for _ in 0..count {
        let a = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let b = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let across = (b - a).normalize().any_orthonormal_vector() * width;
        positions.extend([a, b, b + across]);
    }
    let triangles = (0..count).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
    let normals = vec![Vec3::Z; positions.len()];
    mesh("slivers", positions, normals, triangles)
}

/// `mesh` scaled by `scale` about the origin, then moved by `offset`.
pub fn placed(mut mesh: Mesh, scale: f32, offset: Vec3) -> Mesh {
    for p in &mut mesh.positions {
        *p = *p * scale + offset;
    }
    mesh
}

pub fn scene(meshes: Vec<Mesh>) -> Scene {
    Scene::from_meshes(std::path::Path::new("test-scene"), meshes, Vec::new())
        .expect("valid test scene")
}

// ---------------------------------------------------------------------------------------------
// Baking selected vertices

/// Bakes only `vertices` (the oracle vertices of a large scene) through the real estimator and
/// Embree (the direct pass: shadowed or unshadowed transfer, and the rays' visibility).
pub fn bake_selected(
    scene: &Scene,
    options: &BakeOptions,
    vertices: &[usize],
) -> Vec<(Vec<f64>, Visibility)> {
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("embree scene");
    let estimator = Estimator::new(scene, options).expect("valid options");
    let n = sh::coeff_count(options.order);
    let mut scratch = Scratch::new(n);
    let tracer =
        (options.mode == Mode::Shadowed).then_some(&tracer as &dyn prt_baker::trace::Tracer);
    vertices
        .iter()
        .map(|&v| {
            let mut out = vec![0.0f32; n];
            let visibility = estimator.receiver_transfer(v, tracer, &mut scratch, &mut out, None);
            (out.into_iter().map(f64::from).collect(), visibility)
        })
        .collect()
}

/// The transfer coefficients of `vertices`, baked alone (see [`bake_selected`]).
pub fn bake_vertices(scene: &Scene, options: &BakeOptions, vertices: &[usize]) -> Vec<Vec<f64>> {
    bake_selected(scene, options, vertices)
        .into_iter()
        .map(|(t, _)| t)
        .collect()
}

/// The accessibility and bent normal of `vertices`, from the same rays.
pub fn visibility_of(scene: &Scene, options: &BakeOptions, vertices: &[usize]) -> Vec<Visibility> {
    bake_selected(scene, options, vertices)
        .into_iter()
        .map(|(_, v)| v)
        .collect()
}

/// A whole-scene bake through the library entry point (every vertex, any mode).
/// An Embree tracer over `scene` in `mode` (robust, the watertight default, fast), for the
/// tests that compare modes.
pub fn embree_tracer(scene: &Scene, mode: EmbreeMode) -> EmbreeTracer {
    EmbreeTracer::new(
        scene,
        EmbreeOptions {
            mode,
            ..EmbreeOptions::default()
        },
    )
    .expect("embree scene")
}

pub fn bake_scene(scene: &Scene, options: &BakeOptions) -> prt_baker::Transfer {
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("embree scene");
    prt_baker::bake(
        scene,
        Some(&tracer),
        options,
        &prt_baker::support::progress::Silent,
    )
    .expect("bake")
}

pub fn shadowed(order: usize, samples: u32) -> BakeOptions {
    BakeOptions {
        order,
        samples,
        mode: Mode::Shadowed,
        seed: 7,
        ..BakeOptions::default()
    }
}

/// The largest |got − expected| entry of two row-major matrices with `n` columns (or of
/// two vectors, n = their length), printed with its row and column; fails beyond
/// `tolerance`.
pub fn assert_entries_close(what: &str, got: &[f64], expected: &[f64], n: usize, tolerance: f64) {
    assert_eq!(got.len(), expected.len());
    let (worst, k) = got
        .iter()
        .zip(expected)
        .enumerate()
        .map(|(k, (g, e))| ((g - e).abs(), k))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    eprintln!(
        "{what}: worst entry ({}, {}) off by {worst:.2e} (got {:.5}, expected {:.5})",
        k / n,
        k % n,
        got[k],
        expected[k]
    );
    assert!(
        worst <= tolerance,
        "{what}: entry ({}, {}) is {} but should be {} (± {tolerance})",
        k / n,
        k % n,
        got[k],
        expected[k]
    );
}

/// Asserts every coefficient of `got` is within tolerance of the moments' mean; prints the
/// worst case in units of its tolerance, so a regression shows how far off it is.
pub fn assert_matches(what: &str, got: &[f64], expected: &Moments, samples: u32) {
    let mut worst = (0.0f64, 0usize);
    for (j, g) in got.iter().enumerate() {
        let tol = tolerance(expected.variance(j), samples);
        let ratio = (g - expected.mean[j]).abs() / tol;
        if ratio > worst.0 {
            worst = (ratio, j);
        }
        assert!(
            ratio <= 1.0,
            "{what}: coefficient {j} {:?} = {g:.6}, expected {:.6} ± {tol:.2e} (per-sample σ² = {:.3e}, N = {samples})",
            sh::band_and_m(j),
            expected.mean[j],
            expected.variance(j),
        );
    }
    eprintln!(
        "{what}: worst coefficient {} at {:.3} of its tolerance",
        worst.1, worst.0
    );
}

/// Lightmap UVs for the floor square [−half, half]² at z = 0 (uv = (x, y)/(2·half) + ½);
/// every other vertex is left out of the atlas (all its triangles' UVs coincide).
pub fn floor_uvs(scene: &Scene, half: f32) -> Vec<Vec2> {
    scene
        .positions
        .iter()
        .zip(&scene.normals)
        .map(|(p, n)| match p.z == 0.0 && n.z > 0.99 {
            true => Vec2::new(p.x, p.y) / (2.0 * half) + Vec2::splat(0.5),
            false => Vec2::splat(-1.0),
        })
        .collect()
}

/// A binary glTF (`.glb`) of the serialized JSON document `json` and the buffer `bin`: the
/// 12-byte header, the JSON chunk padded with spaces and the BIN chunk (glTF 2.0, §4.4).
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut text = json.to_vec();
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + text.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

/// The radiance floats of the vertices of a PLY written by `prt-bake relight`.
pub fn read_ply_radiance(bytes: &[u8], vertices: usize) -> Vec<[f32; 3]> {
    let end = b"end_header\n";
    let start = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    // Per vertex: x y z nx ny nz (floats), red green blue (bytes), then the radiance.
    let offset = 6 * 4 + 3;
    (0..vertices)
        .map(|v| {
            let at = start + v * prt_baker::formats::ply::VERTEX_BYTES + offset;
            std::array::from_fn(|c| {
                f32::from_le_bytes(bytes[at + 4 * c..at + 4 * c + 4].try_into().unwrap())
            })
        })
        .collect()
}
