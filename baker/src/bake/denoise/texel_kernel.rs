//! A texel cluster's fit, where no normal map turns its normals: over its tangent plane
//! ([`texel_fit::fit`]), then, each by Lepski's rule where it departs from the fit so far by
//! more than their difference's noise, in its contact term ([`contact::blend`]) and in the
//! plane's squares ([`texel_fit::blend_curved`]).

use glam::Vec4;

use super::contact;
use super::normal_fit::NORMAL;
use super::texel_fit::{self, CURVED, Entry, PLANE, PLANE_RIDGES, Scratch};

/// What [`fit_kernel`] forms for each cluster.
#[derive(Default)]
pub(super) struct Fits {
    plane: Scratch<PLANE>,
    contact: contact::Fits,
    curved: Scratch<CURVED>,
    /// Each entry's weights on every term while the fits are blended.
    current: Vec<[f64; CURVED]>,
}

/// Turns a cluster's kernel entries (k, [w, u, v]) into its fit's weights on (1, u, v),
/// and each entry's weights on the terms past them, (c, u², uv, v²), into `extra`.
/// `contact(k)` is neighbour k's contact term less the cluster's; the fit is `curved` where
/// the settings have the plane's squares. Returns how many terms past (1, u, v) the fit
/// has: 0 (`extra` empty), 1 (the contact term) or 4; `None` where the plane's fit is
/// singular (the kernel untouched).
pub(super) fn fit_kernel<'g>(
    (kernel, extra): (&mut [Entry], &mut Vec<[f32; NORMAL]>),
    fits: &mut Fits,
    contact: impl Fn(u32) -> f32,
    (sw, curved): (usize, bool),
    guide: impl Fn(u32) -> (&'g [Vec4], f32) + Copy,
) -> Option<usize> {
    let Fits {
        plane,
        contact: contact_fits,
        curved: curved_fit,
        current,
    } = fits;
    plane.clear();
    plane.extend((kernel.iter()).map(|&(k, [w, u, v])| (k, w, [1.0, u, v].map(f64::from))));
    if !texel_fit::fit(plane, &PLANE_RIDGES) {
        return None;
    }
    current.clear();
    current.extend(plane.fitted.iter().map(|f| {
        let mut e = [0.0; CURVED];
        e[..PLANE].copy_from_slice(f);
        e
    }));
    let entries = (&kernel[..], &mut current[..]);
    let in_contact = contact::blend(entries, contact_fits, &contact, sw, guide);
    let curves = curved && {
        curved_fit.clear();
        curved_fit.extend(kernel.iter().map(|&(k, [w, u, v])| {
            let (u, v, c) = (f64::from(u), f64::from(v), f64::from(contact(k)));
            (k, w, [1.0, u, v, c, u * u, u * v, v * v])
        }));
        texel_fit::blend_curved(curved_fit, current, sw, guide)
    };
    let count = match (in_contact, curves) {
        (_, true) => CURVED - PLANE,
        (true, false) => 1,
        (false, false) => 0,
    };
    extra.clear();
    for ((_, e), f) in kernel.iter_mut().zip(current.iter()) {
        *e = std::array::from_fn(|t| f[t] as f32);
        if count > 0 {
            extra.push(std::array::from_fn(|t| {
                f.get(PLANE + t).map_or(0.0, |&f| f as f32)
            }));
        }
    }
    Some(count)
}
