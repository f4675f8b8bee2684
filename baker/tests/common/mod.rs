//! Helpers shared by the end-to-end tests of the `prt-bake` binary (`cli.rs`, `cli_lights.rs`).
//!
//! Every test runs the real executable inside a scratch folder of its own, with relative
//! paths so messages can be checked exactly, and writes its outputs under that folder's
//! `out/`, so "nothing left behind" is "`out/` holds exactly the expected names".

// Each test binary includes this module and uses a different part of it.
#![allow(dead_code)]

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use tempfile::TempDir;

/// Exit codes of `prt-bake` (see `main.rs`).
pub const EXIT_BAD_COMMAND_LINE: i32 = 2;
pub const EXIT_BAD_INPUT: i32 = 3;

/// A scratch folder for one test: inputs at its root, outputs under `out/`.
pub struct Scratch {
    dir: TempDir,
}

impl Scratch {
    pub fn new() -> Scratch {
        let dir = tempfile::tempdir().expect("create a scratch folder");
        std::fs::create_dir(dir.path().join("out")).expect("create out/");
        Scratch { dir }
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    pub fn write(&self, name: &str, contents: impl AsRef<[u8]>) {
        std::fs::write(self.path(name), contents).expect("write a scratch file");
    }

    pub fn read(&self, name: &str) -> Vec<u8> {
        std::fs::read(self.path(name)).unwrap_or_else(|err| panic!("read {name}: {err}"))
    }

    /// The linear radiance of every vertex of a PLY written by `relight`.
    pub fn ply_radiance(&self, name: &str) -> Vec<[f32; 3]> {
        let points = prt_baker::formats::ply::read_radiance(&self.read(name));
        points.unwrap().into_iter().map(|(_, r)| r).collect()
    }

    /// Runs `prt-bake` with `args` inside the scratch folder.
    pub fn run(&self, args: &[&str]) -> Run {
        let output = Command::new(env!("CARGO_BIN_EXE_prt-bake"))
            .args(args)
            .current_dir(self.dir.path())
            .output()
            .expect("start prt-bake");
        Run {
            args: args.join(" "),
            code: output.status.code(),
            stdout: String::from_utf8(output.stdout).expect("stdout is UTF-8"),
            stderr: String::from_utf8(output.stderr).expect("stderr is UTF-8"),
        }
    }

    /// Bakes a scene quietly into `out/NAME` (with 64 samples unless `extra` sets `--samples`)
    /// and checks it succeeded.
    pub fn bake(&self, scene: &str, output: &str, extra: &[&str]) -> Run {
        let output = format!("out/{output}");
        let mut args = vec!["bake", scene, "-o", &output, "--quiet"];
        args.extend(extra);
        if !extra.contains(&"--samples") {
            args.extend(["--samples", "64"]);
        }
        // Texel bakes are raw here unless a test asks, which keeps these tests quick: the
        // denoiser is tested by tests/denoise.rs and cli_lightmap.rs, and denoised shards,
        // checkpoints and stages by the tests that ask for --denoise.
        if extra.contains(&"--lightmap") && !extra.contains(&"--denoise") {
            args.extend(["--denoise", "off"]);
        }
        self.run(&args).success()
    }

    /// Asserts that `out/` holds exactly `names`: no partial output, no temporary file.
    pub fn assert_out_holds(&self, names: &[&str]) {
        assert_folder_holds(&self.path("out"), names);
    }
}

pub fn assert_folder_holds(folder: &Path, names: &[&str]) {
    let found: BTreeSet<String> = std::fs::read_dir(folder)
        .expect("list the folder")
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let expected: BTreeSet<String> = names.iter().map(|n| n.to_string()).collect();
    assert_eq!(
        found,
        expected,
        "unexpected contents of {}",
        folder.display()
    );
}

/// What one run of `prt-bake` did.
pub struct Run {
    pub args: String,
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Run {
    pub fn success(self) -> Run {
        assert_eq!(
            self.code,
            Some(0),
            "prt-bake {} failed:\n{}",
            self.args,
            self.stderr
        );
        self
    }

    /// Asserts exit code `code`, nothing on stdout, and a single error line that contains every
    /// one of `needles`.
    pub fn fails_with(&self, code: i32, needles: &[&str]) {
        assert_eq!(
            self.code,
            Some(code),
            "prt-bake {}: exit code; stderr:\n{}",
            self.args,
            self.stderr
        );
        assert_eq!(self.stdout, "", "prt-bake {}: stdout", self.args);
        assert!(
            self.stderr.starts_with("prt-bake: error: ") && self.stderr.lines().count() == 1,
            "prt-bake {}: expected one error line, got:\n{}",
            self.args,
            self.stderr
        );
        for needle in needles {
            assert!(
                self.stderr.contains(needle),
                "prt-bake {}: error message lacks {needle:?}:\n{}",
                self.args,
                self.stderr
            );
        }
    }

    pub fn fails_with_bad_input(&self, needles: &[&str]) {
        self.fails_with(EXIT_BAD_INPUT, needles);
    }
}

/// Standard base64 (RFC 4648, padded), for glTF data URIs.
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}
