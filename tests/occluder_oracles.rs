//! Moving occluders: the Cornell floor baked alone and darkened at run time by a ball's sphere
//! set (closed-form cap visibility, SH triple products with the light and the transfer)
//! against the floor baked with the ball in place, at the same rays (order 4, 1,024 rays per
//! vertex, seed 7) and the same rig (a sun 40° from the zenith and a sky, Hanning-windowed).
//!
//! * one ball at 4 positions: within 3 radii of the ball's centre, the relit floor's RMS error
//!   is at most 1/3 of the error of drawing no shadow;
//! * two balls at once, their shadows overlapping: no worse than the two single-ball errors
//!   added (over the same vertices), so the visibilities' product composes;
//! * a scalar occlusion (the receiver's T·L times the fraction of its cosine-weighted
//!   hemisphere the ball leaves open) is worse than the triple product near the ball;
//! * under the viewer's default rig (unwindowed sun 65° from the zenith) the order-4 ratios
//!   miss 1/3, and T and V at order 8 under the same order-4 light bring them within it.

use glam::{DQuat, DVec3, Vec3};
use prt_baker::Scene;
use prt_baker::export::relight_occluded::OccludedLight;
use prt_baker::formats::occluder_file::OccluderFile;
use prt_baker::light::{LightCoefficients, Rig};
use prt_baker::math::occlusion::Sphere;
use prt_tests::*;

const ORDER: usize = 4;
const SAMPLES: u32 = 1024;
const RADIUS: f32 = 0.2;
/// The ball's centre height: resting just above the floor.
const HEIGHT: f32 = RADIUS + 0.02;
/// Ball positions on the floor clear of the two boxes.
const POSITIONS: [[f32; 2]; 4] = [[-0.55, -0.6], [-0.25, -0.3], [0.55, 0.5], [0.3, 0.75]];

fn cornell_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell")
}

/// The Cornell room, with a tessellated ball (radius [`RADIUS`]) at each of `centres`
/// written after it as OBJ objects, so the floor keeps vertex indices 0..576.
fn cornell_with_balls(dir: &std::path::Path, centres: &[Vec3]) -> Scene {
    for name in ["cornell.obj", "cornell.mtl"] {
        std::fs::copy(cornell_dir().join(name), dir.join(name)).expect("copy the room");
    }
    let mut scene_file = String::from("\"cornell.obj\"\n");
    for (k, c) in centres.iter().enumerate() {
        let name = format!("ball{k}.obj");
        std::fs::write(dir.join(&name), ball_obj(*c)).expect("write ball");
        scene_file.push_str(&format!("\"{name}\"\n"));
    }
    let path = dir.join(format!("room{}.scene", centres.len()));
    std::fs::write(&path, scene_file).expect("write scene");
    Scene::load(&path).expect("scene loads")
}

/// A UV sphere of radius [`RADIUS`] about `centre`, as OBJ text.
fn ball_obj(centre: Vec3) -> String {
    let mesh = placed(sphere(Vec3::ZERO, RADIUS, 24, 48), 1.0, centre);
    let mut text = String::from("o ball\n");
    for p in &mesh.positions {
        text.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
    }
    for t in &mesh.triangles {
        text.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    text
}

/// The occluder file of one ball, fitted to its mesh about the origin as `bake --occluder` does.
fn ball_occluder() -> OccluderFile {
    let ball = scene(vec![sphere(Vec3::ZERO, RADIUS, 24, 48)]);
    let file = prt_baker::bake::occluder_fit::fit_spheres(&ball, 1).expect("fit");
    let s = file.spheres[0];
    assert!(
        s.centre.length() < 1e-4 && (s.radius - RADIUS).abs() < 1e-4,
        "{s:?}"
    );
    file
}

/// The viewer's default sky and sun, the sun 40° from the zenith, with the Hanning window
/// against ringing. (The default 65° sun, unwindowed, gives ratios of 0.47–1.07: its ringing
/// weighs what the truncated product of order-4 T and V leaves out, as
/// `under_the_default_rig_the_error_is_the_order_of_the_product` shows; docs/guides/occluders.md,
/// "Limits".)
const RIG: &str = r#"window = "hanning"
[[light]]
kind = "sun"
theta = 40
phi = 30
color = [1.0, 0.92, 0.8]
intensity = 3.0
[[light]]
kind = "hemisphere"
color = [0.15, 0.19, 0.27]
ground_color = [0.05, 0.045, 0.04]
"#;

struct Floor {
    points: Vec<Vec3>,
    normals: Vec<Vec3>,
    /// Grey transfer per floor vertex.
    transfer: Vec<Vec<f32>>,
}

fn bake_floor(scene: &Scene) -> Floor {
    let floor = &scene.objects[0];
    assert_eq!(floor.name, "floor");
    let vertices: Vec<usize> =
        (floor.vertices.start as usize..floor.vertices.end as usize).collect();
    let transfer = bake_vertices(scene, &shadowed(ORDER, SAMPLES), &vertices)
        .into_iter()
        .map(|t| t.into_iter().map(|x| x as f32).collect())
        .collect();
    Floor {
        points: vertices.iter().map(|&v| scene.positions[v]).collect(),
        normals: vertices.iter().map(|&v| scene.normals[v]).collect(),
        transfer,
    }
}

fn rig() -> LightCoefficients {
    Rig::parse(RIG, std::path::Path::new("rig.toml"))
        .expect("rig")
        .project(ORDER)
}

/// Per floor vertex, the light it reflects (albedo 1, RGB) through `spheres`.
fn relit(light: &OccludedLight, floor: &Floor, spheres: &[Sphere]) -> Vec<[f64; 3]> {
    (0..floor.points.len())
        .map(|v| {
            let t = &floor.transfer[v][..];
            light.radiance([t, t, t], floor.points[v], floor.normals[v], spheres)
        })
        .collect()
}

/// RMS over `near` vertices and the three channels of a − b.
fn rms(a: &[[f64; 3]], b: &[[f64; 3]], near: &[usize]) -> f64 {
    let sum: f64 = near
        .iter()
        .flat_map(|&v| (0..3).map(move |c| (a[v][c] - b[v][c]).powi(2)))
        .sum();
    (sum / (3 * near.len()) as f64).sqrt()
}

/// Floor vertices within 3 radii of any of `centres`.
fn near(floor: &Floor, centres: &[Vec3]) -> Vec<usize> {
    (0..floor.points.len())
        .filter(|&v| {
            centres
                .iter()
                .any(|c| floor.points[v].distance(*c) <= 3.0 * RADIUS)
        })
        .collect()
}

fn centre(k: usize) -> Vec3 {
    Vec3::new(POSITIONS[k][0], POSITIONS[k][1], HEIGHT)
}

/// A scalar occlusion for comparison: T·L times the cosine-weighted fraction of the
/// hemisphere the spheres leave open (what an AO-style shadow would draw).
fn scalar_occlusion(light: &LightCoefficients, floor: &Floor, spheres: &[Sphere]) -> Vec<[f64; 3]> {
    (0..floor.points.len())
        .map(|v| {
            let (p, n) = (floor.points[v].as_dvec3(), floor.normals[v].as_dvec3());
            let open = open_fraction(p, n, spheres);
            std::array::from_fn(|c| {
                let tl: f64 = floor.transfer[v]
                    .iter()
                    .zip(&light.rgb[c])
                    .map(|(t, l)| f64::from(*t) * l)
                    .sum();
                tl * open
            })
        })
        .collect()
}

/// The cosine-weighted fraction of the hemisphere about `n` no sphere blocks, by a fixed
/// 64 × 128 midpoint grid.
fn open_fraction(p: DVec3, n: DVec3, spheres: &[Sphere]) -> f64 {
    let rotation = DQuat::from_rotation_arc(DVec3::Z, n);
    let (mut open, mut total) = (0.0, 0.0);
    for i in 0..64 {
        let theta = std::f64::consts::FRAC_PI_2 * (i as f64 + 0.5) / 64.0;
        for j in 0..128 {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / 128.0;
            let d = rotation
                * DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
            let w = theta.cos() * theta.sin();
            total += w;
            let blocked = spheres.iter().any(|s| {
                let oc = s.centre - p;
                let b = oc.dot(d);
                b > 0.0 && oc.length_squared() - b * b < s.radius * s.radius
            });
            if !blocked {
                open += w;
            }
        }
    }
    open / total
}

#[test]
fn one_ball_shadows_the_floor_within_a_third_of_no_shadow() {
    let dir = tempfile::tempdir().expect("tempdir");
    let light = rig();
    let occluded = OccludedLight::new(&light);
    let occluder = ball_occluder();
    let alone = bake_floor(&cornell_with_balls(dir.path(), &[]));
    let unshadowed = relit(&occluded, &alone, &[]);
    for k in 0..POSITIONS.len() {
        let c = centre(k);
        let truth = relit(
            &occluded,
            &bake_floor(&cornell_with_balls(dir.path(), &[c])),
            &[],
        );
        let spheres = occluder.placed(c.as_dvec3(), DQuat::IDENTITY);
        let ours = relit(&occluded, &alone, &spheres);
        let scalar = scalar_occlusion(&light, &alone, &spheres);
        let near = near(&alone, &[c]);
        let (e, e0, es) = (
            rms(&ours, &truth, &near),
            rms(&unshadowed, &truth, &near),
            rms(&scalar, &truth, &near),
        );
        println!(
            "ball at {c}: {} vertices near; RMS relit {e:.5}, no shadow {e0:.5} (ratio {:.3}), \
             scalar occlusion {es:.5}",
            near.len(),
            e / e0
        );
        assert!(near.len() > 50, "{} vertices near", near.len());
        assert!(
            e <= e0 / 3.0,
            "ball at {c}: relit RMS {e} > 1/3 of no-shadow {e0}"
        );
        assert!(
            e < es,
            "ball at {c}: the triple product {e} is no better than scalar occlusion {es}"
        );
    }
}

#[test]
fn two_balls_are_no_worse_than_their_errors_added() {
    let dir = tempfile::tempdir().expect("tempdir");
    let occluded = OccludedLight::new(&rig());
    let occluder = ball_occluder();
    let alone = bake_floor(&cornell_with_balls(dir.path(), &[]));
    let (a, b) = (centre(0), centre(1));
    let place = |c: Vec3| occluder.placed(c.as_dvec3(), DQuat::IDENTITY);
    let near = near(&alone, &[a, b]);
    let error = |centres: &[Vec3]| {
        let truth = relit(
            &occluded,
            &bake_floor(&cornell_with_balls(dir.path(), centres)),
            &[],
        );
        let spheres: Vec<Sphere> = centres.iter().flat_map(|c| place(*c)).collect();
        let unshadowed = relit(&occluded, &alone, &[]);
        let e0 = rms(&unshadowed, &truth, &near);
        (rms(&relit(&occluded, &alone, &spheres), &truth, &near), e0)
    };
    let ((ea, _), (eb, _), (eab, e0)) = (error(&[a]), error(&[b]), error(&[a, b]));
    println!(
        "{} vertices near either ball: RMS one ball {ea:.5}, the other {eb:.5}, both {eab:.5} \
         (no shadow {e0:.5})",
        near.len()
    );
    assert!(eab <= ea + eb, "two balls: {eab} > {ea} + {eb}");
    assert!(eab <= e0 / 3.0, "two balls: {eab} > 1/3 of no-shadow {e0}");
}

#[test]
fn under_the_default_rig_the_error_is_the_order_of_the_product() {
    // The viewer's default rig (an unwindowed sun 65° from the zenith, and the sky) misses
    // the one-ball bound at order 4 (ratio 0.47 at (−0.55, −0.6)). Not the sphere fit, the
    // reference's noise or the band: the triple product of order-4 T and V is not the
    // order-4 projection of T·V (bands 4 and up of T times those of V reach bands 0–3), and
    // the unwindowed sun's large band-3 coefficients weigh that. With the floor's transfer
    // baked alone at order 8 and V at order 8, the light kept at order 4, ⟨L, P₄(T·V)⟩ is
    // within 1/3 of no shadow at all four places, against the same order-4 reference.
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../viewer/src/default-rig.toml"),
    )
    .expect("the default rig");
    let rig = Rig::parse(&text, std::path::Path::new("default-rig.toml")).expect("rig");
    let light = rig.project(ORDER);
    let mut cut = rig.project(8);
    for channel in &mut cut.rgb {
        channel[ORDER * ORDER..].fill(0.0);
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let occluder = ball_occluder();
    let room = cornell_with_balls(dir.path(), &[]);
    let alone = bake_floor(&room);
    let floor = &room.objects[0];
    let vertices: Vec<usize> =
        (floor.vertices.start as usize..floor.vertices.end as usize).collect();
    let alone8 = Floor {
        points: alone.points.clone(),
        normals: alone.normals.clone(),
        transfer: bake_vertices(&room, &shadowed(8, SAMPLES), &vertices)
            .into_iter()
            .map(|t| t.into_iter().map(|x| x as f32).collect())
            .collect(),
    };
    let (order4, order8) = (OccludedLight::new(&light), OccludedLight::new(&cut));
    for k in 0..POSITIONS.len() {
        let c = centre(k);
        let truth = relit(
            &order4,
            &bake_floor(&cornell_with_balls(dir.path(), &[c])),
            &[],
        );
        let spheres = occluder.placed(c.as_dvec3(), DQuat::IDENTITY);
        let near = near(&alone, &[c]);
        let ratio = |light: &OccludedLight, floor: &Floor| {
            rms(&relit(light, floor, &spheres), &truth, &near)
                / rms(&relit(light, floor, &[]), &truth, &near)
        };
        let (r4, r8) = (ratio(&order4, &alone), ratio(&order8, &alone8));
        println!("ball at {c}: ratio {r4:.3} at order 4, {r8:.3} with T and V at order 8");
        assert!(r8 <= 1.0 / 3.0, "ball at {c}: {r8} with T and V at order 8");
    }
}
