//! The check of `day_night --specular --compare`: a render with Bevy's specular against T·L
//! alone and Bevy's own specular alone, added in linear light.

/// sRGB code to linear.
fn linear(code: u8) -> f64 {
    let c = code as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear to the nearest sRGB code (clamped, as the render target is).
fn code(linear: f64) -> u8 {
    let l = linear.clamp(0.0, 1.0);
    let c = if l <= 0.0031308 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    (c * 255.0).round() as u8
}

/// The check of a specular render `on` against T·L alone (`off`) and Bevy's own specular
/// alone (`bevy`, a StandardMaterial with a black base colour).
pub struct SpecularCheck {
    /// Covered pixels where Bevy's specular is at most 1 code, and the share of those where
    /// `on` is within the tolerance of `off`.
    pub away: usize,
    pub away_share: f64,
    /// Pixels where Bevy's specular is at least 16 codes, and their centre (x, y).
    pub highlight: usize,
    pub centre: [f64; 2],
    /// Covered pixels, and the share where `on` is within the tolerance of `off` + `bevy`
    /// added in linear light; the worst difference.
    pub covered: usize,
    pub sum_share: f64,
    pub worst: u8,
}

pub fn check_specular(on: &[u8], off: &[u8], bevy: &[u8], tolerance: u8) -> SpecularCheck {
    let size = (on.len() / 4).isqrt();
    let (mut away, mut away_close, mut highlight, mut covered, mut sum_close, mut worst) =
        (0usize, 0usize, 0usize, 0usize, 0usize, 0u8);
    let mut centre = [0.0; 2];
    let pixels = on
        .chunks_exact(4)
        .zip(off.chunks_exact(4))
        .zip(bevy.chunks_exact(4));
    for (i, ((p, q), s)) in pixels.enumerate() {
        if p[3] == 0 && q[3] == 0 {
            continue;
        }
        covered += 1;
        let d = |a: &[u8], b: &[u8]| (0..4).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
        let strength = s[0].max(s[1]).max(s[2]);
        if strength <= 1 {
            away += 1;
            away_close += (d(p, q) <= tolerance) as usize;
        } else if strength >= 16 {
            highlight += 1;
            centre[0] += (i % size) as f64;
            centre[1] += (i / size) as f64;
        }
        let mut sum = [0u8; 4];
        for c in 0..3 {
            sum[c] = code(linear(q[c]) + linear(s[c]));
        }
        sum[3] = q[3];
        let e = d(p, &sum);
        worst = worst.max(e);
        sum_close += (e <= tolerance) as usize;
    }
    SpecularCheck {
        away,
        away_share: away_close as f64 / away.max(1) as f64,
        highlight,
        centre: centre.map(|c| c / highlight.max(1) as f64),
        covered,
        sum_share: sum_close as f64 / covered.max(1) as f64,
        worst,
    }
}
