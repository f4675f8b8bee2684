//! Double-sided surfaces (issue 30, part 2; the rule is in docs/scenes.md, "Two-sided
//! surfaces"): transfer is baked for the side a triangle's normal faces; a surface seen from
//! both sides is two single-sided sheets back to back, and each sheet's receivers see past
//! their twin. A single-sided triangle occludes from both sides, on both backends.

use glam::Vec3;
use prt_baker::math::sh;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{Backend, TracerOptions, build};
use prt_baker::{Scene, Transfer};
use prt_tests::*;

const ORDER: usize = 3;
const SAMPLES: u32 = 256;

fn bake(scene: &Scene, backend: Backend) -> Transfer {
    let tracer = build(backend, scene, TracerOptions::default()).expect("tracer");
    prt_baker::bake(scene, Some(&*tracer), &shadowed(ORDER, SAMPLES), &Silent).expect("bake")
}

/// Vertex `v`'s coefficients (channel 0).
fn coefficients(t: &Transfer, v: u32) -> &[f32] {
    let n = sh::coeff_count(ORDER);
    &t.coefficients[v as usize * n * t.channels..][..n]
}

/// The radiance transfer toward a distant light from direction `d` (the light's SH is a
/// delta there): Σ_j c_j y_j(d).
fn response(c: &[f32], d: Vec3) -> f32 {
    let mut y = vec![0.0; c.len()];
    sh::Basis::new(ORDER).eval(d, &mut y);
    c.iter().zip(&y).map(|(a, b)| a * b).sum()
}

/// A 2 × 2 card at height 1: its front sheet faces +z; `back` adds its twin facing −z.
fn card(back: bool) -> Vec<prt_baker::scene::Mesh> {
    let corner = Vec3::new(-1.0, -1.0, 1.0);
    let mut sheets = vec![grid("front", corner, Vec3::X * 2.0, Vec3::Y * 2.0, 4)];
    if back {
        sheets.push(grid("back", corner, Vec3::Y * 2.0, Vec3::X * 2.0, 4));
    }
    sheets
}

/// A card lit only from behind (a light straight below): its front side stays dark and its
/// back side is lit as an engine shows it (the lobe about the flipped normal); the twin
/// sheet does not shadow its partner.
#[test]
fn a_card_lit_from_behind_is_dark_in_front_and_lit_behind() {
    let scene = scene(card(true));
    for backend in [Backend::Embree, Backend::Obvhs] {
        let t = bake(&scene, backend);
        let side = |object: usize| {
            let vertices = scene.objects[object].vertices.clone();
            let count = vertices.len() as f32;
            let (mut below, mut above, mut open) = (0.0, 0.0, 0.0);
            for v in vertices {
                let c = coefficients(&t, v);
                below += response(c, Vec3::NEG_Z) / count;
                above += response(c, Vec3::Z) / count;
                open += t.visibility[v as usize].accessibility / count;
            }
            (below, above, open)
        };
        let (front, back) = (side(0), side(1));
        eprintln!("{backend:?}: front (from below, above, open) {front:?}, back {back:?}");
        // Lit: the order-3 clamped cosine's response at its axis (0.338); dark: its response
        // at the opposite pole (0.020, the truncated series' ringing).
        assert!(
            back.0 > 0.3 && back.1.abs() < 0.03,
            "{backend:?}: back {back:?}"
        );
        assert!(
            front.0.abs() < 0.03 && front.1 > 0.3,
            "{backend:?}: front {front:?}"
        );
        assert!(
            front.2 > 0.99 && back.2 > 0.99,
            "{backend:?}: a twin shadows its partner"
        );
    }
}

/// A single-sided card shadows a floor the same whichever way it faces.
#[test]
fn a_single_sided_card_occludes_from_both_sides() {
    let floor = || {
        grid(
            "floor",
            Vec3::new(-3.0, -3.0, 0.0),
            Vec3::X * 6.0,
            Vec3::Y * 6.0,
            12,
        )
    };
    let up = scene(vec![floor(), card(false).remove(0)]);
    let down = scene(vec![
        floor(),
        grid(
            "down",
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::Y * 2.0,
            Vec3::X * 2.0,
            4,
        ),
    ]);
    let alone = scene(vec![floor()]);
    for backend in [Backend::Embree, Backend::Obvhs] {
        let (up_t, down_t, alone_t) = (
            bake(&up, backend),
            bake(&down, backend),
            bake(&alone, backend),
        );
        let centre = 6 * 13 + 6; // the floor's centre vertex, under the card
        let dc = coefficients(&alone_t, centre)[0];
        let (u, d) = (
            coefficients(&up_t, centre)[0],
            coefficients(&down_t, centre)[0],
        );
        eprintln!(
            "{backend:?}: centre DC open {dc:.4}, under a card facing up {u:.4}, down {d:.4}"
        );
        assert!(
            u < 0.8 * dc,
            "{backend:?}: a card facing away does not occlude"
        );
        for v in up.objects[0].vertices.clone() {
            assert_eq!(
                coefficients(&up_t, v),
                coefficients(&down_t, v),
                "{backend:?}: vertex {v}"
            );
        }
    }
}
