//! A fly camera for z-up scenes: a position, a yaw about +z and a pitch above the horizon.
//! (A y-up bake is shown turned to z-up: see [`crate::bake`].)

use glam::camera::rh;
use glam::{Mat4, Vec3};

use crate::error::{Error, Result};

/// Vertical field of view.
const FOV_Y_DEGREES: f32 = 50.0;

/// Where the default framing looks from, relative to the scene's centre: in front (−y), to
/// the right (+x) and above. The demo scenes are open toward −y (the torus's walls stand at
/// −x and +y, the Cornell box's opening faces −y).
const FRAMING_DIRECTION: Vec3 = Vec3::new(0.6, -1.0, 0.5);
/// The framing keeps every vertex within this fraction of the image's half-width and
/// half-height.
const FRAMING_MARGIN: f32 = 0.95;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Radians about +z from +x (the φ of the viewing direction).
    pub yaw: f32,
    /// Radians above the horizontal, within ±89°.
    pub pitch: f32,
    /// The scene's size (radius of its bounding sphere): sets the clipping planes and how
    /// fast the arrows move the camera.
    pub scale: f32,
}

impl Camera {
    /// Looks at the points from [`FRAMING_DIRECTION`], as close as keeps every point in an
    /// image of this aspect ratio (width / height), with the points' image centred.
    pub fn framing(points: &[Vec3], aspect: f32) -> Camera {
        let (lo, hi) = points
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        let (lo, hi) = if lo.is_finite() && hi.is_finite() {
            (lo, hi)
        } else {
            (Vec3::splat(-1.0), Vec3::ONE)
        };
        let radius = (0.5 * (hi - lo).length()).max(1e-6);
        let direction = FRAMING_DIRECTION.normalize();
        let at = |target: Vec3, distance: f32| {
            Camera::looking_at(target + direction * distance, target, radius)
        };
        // The points' extent in normalised device coordinates, or None if one is behind.
        let extent = |camera: &Camera| {
            let m = camera.view_projection(aspect);
            points.iter().try_fold(
                (glam::Vec2::INFINITY, glam::Vec2::NEG_INFINITY),
                |(lo, hi), p| {
                    let c = m * p.extend(1.0);
                    let ndc = c.truncate().truncate() / c.w;
                    (c.w > 0.0).then(|| (lo.min(ndc), hi.max(ndc)))
                },
            )
        };
        let fits = |camera: &Camera| {
            extent(camera).is_some_and(|(lo, hi)| {
                lo.min_element() >= -FRAMING_MARGIN && hi.max_element() <= FRAMING_MARGIN
            })
        };
        let half_y = 0.5 * FOV_Y_DEGREES.to_radians();
        let half = half_y.min((half_y.tan() * aspect).atan());
        let mut target = 0.5 * (lo + hi);
        let mut camera = at(target, radius / half.sin());
        // Twice: fit the distance by bisection (moving back along the view keeps what is in
        // view in view, and from `far` the bounding sphere fits with room for the margin),
        // then move the target so the points' image is centred.
        for _ in 0..2 {
            let (mut near, mut far) = (0.0, 2.0 * radius / (FRAMING_MARGIN * half.sin()));
            for _ in 0..24 {
                let mid = 0.5 * (near + far);
                if fits(&at(target, mid)) {
                    far = mid;
                } else {
                    near = mid;
                }
            }
            camera = at(target, far);
            if let Some((lo, hi)) = extent(&camera) {
                let centre = 0.5 * (lo + hi);
                let up = camera.right().cross(camera.forward());
                let half_height = far * half_y.tan();
                target +=
                    camera.right() * centre.x * half_height * aspect + up * centre.y * half_height;
            }
        }
        camera
    }

    /// A camera at `position` looking at `target`.
    pub fn looking_at(position: Vec3, target: Vec3, scale: f32) -> Camera {
        let d = (target - position).normalize_or(Vec3::X);
        Camera {
            position,
            yaw: d.y.atan2(d.x),
            pitch: d.z.clamp(-1.0, 1.0).asin(),
            scale,
        }
    }

    /// Parses `--camera x,y,z,yaw,pitch` (angles in degrees); `scale` as for the framing.
    pub fn parse(text: &str, scale: f32) -> Result<Camera> {
        let numbers: Vec<f32> = text
            .split(',')
            .map(|s| s.trim().parse::<f32>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|err| {
                Error::InvalidOption(format!(
                    "--camera {text}: {err} (expected x,y,z,yaw,pitch, angles in degrees)"
                ))
            })?;
        let [x, y, z, yaw, pitch] = numbers[..] else {
            return Err(Error::InvalidOption(format!(
                "--camera {text}: expected 5 numbers x,y,z,yaw,pitch, found {}",
                numbers.len()
            )));
        };
        if numbers.iter().any(|n| !n.is_finite()) {
            return Err(Error::InvalidOption(format!(
                "--camera {text}: numbers must be finite"
            )));
        }
        let mut camera = Camera {
            position: Vec3::new(x, y, z),
            yaw: yaw.to_radians(),
            pitch: 0.0,
            scale,
        };
        camera.set_pitch(pitch.to_radians());
        Ok(camera)
    }

    /// The `--camera` argument that reproduces this camera.
    pub fn to_argument(&self) -> String {
        let p = self.position;
        format!(
            "{:.3},{:.3},{:.3},{:.2},{:.2}",
            p.x,
            p.y,
            p.z,
            self.yaw.to_degrees(),
            self.pitch.to_degrees()
        )
    }

    /// Sets the pitch, kept within ±89° so the view never flips over the pole.
    pub fn set_pitch(&mut self, pitch: f32) {
        let limit = 89f32.to_radians();
        self.pitch = pitch.clamp(-limit, limit);
    }

    /// The unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(cp * cy, cp * sy, sp)
    }

    /// The unit vector to the right of the view, horizontal.
    pub fn right(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        Vec3::new(sy, -cy, 0.0)
    }

    /// World to clip space (wgpu's depth range 0..1) for a viewport of this aspect ratio.
    pub fn view_projection(&self, aspect: f32) -> Mat4 {
        let view = rh::view::look_to_mat4(self.position, self.forward(), Vec3::Z);
        // wgpu's clip space is DirectX's: depth 0..1, y up.
        let projection = rh::proj::directx::perspective(
            FOV_Y_DEGREES.to_radians(),
            aspect,
            self.scale * 1e-2,
            self.scale * 50.0,
        );
        projection * view
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_sees_the_whole_scene_tightly() {
        let corners: Vec<Vec3> = (0..8)
            .map(|i| {
                Vec3::new(
                    if i & 1 == 0 { -3.0 } else { 3.0 },
                    if i & 2 == 0 { -3.0 } else { 3.0 },
                    if i & 4 == 0 { 0.0 } else { 6.0 },
                )
            })
            .collect();
        for aspect in [16.0 / 9.0, 0.5] {
            let camera = Camera::framing(&corners, aspect);
            // Every corner projects inside the view, and one touches the margin.
            let m = camera.view_projection(aspect);
            let mut widest = 0.0f32;
            for corner in &corners {
                let clip = m * corner.extend(1.0);
                let ndc = clip.truncate() / clip.w;
                assert!(ndc.x.abs() <= FRAMING_MARGIN + 1e-4, "{corner}: {ndc}");
                assert!(ndc.y.abs() <= FRAMING_MARGIN + 1e-4, "{corner}: {ndc}");
                assert!((0.0..=1.0).contains(&ndc.z), "{corner}: {ndc}");
                widest = widest.max(ndc.x.abs()).max(ndc.y.abs());
            }
            assert!(widest > FRAMING_MARGIN - 1e-3, "{widest}");
        }
    }

    #[test]
    fn the_camera_argument_round_trips() {
        let camera = Camera::parse("1,-2,3.5,30,-20", 5.0).unwrap();
        assert_eq!(camera.position, Vec3::new(1.0, -2.0, 3.5));
        assert!((camera.yaw.to_degrees() - 30.0).abs() < 1e-4);
        let again = Camera::parse(&camera.to_argument(), 5.0).unwrap();
        assert!((again.position - camera.position).length() < 1e-3);
        assert!((again.pitch - camera.pitch).abs() < 1e-4);
    }

    #[test]
    fn malformed_camera_arguments_are_refused() {
        for bad in ["1,2,3", "1,2,3,4,x", "1,2,3,4,5,6", "1,2,inf,4,5"] {
            assert!(Camera::parse(bad, 1.0).is_err(), "{bad}");
        }
    }

    #[test]
    fn yaw_and_pitch_follow_the_sh_angle_convention() {
        // Yaw is measured from +x towards +y, as φ is.
        let camera = Camera::parse("0,0,0,90,0", 1.0).unwrap();
        assert!((camera.forward() - Vec3::Y).length() < 1e-6);
        assert!((camera.right() - Vec3::X).length() < 1e-6);
    }
}
