//! The output policy and the resource limits, end to end through `prt-bake`: an output that
//! is an input, a directory or a full device is refused or reported, a panic or a signal in
//! the middle of a write leaves the previous output and no temporary file, and sizes declared
//! in headers or asked on the command line are refused before they are allocated.

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

use common::*;

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A scene file naming an OBJ with a material library and a texture.
fn textured_scene(scratch: &Scratch) {
    scratch.write("mesh.obj", format!("mtllib mesh.mtl\nusemtl m\n{TRIANGLE}"));
    scratch.write("mesh.mtl", "newmtl m\nKd 1 1 1\nmap_Kd tex.tga\n");
    let mut tga = vec![0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 1, 0, 24, 0x20];
    tga.extend([10, 20, 30]);
    scratch.write("tex.tga", tga);
    scratch.write("scene.scene", "\"mesh.obj\"\n");
}

fn temporary_files(scratch: &Scratch, folder: &str) -> Vec<String> {
    std::fs::read_dir(scratch.path(folder))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let scratch = Scratch::new();
    textured_scene(&scratch);
    for input in ["scene.scene", "mesh.obj", "mesh.mtl", "tex.tga"] {
        let before = scratch.read(input);
        scratch
            .run(&[
                "bake",
                "scene.scene",
                "-o",
                input,
                "--quiet",
                "--samples",
                "8",
            ])
            .fails_with(
                EXIT_BAD_COMMAND_LINE,
                &[input, "is an input of this command"],
            );
        assert_eq!(scratch.read(input), before, "{input} was changed");
    }
    // Through a link, and a bare OBJ.
    std::os::unix::fs::symlink("../mesh.obj", scratch.path("out/link.prt")).unwrap();
    scratch
        .run(&["bake", "mesh.obj", "-o", "out/link.prt", "--quiet"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["same file as the input mesh.obj"]);
    assert!(temporary_files(&scratch, ".").is_empty());
}

#[test]
fn export_light_and_relight_refuse_their_inputs() {
    let scratch = Scratch::new();
    textured_scene(&scratch);
    scratch.bake("scene.scene", "a.prt", &[]);
    scratch.write("rig.toml", "[[light]]\nkind = \"constant\"\n");
    let prt = scratch.read("out/a.prt");
    scratch
        .run(&[
            "export",
            "out/a.prt",
            "--scene",
            "scene.scene",
            "--npz",
            "out/a.prt",
        ])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["is an input"]);
    scratch
        .run(&[
            "export",
            "out/a.prt",
            "--scene",
            "scene.scene",
            "--npz",
            "tex.tga",
        ])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["is an input"]);
    scratch
        .run(&["light", "rig.toml", "-o", "rig.toml"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["is an input"]);
    scratch
        .run(&[
            "relight",
            "scene.scene",
            "out/a.prt",
            "--lights",
            "rig.toml",
            "-o",
            "mesh.mtl",
        ])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["is an input"]);
    assert_eq!(scratch.read("out/a.prt"), prt);
    scratch.assert_out_holds(&["a.prt"]);
}

#[test]
fn directories_devices_and_standard_output() {
    let scratch = Scratch::new();
    scratch.write("t.obj", TRIANGLE);
    scratch
        .run(&["bake", "t.obj", "-o", "out", "--quiet"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["out: is a directory"]);
    // A full device: the error is reported, and the device stays a device.
    scratch
        .run(&["bake", "t.obj", "-o", "/dev/full", "--quiet"])
        .fails_with(1, &["/dev/full: No space left on device"]);
    use std::os::unix::fs::FileTypeExt;
    let kind = std::fs::symlink_metadata("/dev/full").unwrap().file_type();
    assert!(kind.is_char_device());
    scratch
        .run(&["bake", "t.obj", "-o", "/dev/null", "--quiet"])
        .success();
    // `-`: standard output for JSON, refused where stdout carries the summary.
    scratch.write("rig.toml", "[[light]]\nkind = \"constant\"\n");
    let run = scratch.run(&["light", "rig.toml", "-o", "-"]).success();
    assert!(
        run.stdout.starts_with("{\n  \"order\": 4"),
        "{}",
        run.stdout
    );
    scratch
        .run(&["bake", "t.obj", "-o", "-", "--quiet"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["standard output"]);
    scratch.assert_out_holds(&[]);
}

#[test]
fn a_panic_mid_write_keeps_the_old_output_and_leaves_no_temporary_file() {
    let scratch = Scratch::new();
    scratch.write("t.obj", TRIANGLE);
    scratch.bake("t.obj", "a.prt", &[]);
    let before = scratch.read("out/a.prt");
    let output = Command::new(env!("CARGO_BIN_EXE_prt-bake"))
        .args(["bake", "t.obj", "-o", "out/a.prt", "--quiet", "--seed", "7"])
        .current_dir(scratch.path("."))
        .env("PRT_TEST_FAULT", "panic-mid-write")
        .output()
        .unwrap();
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.starts_with("prt-bake: error: internal error (a bug at ")
            && stderr.contains("no output was written")
            && stderr.lines().count() == 1,
        "{stderr}"
    );
    assert_eq!(scratch.read("out/a.prt"), before);
    scratch.assert_out_holds(&["a.prt"]);
}

/// Starts the child with `signal` at its default action and unblocked, whatever this test
/// inherited: started in the background (`make test &` in a script, `nohup`), a shell has
/// SIGINT ignored, the child inherits that, and the baker rightly keeps an ignored signal
/// ignored (as `nohup` means it), so it would not die of the SIGINT sent below.
fn with_default_disposition(command: &mut Command, signal: libc::c_int) {
    use std::os::unix::process::CommandExt;
    // SAFETY: between fork and exec only async-signal-safe calls (signal, sigemptyset,
    // sigaddset, sigprocmask), on the child's own state.
    unsafe {
        command.pre_exec(move || {
            if libc::signal(signal, libc::SIG_DFL) == libc::SIG_ERR {
                return Err(std::io::Error::last_os_error());
            }
            let mut set: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            libc::sigaddset(&mut set, signal);
            if libc::sigprocmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut()) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
}

#[test]
fn a_signal_mid_write_keeps_the_old_output_and_leaves_no_temporary_file() {
    for signal in [libc::SIGTERM, libc::SIGINT] {
        let scratch = Scratch::new();
        scratch.write("t.obj", TRIANGLE);
        scratch.bake("t.obj", "a.prt", &[]);
        let before = scratch.read("out/a.prt");
        let mut command = Command::new(env!("CARGO_BIN_EXE_prt-bake"));
        command
            .args(["bake", "t.obj", "-o", "out/a.prt", "--quiet", "--seed", "7"])
            .current_dir(scratch.path("."))
            .env("PRT_TEST_FAULT", "pause-mid-write")
            .stderr(Stdio::piped())
            .stdout(Stdio::null());
        with_default_disposition(&mut command, signal);
        let mut child = command.spawn().unwrap();
        let mut stderr = BufReader::new(child.stderr.take().unwrap());
        let mut line = String::new();
        stderr.read_line(&mut line).unwrap();
        assert!(line.contains("paused mid-write"), "{line}");
        // The temporary file exists now, complete but not renamed.
        assert_eq!(temporary_files(&scratch, "out").len(), 1);
        // SAFETY: signalling our own child.
        assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
        let status = child.wait().unwrap();
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(status.signal(), Some(signal), "ends as the signal would");
        assert_eq!(scratch.read("out/a.prt"), before);
        scratch.assert_out_holds(&["a.prt"]);
    }
}

#[test]
fn absurd_sizes_are_refused_before_allocation() {
    let scratch = Scratch::new();
    scratch.write("t.obj", TRIANGLE);
    scratch
        .run(&[
            "bake",
            "t.obj",
            "-o",
            "out/a.prt",
            "--samples",
            "4000000000",
            "--order",
            "45",
        ])
        .fails_with(
            EXIT_BAD_COMMAND_LINE,
            &[
                "--samples: 4000000000 samples at order 45",
                "needs 29.6 TiB",
                "memory limit",
            ],
        );
    scratch
        .run(&["bake", "t.obj", "-o", "out/a.prt", "--order", "46"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["--order 46 is outside 1..=45"]);
    // A TGA declaring 65535×65535 pixels (64 GiB to decode), with a 1 GiB limit.
    let mut tga = vec![
        0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff, 32, 0x28,
    ];
    tga.extend([0; 64]);
    scratch.write("huge.tga", tga);
    scratch.write("s.scene", "t.obj huge.tga\n");
    scratch
        .run(&["--max-memory", "1024", "bake", "s.scene", "-o", "out/a.prt"])
        .fails_with_bad_input(&[
            "s.scene:1: texture huge.tga: decoding its declared 65535×65535 pixels needs 64.0 GiB",
            "over the memory limit of 1.0 GiB",
        ]);
    // An endless device given as the scene is read only so far.
    scratch
        .run(&["bake", "/dev/zero", "-o", "out/a.prt"])
        .fails_with_bad_input(&["/dev/zero: not a regular file, and longer than the 256.0 MiB"]);
    // An OBJ index of 10^18.
    scratch.write(
        "far.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1000000000000000000\n",
    );
    scratch
        .run(&["bake", "far.obj", "-o", "out/a.prt"])
        .fails_with_bad_input(&["far.obj:4: ", "face index out of range"]);
    // A coefficient file claiming 2^32 vertices: refused by its size before anything else.
    scratch.bake("t.obj", "small.prt", &[]);
    let mut prt = scratch.read("out/small.prt");
    prt[24..32].copy_from_slice(&(1u64 << 32).to_le_bytes());
    prt[72..80].copy_from_slice(&((1u64 << 32) * 64).to_le_bytes());
    scratch.write("huge.prt", prt);
    scratch
        .run(&["inspect", "huge.prt"])
        .fails_with_bad_input(&["huge.prt: truncated: the header announces 274877906944 bytes"]);
    // A bake larger than --max-memory is refused before it starts.
    let mut many = String::new();
    for i in 0..10_000 {
        many += &format!("v {i} 0 0\nv {i} 1 0\nv {i} 0 1\nf -3 -2 -1\n");
    }
    scratch.write("many.obj", many);
    scratch
        .run(&["--max-memory", "1", "bake", "many.obj", "-o", "out/a.prt"])
        .fails_with_bad_input(&[
            "many.obj: baking 30000 vertices at order 4 with 1024 samples needs",
            "over the memory limit of 1.0 MiB",
        ]);
    scratch.assert_out_holds(&["small.prt"]);
}
