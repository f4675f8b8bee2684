//! `prt-view` from the command line: headless screenshots, refusing a file baked for another
//! scene, bad options.

mod common;

use std::process::Command;

fn prt_view() -> Command {
    Command::new(env!("CARGO_BIN_EXE_prt-view"))
}

#[test]
fn headless_screenshots_have_the_requested_size_in_both_modes() {
    let folder = tempfile::tempdir().unwrap();
    let mut bake = common::demo_bake(4);
    let file = folder.path().join("demo.prt");
    bake.file.write(&file).unwrap();
    for mode in ["prt", "phong"] {
        let png = folder.path().join(format!("{mode}.png"));
        let output = prt_view()
            .arg(common::demo_scene_path())
            .arg(&file)
            .args(["--headless", "--screenshot"])
            .arg(&png)
            .args([
                "--size",
                "200x120",
                "--mode",
                mode,
                "--camera",
                "5,-5,3.5,135,-23",
            ])
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let image = image::open(&png).unwrap();
        assert_eq!((image.width(), image.height()), (200, 120));
    }
}

#[test]
fn a_file_baked_for_another_scene_is_refused() {
    let folder = tempfile::tempdir().unwrap();
    let mut bake = common::demo_bake(1);
    let file = folder.path().join("torus.prt");
    bake.file.write(&file).unwrap();
    let cornell = common::workspace().join("scenes/cornell/cornell.scene");
    let output = prt_view()
        .arg(&cornell)
        .arg(&file)
        .args(["--headless", "--screenshot"])
        .arg(folder.path().join("x.png"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("baked for a scene with 13500 vertices"),
        "{stderr}"
    );
    assert!(!folder.path().join("x.png").exists());
}

#[test]
fn malformed_options_are_refused() {
    let scene = common::demo_scene_path();
    for (args, message) in [
        (&["--headless"][..], "--screenshot"),
        (&["--size", "12x"][..], "not a size"),
        (&["--keys", "F1,F9"][..], "unknown key F9"),
    ] {
        let output = prt_view()
            .arg(&scene)
            .arg("x.prt")
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
    }
}

/// The output policy: a screenshot may not replace an input (the scene's texture here, the
/// coefficient file, through a link), checked before the GPU starts; the inputs stay as they were.
#[test]
fn a_screenshot_over_an_input_is_refused() {
    let folder = tempfile::tempdir().unwrap();
    let mut bake = common::demo_bake(1);
    let file = folder.path().join("demo.prt");
    bake.file.write(&file).unwrap();
    let texture = common::workspace().join("scenes/torus/torus.tga");
    let link = folder.path().join("link.png");
    std::os::unix::fs::symlink(&file, &link).unwrap();
    for target in [&texture, &file, &link] {
        let before = std::fs::read(target).unwrap();
        let output = prt_view()
            .arg(common::demo_scene_path())
            .arg(&file)
            .args(["--headless", "--screenshot"])
            .arg(target)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("input"), "{stderr}");
        assert_eq!(std::fs::read(target).unwrap(), before);
    }
}
