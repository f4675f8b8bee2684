//! The thesis's controls (§7 of the digest), acting on a [`View`]: everything a frame depends
//! on except the GPU. Window events, the `--keys` script and tests all go through
//! [`View::key`], [`View::advance`] and [`View::turn`].
//!
//! | action | key |
//! |---|---|
//! | camera forward / back / left / right | arrow keys |
//! | camera yaw / pitch | mouse (drag with the left button) |
//! | select the active light | 1–8 |
//! | light θ up / down | Q / A |
//! | light φ up / down | W / E |
//! | textures on/off | T |
//! | draw normals on/off | N |
//! | draw light vectors on/off | L |
//! | draw transfer probes on/off (`--probes`) | P |
//! | Blinn-Phong / PRT | F1 / F2 |
//! | quit | Escape |
//!
//! Held keys act at a rate per second of frame time, so movement does not depend on the frame
//! rate or the keyboard's repeat rate.

use std::f64::consts::PI;

use crate::camera::Camera;
use crate::lights::{Lights, MAX_LIGHTS};

/// How fast Q/A and W/E turn the active light.
pub const LIGHT_DEGREES_PER_SECOND: f64 = 45.0;
/// How fast the arrows move the camera, in scene radii per second.
pub const CAMERA_RADII_PER_SECOND: f32 = 0.5;
/// How far a mouse drag turns the camera.
pub const MOUSE_DEGREES_PER_PIXEL: f64 = 0.25;

/// The shading model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Per-vertex precomputed radiance transfer.
    Prt,
    /// Classic per-pixel Blinn-Phong with the same lights as directional lights.
    Phong,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Prt => "PRT",
            Mode::Phong => "Blinn-Phong",
        }
    }
}

/// The keys the viewer knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    Up,
    Down,
    Left,
    Right,
    /// 1–8: select light `n − 1`.
    Digit(u8),
    Q,
    A,
    W,
    E,
    T,
    N,
    L,
    /// Transfer probes on/off (the window passes it to the probe scene).
    P,
    F1,
    F2,
    Escape,
}

impl Key {
    /// A key by name, as `--keys` lists them: `Up`, `Down`, `Left`, `Right`, `1`–`8`, `Q`, `A`,
    /// `W`, `E`, `T`, `N`, `L`, `P`, `F1`, `F2`, `Escape` (any case).
    pub fn parse(name: &str) -> Option<Key> {
        let key = match name.trim().to_ascii_lowercase().as_str() {
            "up" => Key::Up,
            "down" => Key::Down,
            "left" => Key::Left,
            "right" => Key::Right,
            "q" => Key::Q,
            "a" => Key::A,
            "w" => Key::W,
            "e" => Key::E,
            "t" => Key::T,
            "n" => Key::N,
            "l" => Key::L,
            "p" => Key::P,
            "f1" => Key::F1,
            "f2" => Key::F2,
            "escape" | "esc" => Key::Escape,
            digit => match digit.parse::<u8>() {
                Ok(n @ 1..=8) => Key::Digit(n),
                _ => return None,
            },
        };
        Some(key)
    }

    /// Keys that act for as long as they are held.
    fn is_held(self) -> bool {
        matches!(
            self,
            Key::Up | Key::Down | Key::Left | Key::Right | Key::Q | Key::A | Key::W | Key::E
        )
    }
}

/// What the caller should do after a key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Response {
    Continue,
    Quit,
}

/// The viewer's state: camera, lights, shading model and the toggles.
#[derive(Clone, Debug)]
pub struct View {
    pub camera: Camera,
    pub lights: Lights,
    pub mode: Mode,
    pub textures: bool,
    pub normals: bool,
    pub light_vectors: bool,
    /// The light that Q/A/W/E turn (index into `lights`).
    pub active_light: usize,
    /// Exposure in stops: radiance × 2^exposure before clamping, as `prt-bake relight
    /// --exposure`.
    pub exposure: f32,
    held: Vec<Key>,
}

impl View {
    /// PRT, textures on, no normals or light vectors, light 1 active, exposure 0.
    pub fn new(camera: Camera, lights: Lights) -> View {
        View {
            camera,
            lights,
            mode: Mode::Prt,
            textures: true,
            normals: false,
            light_vectors: false,
            active_light: 0,
            exposure: 0.0,
            held: Vec::new(),
        }
    }

    /// A key went down (`pressed`) or up. Toggles act on the press; held keys act in
    /// [`View::advance`] until released.
    pub fn key(&mut self, key: Key, pressed: bool) -> Response {
        if key.is_held() {
            self.held.retain(|k| *k != key);
            if pressed {
                self.held.push(key);
            }
            return Response::Continue;
        }
        if !pressed {
            return Response::Continue;
        }
        match key {
            Key::Digit(n) => {
                let i = usize::from(n - 1);
                if i < self.lights.len().min(MAX_LIGHTS) {
                    self.active_light = i;
                }
            }
            Key::T => self.textures = !self.textures,
            Key::N => self.normals = !self.normals,
            Key::L => self.light_vectors = !self.light_vectors,
            Key::F1 => self.mode = Mode::Phong,
            Key::F2 => self.mode = Mode::Prt,
            Key::Escape => return Response::Quit,
            _ => {}
        }
        Response::Continue
    }

    /// Releases every held key (the window lost focus).
    pub fn release_all(&mut self) {
        self.held.clear();
    }

    /// Applies the held keys for `seconds` of frame time (f64, so that light angles
    /// accumulate no f32 rounding of the frame time).
    pub fn advance(&mut self, seconds: f64) {
        let step = seconds * LIGHT_DEGREES_PER_SECOND.to_radians();
        let travel = seconds as f32 * CAMERA_RADII_PER_SECOND * self.camera.scale;
        for key in self.held.clone() {
            match key {
                Key::Up => self.camera.position += self.camera.forward() * travel,
                Key::Down => self.camera.position -= self.camera.forward() * travel,
                Key::Right => self.camera.position += self.camera.right() * travel,
                Key::Left => self.camera.position -= self.camera.right() * travel,
                Key::Q => self.turn_light(step, 0.0),
                Key::A => self.turn_light(-step, 0.0),
                Key::W => self.turn_light(0.0, step),
                Key::E => self.turn_light(0.0, -step),
                _ => {}
            }
        }
    }

    /// Turns the active light by (dθ, dφ) radians: θ stays in [0, π], φ in (−π, π].
    pub fn turn_light(&mut self, d_theta: f64, d_phi: f64) {
        if let Some(light) = self.lights.get_mut(self.active_light) {
            let s = &mut light.steerable;
            s.theta = (s.theta + d_theta).clamp(0.0, PI);
            s.phi += d_phi;
            if s.phi > PI {
                s.phi -= 2.0 * PI;
            } else if s.phi <= -PI {
                s.phi += 2.0 * PI;
            }
        }
    }

    /// A mouse drag of (dx, dy) pixels: right turns right, up looks up.
    pub fn turn(&mut self, dx: f64, dy: f64) {
        let k = MOUSE_DEGREES_PER_PIXEL.to_radians();
        self.camera.yaw -= (dx * k) as f32;
        let pitch = self.camera.pitch - (dy * k) as f32;
        self.camera.set_pitch(pitch);
    }

    /// The on-screen readout: mode, frame rate, active light and its angles, the keys.
    pub fn readout(&self, fps: Option<f64>) -> String {
        let fps = fps.map_or(String::from("-"), |f| format!("{f:.1}"));
        let mut text = format!(
            "{}  {fps} FPS  ORDER {}{}\n",
            self.mode.name(),
            self.lights.order(),
            if self.textures { "" } else { "  NO TEXTURES" }
        );
        match self.lights.get(self.active_light) {
            Some(light) => {
                text += &format!(
                    "LIGHT {}/{} {}  THETA {:.1}°  PHI {:.1}°\n",
                    self.active_light + 1,
                    self.lights.len(),
                    light.kind,
                    light.steerable.theta.to_degrees(),
                    light.steerable.phi.to_degrees()
                );
            }
            None => text += "NO LIGHTS\n",
        }
        text += "ARROWS/DRAG CAMERA  1-8 Q/A W/E LIGHT\nT TEXTURES  N NORMALS  L LIGHTS  F1/F2";
        text.to_uppercase()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn view() -> View {
        let camera = Camera::framing(&[Vec3::splat(-1.0), Vec3::splat(1.0)], 1.0);
        View::new(camera, Lights::load(None, 4).unwrap())
    }

    #[test]
    fn toggles_and_modes_follow_the_thesis_keys() {
        let mut v = view();
        for (key, check) in [
            (Key::T, &(|v: &View| !v.textures) as &dyn Fn(&View) -> bool),
            (Key::N, &|v: &View| v.normals),
            (Key::L, &|v: &View| v.light_vectors),
            (Key::F1, &|v: &View| v.mode == Mode::Phong),
            (Key::F2, &|v: &View| v.mode == Mode::Prt),
            (Key::Digit(2), &|v: &View| v.active_light == 1),
        ] {
            assert_eq!(v.key(key, true), Response::Continue);
            v.key(key, false);
            assert!(check(&v), "{key:?}");
        }
        // The default rig has two lights: 3 selects nothing.
        v.key(Key::Digit(3), true);
        assert_eq!(v.active_light, 1);
        assert_eq!(v.key(Key::Escape, true), Response::Quit);
    }

    #[test]
    fn held_keys_turn_the_active_light_at_the_stated_rate() {
        let mut v = view();
        let (theta, phi) = {
            let s = &v.lights.get(0).unwrap().steerable;
            (s.theta, s.phi)
        };
        v.key(Key::Q, true);
        v.key(Key::E, true);
        for _ in 0..10 {
            v.advance(0.1);
        }
        v.key(Key::Q, false);
        v.key(Key::E, false);
        v.advance(1.0); // released: nothing moves
        let s = &v.lights.get(0).unwrap().steerable;
        let turned = LIGHT_DEGREES_PER_SECOND.to_radians();
        assert!((s.theta - (theta + turned)).abs() < 1e-6);
        assert!((s.phi - (phi - turned)).abs() < 1e-6);
    }

    #[test]
    fn theta_is_clamped_and_phi_wraps() {
        let mut v = view();
        v.turn_light(10.0, 0.0);
        v.turn_light(0.0, 3.0 * PI / 2.0 + 0.1);
        let s = &v.lights.get(0).unwrap().steerable;
        assert_eq!(s.theta, PI);
        assert!(s.phi > -PI && s.phi <= PI);
    }

    #[test]
    fn arrows_move_along_the_view() {
        let mut v = view();
        let start = v.camera.position;
        v.key(Key::Up, true);
        v.advance(1.0);
        let moved = v.camera.position - start;
        let want = v.camera.forward() * CAMERA_RADII_PER_SECOND * v.camera.scale;
        assert!((moved - want).length() < 1e-4);
    }

    #[test]
    fn key_names_parse() {
        assert_eq!(Key::parse("f1"), Some(Key::F1));
        assert_eq!(Key::parse(" 8 "), Some(Key::Digit(8)));
        assert_eq!(Key::parse("9"), None);
        assert_eq!(Key::parse("Esc"), Some(Key::Escape));
    }
}
