//! `prt-view --bench`: the thesis's Table 2 — frames per second of Blinn-Phong and PRT with 1
//! and 8 lights — measured in one run, on one device, along one camera path.
//!
//! Every configuration renders the same frames offscreen at the same size: the camera swings
//! through 60° around the scene, and every light turns a little each frame, so PRT re-rotates
//! and re-sums its coefficients on the CPU every frame (its whole per-light cost). A frame's
//! time runs from the start of its update to the GPU's completion of it (waited for), so it is
//! the frame's full cost, not its submission.
//!
//! Further coefficient files of the same scene (`--bench-also`: a transfer-matrix bake,
//! uncompressed or CPCA-compressed, shown as glossy PRT) add PRT rows to the same run, each
//! with its own renderer, in the same turns: a glossy frame re-evaluates every vertex's lobe
//! in its reflected view direction, which the camera's arc changes every frame.
//!
//! The configurations take turns in blocks of [`BLOCK`] frames, round after round, and each
//! reports the median of its frame times. The machines are shared, so taking turns spreads
//! whatever disturbs the run over every configuration alike, and the median ignores the
//! frames that another process interrupted. Blocks rather than single frames, because on
//! lavapipe the frame after a switch from another configuration runs slower (by about 10 %
//! after Blinn-Phong with 8 lights, the heaviest): the first frame of every block is rendered
//! but not timed, and every other round takes the configurations in reverse order, so no
//! configuration always follows the same one.
//!
//! Moving occluders (`--bench-occluder OCC`, `--bench-occluders N`) add PRT rows for the
//! main bake shadowed by N copies of the occluder (docs/guides/occluders.md), each frame
//! moved along its own circle over the scene, all of them within reach of most receivers:
//! a lightmap's radiance pass then evaluates every texel's triple product
//! ([`crate::texel_occluders`]), a vertex bake's transfer is darkened on the CPU and uploaded.
//!
//! Nothing is timed until every configuration is warm: [`WARM_UP_ROUNDS`] whole rounds of
//! untimed blocks run first, so every pipeline has been compiled and used, every buffer
//! written and every cache filled, in every configuration, before the first timed frame of
//! any (otherwise the first configuration is timed while later ones still warm up).

use std::time::Instant;

use glam::{DQuat, DVec3, Vec3};
use prt_baker::formats::occluder_file::OccluderFile;
use prt_baker::math::occlusion::Sphere;

use crate::bake::Bake;
use crate::camera::Camera;
use crate::controls::{Mode, View};
use crate::error::{Error, Result};
use crate::gpu::Gpu;
use crate::lights::Lights;
use crate::occluders::MoverShadow;
use crate::offscreen::{self, Offscreen};
use crate::renderer::{FrameInputs, Renderer};

/// The light counts the thesis measured.
pub const LIGHT_COUNTS: [usize; 2] = [1, 8];
/// The targets: PRT's frame rate barely changes with the number of lights, and PRT is
/// at least as fast as Blinn-Phong with 8 lights.
pub const PRT_LIGHT_RATIO_TARGET: f64 = 0.95;
pub const PRT_OVER_PHONG_TARGET: f64 = 1.0;
/// With moving occluders, PRT keeps at least half its frame rate.
pub const OCCLUDED_RATIO_TARGET: f64 = 0.5;
/// How far the lights turn per frame.
const LIGHT_DEGREES_PER_FRAME: f64 = 1.0;
/// The camera path: an arc of this many degrees about the scene's vertical axis.
const CAMERA_ARC_DEGREES: f32 = 60.0;

/// Whole rounds of untimed blocks, every configuration in turn, before any frame is timed.
pub const WARM_UP_ROUNDS: u32 = 2;
/// Frames a configuration renders in a row before the next takes its turn; the first of each
/// block (the one after the switch) is not timed.
pub const BLOCK: u32 = 8;

#[derive(Clone, Copy, Debug)]
pub struct BenchOptions {
    pub size: (u32, u32),
    /// Timed frames per configuration.
    pub frames: u32,
}

/// One configuration's frame times.
#[derive(Clone, Debug)]
pub struct Measurement {
    pub mode: Mode,
    pub lights: usize,
    /// Which bake: 0 the main one, i the i-th of `--bench-also`.
    pub bake: usize,
    /// The table's row: the model and, for PRT, the transfer.
    pub label: String,
    /// Seconds per frame, in frame order.
    pub frame_seconds: Vec<f64>,
}

impl Measurement {
    /// Frames per second: one over the median frame time.
    pub fn fps(&self) -> f64 {
        let mut times = self.frame_seconds.clone();
        times.sort_by(f64::total_cmp);
        let n = times.len();
        if n == 0 {
            return f64::NAN;
        }
        let median = if n % 2 == 1 {
            times[n / 2]
        } else {
            0.5 * (times[n / 2 - 1] + times[n / 2])
        };
        1.0 / median
    }
}

/// A benchmark run.
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub device: String,
    pub options: BenchOptions,
    pub vertices: usize,
    pub triangles: usize,
    pub order: usize,
    /// A lightmap (texel) bake's W×H, shaded per pixel.
    pub lightmap: Option<(u32, u32)>,
    pub measurements: Vec<Measurement>,
    /// The rows shadowed by moving occluders: their `bake` index.
    pub occluded: Option<usize>,
}

impl BenchReport {
    /// The main bake's frame rate in `mode` with `lights` lights.
    pub fn fps(&self, mode: Mode, lights: usize) -> f64 {
        self.fps_of(0, mode, lights)
    }

    /// Bake `bake`'s (0 the main one, i the i-th of `--bench-also`).
    pub fn fps_of(&self, bake: usize, mode: Mode, lights: usize) -> f64 {
        self.measurements
            .iter()
            .find(|m| m.bake == bake && m.mode == mode && m.lights == lights)
            .map_or(f64::NAN, Measurement::fps)
    }

    /// PRT with 8 lights over PRT with 1.
    pub fn prt_light_ratio(&self) -> f64 {
        self.fps(Mode::Prt, 8) / self.fps(Mode::Prt, 1)
    }

    /// PRT over Blinn-Phong, both with 8 lights.
    pub fn prt_over_phong(&self) -> f64 {
        self.fps(Mode::Prt, 8) / self.fps(Mode::Phong, 8)
    }

    /// The table, as Markdown, with the two ratios and their targets.
    pub fn table(&self) -> String {
        let (w, h) = self.options.size;
        let transfer = match self.lightmap {
            Some((lw, lh)) => format!("order {}, a {lw}×{lh} lightmap (PRT per pixel)", self.order),
            None => format!("order {}", self.order),
        };
        let mut text = format!(
            "prt-view --bench: {} vertices, {} triangles, {transfer}, {w}×{h}, {} frames per configuration in turns of {BLOCK} (the first untimed) after {WARM_UP_ROUNDS} untimed rounds (fps = 1 / median frame time)\n\
             device: {}\n\n\
             | model | 1 light | 8 lights |\n|---|---:|---:|\n",
            self.vertices, self.triangles, self.options.frames, self.device
        );
        for m in self
            .measurements
            .iter()
            .filter(|m| m.lights == LIGHT_COUNTS[0])
        {
            text += &format!(
                "| {} | {:.1} | {:.1} |\n",
                m.label,
                self.fps_of(m.bake, m.mode, 1),
                self.fps_of(m.bake, m.mode, 8)
            );
        }
        let verdict = |ok: bool| if ok { "met" } else { "NOT MET" };
        let (a, b) = (self.prt_light_ratio(), self.prt_over_phong());
        text += &format!(
            "\nPRT, 8 lights / 1 light: {a:.3} (target ≥ {PRT_LIGHT_RATIO_TARGET}: {})\n\
             PRT / Blinn-Phong, 8 lights: {b:.3} (target ≥ {PRT_OVER_PHONG_TARGET}: {})",
            verdict(a >= PRT_LIGHT_RATIO_TARGET),
            verdict(b >= PRT_OVER_PHONG_TARGET)
        );
        if let Some(b) = self.occluded {
            let ratios =
                LIGHT_COUNTS.map(|n| self.fps_of(b, Mode::Prt, n) / self.fps(Mode::Prt, n));
            text += &format!(
                "\nPRT with moving occluders / PRT: {:.3} (1 light), {:.3} (8 lights) (target ≥ {OCCLUDED_RATIO_TARGET}: {})",
                ratios[0],
                ratios[1],
                verdict(ratios.iter().all(|&r| r >= OCCLUDED_RATIO_TARGET))
            );
        }
        let extra = self
            .measurements
            .iter()
            .filter(|m| m.bake > 0 && Some(m.bake) != self.occluded && m.lights == 1);
        for m in extra {
            let (one, eight) = (
                self.fps_of(m.bake, m.mode, 1),
                self.fps_of(m.bake, m.mode, 8),
            );
            text += &format!(
                "\n{}: 8 lights / 1 light {:.3}; / Blinn-Phong, 8 lights {:.3}; / PRT, 8 lights {:.3}",
                m.label,
                eight / one,
                eight / self.fps(Mode::Phong, 8),
                eight / self.fps(Mode::Prt, 8)
            );
        }
        text
    }
}

/// The camera of frame `k` of `frames`: the default framing swung about the vertical axis
/// through the scene's centre.
fn camera_on_path(framing: &Camera, centre: Vec3, k: u32, frames: u32) -> Camera {
    let t = k as f32 / frames.max(1) as f32 - 0.5;
    let angle = (CAMERA_ARC_DEGREES * t).to_radians();
    let offset = glam::Quat::from_rotation_z(angle) * (framing.position - centre);
    Camera::looking_at(centre + offset, centre, framing.scale)
}

/// The PRT row's name for a bake: diffuse PRT, or glossy PRT from matrices, uncompressed or
/// CPCA-compressed.
fn prt_label(bake: &Bake) -> String {
    match (bake.is_matrix(), &bake.cpca) {
        (false, None) => "PRT".into(),
        (false, Some(c)) => format!("PRT, CPCA {}×{}", c.clusters(), c.pcs),
        (true, None) => "glossy PRT, matrix".into(),
        (true, Some(c)) => format!("glossy PRT, matrix CPCA {}×{}", c.clusters(), c.pcs),
    }
}

/// One frame of a run: the configuration that renders it, its index on the camera path, and
/// whether it is timed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    pub configuration: usize,
    pub k: u32,
    pub timed: bool,
}

/// The run's frames in order, for `configurations` configurations of `frames` timed frames
/// each, and the camera path's length: [`WARM_UP_ROUNDS`] untimed rounds, then rounds until
/// every configuration has its frames; a round is one block of [`BLOCK`] frames per
/// configuration, forwards in even rounds and backwards in odd ones; a block's first frame
/// is untimed.
pub fn schedule(configurations: usize, frames: u32) -> (Vec<Slot>, u32) {
    let rounds = WARM_UP_ROUNDS + frames.div_ceil(BLOCK - 1);
    let mut timed = vec![0u32; configurations];
    let mut slots = Vec::new();
    for round in 0..rounds {
        let order: Vec<usize> = match round % 2 {
            0 => (0..configurations).collect(),
            _ => (0..configurations).rev().collect(),
        };
        for configuration in order {
            for k in round * BLOCK..(round + 1) * BLOCK {
                let time =
                    round >= WARM_UP_ROUNDS && k % BLOCK != 0 && timed[configuration] < frames;
                timed[configuration] += u32::from(time);
                slots.push(Slot {
                    configuration,
                    k,
                    timed: time,
                });
            }
        }
    }
    (slots, rounds * BLOCK)
}

/// Runs the benchmark on `gpu`.
pub fn run(gpu: &Gpu, bake: &Bake, options: BenchOptions) -> Result<BenchReport> {
    run_with(gpu, bake, &[], options)
}

/// Runs the benchmark on `gpu` with PRT rows for `also` (further bakes of the same scene:
/// the same vertices, so the same camera path and frames).
pub fn run_with(
    gpu: &Gpu,
    bake: &Bake,
    also: &[Bake],
    options: BenchOptions,
) -> Result<BenchReport> {
    run_occluded(gpu, (bake, also), None, options)
}

/// Moving occluders for the bench: `count` copies of one occluder.
#[derive(Clone, Debug)]
pub struct BenchOccluders {
    pub occluder: OccluderFile,
    pub count: usize,
}

/// The spheres of `occluders` at frame `k`: copy i circles the scene's vertical axis at a
/// quarter of its horizontal extent from the centre, 0.3 of the way up from its bottom,
/// starting at 2πi/N and turning 1° a frame.
pub fn occluder_spheres(occluders: &BenchOccluders, bake: &Bake, k: u32) -> Vec<Sphere> {
    let frame = bake.up().from_z_up();
    let (lo, hi) = bake.scene.bounds();
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let (x, y, z) = (frame * DVec3::X, frame * DVec3::Y, frame * DVec3::Z);
    let centre = 0.5 * (lo + hi);
    let extent = hi - lo;
    let radius = 0.25 * (extent.dot(x).abs()).min(extent.dot(y).abs());
    let height = lo.dot(z).min(hi.dot(z)) + 0.3 * extent.dot(z).abs();
    let axis = centre - centre.dot(z) * z + height * z;
    (0..occluders.count)
        .flat_map(|i| {
            let angle = std::f64::consts::TAU * i as f64 / occluders.count as f64
                + f64::from(k).to_radians();
            let at = axis + radius * (angle.cos() * x + angle.sin() * y);
            occluders
                .occluder
                .placed(at, DQuat::from_axis_angle(z, angle))
        })
        .collect()
}

/// [`run_with`], and with `occluders` PRT rows of the main bake shadowed by them.
pub fn run_occluded(
    gpu: &Gpu,
    (bake, also): (&Bake, &[Bake]),
    occluders: Option<&BenchOccluders>,
    options: BenchOptions,
) -> Result<BenchReport> {
    if let Some(other) = also
        .iter()
        .find(|b| b.scene.vertex_count() != bake.scene.vertex_count() || b.lightmap().is_some())
    {
        return Err(Error::InvalidOption(format!(
            "--bench-also {}: not a per-vertex bake of the same scene as {}",
            other.file_path.display(),
            bake.file_path.display()
        )));
    }
    if options.frames == 0 {
        return Err(Error::InvalidOption(
            "--bench-frames must be at least 1".into(),
        ));
    }
    let (device, queue) = (&gpu.device, &gpu.queue);
    let bakes: Vec<&Bake> = std::iter::once(bake).chain(also).collect();
    let mut renderers = bakes
        .iter()
        .map(|b| Renderer::new(device, queue, b, offscreen::FORMAT, options.size))
        .collect::<Result<Vec<_>>>()?;
    // The occluded rows' renderer (the main bake's), and the shadow that darkens it.
    let occluded = bakes.len();
    let shadow = match occluders {
        Some(o) => {
            let mut copies = o.occluder.clone();
            let one = o.occluder.spheres.clone();
            copies.spheres = (0..o.count).flat_map(|_| one.clone()).collect();
            let shadow = MoverShadow::new(bake, copies)?;
            let mut renderer = Renderer::new(device, queue, bake, offscreen::FORMAT, options.size)?;
            renderer.add_occluders(device, bake)?;
            renderers.push(renderer);
            Some(shadow)
        }
        None => None,
    };
    let target = Offscreen::new(device, options.size);
    let (w, h) = options.size;
    let framing = Camera::framing(&bake.scene.positions, w as f32 / h as f32);
    let bounds = bake.scene.bounds();
    let centre = 0.5 * (bounds.0 + bounds.1);
    let configurations = [(0, Mode::Phong), (0, Mode::Prt)]
        .into_iter()
        .chain((1..renderers.len()).map(|b| (b, Mode::Prt)));
    let mut views: Vec<(usize, String, View)> = configurations
        .flat_map(|(b, mode)| {
            let label = match (mode, occluders) {
                (Mode::Phong, _) => mode.name().to_string(),
                (Mode::Prt, Some(o)) if b == occluded => {
                    format!("{}, {} moving occluders", prt_label(bake), o.count)
                }
                (Mode::Prt, _) => prt_label(bakes[b]),
            };
            let of = bakes.get(b).copied().unwrap_or(bake);
            LIGHT_COUNTS.map(|count| {
                let lights = Lights::suns(count, of.order()).for_up(of.up());
                let mut view = View::new(framing, lights);
                view.mode = mode;
                (b, label.clone(), view)
            })
        })
        .collect();
    let mut times = vec![Vec::with_capacity(options.frames as usize); views.len()];
    let (slots, path_frames) = schedule(views.len(), options.frames);
    for slot in slots {
        let (b, _, view) = &mut views[slot.configuration];
        let renderer = &mut renderers[*b];
        let started = Instant::now();
        view.camera = camera_on_path(&framing, centre, slot.k, path_frames);
        for light in view.lights.iter_mut() {
            light.steerable.phi += LIGHT_DEGREES_PER_FRAME.to_radians();
        }
        if let (Some(o), Some(shadow), true) = (occluders, &shadow, *b == occluded) {
            let spheres = occluder_spheres(o, bake, slot.k);
            if shadow.is_texel() {
                renderer.set_occluder_spheres(queue, &spheres)?;
            } else {
                renderer.set_transfer(queue, &shadow.transfer_for(&spheres));
            }
        }
        renderer.update(queue, &FrameInputs::from_view(view, None));
        renderer.render(&target.view, device, queue);
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|err| Error::Gpu(format!("waiting for a frame: {err}")))?;
        if slot.timed {
            times[slot.configuration].push(started.elapsed().as_secs_f64());
        }
    }
    let measurements = views
        .into_iter()
        .zip(times)
        .map(|((bake, label, view), frame_seconds)| Measurement {
            mode: view.mode,
            lights: view.lights.len(),
            bake,
            label,
            frame_seconds,
        })
        .collect();
    Ok(BenchReport {
        device: gpu.description(),
        options,
        vertices: bake.scene.vertex_count(),
        triangles: bake.scene.triangles.len(),
        order: bake.order(),
        lightmap: bake.lightmap().map(|l| (l.width, l.height)),
        measurements,
        occluded: occluders.map(|_| occluded),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fps_is_one_over_the_median_frame_time() {
        let m = |frame_seconds: Vec<f64>| Measurement {
            mode: Mode::Prt,
            lights: 1,
            bake: 0,
            label: "PRT".into(),
            frame_seconds,
        };
        // One frame interrupted by another process does not move the median.
        assert_eq!(m(vec![0.02, 0.5, 0.02]).fps(), 50.0);
        assert_eq!(m(vec![0.01, 0.03]).fps(), 50.0);
        assert!(m(vec![]).fps().is_nan());
    }

    #[test]
    fn every_configuration_is_warm_before_any_frame_is_timed() {
        let (slots, path) = schedule(4, 20);
        let first_timed = slots.iter().position(|s| s.timed).unwrap();
        for c in 0..4 {
            // Every configuration has rendered its warm-up blocks before the first timed frame.
            let warm = slots[..first_timed]
                .iter()
                .filter(|s| s.configuration == c)
                .count();
            assert!(
                warm as u32 >= WARM_UP_ROUNDS * BLOCK,
                "configuration {c}: {warm}"
            );
            // Exactly the frames asked for, none of them a block's first.
            let timed: Vec<&Slot> = slots
                .iter()
                .filter(|s| s.configuration == c && s.timed)
                .collect();
            assert_eq!(timed.len(), 20);
            assert!(timed.iter().all(|s| s.k % BLOCK != 0 && s.k < path));
        }
        // Rounds alternate direction: no configuration always follows the same one.
        let block_starts: Vec<usize> = slots
            .iter()
            .filter(|s| s.k % BLOCK == 0)
            .map(|s| s.configuration)
            .collect();
        assert_eq!(&block_starts[..8], &[0, 1, 2, 3, 3, 2, 1, 0]);
    }
}
