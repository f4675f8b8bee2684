//! Latitude–longitude (equirectangular) HDR environment maps and their exact projection.
//!
//! # Orientation
//!
//! A W×H map covers the sphere as a panorama seen from inside, +z up, the same way Blender
//! maps an equirectangular environment texture in a z-up world, so maps made for it (Poly
//! Haven's, for instance) light a scene the way they do there:
//!
//! * row y (0 = top) covers polar angles θ ∈ [πy/H, π(y+1)/H]: the top row touches the zenith
//!   +z, the bottom row the nadir −z;
//! * column x covers u ∈ [x/W, (x+1)/W] with φ = π − 2πu: the centre of the image (u = ½)
//!   looks along +x, u = ¼ along +y, u = ¾ along −y, and both side edges along −x. φ
//!   *decreases* to the right, which is what keeps the panorama unmirrored from inside.
//!
//! # Projection
//!
//! Each pixel is taken as constant radiance over its θ–φ rectangle, and its contribution is
//! the exact integral of every basis function over that rectangle (for y_00 that is the
//! pixel's solid angle Δφ·(cos θ_top − cos θ_bottom) times 1/√(4π)). The integral separates:
//! y_l^{±m}(θ, φ) = y_l^{|m|}(θ, 0)·(cos, sin)(mφ), so the φ part is closed-form per column and
//! the θ part is Gauss–Legendre quadrature per row (a trigonometric polynomial of degree ≤ n,
//! integrated to rounding). A constant map therefore projects to its DC term alone, to
//! rounding, at any resolution, and no supersampling is needed: nothing is point-sampled.

use std::f64::consts::{PI, TAU};
use std::path::Path;

use glam::DVec3;
use rayon::prelude::*;

use super::coefficients::LightCoefficients;
use crate::math::sh::{self, Basis};
use crate::support::error::{Error, Location, Result};

/// Longest stretch of θ integrated by one Gauss–Legendre rule: with n + 2 nodes the rule's
/// error on a degree-n trigonometric polynomial over π/16 is below 1e-15 relative for every
/// order up to [`sh::MAX_ORDER`]; taller rows (tiny maps) are split.
const MAX_QUADRATURE_SPAN: f64 = PI / 16.0;

/// A latitude–longitude map of linear RGB radiance.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    width: usize,
    height: usize,
    /// Row-major, top row first.
    pixels: Vec<[f32; 3]>,
    /// The file it was read from, if any (an output must not replace it).
    source: Option<std::path::PathBuf>,
}

impl EnvironmentMap {
    /// A map from its pixels (row-major, top row first). Panics unless `pixels` holds
    /// `width × height` values and both are at least 1.
    pub fn new(width: usize, height: usize, pixels: Vec<[f32; 3]>) -> EnvironmentMap {
        assert!(width >= 1 && height >= 1, "an environment map needs pixels");
        assert_eq!(pixels.len(), width * height, "pixel count");
        EnvironmentMap {
            width,
            height,
            pixels,
            source: None,
        }
    }

    /// Reads a Radiance `.hdr` or OpenEXR `.exr` file (recognised by its content). Other image
    /// formats are refused: they hold display-referred 8-bit colour, not radiance.
    pub fn load(path: &Path) -> Result<EnvironmentMap> {
        let fail = |message: String| Error::Light {
            location: Location::file(path),
            message,
        };
        // Only a regular file, no larger than the memory limit (crate::support::input_path).
        let bytes = crate::support::input_path::read(path)?;
        crate::support::limits::check_exr(path, &bytes)?;
        let open = || {
            let mut reader = image::ImageReader::new(std::io::Cursor::new(&bytes[..]));
            if let Ok(format) = image::ImageFormat::from_path(path) {
                reader.set_format(format);
            }
            reader
                .with_guessed_format()
                .map_err(|err| Error::io(path, err))
        };
        let reader = open()?;
        match reader.format() {
            Some(image::ImageFormat::Hdr | image::ImageFormat::OpenExr) => {}
            other => {
                return Err(fail(format!(
                    "not a Radiance .hdr or OpenEXR .exr file ({})",
                    other.map_or("unknown format", |f| f.extensions_str()[0])
                )));
            }
        }
        // The header's size first: decoding (up to 16 bytes a pixel), the RGB float copy and
        // the kept pixels (12 each) must fit before a byte of pixels is allocated.
        let (width, height) = open()?
            .into_dimensions()
            .map_err(|err| fail(format!("cannot decode the environment map: {err}")))?;
        crate::support::limits::check_image(path, width, height, 40)?;
        let mut reader = reader;
        reader.limits(crate::support::limits::image_limits());
        let image = reader
            .decode()
            .map_err(|err| fail(format!("cannot decode the environment map: {err}")))?
            .into_rgb32f();
        let (width, height) = (image.width() as usize, image.height() as usize);
        if width == 0 || height == 0 {
            return Err(fail("the environment map has no pixels".into()));
        }
        let pixels: Vec<[f32; 3]> = image.pixels().map(|p| p.0).collect();
        if let Some(i) = pixels.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(fail(format!(
                "pixel ({}, {}) is not finite",
                i % width,
                i / width
            )));
        }
        let mut map = EnvironmentMap::new(width, height, pixels);
        map.source = Some(path.to_path_buf());
        Ok(map)
    }

    /// The file the map was read from (None for a map made in memory).
    pub fn source(&self) -> Option<&Path> {
        self.source.as_deref()
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    /// Pixel (x, y), x from the left, y from the top.
    pub fn pixel(&self, x: usize, y: usize) -> [f32; 3] {
        self.pixels[y * self.width + x]
    }

    /// The polar range [θ_top, θ_bottom] of row y.
    pub fn row_theta(&self, y: usize) -> (f64, f64) {
        let h = self.height as f64;
        (PI * y as f64 / h, PI * (y + 1) as f64 / h)
    }

    /// The azimuth range [φ_low, φ_high] of column x (φ_high is its left edge).
    pub fn column_phi(&self, x: usize) -> (f64, f64) {
        let w = self.width as f64;
        (PI - TAU * (x + 1) as f64 / w, PI - TAU * x as f64 / w)
    }

    /// The pixel whose rectangle holds direction `d`.
    pub fn pixel_at(&self, d: DVec3) -> (usize, usize) {
        let (theta, phi) = sh::angles(d);
        let u = (0.5 - phi / TAU).rem_euclid(1.0);
        let x = ((u * self.width as f64) as usize).min(self.width - 1);
        let y = ((theta / PI * self.height as f64) as usize).min(self.height - 1);
        (x, y)
    }

    /// The exact coefficients of the piecewise-constant map (see the module documentation).
    pub fn project(&self, order: usize) -> LightCoefficients {
        let columns = self.column_integrals(order);
        let basis = Basis::new(order);
        let (nodes, weights) = sh::gauss_legendre(order + 2);
        // One contribution per row, summed in row order afterwards: the same bits whatever
        // the number of threads.
        let rows: Vec<[Vec<f64>; 3]> = (0..self.height)
            .into_par_iter()
            .map(|y| {
                let theta_part = self.row_theta_integrals(y, &basis, &nodes, &weights);
                self.row_contribution(y, order, &columns, &theta_part)
            })
            .collect();
        let mut sum = LightCoefficients::zero(order);
        for row in &rows {
            for (acc, add) in sum.rgb.iter_mut().zip(row) {
                for (a, b) in acc.iter_mut().zip(add) {
                    *a += b;
                }
            }
        }
        sum
    }

    /// Per column and m ≥ 0: ∫ cos mφ dφ and ∫ sin mφ dφ over the column, written as
    /// products (2 cos(mφ̄) sin(mΔ/2)/m …) so narrow columns lose no digits.
    fn column_integrals(&self, order: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
        (0..self.width)
            .map(|x| {
                let (lo, hi) = self.column_phi(x);
                let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
                let cos = (0..order)
                    .map(|m| match m {
                        0 => hi - lo,
                        m => 2.0 * (m as f64 * mid).cos() * (m as f64 * half).sin() / m as f64,
                    })
                    .collect();
                let sin = (0..order)
                    .map(|m| match m {
                        0 => 0.0,
                        m => 2.0 * (m as f64 * mid).sin() * (m as f64 * half).sin() / m as f64,
                    })
                    .collect();
                (cos, sin)
            })
            .collect()
    }

    /// ∫ y_l^{|m|}(θ, 0) sin θ dθ over row y, at index(l, |m|): Gauss–Legendre on spans no
    /// wider than [`MAX_QUADRATURE_SPAN`].
    fn row_theta_integrals(
        &self,
        y: usize,
        basis: &Basis,
        nodes: &[f64],
        weights: &[f64],
    ) -> Vec<f64> {
        let n = sh::coeff_count(basis.order());
        let mut theta_part = vec![0.0; n];
        let mut values = vec![0.0; n];
        let (top, bottom) = self.row_theta(y);
        let spans = ((bottom - top) / MAX_QUADRATURE_SPAN).ceil().max(1.0) as usize;
        let span = (bottom - top) / spans as f64;
        for s in 0..spans {
            let mid = top + (s as f64 + 0.5) * span;
            for (t, w) in nodes.iter().zip(weights) {
                let theta = mid + 0.5 * span * t;
                let weight = 0.5 * span * w * theta.sin();
                basis.eval_recurrence(DVec3::new(theta.sin(), 0.0, theta.cos()), &mut values);
                for (acc, v) in theta_part.iter_mut().zip(&values) {
                    *acc += weight * v;
                }
            }
        }
        theta_part
    }

    /// Row y's coefficients per channel: the θ integrals times Σ over the row's pixels of
    /// radiance × φ integral, per channel and m.
    fn row_contribution(
        &self,
        y: usize,
        order: usize,
        columns: &[(Vec<f64>, Vec<f64>)],
        theta_part: &[f64],
    ) -> [Vec<f64>; 3] {
        let n = sh::coeff_count(order);
        let mut cos_sums = vec![[0.0f64; 3]; order];
        let mut sin_sums = vec![[0.0f64; 3]; order];
        for (x, (cos, sin)) in columns.iter().enumerate() {
            let p = self.pixel(x, y).map(f64::from);
            for m in 0..order {
                for c in 0..3 {
                    cos_sums[m][c] += p[c] * cos[m];
                    sin_sums[m][c] += p[c] * sin[m];
                }
            }
        }
        [0, 1, 2].map(|c| {
            (0..n)
                .map(|j| {
                    let (l, m) = sh::band_and_m(j);
                    let am = m.unsigned_abs() as usize;
                    let phi_sums = if m >= 0 { &cos_sums[am] } else { &sin_sums[am] };
                    theta_part[sh::index(l, am as i32)] * phi_sums[c]
                })
                .collect::<Vec<f64>>()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_map_projects_to_its_dc_term_only() {
        let radiance = [0.5f32, 1.25, 2.0];
        for (w, h) in [(1, 1), (8, 4), (37, 19)] {
            let map = EnvironmentMap::new(w, h, vec![radiance; w * h]);
            let c = map.project(6);
            for (channel, &l) in c.rgb.iter().zip(&radiance) {
                let dc = l as f64 * (4.0 * PI).sqrt();
                assert!(
                    (channel[0] - dc).abs() < 1e-13 * dc,
                    "{w}×{h}: {}",
                    channel[0]
                );
                for (j, x) in channel.iter().enumerate().skip(1) {
                    assert!(x.abs() < 1e-13, "{w}×{h}: coefficient {j} = {x}");
                }
            }
        }
    }

    #[test]
    fn pixel_at_follows_the_documented_orientation() {
        // An odd width puts u = ½ (+x) in the middle of column 4.
        let map = EnvironmentMap::new(9, 5, vec![[0.0; 3]; 45]);
        assert_eq!(map.pixel_at(DVec3::X), (4, 2));
        assert_eq!(map.pixel_at(DVec3::Y), (2, 2)); // u = ¼
        assert_eq!(map.pixel_at(-DVec3::Y), (6, 2)); // u = ¾
        assert_eq!(map.pixel_at(-DVec3::X), (0, 2)); // u = 0
        assert_eq!(map.pixel_at(DVec3::new(0.0, 0.0, 1.0)).1, 0);
        assert_eq!(map.pixel_at(-DVec3::Z).1, 4);
        // Every pixel's own centre maps back to it.
        for y in 0..5 {
            for x in 0..9 {
                let (t0, t1) = map.row_theta(y);
                let (p0, p1) = map.column_phi(x);
                let (theta, phi) = (0.5 * (t0 + t1), 0.5 * (p0 + p1));
                let d = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                assert_eq!(map.pixel_at(d), (x, y));
            }
        }
    }
}
