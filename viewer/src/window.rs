//! The interactive window (winit): the thesis's controls, the readout, and a frame limit and
//! key script for unattended runs (`--frames`, `--keys`).

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key as WinitKey, NamedKey};
use winit::window::{Window, WindowId};

use crate::bake::Bake;
use crate::controls::{Key, Response, View};
use crate::error::{Error, Result};
use crate::gpu::{self, Gpu};
use crate::moving::{Mover, Probes};
use crate::renderer::{FrameInputs, Renderer};

/// How often the readout's frame rate is refreshed.
const FPS_INTERVAL: Duration = Duration::from_millis(500);

#[derive(Clone, Debug, Default)]
pub struct WindowOptions {
    /// Initial size in pixels.
    pub size: (u32, u32),
    /// Quit after this many frames.
    pub frames: Option<u64>,
    /// Keys pressed one per frame from the first frame (each released on the next).
    pub keys: Vec<Key>,
    /// Transfer probes to draw and an object moving through them (`--probes`, `--mover`).
    pub probes: Option<(Probes, Option<Mover>)>,
    /// The mover's shadow on the scene (`--mover-occluder`).
    pub shadow: Option<crate::occluders::MoverShadow>,
    /// A skinned glTF's LDPRT bake, posed each frame (skinned.rs).
    pub skinned: Option<crate::skinned::Skinned>,
    /// A skinned character walking through the probes (`--character`).
    pub walker: Option<crate::skinned::Skinned>,
}

/// What a window session did.
#[derive(Clone, Copy, Debug)]
pub struct FrameStats {
    pub frames: u64,
    pub seconds: f64,
    /// The adapter's backend, for the summary line.
    pub backend: Option<wgpu::Backend>,
}

/// Opens the window and runs until it is closed, Escape is pressed, or the frame limit.
pub fn run(bake: Bake, view: View, options: WindowOptions) -> Result<FrameStats> {
    let event_loop = EventLoop::new().map_err(|err| {
        Error::Window(format!(
            "{err} (is there a display? without one, use --headless --screenshot OUT.png)"
        ))
    })?;
    let mut app = App {
        script: options.keys.iter().copied().collect(),
        options,
        bake,
        view,
        running: None,
        error: None,
        frames: 0,
        started: None,
        last_frame: None,
        pending_release: None,
        dragging: false,
        cursor: None,
        fps: None,
        fps_window: (Instant::now(), 0),
    };
    event_loop
        .run_app(&mut app)
        .map_err(|err| Error::Window(err.to_string()))?;
    if let Some(err) = app.error {
        return Err(err);
    }
    Ok(FrameStats {
        frames: app.frames,
        seconds: app.started.map_or(0.0, |s| s.elapsed().as_secs_f64()),
        backend: app.running.map(|r| r.gpu.adapter.get_info().backend),
    })
}

/// The window and everything drawn into it.
struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// The format rendered through: the surface's own if it is sRGB, else its sRGB view.
    view_format: wgpu::TextureFormat,
    gpu: Gpu,
    renderer: Renderer,
}

impl Running {
    fn start(
        event_loop: &ActiveEventLoop,
        bake: &Bake,
        options: &WindowOptions,
    ) -> Result<Running> {
        let size = options.size;
        let attributes = Window::default_attributes()
            .with_title("prt-view")
            .with_inner_size(PhysicalSize::new(size.0, size.1));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|err| Error::Window(err.to_string()))?,
        );
        let (surface, gpu) = open_surface(event_loop, &window)?;
        let capabilities = surface.get_capabilities(&gpu.adapter);
        let format = capabilities
            .formats
            .iter()
            .copied()
            .find(wgpu::TextureFormat::is_srgb)
            .or_else(|| capabilities.formats.first().copied())
            .ok_or_else(|| Error::Window("the window offers no colour format".into()))?;
        let view_format = format.add_srgb_suffix();
        let actual = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: Default::default(),
            width: actual.width.max(1),
            height: actual.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: capabilities.alpha_modes[0],
            view_formats: if view_format == format {
                vec![]
            } else {
                vec![view_format]
            },
        };
        surface.configure(&gpu.device, &config);
        let mut renderer = Renderer::new(
            &gpu.device,
            &gpu.queue,
            bake,
            view_format,
            (config.width, config.height),
        )?;
        if let Some((probes, mover)) = &options.probes {
            renderer.set_probe_scene(&gpu.device, probes.clone(), mover.clone())?;
        }
        if let Some(walker) = &options.walker {
            renderer.set_walker(&gpu.device, walker.clone())?;
        }
        if let Some(shadow) = &options.shadow {
            renderer.set_mover_shadow(&gpu.device, bake, shadow.clone())?;
        }
        Ok(Running {
            window,
            surface,
            config,
            view_format,
            gpu,
            renderer,
        })
    }

    fn resize(&mut self, size: PhysicalSize<u32>) {
        if size.width == 0 || size.height == 0 {
            return; // minimised
        }
        self.config.width = size.width;
        self.config.height = size.height;
        self.surface.configure(&self.gpu.device, &self.config);
        self.renderer
            .resize(&self.gpu.device, (size.width, size.height));
    }

    /// Renders and presents one frame; `Ok(false)` when the surface had no image to give.
    fn draw(&mut self, inputs: &FrameInputs) -> Result<bool> {
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(false);
            }
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.gpu.device, &self.config);
                return Ok(false);
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(Error::Gpu("the window's surface failed validation".into()));
            }
        };
        let view = texture.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.view_format),
            ..Default::default()
        });
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        self.renderer.update(queue, inputs);
        self.renderer.render(&view, device, queue);
        self.window.pre_present_notify();
        queue.present(texture);
        Ok(true)
    }
}

struct App {
    options: WindowOptions,
    bake: Bake,
    view: View,
    running: Option<Running>,
    error: Option<Error>,
    frames: u64,
    started: Option<Instant>,
    last_frame: Option<Instant>,
    script: VecDeque<Key>,
    /// A scripted key pressed last frame, released this one.
    pending_release: Option<Key>,
    dragging: bool,
    cursor: Option<PhysicalPosition<f64>>,
    /// The frame rate shown, refreshed every [`FPS_INTERVAL`].
    fps: Option<f64>,
    fps_window: (Instant, u64),
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, err: Error) {
        self.error = Some(err);
        event_loop.exit();
    }

    /// Passes a key to the view; `true` if it asked to quit.
    fn key(&mut self, event_loop: &ActiveEventLoop, key: Key, pressed: bool) -> bool {
        let probes = self
            .running
            .as_mut()
            .and_then(|r| r.renderer.probe_scene_mut());
        if let (Key::P, true, Some(probes)) = (key, pressed, probes) {
            probes.show_probes = !probes.show_probes;
        }
        let quit = self.view.key(key, pressed) == Response::Quit;
        if quit {
            event_loop.exit();
        }
        quit
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        let now = Instant::now();
        let dt = self.last_frame.map_or(0.0, |t| (now - t).as_secs_f64());
        self.last_frame = Some(now);
        self.started.get_or_insert(now);

        let quit = if let Some(key) = self.pending_release.take() {
            self.key(event_loop, key, false)
        } else if let Some(key) = self.script.pop_front() {
            self.pending_release = Some(key);
            self.key(event_loop, key, true)
        } else {
            false
        };
        if quit {
            return;
        }
        self.view.advance(dt);

        let (since, count) = self.fps_window;
        if now - since >= FPS_INTERVAL {
            self.fps = Some((self.frames - count) as f64 / (now - since).as_secs_f64());
            self.fps_window = (now, self.frames);
        }
        let inputs = FrameInputs::from_view(&self.view, Some(self.view.readout(self.fps)));
        let Some(running) = self.running.as_mut() else {
            return;
        };
        if let (Some(probes), Some(start)) = (running.renderer.probe_scene_mut(), self.started) {
            probes.set_time((now - start).as_secs_f64());
        }
        if let (Some(skinned), Some(start)) = (&self.options.skinned, self.started) {
            let pose = skinned.pose_at((now - start).as_secs_f64());
            match skinned.posed(&pose) {
                Ok(posed) => {
                    let queue = &running.gpu.queue;
                    running.renderer.set_vertices(queue, &posed.scene);
                    running.renderer.set_transfer(queue, &posed.transfer);
                }
                Err(err) => return self.fail(event_loop, err),
            }
        }
        match running.draw(&inputs) {
            Ok(true) => self.frames += 1,
            Ok(false) => {}
            Err(err) => return self.fail(event_loop, err),
        }
        if self.options.frames.is_some_and(|n| self.frames >= n) {
            event_loop.exit();
        }
    }
}

/// A surface on the window and a device that can draw to it, from the first of
/// [`gpu::BACKENDS`] that has one.
fn open_surface(
    event_loop: &ActiveEventLoop,
    window: &Arc<Window>,
) -> Result<(wgpu::Surface<'static>, Gpu)> {
    let mut failures = Vec::new();
    for backends in gpu::BACKENDS {
        let instance = gpu::instance(backends, Some(event_loop.owned_display_handle()));
        let surface = match instance.create_surface(window.clone()) {
            Ok(surface) => surface,
            Err(err) => {
                failures.push(format!("{backends:?}: cannot draw into the window: {err}"));
                continue;
            }
        };
        let options = wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: Some(&surface),
            ..Default::default()
        };
        match pollster::block_on(instance.request_adapter(&options)) {
            Ok(adapter) => return Ok((surface, Gpu::open(instance, adapter)?)),
            Err(err) => failures.push(format!("{backends:?}: {err}")),
        }
    }
    Err(Error::NoAdapter(failures.join("; ")))
}

/// The viewer's key for a key event: named keys by name, characters by their letter (so Q
/// is Q on any keyboard layout).
fn viewer_key(event: &KeyEvent) -> Option<Key> {
    match &event.logical_key {
        WinitKey::Named(named) => match named {
            NamedKey::ArrowUp => Some(Key::Up),
            NamedKey::ArrowDown => Some(Key::Down),
            NamedKey::ArrowLeft => Some(Key::Left),
            NamedKey::ArrowRight => Some(Key::Right),
            NamedKey::F1 => Some(Key::F1),
            NamedKey::F2 => Some(Key::F2),
            NamedKey::Escape => Some(Key::Escape),
            _ => None,
        },
        WinitKey::Character(text) => Key::parse(text),
        _ => None,
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match Running::start(event_loop, &self.bake, &self.options) {
            Ok(running) => {
                running.window.request_redraw();
                self.running = Some(running);
            }
            Err(err) => self.fail(event_loop, err),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(running) = self.running.as_mut() {
                    running.resize(size);
                }
            }
            WindowEvent::Focused(false) => self.view.release_all(),
            WindowEvent::KeyboardInput { event, .. } if !event.repeat => {
                if let Some(key) = viewer_key(&event) {
                    self.key(event_loop, key, event.state == ElementState::Pressed);
                }
            }
            WindowEvent::MouseInput {
                button: MouseButton::Left,
                state,
                ..
            } => self.dragging = state == ElementState::Pressed,
            WindowEvent::CursorMoved { position, .. } => {
                if let (true, Some(last)) = (self.dragging, self.cursor) {
                    self.view.turn(position.x - last.x, position.y - last.y);
                }
                self.cursor = Some(position);
            }
            WindowEvent::RedrawRequested => self.frame(event_loop),
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(running) = &self.running {
            running.window.request_redraw();
        }
    }
}
