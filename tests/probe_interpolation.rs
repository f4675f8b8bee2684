//! Probes between probes and objects that move: the interpolated incident radiance
//! against probes baked exactly at the query points, with and without leaving out the probes
//! inside geometry; and a rigid object, baked alone in its own frame, moved and turned through
//! a probe grid, against the same object lit by a probe baked exactly where it stands.
//!
//! The scene: a floor of albedo 0.5 (z = 0, 6 × 6) with a closed box on it (1 × 1 × 1, red),
//! under a sun from high in +x and a dim constant sky. A 6 × 6 × 3 grid over
//! [−1.5, 1.5]² × [0, 1.5] puts some probes inside the box and none under the floor.

use glam::{DQuat, DVec3, Vec3};
use prt_baker::bake::options::TransferKind;
use prt_baker::bake::probes;
use prt_baker::export::probe_field::{ProbeField, into_object_frame, rigid_radiance};
use prt_baker::formats::probe_block::{ProbeBlock, ProbeGrid};
use prt_baker::light::LightCoefficients;
use prt_baker::math::sampling::Pcg32;
use prt_baker::math::sh;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer, Tracer};
use prt_baker::{BakeOptions, CoefficientFile, Mode, Scene};
use prt_tests::*;

const ORDER: usize = 3;
const SAMPLES: u32 = 4096;

fn options(mode: Mode) -> BakeOptions {
    BakeOptions {
        transfer: TransferKind::Matrix,
        mode,
        bounces: u32::from(mode == Mode::Interreflected),
        ..shadowed(ORDER, SAMPLES)
    }
}

fn coloured(mut mesh: prt_baker::scene::Mesh, kd: Vec3) -> prt_baker::scene::Mesh {
    mesh.material = prt_baker::scene::Material {
        name: format!("kd {kd}"),
        kd,
        ..Default::default()
    };
    mesh
}

/// A closed unit box standing on the floor at the origin, faces outward.
fn closed_box() -> prt_baker::scene::Mesh {
    let faces = [
        (Vec3::new(-0.5, -0.5, 1.0), Vec3::X, Vec3::Y),
        (Vec3::new(-0.5, -0.5, 0.0), Vec3::Y, Vec3::X),
        (Vec3::new(-0.5, -0.5, 0.0), Vec3::X, Vec3::Z),
        (Vec3::new(-0.5, 0.5, 0.0), Vec3::Z, Vec3::X),
        (Vec3::new(-0.5, -0.5, 0.0), Vec3::Z, Vec3::Y),
        (Vec3::new(0.5, -0.5, 0.0), Vec3::Y, Vec3::Z),
    ];
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    for (corner, u, v) in faces {
        let base = positions.len() as u32;
        let n = u.cross(v);
        positions.extend([corner, corner + u, corner + u + v, corner + v]);
        normals.extend([n; 4]);
        triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    }
    coloured(
        mesh("box", positions, normals, triangles),
        Vec3::new(0.8, 0.1, 0.1),
    )
}

fn room() -> Scene {
    let floor = grid(
        "floor",
        Vec3::new(-3.0, -3.0, 0.0),
        Vec3::new(6.0, 0.0, 0.0),
        Vec3::new(0.0, 6.0, 0.0),
        12,
    );
    scene(vec![coloured(floor, Vec3::splat(0.5)), closed_box()])
}

/// A sun from high in +x (radiance integral 3) plus a constant sky of 0.2.
fn light() -> LightCoefficients {
    let n = sh::coeff_count(ORDER);
    let d = Vec3::new(0.5, 0.2, 1.0).normalize();
    let mut y = vec![0.0f32; n];
    sh::Basis::new(ORDER).eval(d, &mut y);
    let mut c: Vec<f64> = y.iter().map(|&y| 3.0 * f64::from(y)).collect();
    c[0] += 0.2 * (4.0 * std::f64::consts::PI).sqrt();
    LightCoefficients::tinted(ORDER, &c, DVec3::ONE)
}

/// Irradiance E(n) = Σ Â_l L_lm y_lm(n) of incident radiance `l`, summed over RGB, at the
/// six axis normals.
fn irradiance(l: &LightCoefficients) -> [f64; 6] {
    let factors = [
        std::f64::consts::PI,
        std::f64::consts::TAU / 3.0,
        std::f64::consts::PI / 4.0,
    ];
    let n = sh::coeff_count(ORDER);
    let normals = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    normals.map(|normal| {
        let mut y = vec![0.0f32; n];
        sh::Basis::new(ORDER).eval(normal, &mut y);
        (0..n)
            .map(|j| {
                let a = factors[sh::band_and_m(j).0];
                a * f64::from(y[j]) * l.rgb.iter().map(|c| c[j]).sum::<f64>()
            })
            .sum()
    })
}

fn bake_file(
    scene: &Scene,
    tracer: &dyn Tracer,
    mode: Mode,
    probes: ProbeBlock,
) -> CoefficientFile {
    let transfer = probes::bake(
        scene,
        Some(tracer),
        &options(mode),
        &probes.positions,
        &Silent,
    )
    .expect("probe bake");
    CoefficientFile::from_probe_bake(scene, &transfer, Some(tracer), probes)
}

fn grid_file(scene: &Scene, tracer: &dyn Tracer, counts: [u32; 3]) -> CoefficientFile {
    let grid = ProbeGrid {
        counts,
        lo: Vec3::new(-1.5, -1.5, 0.0),
        hi: Vec3::new(1.5, 1.5, 1.5),
    };
    let probes = ProbeBlock {
        positions: grid.positions(),
        grid: Some(grid),
        backfaces: Vec::new(),
    };
    bake_file(scene, tracer, Mode::Interreflected, probes)
}

/// Query points in the open space of the grid (off the box by at least 0.05), from a fixed seed.
fn query_points(count: usize) -> Vec<Vec3> {
    let mut rng = Pcg32::new(32, 1);
    let mut points = Vec::new();
    while points.len() < count {
        let p = Vec3::new(
            -1.25 + 2.5 * rng.next_f32(),
            -1.25 + 2.5 * rng.next_f32(),
            0.25 + 1.0 * rng.next_f32(),
        );
        let inside = p.x.abs() < 0.55 && p.y.abs() < 0.55 && p.z < 1.05;
        if !inside {
            points.push(p);
        }
    }
    points
}

#[test]
fn probes_inside_the_box_are_found_and_left_out() {
    let scene = room();
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).expect("embree");
    let file = grid_file(&scene, &tracer, [6, 6, 3]);
    let probes = file.probes.as_ref().unwrap();
    // Inside the box: the probes whose centres lie in [−0.5, 0.5]² × [0, 1].
    for (p, x) in probes.positions.iter().enumerate() {
        let inside = x.x.abs() < 0.5 && x.y.abs() < 0.5 && x.z < 1.0;
        assert_eq!(
            probes.valid(p),
            !inside,
            "probe {p} at {x}: back-face fraction {}",
            probes.backfaces[p]
        );
    }
    assert!(
        probes
            .positions
            .iter()
            .enumerate()
            .any(|(p, _)| !probes.valid(p))
    );

    // At its own position a probe is read back exactly.
    let field = ProbeField::new(&file).unwrap();
    let light = light();
    let p = 3;
    let at = field.incident(probes.positions[p], &light, true);
    let own = field.probe_incident(p, &light);
    for (a, b) in at.rgb.iter().flatten().zip(own.rgb.iter().flatten()) {
        assert!((a - b).abs() < 1e-9);
    }

    // Interpolated against probes baked at the query points: the error with the inside
    // probes left out, and with them blended in.
    let points = query_points(48);
    let direct = bake_file(
        &scene,
        &tracer,
        Mode::Interreflected,
        ProbeBlock {
            positions: points.clone(),
            grid: None,
            backfaces: Vec::new(),
        },
    );
    let direct_probes = direct.probes.as_ref().unwrap();
    assert!((0..points.len()).all(|p| direct_probes.valid(p)));
    let reference = ProbeFieldPoints(&direct);
    let (mut err_valid, mut err_naive, mut norm) = (0.0, 0.0, 0.0);
    let (mut near_valid, mut near_naive) = (0.0f64, 0.0f64);
    for (q, x) in points.iter().enumerate() {
        let truth = irradiance(&reference.incident(q, &light));
        let valid = irradiance(&field.incident(*x, &light, true));
        let naive = irradiance(&field.incident(*x, &light, false));
        for k in 0..6 {
            err_valid += (valid[k] - truth[k]).powi(2);
            err_naive += (naive[k] - truth[k]).powi(2);
            norm += truth[k].powi(2);
            let near = x.x.abs() < 1.0 && x.y.abs() < 1.0;
            if near {
                near_valid = near_valid.max((valid[k] - truth[k]).abs() / truth[k].abs().max(0.1));
                near_naive = near_naive.max((naive[k] - truth[k]).abs() / truth[k].abs().max(0.1));
            }
        }
    }
    let (rel_valid, rel_naive) = ((err_valid / norm).sqrt(), (err_naive / norm).sqrt());
    eprintln!(
        "interpolated irradiance against probes at the points ({} points × 6 normals): relative \
         rms error {rel_valid:.4} with the inside probes left out, {rel_naive:.4} with them; \
         worst near the box {near_valid:.3} vs {near_naive:.3}",
        points.len()
    );
    assert!(
        rel_valid < rel_naive,
        "leaving out the inside probes must help"
    );
    assert!(rel_valid < 0.25, "relative rms error {rel_valid}");
}

/// A probe file of points read at its own probes (the reference of the measurement).
struct ProbeFieldPoints<'a>(&'a CoefficientFile);

impl ProbeFieldPoints<'_> {
    fn incident(&self, p: usize, light: &LightCoefficients) -> LightCoefficients {
        let file = self.0;
        let n = sh::coeff_count(ORDER);
        let channels = file.header.channels as usize;
        let mut out = LightCoefficients::zero(ORDER);
        for (c, (out, l)) in out.rgb.iter_mut().zip(&light.rgb).enumerate() {
            let ch = if channels == 1 { 0 } else { c };
            let m = &file.coefficients[(p * channels + ch) * n * n..][..n * n];
            for (o, row) in out.iter_mut().zip(m.chunks_exact(n)) {
                *o = row.iter().zip(l).map(|(&a, &b)| f64::from(a) * b).sum();
            }
        }
        out
    }
}

/// A small object (an open "roof" of two patches, which shadow nothing of each other) baked
/// alone: its transfer in its own frame, unshadowed.
fn object() -> Scene {
    scene(vec![
        patch(Vec3::ZERO, Vec3::new(0.6, 0.0, 0.8), 0.2),
        patch(
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::new(-0.3, 0.5, 0.8).normalize(),
            0.2,
        ),
    ])
}

fn object_file(scene: &Scene) -> CoefficientFile {
    let options = BakeOptions {
        mode: Mode::Unshadowed,
        ..shadowed(ORDER, SAMPLES)
    };
    let transfer = prt_baker::bake(scene, None, &options, &Silent).expect("object bake");
    CoefficientFile::from_bake(scene, &transfer)
}

#[test]
fn a_rigid_object_is_lit_by_the_probes_where_it_stands() {
    let scene = room();
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).expect("embree");
    // Probes 0.25 apart: the box's shadow is about a probe spacing from its side.
    let file = grid_file(&scene, &tracer, [12, 12, 6]);
    let field = ProbeField::new(&file).unwrap();
    let light = light();
    let obj_scene = object();
    let obj = object_file(&obj_scene);
    let albedo = vec![Vec3::splat(0.7); obj_scene.vertex_count()];
    let rotation = DQuat::from_euler(glam::EulerRot::ZYX, 0.7, -0.4, 0.3);

    // Turning the object and the light together changes nothing: with a probe field far from
    // everything (L_in = L), R(q⁻¹) of the turned light is the light itself.
    let turned = light.rotated(&prt_baker::math::sh::rotation::ShRotation::from_quat(
        ORDER, rotation,
    ));
    let back = into_object_frame(&turned, rotation);
    for (a, b) in back.rgb.iter().flatten().zip(light.rgb.iter().flatten()) {
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }

    // Along a path through the sun's shadow of the box (behind it, −x) and out into the sun:
    // against the object lit by probes baked exactly at its positions.
    let path = [
        Vec3::new(-0.7, 0.0, 0.3),
        Vec3::new(-0.7, 0.3, 0.4),
        Vec3::new(-1.1, 1.1, 0.6),
        Vec3::new(0.7, 0.0, 0.3),
    ];
    let at_points = bake_file(
        &scene,
        &tracer,
        Mode::Interreflected,
        ProbeBlock {
            positions: path.to_vec(),
            grid: None,
            backfaces: Vec::new(),
        },
    );
    let reference = ProbeFieldPoints(&at_points);
    let mut lit = Vec::new();
    for (k, x) in path.iter().enumerate() {
        let moved = rigid_radiance(&obj, &albedo, &field, (*x, rotation), &light);
        let exact_light = into_object_frame(&reference.incident(k, &light), rotation);
        let exact = prt_baker::export::relight::vertex_radiance(&obj, &albedo, &exact_light);
        let total = |r: &[[f32; 3]]| -> f64 { r.iter().flatten().map(|&x| f64::from(x)).sum() };
        let (got, want) = (total(&moved), total(&exact));
        let red = |r: &[[f32; 3]]| -> f64 {
            let s: f64 = r.iter().map(|c| f64::from(c[0])).sum();
            s / r.iter().map(|c| f64::from(c[1])).sum::<f64>()
        };
        eprintln!(
            "at {x}: interpolated {got:.4}, baked at the point {want:.4} (relative {:+.3}); red/green {:.3} vs {:.3}",
            got / want - 1.0,
            red(&moved),
            red(&exact)
        );
        assert!((got / want - 1.0).abs() < 0.2, "at {x}: {got} vs {want}");
        lit.push((got, red(&moved)));
    }
    // In the box's shadow the object is darker than beside its sunlit side, where it is
    // redder than white light on grey would make it (the box's sunlit red face).
    assert!(
        lit[0].0 < 0.6 * lit[3].0,
        "shadowed {} vs sunlit {}",
        lit[0].0,
        lit[3].0
    );
    assert!(
        lit[3].1 > 1.01,
        "red/green {} beside the red face",
        lit[3].1
    );
}
