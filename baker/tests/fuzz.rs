//! Mutation fuzzing of every parser, on stable Rust: OBJ, MTL, scene file, glTF (`.glb` and
//! `.gltf`), TGA, PNG, HDR, EXR, rig TOML, the `.prt` coefficient file and the occluder file.
//!
//! Each parser gets seeds (valid files made here, plus every file committed under
//! `tests/fuzz-corpus/<parser>/`: hand-made seeds and the crashes found so far, kept as
//! regressions) and a fixed number of mutants of them from a deterministic mutator (bit flips,
//! interesting integers in headers, cut, duplicated and spliced ranges, numbers in text
//! replaced by huge, negative or non-finite ones, lines dropped or repeated). Every case must
//! return `Ok` or `Err`:
//!
//! * a panic fails the test, and the input is saved into the corpus folder as `crash-*`;
//! * a case running longer than [`CASE_TIME_LIMIT`] (a hang) ends the test, saved likewise;
//! * this binary's global allocator counts every byte; a case may not hold more than
//!   [`ALLOCATION_CAP`] at once (the parsers run with a 64 MiB `--max-memory`, so a header
//!   claiming gigabytes must be refused, not allocated). A single request above the cap is
//!   refused on the spot (the process aborts, the input saved as `fuzz-over-allocation.bin`).
//! * a `.prt` mutant whose checksum was not repaired must be rejected (a corruption that is
//!   accepted is counted and fails the test); with the checksum repaired, what is accepted
//!   must read back to the same bytes. An accepted occluder file must too.
//!
//! Besides byte mutants, a quarter of the glTF cases and an eighth of the OBJ, MTL, scene and
//! rig cases are made by structure-aware generators ([`structured_case`]): node hierarchies
//! with cycles, shared children and deep chains; buffer and image uris naming special files
//! (devices, a FIFO, a directory, symbolic links to them and out of the folder, `..` escapes
//! plain and percent-encoded, absolute and `file:` paths); byteLength, byteOffset, byteStride,
//! count and component types at interesting values; and OBJ `mtllib`, MTL `map_Kd`, scene
//! entries and rig maps naming the same special files. Half of those run with
//! `--allow-outside-uris`, so the device and FIFO refusal is reached behind the folder check.
//!
//! The gate is reproducible: without `PRT_FUZZ_SEED`, a run draws its cases from the fixed
//! seeds of [`GATE_SEEDS`], one after another, so the same commit always runs the same cases
//! (a red `make test` is the change's, never a new draw). `PRT_FUZZ_SEED=0x…` runs one seed
//! (a replay), and `PRT_FUZZ_SEED=random` draws a new one from the clock and the process id
//! (`make fuzz`, which also runs 20 times the mutants: the exploring campaign, whose findings
//! are saved into the corpus and so join the gate). Every seed is printed before its run
//! (`fuzz: seed 0x…`). The counts of a run with [`TABLE_SEED`] are the table of
//! `docs/explanation/robustness.md`, which this test checks at `make test`'s mutant count (with
//! `PRT_FUZZ_BLESS=1` it rewrites the table after a parser changed); any other seed checks
//! everything else (no panic, hang, over-allocation or accepted corruption) and prints its
//! table. `PRT_FUZZ_CASES=N` sets the mutants per parser and seed.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::{Cursor, Write};
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use common::base64;
use prt_baker::bake::transfer::{Aux, Mode};
use prt_baker::export::gltf::{Contents, glb_bytes};
use prt_baker::formats::coefficient_file::{Adaptive, CoefficientFile, Header};
use prt_baker::formats::occluder_file::{LocalSphere, OccluderFile};
use prt_baker::light::{EnvironmentMap, Rig};
use prt_baker::math::sampling::Sampling;
use prt_baker::scene::{Texture, Up};
use prt_baker::trace::Backend;
use prt_baker::{Location, Scene};

/// Mutants per parser in `make test`.
const DEFAULT_CASES: usize = 20_000;
/// The memory limit the parsers run under.
const MAX_MEMORY: u64 = 64 << 20;
/// The most one case may hold at once.
const ALLOCATION_CAP: usize = 256 << 20;
/// Longer than any case takes on a loaded machine (they take well under 10 ms).
const CASE_TIME_LIMIT: Duration = Duration::from_secs(10);
/// The seed of the table in `docs/explanation/robustness.md` (the seed every run used before runs drew
/// their own, so the parsers without structured cases keep their counts).
const TABLE_SEED: u64 = 0x5eed_0000;

/// The seeds `make test` runs, in order: the table's seed, the seed of the drawn run that found
/// the EXR block-size crash (docs/explanation/robustness.md), and one more fixed seed.
const GATE_SEEDS: [u64; 3] = [TABLE_SEED, 0x2d7c_19e3_4b5d_ec1a, 0x5eed_0001];

/// This run's seeds: `PRT_FUZZ_SEED` (decimal or `0x` hex) to replay one, `random` to draw a
/// new one from the clock and the process id, else [`GATE_SEEDS`].
fn run_seeds() -> Vec<u64> {
    let Ok(text) = std::env::var("PRT_FUZZ_SEED") else {
        return GATE_SEEDS.to_vec();
    };
    let text = text.trim();
    if text == "random" {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        return vec![Rng(nanos ^ (u64::from(std::process::id()) << 32)).next()];
    }
    let parsed = match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(hex) => u64::from_str_radix(hex, 16),
        None => text.parse(),
    };
    vec![parsed.unwrap_or_else(|_| panic!("PRT_FUZZ_SEED={text:?} is not a number or `random`"))]
}

// ---------------------------------------------------------------------------------------
// The counting allocator.

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
/// The input of the case running now, for the allocator to save if it must refuse.
static CASE_PTR: AtomicUsize = AtomicUsize::new(0);
static CASE_LEN: AtomicUsize = AtomicUsize::new(0);

impl Counting {
    fn over_cap(size: usize) {
        // No allocation in here: raw writes of the case and a fixed message.
        let message =
            b"fuzz: a single allocation over the cap; input saved as fuzz-over-allocation.bin\n";
        // SAFETY: plain system calls on a fixed path and the case's live buffer.
        unsafe {
            libc::write(2, message.as_ptr().cast(), message.len());
            let fd = libc::open(
                c"fuzz-over-allocation.bin".as_ptr(),
                libc::O_CREAT | libc::O_WRONLY | libc::O_TRUNC,
                0o644,
            );
            let (ptr, len) = (
                CASE_PTR.load(Ordering::SeqCst),
                CASE_LEN.load(Ordering::SeqCst),
            );
            if fd >= 0 && ptr != 0 {
                libc::write(fd, ptr as *const libc::c_void, len);
                libc::close(fd);
            }
        }
        let _ = size;
    }

    fn count(size: usize) {
        let live = LIVE.fetch_add(size, Ordering::Relaxed) + size;
        PEAK.fetch_max(live, Ordering::Relaxed);
    }
}

// SAFETY: forwards to the system allocator; only counts, and refuses (null) above the cap.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > ALLOCATION_CAP {
            Counting::over_cap(layout.size());
            return std::ptr::null_mut();
        }
        Counting::count(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > ALLOCATION_CAP {
            Counting::over_cap(layout.size());
            return std::ptr::null_mut();
        }
        Counting::count(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > ALLOCATION_CAP {
            Counting::over_cap(new_size);
            return std::ptr::null_mut();
        }
        let result = unsafe { System.realloc(ptr, layout, new_size) };
        if !result.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            Counting::count(new_size);
        }
        result
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Where [`on_abort`] saves the case running when the process aborts: a stack overflow (a
/// node hierarchy walked recursively) cannot be caught as a panic. Set per parser, to its
/// corpus folder's `crash-aborted`, before its cases run.
static ABORT_PATH: std::sync::atomic::AtomicPtr<libc::c_char> =
    std::sync::atomic::AtomicPtr::new(std::ptr::null_mut());
/// The folder of [`ABORT_PATH`], made by the handler if missing.
static ABORT_FOLDER: std::sync::atomic::AtomicPtr<libc::c_char> =
    std::sync::atomic::AtomicPtr::new(std::ptr::null_mut());

/// SIGABRT handler: saves the running case (raw system calls only), then returns, and the
/// abort ends the process as it would have.
extern "C" fn on_abort(_: libc::c_int) {
    let message = b"fuzz: the process aborted (a stack overflow?); the case is saved as crash-aborted in the parser's corpus folder\n";
    // SAFETY: plain system calls on a NUL-terminated path that lives for the whole run and
    // on the case's live buffer.
    unsafe {
        libc::write(2, message.as_ptr().cast(), message.len());
        let path = ABORT_PATH.load(Ordering::SeqCst);
        let (ptr, len) = (
            CASE_PTR.load(Ordering::SeqCst),
            CASE_LEN.load(Ordering::SeqCst),
        );
        let folder = ABORT_FOLDER.load(Ordering::SeqCst);
        if !folder.is_null() {
            libc::mkdir(folder, 0o755);
        }
        if !path.is_null() && ptr != 0 {
            let fd = libc::open(path, libc::O_CREAT | libc::O_WRONLY | libc::O_TRUNC, 0o644);
            if fd >= 0 {
                libc::write(fd, ptr as *const libc::c_void, len);
                libc::close(fd);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// The deterministic mutator.

/// SplitMix64: tiny, fast, and the same stream everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const INTERESTING_BYTES: [u8; 8] = [0, 1, 0x7f, 0x80, 0xff, b'0', b'-', b'\n'];
const INTERESTING_INTS: [u64; 10] = [
    0,
    1,
    0xff,
    0xffff,
    0x7fff_ffff,
    0xffff_ffff,
    1 << 32,
    0x7fff_ffff_ffff_ffff,
    u64::MAX,
    65535 * 65535,
];
const INTERESTING_NUMBERS: [&str; 12] = [
    "1e18",
    "-1",
    "nan",
    "inf",
    "-inf",
    "1000000000000000000",
    "-9223372036854775808",
    "0",
    "4294967296",
    "1e-45",
    "3.4e39",
    "65535",
];

fn mutate(seed: &[u8], seeds: &[Vec<u8>], text: bool, rng: &mut Rng) -> Vec<u8> {
    let mut data = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let len = data.len();
        match rng.below(if text { 11 } else { 8 }) {
            0 if len > 0 => {
                let i = rng.below(len);
                data[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                data[i] = INTERESTING_BYTES[rng.below(INTERESTING_BYTES.len())];
            }
            2 if len > 0 => {
                // An interesting integer, mostly in the header.
                let width = [2, 4, 8][rng.below(3)];
                let window = if rng.below(4) > 0 { len.min(160) } else { len };
                let at = rng.below(window);
                let value = INTERESTING_INTS[rng.below(INTERESTING_INTS.len())];
                let bytes = if rng.below(2) == 0 {
                    value.to_le_bytes()
                } else {
                    (value << (64 - 8 * width).min(63)).to_be_bytes()
                };
                for k in 0..width {
                    if at + k < len {
                        data[at + k] = bytes[k];
                    }
                }
            }
            3 if len > 0 => {
                let at = rng.below(len);
                let end = (at + 1 + rng.below(32)).min(len);
                data.drain(at..end);
            }
            4 => {
                let at = rng.below(len + 1);
                let piece: Vec<u8> = match len {
                    0 => vec![0],
                    _ => {
                        let from = rng.below(len);
                        data[from..(from + 1 + rng.below(64)).min(len)].to_vec()
                    }
                };
                for _ in 0..1 + rng.below(3) {
                    data.splice(at..at, piece.iter().copied());
                }
            }
            5 if len > 0 => data.truncate(rng.below(len)),
            6 => {
                let other = &seeds[rng.below(seeds.len())];
                if !other.is_empty() {
                    let from = rng.below(other.len());
                    let piece = &other[from..(from + 1 + rng.below(128)).min(other.len())];
                    let at = rng.below(len + 1);
                    data.splice(at..at, piece.iter().copied());
                }
            }
            7 => {
                let at = rng.below(len + 1);
                let count = 1 + rng.below(16);
                let random: Vec<u8> = (0..count).map(|_| rng.next() as u8).collect();
                data.splice(at..at, random);
            }
            8 => replace_number(&mut data, rng),
            9 | 10 => {
                // Repeat or drop a line.
                let lines: Vec<usize> = std::iter::once(0)
                    .chain(
                        data.iter()
                            .enumerate()
                            .filter(|(_, b)| **b == b'\n')
                            .map(|(i, _)| i + 1),
                    )
                    .filter(|&i| i < len)
                    .collect();
                if !lines.is_empty() {
                    let start = lines[rng.below(lines.len())];
                    let end = data[start..]
                        .iter()
                        .position(|&b| b == b'\n')
                        .map_or(len, |p| start + p + 1);
                    let line = data[start..end].to_vec();
                    if rng.below(2) == 0 {
                        data.drain(start..end);
                    } else {
                        data.splice(start..start, line);
                    }
                }
            }
            _ => {}
        }
    }
    data
}

/// Replaces one number of a text with an interesting one.
fn replace_number(data: &mut Vec<u8>, rng: &mut Rng) {
    let starts: Vec<usize> = (0..data.len())
        .filter(|&i| data[i].is_ascii_digit() && (i == 0 || !data[i - 1].is_ascii_digit()))
        .collect();
    if starts.is_empty() {
        return;
    }
    let start = starts[rng.below(starts.len())];
    let end = start
        + data[start..]
            .iter()
            .position(|b| !(b.is_ascii_digit() || *b == b'.' || *b == b'e'))
            .unwrap_or(data.len() - start);
    let number = INTERESTING_NUMBERS[rng.below(INTERESTING_NUMBERS.len())];
    data.splice(start..end, number.bytes());
}

// ---------------------------------------------------------------------------------------
// The parsers under test.

#[derive(Clone, Copy, PartialEq)]
enum Target {
    Obj,
    Mtl,
    SceneFile,
    Tga,
    Png,
    Hdr,
    Exr,
    Rig,
    Prt,
    // Last, so that the earlier targets keep their discriminants, the seeds of their mutators.
    Gltf,
    /// An occluder file (`bake --occluder`): sphere sets.
    Occ,
}

const TARGETS: [Target; 11] = [
    Target::Obj,
    Target::Mtl,
    Target::SceneFile,
    Target::Gltf,
    Target::Tga,
    Target::Png,
    Target::Hdr,
    Target::Exr,
    Target::Rig,
    Target::Prt,
    Target::Occ,
];

impl Target {
    fn name(self) -> &'static str {
        match self {
            Target::Obj => "obj",
            Target::Mtl => "mtl",
            Target::SceneFile => "scene",
            Target::Gltf => "gltf",
            Target::Tga => "tga",
            Target::Png => "png",
            Target::Hdr => "hdr",
            Target::Exr => "exr",
            Target::Rig => "rig",
            Target::Prt => "prt",
            Target::Occ => "occ",
        }
    }

    fn is_text(self) -> bool {
        matches!(
            self,
            Target::Obj
                | Target::Mtl
                | Target::SceneFile
                | Target::Gltf
                | Target::Rig
                | Target::Hdr
        )
    }

    /// The file a case is written to, in the case folder.
    fn file(self) -> &'static str {
        match self {
            Target::Obj => "case.obj",
            Target::Mtl => "case.mtl",
            Target::SceneFile => "case.scene",
            // The `gltf` crate tells a binary file by its magic, not its name: one name serves
            // the `.glb` and the `.gltf` seeds and their mutants.
            Target::Gltf => "case.gltf",
            Target::Tga => "case.tga",
            Target::Png => "case.png",
            Target::Hdr => "case.hdr",
            Target::Exr => "case.exr",
            Target::Rig => "case.toml",
            Target::Prt => "case.prt",
            Target::Occ => "case.occ",
        }
    }

    /// Parses one case (already written to `folder`); true if it was accepted.
    fn run(self, folder: &Path, bytes: &[u8]) -> bool {
        let path = folder.join(self.file());
        let at = Location::file(folder.join("case.scene"));
        match self {
            Target::Obj => Scene::load(&path).is_ok(),
            Target::Mtl => Scene::load(&folder.join("uses-mtl.obj")).is_ok(),
            Target::SceneFile => Scene::load(&path).is_ok(),
            // `Scene::load` without the printing of warnings (a mutant turned into points).
            Target::Gltf => Scene::load_with_warnings(&path).is_ok(),
            Target::Tga | Target::Png => Texture::load(&path, &at).is_ok(),
            Target::Hdr | Target::Exr => EnvironmentMap::load(&path).is_ok(),
            Target::Rig => Rig::load(&path).is_ok(),
            Target::Prt => CoefficientFile::from_bytes(bytes).is_ok(),
            Target::Occ => OccluderFile::read(&path).is_ok(),
        }
    }
}

fn image_bytes(image: image::DynamicImage, format: image::ImageFormat) -> Vec<u8> {
    let mut bytes = Vec::new();
    image
        .write_to(&mut Cursor::new(&mut bytes), format)
        .unwrap();
    bytes
}

fn rgb8(width: u32, height: u32) -> image::DynamicImage {
    image::DynamicImage::ImageRgb8(image::RgbImage::from_fn(width, height, |x, y| {
        image::Rgb([(x * 40) as u8, (y * 60) as u8, 200])
    }))
}

fn rgbf(width: u32, height: u32) -> image::DynamicImage {
    image::DynamicImage::ImageRgb32F(image::Rgb32FImage::from_fn(width, height, |x, y| {
        image::Rgb([x as f32 * 0.5, y as f32 + 0.25, 2.0])
    }))
}

fn prt_seeds() -> Vec<Vec<u8>> {
    let header = |order: u32, channels: u32, mode: Mode, aux: Aux, vertex_count: u64| Header {
        version: 1,
        order,
        channels,
        vertex_count,
        samples_per_vertex: 64,
        mode,
        transfer: Default::default(),
        bounces: u32::from(mode == Mode::Interreflected),
        bounce_samples: if mode == Mode::Interreflected { 16 } else { 0 },
        backend: if mode == Mode::Unshadowed {
            Backend::None
        } else {
            Backend::Obvhs
        },
        sampling: Sampling::OwenSobol,
        seed: 7,
        scene_fingerprint: 0x0123_4567_89ab_cdef,
        aux,
        up: if channels == 3 { Up::Y } else { Up::Z },
        checksum: 0,
        // Shadowed Owen–Sobol seeds are adaptive bakes (--target-error), with their arrays.
        adaptive: (mode == Mode::Shadowed).then_some(Adaptive {
            target_error: 1e-3,
            replicates: 16,
            rays_cast: 64 * vertex_count,
            after_denoise: false,
        }),
        receivers: None,
        denoised: false,
    };
    let file = |h: Header| {
        let v = h.vertex_count as usize;
        let n = h.coefficients_per_vertex();
        let aux = h.aux;
        let adaptive = h.adaptive.is_some();
        CoefficientFile {
            header: h,
            coefficients: (0..v * n).map(|i| (i as f32 * 0.37).sin()).collect(),
            ao: aux
                .ao
                .then(|| (0..v).map(|i| i as f32 / v as f32).collect()),
            bent_normal: aux.bent_normal.then(|| vec![glam::Vec3::Z; v]),
            rays: adaptive.then(|| vec![64; v]),
            error_estimate: adaptive.then(|| (0..v).map(|i| 1e-4 * i as f32).collect()),
            lightmap: None,
            probes: None,
        }
        .to_bytes()
        .0
    };
    let none = Aux::default();
    let both = Aux {
        ao: true,
        bent_normal: true,
    };
    vec![
        file(header(2, 1, Mode::Unshadowed, none, 3)),
        file(header(3, 1, Mode::Shadowed, both, 4)),
        file(header(2, 3, Mode::Interreflected, both, 2)),
        // A bake of some objects: its receiver section ends the payload.
        file(Header {
            receivers: Some(prt_baker::formats::receiver_section::ReceiverObjects {
                object_count: 3,
                objects: vec![0, 2],
            }),
            ..header(3, 1, Mode::Shadowed, both, 4)
        }),
    ]
}

/// Occluder files of one and of three spheres.
fn occ_seeds() -> Vec<Vec<u8>> {
    let sphere = |x: f32, radius: f32| LocalSphere {
        centre: glam::Vec3::new(x, 0.5 * x, -x),
        radius,
    };
    [
        vec![sphere(0.0, 0.2)],
        vec![sphere(-0.3, 0.1), sphere(0.0, 0.25), sphere(0.3, 0.1)],
    ]
    .into_iter()
    .map(|spheres| OccluderFile { spheres }.to_bytes())
    .collect()
}

/// A `.glb` of the case folder's textured triangle, written by the exporter (its buffer in the
/// binary chunk, the texture as a PNG in a buffer view); the same document as a `.gltf` whose
/// buffer is a base64 data URI; and that `.gltf` with its image the case folder's `té.png`,
/// named by its percent-encoded UTF-8 (`t%C3%A9.png`): a bit flipped in those hex digits
/// makes invalid UTF-8, on which gltf 1.4's uri decoding panicked.
fn gltf_seeds() -> Vec<Vec<u8>> {
    let folder = case_folder();
    let scene = Scene::load(&folder.path().join("mesh.obj")).unwrap();
    let contents = Contents {
        file: None,
        light: None,
        up: scene.up,
    };
    let (glb, _) = glb_bytes(&scene, &contents).unwrap();
    let parsed = gltf::Glb::from_slice(&glb).unwrap();
    let mut json: serde_json::Value = serde_json::from_slice(&parsed.json).unwrap();
    let bin = parsed.bin.expect("the exporter writes a binary chunk");
    json["buffers"][0]["uri"] = serde_json::Value::String(format!(
        "data:application/octet-stream;base64,{}",
        base64(&bin)
    ));
    let text = serde_json::to_vec_pretty(&json).unwrap();
    json["images"] = serde_json::json!([{"uri": "t%C3%A9.png"}]);
    // Compact, so that the uri's hex digits are a larger share of the bytes mutated.
    let external = serde_json::to_vec(&json).unwrap();
    vec![glb, text, external]
}

/// Valid inputs of each parser, made here (no binary blobs to keep in step with encoders).
fn generated_seeds(target: Target) -> Vec<Vec<u8>> {
    let text = |items: &[&str]| items.iter().map(|s| s.as_bytes().to_vec()).collect();
    match target {
        Target::Obj => text(&[
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "mtllib m.mtl\no a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             vn 0 0 1\nusemtl m\nf 1/1/1 2/2/1 3/3/1 4/4/1\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n",
            "g x\nv 0 0 0 1\nv 2 0 0\nv 0 2 0\nvn 0 0 1\nf 1//1 2//1 3//1\ns 1\n# comment\n",
        ]),
        Target::Mtl => text(&[
            "newmtl m\nKd 0.5 0.25 1\nmap_Kd tex.tga\n",
            "newmtl m\nKa 1 1 1\nKd 1 1 1\nNs 10\nd 1\nillum 2\n\nnewmtl other\nKd 0 0 0\n",
        ]),
        Target::SceneFile => text(&[
            "\"mesh.obj\" \"tex.tga\"\n",
            "# two objects\nmesh.obj\n\"mesh.obj\"   tex.tga # comment\n",
        ]),
        Target::Gltf => gltf_seeds(),
        Target::Tga => vec![
            image_bytes(rgb8(3, 2), image::ImageFormat::Tga),
            image_bytes(
                image::DynamicImage::ImageLumaA8(image::GrayAlphaImage::new(2, 2)),
                image::ImageFormat::Tga,
            ),
        ],
        Target::Png => vec![
            image_bytes(rgb8(3, 2), image::ImageFormat::Png),
            image_bytes(
                image::DynamicImage::ImageRgba16(image::ImageBuffer::new(2, 3)),
                image::ImageFormat::Png,
            ),
        ],
        Target::Hdr => vec![image_bytes(rgbf(4, 2), image::ImageFormat::Hdr)],
        Target::Exr => vec![image_bytes(rgbf(4, 2), image::ImageFormat::OpenExr)],
        Target::Rig => text(&[
            "[[light]]\nkind = \"directional\"\ndirection = [0.3, 0.4, 0.866]\ncolor = [1.0, 0.5, 0.25]\nintensity = 2.0\n",
            "window = \"hanning\"\nwindow_width = 3\n[[light]]\nkind = \"sun\"\ntheta = 30\nphi = 45\n\
             angular_radius = 2\n[[light]]\nkind = \"hemisphere\"\nsky = [0.2, 0.3, 0.8]\nground = [0.1, 0.1, 0.1]\n\
             [[light]]\nkind = \"environment\"\npath = \"sky.hdr\"\nrotation = [0, 0, 90]\n",
            "[[light]]\nkind = \"sphere\"\ntheta = 20\nphi = 0\nangular_radius = 10\nintensity = 3\n\
             [[light]]\nkind = \"constant\"\ncolor = [1, 1, 1]\n",
        ]),
        Target::Prt => prt_seeds(),
        Target::Occ => occ_seeds(),
    }
}

fn corpus_folder(target: Target) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz-corpus")
        .join(target.name())
}

/// The committed corpus files of a parser, sorted by name.
fn corpus(target: Target) -> Vec<(String, Vec<u8>)> {
    let Ok(entries) = std::fs::read_dir(corpus_folder(target)) else {
        return Vec::new();
    };
    let mut files: Vec<(String, Vec<u8>)> = entries
        .map(|e| e.unwrap())
        .map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            (name, std::fs::read(e.path()).unwrap())
        })
        .collect();
    files.sort();
    files
}

/// The files every case folder holds: what the OBJ, MTL, scene and rig cases refer to.
fn case_folder() -> tempfile::TempDir {
    // In memory where there is a tmpfs: a case is written per run, and a disk shared with
    // other jobs made that most of the time.
    let shm = Path::new("/dev/shm");
    let dir = match shm.is_dir() {
        true => tempfile::tempdir_in(shm).or_else(|_| tempfile::tempdir()),
        false => tempfile::tempdir(),
    }
    .unwrap();
    let write = |name: &str, bytes: &[u8]| std::fs::write(dir.path().join(name), bytes).unwrap();
    write("mesh.obj", b"mtllib m.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n");
    write("m.mtl", b"newmtl m\nKd 1 1 1\nmap_Kd tex.tga\n");
    write("tex.tga", &image_bytes(rgb8(2, 2), image::ImageFormat::Tga));
    write("té.png", &image_bytes(rgb8(2, 2), image::ImageFormat::Png));
    write(
        "uses-mtl.obj",
        b"mtllib case.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    write("sky.hdr", &image_bytes(rgbf(4, 2), image::ImageFormat::Hdr));
    // What the structured cases name: special files, and links to them and out of the folder.
    let path = |name: &str| dir.path().join(name);
    let fifo = std::ffi::CString::new(path("fifo").into_os_string().into_encoded_bytes()).unwrap();
    // SAFETY: a plain system call on a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o644) }, 0, "mkfifo");
    std::fs::create_dir(path("sub")).unwrap();
    for (link, target) in [
        ("link-zero", "/dev/zero"),
        ("link-fifo", "fifo"),
        ("link-out", "/etc/passwd"),
        ("link-sub", "sub"),
        ("link-loop", "link-loop"),
    ] {
        std::os::unix::fs::symlink(target, path(link)).unwrap();
    }
    dir
}

/// Paths the structured cases put in uris, `mtllib`, `map_Kd`, scene entries and rig maps.
const SPECIAL_PATHS: [&str; 32] = [
    "/dev/zero",
    "/dev/null",
    "/dev/urandom",
    "/dev/stdin",
    "/proc/self/fd/0",
    "file:///dev/zero",
    "file:/dev/zero",
    "../../../../../../../../dev/zero",
    "../../../../../../../../etc/passwd",
    "/etc/passwd",
    "%2E%2E/%2E%2E/%2E%2E/%2E%2E/%2E%2E/%2E%2E/%2E%2E/%2E%2E/dev/zero",
    "%2Fdev%2Fzero",
    "..%2F..%2F..%2F..%2F..%2F..%2F..%2F..%2Fetc%2Fpasswd",
    "%2e%2e",
    "fifo",
    "sub",
    ".",
    "..",
    "",
    "link-zero",
    "link-fifo",
    "link-out",
    "link-sub",
    "link-loop",
    "nothere.bin",
    "buf.bin",
    "tex.tga",
    "té.png",
    "t%C3%A9.png",
    "sub/../buf.bin",
    "sub/../../buf.bin",
    "buf.bin%00.png",
];

fn special_path(rng: &mut Rng) -> &'static str {
    SPECIAL_PATHS[rng.below(SPECIAL_PATHS.len())]
}

/// Special paths that name a device, FIFO or directory (directly, through a link or an
/// escape): a case naming one is refused, `--allow-outside-uris` or not.
const NEVER_READ: [&str; 16] = [
    "/dev/zero",
    "/dev/null",
    "/dev/urandom",
    "file:///dev/zero",
    "file:/dev/zero",
    "../../../../../../../../dev/zero",
    "%2E%2E/%2E%2E/%2E%2E/%2E%2E/%2E%2E/%2E%2E/%2E%2E/%2E%2E/dev/zero",
    "%2Fdev%2Fzero",
    "%2e%2e",
    "fifo",
    "sub",
    ".",
    "..",
    "link-zero",
    "link-fifo",
    "link-sub",
];

/// Special paths outside the case folder or absolute: refused without the option.
const OUTSIDE: [&str; 5] = [
    "../../../../../../../../etc/passwd",
    "/etc/passwd",
    "..%2F..%2F..%2F..%2F..%2F..%2F..%2F..%2Fetc%2Fpasswd",
    "link-out",
    "sub/../../buf.bin",
];

/// Whether a structured case must be refused: it names (in a uri, `mtllib`, `map_Kd`, a
/// scene entry or a rig map) a special file that is never read, or one outside the folder
/// while `--allow-outside-uris` is off. An accepted one is an escape, and fails the test.
fn must_be_refused(target: Target, bytes: &[u8], allow_outside: bool) -> bool {
    let refused =
        |path: &str| NEVER_READ.contains(&path) || (!allow_outside && OUTSIDE.contains(&path));
    let text = String::from_utf8_lossy(bytes);
    match target {
        Target::Gltf => {
            let Ok(doc) = serde_json::from_slice::<serde_json::Value>(bytes) else {
                return false;
            };
            let uris = [&doc["buffers"][0]["uri"], &doc["images"][0]["uri"]];
            uris.iter().filter_map(|uri| uri.as_str()).any(refused)
        }
        Target::SceneFile | Target::Rig => text.split('"').any(refused),
        _ => text
            .lines()
            .filter_map(|line| line.split_once(' '))
            .filter(|(key, _)| matches!(*key, "mtllib" | "map_Kd"))
            .any(|(_, path)| refused(path)),
    }
}

/// A number glTF sizes and offsets are set to: around the data's real sizes, zero, past 2³²,
/// negative, fractional, huge.
fn interesting_json_number(rng: &mut Rng, near: u64) -> serde_json::Value {
    use serde_json::json;
    match rng.below(10) {
        0 => json!(0),
        1 => json!(near.saturating_sub(1 + rng.below(4) as u64)),
        2 => json!(near + 1 + rng.below(4) as u64),
        3 => json!(near),
        4 => json!(INTERESTING_INTS[rng.below(INTERESTING_INTS.len())]),
        5 => json!(-1),
        6 => json!(1.5),
        7 => json!(1e300),
        8 => json!(rng.below(64)),
        _ => json!(1u64 << 53),
    }
}

/// One structure-aware case of `target` (see the module's comment), in the case folder whose
/// `buf.bin` holds `bin`; `gltf` is the `.gltf` seed with a data-URI buffer.
fn structured_case(target: Target, gltf: &serde_json::Value, bin: &[u8], rng: &mut Rng) -> Vec<u8> {
    let triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    match target {
        Target::Obj => format!(
            "mtllib {}\nusemtl m\n{triangle}f 1 2 3\n",
            special_path(rng)
        )
        .into_bytes(),
        Target::Mtl => format!("newmtl m\nKd 1 1 1\nmap_Kd {}\n", special_path(rng)).into_bytes(),
        Target::SceneFile => {
            let mut text = String::new();
            for _ in 0..1 + rng.below(2) {
                let object = match rng.below(3) {
                    0 => "mesh.obj",
                    _ => special_path(rng),
                };
                match rng.below(3) {
                    0 => text += &format!("\"{object}\"\n"),
                    1 => text += &format!("\"{object}\" \"{}\"\n", special_path(rng)),
                    _ => text += &format!("\"{object}\" tex.tga\n"),
                }
            }
            text.into_bytes()
        }
        Target::Rig => format!(
            "[[light]]\nkind = \"environment\"\npath = \"{}\"\n",
            special_path(rng)
        )
        .into_bytes(),
        Target::Gltf => structured_gltf(gltf, bin, rng),
        _ => unreachable!("no structured cases for {}", target.name()),
    }
}

/// A `.gltf` seed with one to three structural edits: a hierarchy, a uri, sizes.
fn structured_gltf(seed: &serde_json::Value, bin: &[u8], rng: &mut Rng) -> Vec<u8> {
    use serde_json::{Value, json};
    let mut doc = seed.clone();
    for _ in 0..1 + rng.below(3) {
        match rng.below(4) {
            0 => {
                // The mesh node plus a few more, wired up by a hierarchy of some shape.
                let extra = 1 + rng.below(4);
                let mut nodes: Vec<Value> = vec![json!({"mesh": 0})];
                nodes.extend((0..extra).map(|_| json!({})));
                let n = nodes.len();
                let mut roots = vec![json!(0)];
                match rng.below(7) {
                    0 => nodes[rng.below(n)]["children"] = json!([rng.below(n)]),
                    1 => {
                        // A cycle through every node, from the root.
                        for (i, node) in nodes.iter_mut().enumerate() {
                            node["children"] = json!([(i + 1) % n]);
                        }
                    }
                    2 => {
                        // A child shared by two parents (a diamond).
                        let child = n - 1;
                        for node in nodes.iter_mut().take(n - 1) {
                            node["children"] = json!([child]);
                        }
                    }
                    3 => {
                        // A chain: mostly shallow, sometimes at the reader's depth bound.
                        let depth = match rng.below(40) {
                            0 => 99_990 + rng.below(20),
                            _ => 1 + rng.below(200),
                        };
                        nodes = (1..depth)
                            .map(|child| json!({"children": [child], "translation": [0.0, 1e-3, 0.0]}))
                            .collect();
                        nodes.push(json!({"mesh": 0}));
                    }
                    4 => roots = vec![json!(0), json!(0)],
                    5 => {
                        nodes[0]["children"] = json!([1]);
                        roots = vec![json!(0), json!(1)];
                    }
                    _ => {
                        // Random children lists, out-of-range indices included.
                        for node in nodes.iter_mut() {
                            let count = rng.below(3);
                            let children: Vec<usize> =
                                (0..count).map(|_| rng.below(n + 1)).collect();
                            node["children"] = json!(children);
                        }
                        if rng.below(2) == 0 {
                            roots = vec![json!(rng.below(n + 1))];
                        }
                    }
                }
                doc["nodes"] = Value::Array(nodes);
                doc["scenes"] = json!([{"nodes": roots}]);
            }
            1 => {
                let uri = special_path(rng);
                if rng.below(2) == 0 {
                    doc["buffers"][0]["uri"] = json!(uri);
                } else if let Some(image) = doc["images"].get_mut(0) {
                    *image = json!({"uri": uri});
                    if rng.below(2) == 0 {
                        image["mimeType"] = json!("image/png");
                    }
                }
            }
            2 => {
                // The buffer as the file `buf.bin`, its byteLength around the file's size.
                doc["buffers"][0]["uri"] = json!("buf.bin");
                doc["buffers"][0]["byteLength"] = interesting_json_number(rng, bin.len() as u64);
            }
            _ => {
                let near = bin.len() as u64;
                let views = doc["bufferViews"].as_array().map_or(0, Vec::len);
                let accessors = doc["accessors"].as_array().map_or(0, Vec::len);
                match rng.below(8) {
                    0 => doc["buffers"][0]["byteLength"] = interesting_json_number(rng, near),
                    1 if views > 0 => {
                        let key = ["byteLength", "byteOffset", "byteStride"][rng.below(3)];
                        doc["bufferViews"][rng.below(views)][key] =
                            interesting_json_number(rng, near);
                    }
                    2 if accessors > 0 => {
                        let key = ["count", "byteOffset", "bufferView"][rng.below(3)];
                        doc["accessors"][rng.below(accessors)][key] =
                            interesting_json_number(rng, 4);
                    }
                    3 if accessors > 0 => {
                        let types = [5120, 5121, 5122, 5123, 5125, 5126, 5124, 0];
                        doc["accessors"][rng.below(accessors)]["componentType"] =
                            json!(types[rng.below(types.len())]);
                    }
                    4 if accessors > 0 => {
                        let kinds = [
                            "SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4", "X",
                        ];
                        doc["accessors"][rng.below(accessors)]["type"] =
                            json!(kinds[rng.below(kinds.len())]);
                    }
                    5 if accessors > 0 => {
                        let index_type = [5121, 5123, 5125, 5126][rng.below(4)];
                        doc["accessors"][rng.below(accessors)]["sparse"] = json!({
                            "count": interesting_json_number(rng, 3),
                            "indices": {"bufferView": rng.below(views + 1), "componentType": index_type},
                            "values": {"bufferView": rng.below(views + 1)},
                        });
                    }
                    6 if views > 0 => {
                        doc["bufferViews"][rng.below(views)]["buffer"] = json!(rng.below(3));
                    }
                    _ => {
                        doc["meshes"][0]["primitives"][0]["indices"] =
                            json!(rng.below(accessors + 1));
                    }
                }
            }
        }
    }
    serde_json::to_vec(&doc).unwrap()
}

/// What happened to one parser's cases.
#[derive(Default)]
struct Tally {
    seeds: usize,
    cases: usize,
    accepted: usize,
    panics: Vec<String>,
    /// `.prt` mutants with their checksum left as it was that were accepted anyway (must be 0).
    accepted_corruptions: usize,
    /// `.prt` mutants with a repaired checksum, accepted, that read back to other bytes.
    unfaithful: usize,
    /// Structured cases naming a file the input-path policy refuses that were accepted anyway
    /// (must be none), saved as `escape-*`.
    escapes: Vec<String>,
    peak_bytes: usize,
    slowest: Duration,
}

/// The case being run, for the watchdog: its number (0 = none) and when it started.
static CASE_NUMBER: AtomicU64 = AtomicU64::new(0);
static CASE_STARTED_MS: AtomicU64 = AtomicU64::new(0);
static FINISHED: AtomicBool = AtomicBool::new(false);

fn watchdog(start: Instant, current: std::sync::Arc<std::sync::Mutex<(String, Vec<u8>)>>) {
    std::thread::spawn(move || {
        while !FINISHED.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(200));
            let number = CASE_NUMBER.load(Ordering::SeqCst);
            let started = Duration::from_millis(CASE_STARTED_MS.load(Ordering::SeqCst));
            if number != 0 && start.elapsed().saturating_sub(started) > CASE_TIME_LIMIT {
                let (name, bytes) = current.lock().unwrap().clone();
                let path = corpus_folder_by_name(&name).join(format!("hang-{:016x}", hash(&bytes)));
                let _ = std::fs::create_dir_all(path.parent().unwrap());
                let _ = std::fs::write(&path, &bytes);
                eprintln!(
                    "fuzz: a {name} case ran past {CASE_TIME_LIMIT:?} (a hang); saved as {} \
                     (the run's seed is printed at its start)",
                    path.display()
                );
                std::process::exit(1);
            }
        }
    });
}

fn corpus_folder_by_name(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz-corpus")
        .join(name)
}

fn hash(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// Sets a `.prt` image's checksum to the right one.
fn repair_checksum(bytes: &mut [u8]) {
    if bytes.len() < 128 {
        return;
    }
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&bytes[..124]);
    hasher.update(&[0; 4]);
    hasher.update(&bytes[128..]);
    let crc = hasher.finalize();
    bytes[124..128].copy_from_slice(&crc.to_le_bytes());
}

/// Whether a target gets structured cases, and how often (one mutant in this many).
fn structured_every(target: Target) -> Option<usize> {
    match target {
        Target::Gltf => Some(4),
        Target::Obj | Target::Mtl | Target::SceneFile | Target::Rig => Some(8),
        _ => None,
    }
}

fn fuzz(
    target: Target,
    cases: usize,
    seed: u64,
    start: Instant,
    current: &std::sync::Mutex<(String, Vec<u8>)>,
) -> Tally {
    let folder = case_folder();
    // The structured glTF cases start from the `.gltf` seed (a data-URI buffer), whose
    // buffer is also written as the case folder's `buf.bin`.
    let gltf_seeds = generated_seeds(Target::Gltf);
    let gltf_seed: serde_json::Value = serde_json::from_slice(&gltf_seeds[1]).unwrap();
    let bin = gltf::Glb::from_slice(&gltf_seeds[0])
        .unwrap()
        .bin
        .unwrap()
        .into_owned();
    std::fs::write(folder.path().join("buf.bin"), &bin).unwrap();
    let mut seeds = generated_seeds(target);
    let first_corpus_seed = seeds.len();
    let corpus = corpus(target);
    // The escapes found so far are regressions of the input-path policy: still refused.
    let escape_seeds: Vec<bool> = corpus
        .iter()
        .map(|(name, _)| name.starts_with("escape-"))
        .collect();
    seeds.extend(corpus.into_iter().map(|(_, bytes)| bytes));
    let c_path = |path: PathBuf| {
        // Leaked: the handler may read it until the process ends.
        std::ffi::CString::new(path.into_os_string().into_encoded_bytes())
            .unwrap()
            .into_raw()
    };
    ABORT_FOLDER.store(c_path(corpus_folder(target)), Ordering::SeqCst);
    ABORT_PATH.store(
        c_path(corpus_folder(target).join("crash-aborted")),
        Ordering::SeqCst,
    );
    let mut tally = Tally {
        seeds: seeds.len(),
        ..Tally::default()
    };
    let mut rng = Rng(seed.wrapping_add(target as u64));
    let total = seeds.len() + cases;
    for k in 0..total {
        // Seeds first, as they are (the regressions among them), then mutants.
        let structured =
            k >= seeds.len() && structured_every(target).is_some_and(|every| k % every == 1);
        let allow_outside = structured && rng.below(2) == 0;
        prt_baker::support::input_path::set_allow_outside(allow_outside);
        let (mut bytes, repaired) = match k < seeds.len() {
            true => (seeds[k].clone(), false),
            false if structured => (structured_case(target, &gltf_seed, &bin, &mut rng), false),
            false => {
                let seed = &seeds[rng.below(seeds.len())];
                let mut bytes = mutate(seed, &seeds, target.is_text(), &mut rng);
                // Half the .prt mutants get a valid checksum, to reach the structural checks.
                let repaired = target == Target::Prt && k % 2 == 0;
                if repaired {
                    repair_checksum(&mut bytes);
                }
                (bytes, repaired)
            }
        };
        if target != Target::Prt {
            std::fs::write(folder.path().join(target.file()), &bytes).unwrap();
        }
        *current.lock().unwrap() = (target.name().to_string(), bytes.clone());
        CASE_PTR.store(bytes.as_ptr() as usize, Ordering::SeqCst);
        CASE_LEN.store(bytes.len(), Ordering::SeqCst);
        let live_before = LIVE.load(Ordering::SeqCst);
        PEAK.store(live_before, Ordering::SeqCst);
        CASE_STARTED_MS.store(start.elapsed().as_millis() as u64, Ordering::SeqCst);
        CASE_NUMBER.store(k as u64 + 1, Ordering::SeqCst);
        let began = Instant::now();
        let outcome =
            std::panic::catch_unwind(AssertUnwindSafe(|| target.run(folder.path(), &bytes)));
        let took = began.elapsed();
        CASE_NUMBER.store(0, Ordering::SeqCst);
        tally.slowest = tally.slowest.max(took);
        let held = PEAK.load(Ordering::SeqCst).saturating_sub(live_before);
        tally.peak_bytes = tally.peak_bytes.max(held);
        tally.cases += 1;
        match outcome {
            Err(_) => {
                let path = corpus_folder(target).join(format!("crash-{:016x}", hash(&bytes)));
                std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                std::fs::write(&path, &bytes).unwrap();
                tally.panics.push(path.display().to_string());
            }
            Ok(false) => {}
            Ok(true) => {
                tally.accepted += 1;
                let escape_seed = k >= first_corpus_seed
                    && escape_seeds.get(k - first_corpus_seed) == Some(&true);
                if escape_seed || (structured && must_be_refused(target, &bytes, allow_outside)) {
                    let name = format!("escape-{:016x}", hash(&bytes));
                    let path = corpus_folder(target).join(name);
                    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                    std::fs::write(&path, &bytes).unwrap();
                    tally.escapes.push(path.display().to_string());
                }
                // An accepted occluder file is written back byte for byte.
                if target == Target::Occ {
                    let again = OccluderFile::from_bytes(&bytes).map(|f| f.to_bytes());
                    if again.as_deref() != Ok(&bytes[..]) {
                        tally.unfaithful += 1;
                    }
                }
                if target == Target::Prt && k >= seeds.len() {
                    let is_a_seed = seeds.contains(&bytes);
                    if !repaired && !is_a_seed {
                        tally.accepted_corruptions += 1;
                    }
                    let again = CoefficientFile::from_bytes(&bytes).unwrap().to_bytes().0;
                    if again != bytes {
                        tally.unfaithful += 1;
                    }
                }
            }
        }
        bytes.clear();
        CASE_PTR.store(0, Ordering::SeqCst);
    }
    tally
}

const TABLE_BEGIN: &str = "<!-- fuzz-table:begin (written by baker/tests/fuzz.rs) -->";
const TABLE_END: &str = "<!-- fuzz-table:end -->";

#[test]
fn every_parser_survives_its_mutants() {
    prt_baker::support::limits::set_max_memory(MAX_MEMORY);
    let cases: usize = std::env::var("PRT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES);
    let seeds = run_seeds();
    // A panic is caught and counted per case; the default hook's report would only be noise.
    std::panic::set_hook(Box::new(|_| {}));
    // SAFETY: installs a handler that makes only async-signal-safe calls.
    unsafe { libc::signal(libc::SIGABRT, on_abort as *const () as libc::sighandler_t) };
    let start = Instant::now();
    let current = std::sync::Arc::new(std::sync::Mutex::new((String::new(), Vec::new())));
    watchdog(start, current.clone());
    let mut failures = Vec::new();
    let mut tables = Vec::new();
    for &seed in &seeds {
        let (table, seed_failures) = fuzz_every_parser(seed, cases, start, &current);
        if !seed_failures.is_empty() {
            failures.push(format!(
                "seed {seed:#x} (replay with PRT_FUZZ_SEED={seed:#x}):\n{}",
                seed_failures.join("\n")
            ));
        }
        tables.push((seed, table));
    }
    FINISHED.store(true, Ordering::SeqCst);
    let _ = std::panic::take_hook();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    for (seed, table) in tables {
        if cases == DEFAULT_CASES && seed == TABLE_SEED {
            check_docs_table(&table);
        }
    }
}

/// One seed's run over every parser: its table and what failed.
fn fuzz_every_parser(
    seed: u64,
    cases: usize,
    start: Instant,
    current: &std::sync::Arc<std::sync::Mutex<(String, Vec<u8>)>>,
) -> (String, Vec<String>) {
    // Written to the standard error itself, not through `eprintln!`, which the test harness
    // captures: the seed of every run is logged, passing or not.
    let _ = writeln!(
        std::io::stderr(),
        "fuzz: seed {seed:#x} (replay this run with PRT_FUZZ_SEED={seed:#x})"
    );
    let mut rows = vec![
        "| parser | seeds | mutants | accepted | rejected | panics | hangs | accepted corruptions |".to_string(),
        "|---|---:|---:|---:|---:|---:|---:|---:|".to_string(),
    ];
    let mut failures = Vec::new();
    for target in TARGETS {
        let began = Instant::now();
        let t = fuzz(target, cases, seed, start, current);
        eprintln!(
            "fuzz {:5}: {} cases in {:.2} s, slowest {:.1} ms, most held {:.1} MiB, {} accepted",
            target.name(),
            t.cases,
            began.elapsed().as_secs_f64(),
            t.slowest.as_secs_f64() * 1e3,
            t.peak_bytes as f64 / f64::from(1 << 20),
            t.accepted
        );
        let corruptions = match target {
            Target::Prt => t.accepted_corruptions.to_string(),
            _ => "—".to_string(),
        };
        rows.push(format!(
            "| {} | {} | {} | {} | {} | {} | 0 | {} |",
            target.name(),
            t.seeds,
            t.cases - t.seeds,
            t.accepted,
            t.cases - t.accepted - t.panics.len(),
            t.panics.len(),
            corruptions
        ));
        if !t.panics.is_empty() {
            let mut saved = t.panics.clone();
            saved.sort();
            saved.dedup();
            failures.push(format!(
                "{}: {} panics, saved as {} files in {} (first: {})",
                target.name(),
                t.panics.len(),
                saved.len(),
                corpus_folder(target).display(),
                saved[0]
            ));
        }
        if !t.escapes.is_empty() {
            failures.push(format!(
                "{}: {} cases naming a device, FIFO, directory or outside file were accepted (first: {})",
                target.name(),
                t.escapes.len(),
                t.escapes[0]
            ));
        }
        if t.peak_bytes > ALLOCATION_CAP {
            failures.push(format!(
                "{}: a case held {} bytes",
                target.name(),
                t.peak_bytes
            ));
        }
        if t.accepted_corruptions > 0 || t.unfaithful > 0 {
            failures.push(format!(
                "{}: {} corruptions accepted, {} accepted files read back differently",
                target.name(),
                t.accepted_corruptions,
                t.unfaithful
            ));
        }
    }
    let table = rows.join("\n");
    eprintln!("{table}");
    (table, failures)
}

/// The table in docs/explanation/robustness.md must be this run's (PRT_FUZZ_BLESS=1 rewrites it).
fn check_docs_table(table: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/explanation/robustness.md");
    let doc = std::fs::read_to_string(&path).expect("docs/explanation/robustness.md");
    let (Some(begin), Some(end)) = (doc.find(TABLE_BEGIN), doc.find(TABLE_END)) else {
        panic!("docs/explanation/robustness.md lacks the fuzz table markers");
    };
    let current = doc[begin + TABLE_BEGIN.len()..end].trim();
    if current == table {
        return;
    }
    if std::env::var_os("PRT_FUZZ_BLESS").is_some() {
        let updated = format!("{}{TABLE_BEGIN}\n{table}\n{}", &doc[..begin], &doc[end..]);
        std::fs::write(&path, updated).unwrap();
        return;
    }
    panic!(
        "docs/explanation/robustness.md's fuzz table is not this run's (a parser changed what it accepts?); \
         if the change is intended, rewrite the table with \
         `PRT_FUZZ_BLESS=1 cargo test --release -p prt-baker --test fuzz` and commit it.\n\
         docs:\n{current}\nthis run:\n{table}"
    );
}
