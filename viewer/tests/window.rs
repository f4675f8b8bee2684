//! The window path, under a virtual X server (Xvfb, which `scripts/install-deps.sh`
//! installs): the viewer opens a window, renders frames with scripted keys, and exits on a
//! frame count or on Escape.

mod common;

use std::path::Path;
use std::process::Command;

fn xvfb_run() -> Command {
    let status = Command::new("sh")
        .args(["-c", "command -v xvfb-run"])
        .output()
        .expect("sh runs");
    assert!(
        status.status.success(),
        "xvfb-run is missing: run scripts/install-deps.sh (make test does)"
    );
    let mut command = Command::new("xvfb-run");
    command.args(["-a", "-s", "-screen 0 1024x768x24"]);
    command
}

fn bake_to(folder: &Path) -> std::path::PathBuf {
    let mut bake = common::demo_bake(4);
    let path = folder.join("demo.prt");
    bake.file.write(&path).unwrap();
    path
}

fn run(args: &[&str], file: &Path) -> (String, String) {
    let output = xvfb_run()
        .arg(env!("CARGO_BIN_EXE_prt-view"))
        .arg(common::demo_scene_path())
        .arg(file)
        .args(["--size", "320x180"])
        .args(args)
        .output()
        .expect("xvfb-run starts");
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(
        output.status.success(),
        "prt-view {args:?} failed ({}):\n{stdout}\n{stderr}",
        output.status
    );
    (stdout, stderr)
}

#[test]
fn the_window_renders_frames_with_every_control_and_exits_after_a_frame_count() {
    let folder = tempfile::tempdir().unwrap();
    let file = bake_to(folder.path());
    let keys = "F1,Q,A,W,E,2,1,T,N,L,Up,Down,Left,Right,F2";
    let (stdout, _) = run(&["--frames", "40", "--keys", keys], &file);
    assert!(stdout.contains("prt-view: 40 frames in"), "{stdout}");
}

#[test]
fn the_window_exits_on_escape() {
    let folder = tempfile::tempdir().unwrap();
    let file = bake_to(folder.path());
    // No frame limit: only the scripted Escape ends the run. Each key is pressed on one frame
    // and released on the next, so Escape comes on the fifth, after 4 drawn frames.
    let (stdout, _) = run(&["--keys", "F1,F2,Escape"], &file);
    assert!(stdout.contains("prt-view: 4 frames in"), "{stdout}");
}
