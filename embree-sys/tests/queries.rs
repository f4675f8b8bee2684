//! The safe API against hand-checkable geometry: one unit square (two triangles) in z = 0.

use embree_sys::{
    BuildQuality, CommittedScene, Device, ErrorKind, PACKET_WIDTH, Ray, Ray16, RayHit, RayHit16,
    SceneBuilder, SceneFlags,
};

const SQUARE: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];
const SQUARE_TRIS: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

fn square_scene() -> CommittedScene {
    let device = Device::new().expect("device");
    let mut builder = SceneBuilder::new(&device).expect("scene");
    builder.set_build_quality(BuildQuality::High);
    builder.set_flags(SceneFlags {
        robust: true,
        compact: false,
    });
    assert_eq!(
        builder
            .add_triangle_mesh(&SQUARE, &SQUARE_TRIS)
            .expect("mesh"),
        0
    );
    builder.commit().expect("commit")
}

/// Rays from z = 1 straight down over a grid that straddles the square's edges.
fn grid_rays(n: usize) -> Vec<Ray> {
    (0..n * n)
        .map(|k| {
            let x = -0.25 + 1.5 * (k % n) as f32 / (n - 1) as f32;
            let y = -0.25 + 1.5 * (k / n) as f32 / (n - 1) as f32;
            Ray::new(
                [x + 1e-3, y + 2e-3, 1.0],
                [0.0, 0.0, -1.0],
                0.0,
                f32::INFINITY,
            )
        })
        .collect()
}

fn inside_square(ray: &Ray) -> bool {
    let [x, y, _] = ray.origin();
    (0.0..=1.0).contains(&x) && (0.0..=1.0).contains(&y)
}

#[test]
fn committed_scene_is_send_and_sync() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<CommittedScene>();
    assert_send_sync::<Device>();
}

#[test]
fn closest_hit_reports_primitive_barycentrics_distance_and_normal() {
    let scene = square_scene();
    assert_eq!(scene.triangle_count(), 2);
    let hit = scene
        .intersect1(&Ray::new(
            [0.75, 0.25, 2.0],
            [0.0, 0.0, -1.0],
            0.0,
            f32::INFINITY,
        ))
        .expect("the ray passes through triangle 0");
    assert_eq!((hit.prim_id, hit.geom_id), (0, 0));
    assert!((hit.t - 2.0).abs() < 1e-6, "t = {}", hit.t);
    // Point (0.75, 0.25) = (1-u-v)·v0 + u·v1 + v·v2 with v1 = (1,0), v2 = (1,1): u = 0.5, v = 0.25.
    assert!(
        (hit.u - 0.5).abs() < 1e-6 && (hit.v - 0.25).abs() < 1e-6,
        "{hit:?}"
    );
    // Counter-clockwise seen from +z: (v1 − v0) × (v2 − v0) points to +z.
    let n = hit.ng;
    assert!(
        n[2] > 0.0 && n[0].abs() < 1e-6 && n[1].abs() < 1e-6,
        "Ng = {n:?}"
    );

    let hit = scene
        .intersect1(&Ray::new(
            [0.25, 0.75, -1.0],
            [0.0, 0.0, 1.0],
            0.0,
            f32::INFINITY,
        ))
        .expect("hit from below");
    assert_eq!(hit.prim_id, 1);
    assert!(
        hit.ng[2] > 0.0,
        "the normal does not depend on the side the ray comes from"
    );

    let miss = scene.intersect1(&Ray::new(
        [2.0, 2.0, 1.0],
        [0.0, 0.0, -1.0],
        0.0,
        f32::INFINITY,
    ));
    assert_eq!(miss, None);
    let short = scene.intersect1(&Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0], 0.0, 0.5));
    assert_eq!(short, None, "tfar bounds the segment");
}

#[test]
fn single_packet_and_stream_occlusion_agree_with_geometry() {
    let scene = square_scene();
    let rays = grid_rays(37);
    let expected: Vec<bool> = rays.iter().map(inside_square).collect();

    let single: Vec<bool> = rays.iter().map(|r| scene.occluded1(r)).collect();
    assert_eq!(single, expected);

    let mut stream = rays.clone();
    scene.occluded_stream(&mut stream);
    assert_eq!(
        stream.iter().map(Ray::is_occluded).collect::<Vec<_>>(),
        expected
    );

    let mut packet = Ray16::default();
    let mut packed = Vec::new();
    for chunk in rays.chunks(PACKET_WIDTH) {
        packet.clear();
        for (i, r) in chunk.iter().enumerate() {
            packet.set(i, r.origin(), r.dir(), 0.0, r.tfar());
        }
        scene.occluded16(&mut packet);
        packed.extend((0..chunk.len()).map(|i| packet.is_occluded(i)));
        assert!((chunk.len()..PACKET_WIDTH).all(|i| !packet.is_active(i)));
    }
    assert_eq!(packed, expected);
}

#[test]
fn packet_and_stream_closest_hits_equal_single_ray_hits() {
    let scene = square_scene();
    let rays = grid_rays(29);
    let single: Vec<_> = rays.iter().map(|r| scene.intersect1(r)).collect();
    assert!(single.iter().filter(|h| h.is_some()).count() > 100);

    let mut stream: Vec<RayHit> = rays.iter().map(|r| RayHit::new(*r)).collect();
    scene.intersect_stream(&mut stream);
    assert_eq!(stream.iter().map(RayHit::hit).collect::<Vec<_>>(), single);

    let mut packet = RayHit16::default();
    let mut packed = Vec::new();
    for chunk in rays.chunks(PACKET_WIDTH) {
        packet.clear();
        for (i, r) in chunk.iter().enumerate() {
            packet.set(i, r.origin(), r.dir(), 0.0, r.tfar());
        }
        scene.intersect16(&mut packet);
        packed.extend((0..chunk.len()).map(|i| packet.hit(i)));
    }
    assert_eq!(packed, single);
}

#[test]
fn queries_from_many_threads_share_one_scene() {
    let scene = square_scene();
    let rays = grid_rays(64);
    let expected: Vec<bool> = rays.iter().map(inside_square).collect();
    std::thread::scope(|s| {
        for part in 0..4 {
            let (scene, rays, expected) = (&scene, &rays, &expected);
            s.spawn(move || {
                for (r, &e) in rays.iter().zip(expected).skip(part).step_by(4) {
                    assert_eq!(scene.occluded1(r), e);
                }
            });
        }
    });
}

#[test]
fn out_of_range_index_is_rejected_before_embree_reads_it() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device).unwrap();
    let err = builder
        .add_triangle_mesh(&SQUARE, &[[0, 1, 4]])
        .unwrap_err();
    assert_eq!(err.kind, ErrorKind::InvalidArgument);
    assert!(err.to_string().contains("index [0, 1, 4]"), "{err}");
    let err = builder.add_triangle_mesh(&[], &[]).unwrap_err();
    assert_eq!(err.kind, ErrorKind::InvalidArgument);
}

#[test]
fn bad_device_configuration_is_a_typed_error() {
    let err = Device::with_config("threads=2\0verbose=1").unwrap_err();
    assert_eq!(err.kind, ErrorKind::InvalidArgument);
    assert!(err.to_string().contains("NUL"), "{err}");
    assert!(Device::with_config("threads=2").is_ok());
}

#[test]
fn failed_device_creation_is_a_typed_error() {
    let err = Device::with_config("threads=abc").unwrap_err();
    assert!(err.to_string().starts_with("embree: "), "{err}");
}

#[test]
fn empty_committed_scene_blocks_nothing() {
    let scene = SceneBuilder::new(&Device::new().unwrap())
        .unwrap()
        .commit()
        .unwrap();
    assert!(!scene.occluded1(&Ray::new([0.0; 3], [0.0, 0.0, 1.0], 0.0, f32::INFINITY)));
    assert_eq!(
        scene.intersect1(&Ray::new([0.0; 3], [0.0, 0.0, 1.0], 0.0, f32::INFINITY)),
        None
    );
}

/// An instance of the square scene, scaled by 2 and moved to x ≥ 10: rays hit it there (with
/// the instance's id, and the square's own primitive ids and mesh-space barycentrics), both
/// by occlusion and closest hit, and not where the square itself lies.
#[test]
fn instances_are_hit_where_their_transform_places_them() {
    let device = Device::new().expect("device");
    let square = std::sync::Arc::new(square_scene());
    let mut builder = SceneBuilder::new(&device).expect("scene");
    // Column-major 3×4: x, y, z axes, then the translation.
    let to_world = [2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0, 10.0, 0.0, 0.0];
    let id = builder.add_instance(&square, &to_world).expect("instance");
    let top = builder.commit().expect("commit");
    assert_eq!(top.triangle_count(), 2);
    let down = |x: f32, y: f32| Ray::new([x, y, 1.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY);
    let hit = top
        .intersect1(&down(11.5, 0.5))
        .expect("a hit on the instance");
    assert_eq!(hit.inst_id, Some(id));
    assert_eq!((hit.geom_id, hit.prim_id), (0, 0));
    assert!(
        (hit.t - 1.0).abs() < 1e-6 && (hit.u - 0.5).abs() < 1e-6,
        "{hit:?}"
    );
    assert!(top.occluded1(&down(11.5, 0.5)));
    assert!(!top.occluded1(&down(0.5, 0.5)));
    assert!(top.intersect1(&down(0.5, 0.5)).is_none());
    assert_eq!(
        square
            .intersect1(&down(0.5, 0.5))
            .expect("the square")
            .inst_id,
        None
    );
    let bad = [f32::NAN; 12];
    let mut builder = SceneBuilder::new(&device).expect("scene");
    let err = builder
        .add_instance(&square, &bad)
        .expect_err("a NaN transform");
    assert_eq!(err.kind, ErrorKind::InvalidArgument);
}
