//! The filter's geometric terms, on synthetic sheets of receivers.

use super::*;
use glam::Vec3;

/// A square `side` × `side` grid of receivers at spacing 1 from `origin` along `u`, `v`,
/// facing `normal`, in `group`.
fn sheet(guides: &mut Guides, origin: Vec3, u: Vec3, v: Vec3, normal: Vec3, group: u32) {
    for a in 0..12 {
        for b in 0..12 {
            guides.points.push(origin + u * a as f32 + v * b as f32);
            guides.normals.push(normal);
            guides.surfaces.push(normal);
            guides.groups.push(group);
            guides.spacing.push(1.0);
            guides.noise.push(1e-4);
        }
    }
}

/// The largest weight any receiver of the first sheet (the first 144) gives the second,
/// every receiver holding the same transfer, so only the geometric terms can tell them
/// apart.
fn weight_across(guides: &Guides) -> f32 {
    let transfer = vec![0.5f32; guides.points.len() * 4];
    let filter = Filter::new(guides, Settings::TEXELS, &transfer, 1, 4);
    let mut row = Vec::new();
    let mut most = 0.0f32;
    for i in 0..144 {
        filter.row(i, &mut row);
        for &(j, w) in &row {
            if j >= 144 {
                most = most.max(w.abs());
            }
        }
    }
    most
}

#[test]
fn a_crease_a_step_and_another_object_get_no_weight() {
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    // A floor meeting a wall at a right angle.
    let mut crease = Guides::default();
    sheet(&mut crease, Vec3::ZERO, x, y, z, 0);
    sheet(&mut crease, Vec3::new(0.0, 12.0, 0.5), x, z, -y, 0);
    assert!(weight_across(&crease) < 1e-3, "{}", weight_across(&crease));
    // A slab three texels above the floor, facing the same way.
    let mut step = Guides::default();
    sheet(&mut step, Vec3::ZERO, x, y, z, 0);
    sheet(&mut step, Vec3::new(6.0, 0.0, 3.0), x, y, z, 0);
    assert!(weight_across(&step) < 1e-3, "{}", weight_across(&step));
    // Two objects side by side in one plane.
    let mut objects = Guides::default();
    sheet(&mut objects, Vec3::ZERO, x, y, z, 0);
    sheet(&mut objects, Vec3::new(12.0, 0.0, 0.0), x, y, z, 1);
    assert_eq!(weight_across(&objects), 0.0);
    // Two objects meeting closer than a texel, within one cluster's reach: no cluster
    // takes in both.
    let mut touching = Guides::default();
    sheet(&mut touching, Vec3::ZERO, x, y, z, 0);
    sheet(&mut touching, Vec3::new(11.5, 0.0, 0.0), x, y, z, 1);
    assert_eq!(weight_across(&touching), 0.0);
    // And one object continuing in that plane does share.
    let mut one = Guides::default();
    sheet(&mut one, Vec3::ZERO, x, y, z, 0);
    sheet(&mut one, Vec3::new(12.0, 0.0, 0.0), x, y, z, 0);
    assert!(weight_across(&one) > 1e-2);
}
