//! The up axis in the viewer: the y-up glTF that `prt-bake export --gltf` makes of the z-up
//! Cornell box, baked and shown with the same default camera and rig, gives the OBJ's image
//! (up to the two bakes' noise); shown as if it were z-up, it does not.

mod common;

use std::path::Path;

use prt_baker::export::gltf::{Contents, glb_bytes};
use prt_baker::scene::Up;
use prt_baker::{BakeOptions, Mode, Scene};
use prt_viewer::lights::Lights;
use prt_viewer::{Bake, Camera, FrameInputs, View};

const SIZE: (u32, u32) = (320, 240);

fn image(gpu: &prt_viewer::Gpu, bake: &Bake) -> image::RgbaImage {
    // What `prt-view --headless` does without --camera and --lights.
    let camera = Camera::framing(&bake.scene.positions, SIZE.0 as f32 / SIZE.1 as f32);
    let lights = Lights::load(None, bake.order()).unwrap().for_up(bake.up());
    let view = View::new(camera, lights);
    common::render(gpu, bake, &FrameInputs::from_view(&view, None), SIZE)
}

#[test]
fn a_y_up_gltf_looks_like_the_z_up_obj_of_the_same_geometry() {
    let Some(gpu) = common::gpu() else { return };
    let options = BakeOptions {
        order: 4,
        samples: 512,
        mode: Mode::Shadowed,
        seed: 2,
        ..BakeOptions::default()
    };
    let cornell = common::workspace().join("scenes/cornell/cornell.scene");
    let obj = common::bake(&cornell, options.clone());

    let folder = tempfile::tempdir().unwrap();
    let glb = folder.path().join("cornell.glb");
    let scene = Scene::load(&cornell).unwrap();
    let contents = Contents {
        file: None,
        light: None,
        up: Up::Z,
    };
    std::fs::write(&glb, glb_bytes(&scene, &contents).unwrap().0).unwrap();
    let gltf = common::bake(&glb, options);
    assert_eq!(gltf.up(), Up::Y);
    // Shown turned to z-up: the OBJ's vertices.
    for (p, q) in obj.scene.positions.iter().zip(&gltf.scene.positions) {
        assert!((*p - *q).length() < 1e-5, "{p} vs {q}");
    }

    let expected = image(&gpu, &obj);
    let same = common::difference(&image(&gpu, &gltf), &expected, 8);
    eprintln!(
        "y-up glTF vs z-up OBJ: mean {:.3} codes, max {}, {:.3} % of pixels off by > 8",
        same.mean,
        same.max,
        100.0 * same.outliers
    );
    assert!(
        same.mean <= 1.0 && same.outliers <= 0.01,
        "the y-up glTF looks different: {same:?}"
    );

    // The same bake with its up axis ignored: lit from the side.
    let mut file = gltf.file.clone();
    file.header.up = Up::Z;
    let wrong_scene = Scene::load(&glb).unwrap();
    let wrong = Bake::new(wrong_scene, file, Path::new("wrong.prt")).unwrap();
    let wrong = common::difference(&image(&gpu, &wrong), &expected, 8);
    eprintln!("with the up axis ignored: mean {:.3} codes", wrong.mean);
    assert!(
        wrong.mean > 5.0,
        "a wrong up axis went unnoticed: {wrong:?}"
    );
}
