//! Applying a [`Filter`]: each cluster's kernel formed once and its fit's sums kept, read
//! by every member at its own place and blended with the fits about it ([`super::blend`]).

use rayon::prelude::*;

use super::blend::{self, TERMS};
use super::{Filter, clusters, lanes, normal_fit, vertices};

/// A receiver and its [`Filter::row`].
type MemberRow = (u32, Vec<(u32, f32)>);

/// What [`Filter::rows`] reuses from one cluster to the next: the clusters whose fits a
/// cluster's members blend, each one's kernel and sums of the signal once formed, and a
/// member's shares of them, its fits of the signal, its weights through each and their
/// sums.
#[derive(Default)]
struct RowScratch {
    near: Vec<u32>,
    shares: Vec<f32>,
    kernels: Vec<vertices::Scratch>,
    formed: Vec<bool>,
    sums: Vec<Vec<f32>>,
    signal: Vec<f32>,
    through: Vec<Vec<(u32, f32)>>,
    /// Each receiver's weight in the row being summed, `None` where it has none yet.
    dense: Vec<Option<f32>>,
    /// The receivers the row has weights on, in the order first met.
    touched: Vec<u32>,
}

/// Clusters per block of [`Filter::apply_with_means`]: one lock per block's values, which
/// stay in a core's cache (about 400 texels' at 64).
const APPLY_BLOCK: usize = 64;

impl Filter<'_> {
    /// Member m's place about cluster c's centroid, in c's representative's tangent plane, in
    /// its spacings: (1, u, v).
    pub(super) fn member_place(&self, c: usize, m: usize) -> [f32; 3] {
        let g = self.guides;
        let r = self.clusters.reps[c] as usize;
        let (t1, t2) = self.frames[c];
        let d = (g.points[m] - self.clusters.points[c]) / g.spacing[r];
        [1.0, d.dot(t1), d.dot(t2)]
    }

    /// Member m's terms past the plane's, where its cluster c's fit has them: over a normal
    /// map, its shading normal's less c's representative's, in c's frame, and their squares
    /// and product ([`super::normal_fit`]); elsewhere its contact term less c's and its
    /// place's squares and product ([`super::texel_kernel`]).
    pub(super) fn member_extra(&self, c: usize, m: usize) -> [f32; normal_fit::NORMAL] {
        let g = self.guides;
        let r = self.clusters.reps[c] as usize;
        if !self.fitted_in_normal(g.groups[r]) {
            let contact = match (self.contact.terms.get(m), self.tap_contact.get(c)) {
                (Some(member), Some(cluster)) => member - cluster,
                _ => 0.0,
            };
            let [_, u, v] = self.member_place(c, m);
            return [contact, u * u, u * v, v * v, 0.0];
        }
        let offset = normal_fit::offset(g.normals[m], g.normals[r], self.frames[c]);
        normal_fit::normal_terms(offset, true)
    }

    /// Receiver i's weights on every receiver, normalised, in the receivers' order: through
    /// each fit it blends ([`super::blend`]), that cluster's kernel read at i's place times
    /// each cluster's weights on its members, times i's share of the fit. Over a normal map
    /// [`Filter::apply_to_transfer`] adds to what they give each texel's lobe less their sum
    /// of its neighbours' ([`super::demodulate`]).
    pub fn row(&self, i: usize, out: &mut Vec<(u32, f32)>) {
        let c = self.cluster_of[i] as usize;
        let mut rows = Vec::new();
        self.member_rows(c, &mut RowScratch::default(), &mut rows);
        out.clear();
        if let Some((_, row)) = rows.into_iter().find(|&(m, _)| m as usize == i) {
            *out = row;
        }
    }

    /// Every receiver's [`Filter::row`], in receiver order: the fits a cluster's members
    /// blend are formed once for all of them, not once per member.
    pub fn rows(&self) -> Vec<Vec<(u32, f32)>> {
        let per_cluster: Vec<Vec<MemberRow>> = (0..self.clusters.reps.len())
            .into_par_iter()
            .map_init(RowScratch::default, |scratch, c| {
                let mut rows = Vec::new();
                self.member_rows(c, scratch, &mut rows);
                rows
            })
            .collect();
        let mut rows = vec![Vec::new(); self.cluster_of.len()];
        for (m, row) in per_cluster.into_iter().flatten() {
            rows[m as usize] = row;
        }
        rows
    }

    /// Each member of cluster c with its [`Filter::row`], into `out`: each fit a member
    /// reads (its kernel, and its sums of the signal) is formed the first time a member
    /// reads it.
    fn member_rows(&self, c: usize, scratch: &mut RowScratch, out: &mut Vec<MemberRow>) {
        let RowScratch {
            near,
            shares,
            kernels,
            formed,
            sums,
            signal,
            through,
            dense,
            touched,
        } = scratch;
        self.blend_neighbours(c, near);
        let sw = self.signal_width;
        kernels.resize_with(kernels.len().max(near.len()), Default::default);
        sums.resize_with(sums.len().max(near.len()), Vec::new);
        through.resize_with(through.len().max(near.len()), Vec::new);
        formed.clear();
        formed.resize(near.len(), false);
        signal.resize(near.len() * sw, 0.0);
        dense.resize(self.cluster_of.len(), None);
        for &(m, _) in self.clusters.row(c) {
            let i = m as usize;
            self.blend_tents((c, i), near, shares);
            // Through each fit i reads: its weights, and its fit of the signal at i, as the
            // filter's application reads them.
            for (n, &k) in near.iter().enumerate() {
                through[n].clear();
                if shares[n] == 0.0 {
                    continue;
                }
                let k = k as usize;
                if !formed[n] {
                    self.cluster_kernel(k, &mut kernels[n]);
                    if near.len() > 1 {
                        sums[n].clear();
                        self.fit_sums(&kernels[n], (self.signal_means(), &[]), sw, &mut sums[n]);
                    }
                    formed[n] = true;
                }
                self.kernel_row(k, i, &kernels[n], &mut through[n]);
                if near.len() > 1 {
                    let terms = 3 + kernels[n].extra_terms;
                    let p = self.member_terms(k, i, terms);
                    blend::read_fit(&sums[n], (terms, sw), &p, &mut signal[n * sw..][..sw]);
                }
            }
            for n in 1..near.len() {
                if shares[n] != 0.0 {
                    let pair = (c, near[n] as usize);
                    shares[n] *= self.agreement(pair, &signal[..sw], &signal[n * sw..][..sw]);
                }
            }
            // The weights on each receiver summed in the order they come, gathered in a
            // dense row (what a stable sort by receiver and a sum of the runs would give,
            // without sorting every entry).
            let total: f32 = shares.iter().sum();
            touched.clear();
            for (row, &share) in through.iter().zip(shares.iter()) {
                for &(j, w) in row {
                    let w = share / total * w;
                    match &mut dense[j as usize] {
                        Some(sum) => *sum += w,
                        first => {
                            *first = Some(w);
                            touched.push(j);
                        }
                    }
                }
            }
            touched.sort_unstable();
            let row = (touched.iter())
                .map(|&j| (j, dense[j as usize].take().expect("touched")))
                .collect();
            out.push((m, row));
        }
    }

    /// Appends receiver i's weights on every receiver through cluster c's fit, its kernel
    /// in `scratch`, read at i's place (one entry per member of each cluster it reads).
    fn kernel_row(
        &self,
        c: usize,
        i: usize,
        scratch: &vertices::Scratch,
        out: &mut Vec<(u32, f32)>,
    ) {
        let place = self.member_place(c, i);
        let terms = vertices::terms(place[1], place[2]);
        let member_extra = self.member_extra(c, i);
        for (n, &(k, e)) in scratch.kernel.iter().enumerate() {
            let mut w = match self.settings.quadratic {
                true => vertices::dot(&scratch.weights[n], &terms),
                false => e[0] * place[0] + e[1] * place[1] + e[2] * place[2],
            };
            if let Some(extra) = scratch.extra.get(n) {
                let terms = extra.iter().zip(&member_extra);
                w += terms.map(|(n, m)| n * m).sum::<f32>();
            }
            let members = self.clusters.row(k as usize).iter();
            out.extend(members.map(|&(j, m)| (j, w * m)));
        }
    }

    /// The filtered values: `values` holds `width` floats per receiver, and so does the
    /// result.
    pub fn apply(&self, values: &[f32], width: usize) -> Vec<f32> {
        let mut out = values.to_vec();
        self.apply_in_place(&mut out, width, &mut []);
        out
    }

    /// [`Filter::apply`] of `values` and of `scalars` (one float per receiver, or none)
    /// with the same kernels, in place: each cluster's kernel is formed once.
    pub fn apply_in_place(&self, values: &mut [f32], width: usize, scalars: &mut [f32]) {
        let means = self.clusters.means(values, width);
        self.apply_with_means(values, (&means, false), width, scalars);
    }

    /// [`Filter::apply_in_place`] of the very transfer the filter was formed for (`width`
    /// floats per receiver, unchanged since): where that transfer was the filter's signal,
    /// its clusters' means are already at hand, the same floats. Over a normal map the
    /// filter smooths the transfer less each texel's unoccluded lobe
    /// ([`super::demodulate`]), and each texel's own is added back.
    pub fn apply_to_transfer(&self, transfer: &mut [f32], width: usize, scalars: &mut [f32]) {
        let demodulate = |transfer: &mut [f32], sign: f32| {
            if let Some(demodulation) = &self.demodulation {
                demodulation.shift(self.guides, transfer, sign);
            }
        };
        match self.transfer_means && self.signal_width == width {
            // The means were formed from the demodulated signal, and every receiver's
            // value is written over: the transfer itself is not read, so not demodulated.
            true => self.apply_with_means(transfer, (self.signal_means(), true), width, scalars),
            false => {
                demodulate(transfer, -1.0);
                self.apply_in_place(transfer, width, scalars)
            }
        }
        demodulate(transfer, 1.0);
    }

    /// The clusters' means of the filter's signal, `signal_width` floats each: the first
    /// rows of its guides.
    fn signal_means(&self) -> &[f32] {
        &self.tap_guide[..self.clusters.reps.len() * self.signal_width]
    }

    /// [`Filter::apply_in_place`] with each cluster's mean of the values given, and whether
    /// those means are the signal's ([`Filter::signal_means`]). Every cluster's kernel is
    /// formed first: with [`Settings::blend`] it keeps its fit's sums, of the values and of
    /// the signal, for its members and its neighbours' to read; else it answers its members
    /// at once. Then, blended, each cluster's members read the fits about them. The sums are
    /// the fit's Σ e_k · mean_k for each term: a member's value is their dot with its terms,
    /// so the neighbours' means are read once per cluster, not once per member. Where the
    /// values are the signal (shadowed transfer up to order 3), their sums and fits serve as
    /// the signal's: the same floats, formed once.
    ///
    /// [`Settings::blend`]: super::Settings::blend
    fn apply_with_means(
        &self,
        values: &mut [f32],
        (means, means_are_signal): (&[f32], bool),
        width: usize,
        scalars: &mut [f32],
    ) {
        if self.settings.quadratic {
            return self.apply_quadratic(values, means, width, scalars);
        }
        let scalar_means = match scalars.is_empty() {
            true => Vec::new(),
            false => self.clusters.means(scalars, 1),
        };
        let (count, sw) = (self.clusters.reps.len(), self.signal_width);
        // The signal's sums and fits are the values' own (their first `sw` floats).
        let signal_is_values = means_are_signal && width == sw;
        // Each blended cluster's sums: of the values (with the scalars'), then, unless they
        // are the signal's, of the signal.
        let signal_floats = match signal_is_values {
            true => 0,
            false => sw + 1,
        };
        let block = |b: usize| b * APPLY_BLOCK..((b + 1) * APPLY_BLOCK).min(count);
        let blocks = count.div_ceil(APPLY_BLOCK);
        // Per block, each cluster's sums or its members' answers, and where each starts.
        let formed: Vec<(Vec<usize>, Vec<f32>)> = (0..blocks)
            .into_par_iter()
            .map_init(
                || (vertices::Scratch::default(), Vec::new()),
                |(scratch, sums): &mut (_, Vec<f32>), b| {
                    let (mut starts, mut data) = (Vec::with_capacity(APPLY_BLOCK + 1), Vec::new());
                    for c in block(b) {
                        starts.push(data.len());
                        self.cluster_kernel(c, scratch);
                        match self.settings.blend {
                            true => {
                                self.fit_sums(scratch, (means, &scalar_means), width, &mut data);
                                if !signal_is_values {
                                    let signal = (self.signal_means(), &[][..]);
                                    self.fit_sums(scratch, signal, sw, &mut data);
                                }
                            }
                            false => {
                                let means = (means, &scalar_means[..]);
                                self.answer_members(c, scratch, means, width, sums, &mut data)
                            }
                        }
                    }
                    starts.push(data.len());
                    (starts, data)
                },
            )
            .collect();
        let formed_of = |c: usize| {
            let (starts, data) = &formed[c / APPLY_BLOCK];
            &data[starts[c % APPLY_BLOCK]..starts[c % APPLY_BLOCK + 1]]
        };
        // A blended cluster's sums: of the values (with the scalars'), of the signal, and
        // the fit's terms.
        let sums_of = |k: usize| {
            let data = formed_of(k);
            let terms = data.len() / (width + 1 + signal_floats);
            let (values, signal) = data.split_at(terms * (width + 1));
            (values, signal, terms)
        };
        // Each block's members' values are formed outside the lock and copied in under it;
        // every receiver is one cluster's member, so the result is the same in any order.
        let out = std::sync::Mutex::new((values, scalars));
        (0..blocks).into_par_iter().for_each_init(
            || (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new()),
            |(near, shares, signal, fits, rows), b| {
                rows.clear();
                for c in block(b) {
                    if !self.settings.blend {
                        rows.extend_from_slice(formed_of(c));
                        continue;
                    }
                    self.blend_neighbours(c, near);
                    for &(m, _) in self.clusters.row(c) {
                        let m = m as usize;
                        self.blend_tents((c, m), near, shares);
                        // Each fit the member reads, of the signal and of the values.
                        signal.resize(near.len() * sw, 0.0);
                        fits.resize(near.len() * (width + 1), 0.0);
                        for (n, &k) in near.iter().enumerate() {
                            if shares[n] == 0.0 {
                                continue;
                            }
                            let (values, signal_sums, terms) = sums_of(k as usize);
                            let p = self.member_terms(k as usize, m, terms);
                            if !signal_is_values {
                                let into = &mut signal[n * sw..][..sw];
                                blend::read_fit(signal_sums, (terms, sw), &p, into);
                            }
                            let into = &mut fits[n * (width + 1)..][..width + 1];
                            blend::read_fit(values, (terms, width), &p, into);
                        }
                        // Fit n's signal at the member.
                        let signal_of = |n: usize| match signal_is_values {
                            true => &fits[n * (width + 1)..][..sw],
                            false => &signal[n * sw..][..sw],
                        };
                        for n in 1..near.len() {
                            if shares[n] != 0.0 {
                                let pair = (c, near[n] as usize);
                                shares[n] *= self.agreement(pair, signal_of(0), signal_of(n));
                            }
                        }
                        let total: f32 = shares.iter().sum();
                        let start = rows.len();
                        rows.resize(start + width + 1, 0.0);
                        for (n, &share) in shares.iter().enumerate() {
                            if share != 0.0 {
                                let fit = &fits[n * (width + 1)..][..width + 1];
                                clusters::add_scaled(&mut rows[start..], share / total, fit);
                            }
                        }
                    }
                }
                let mut out = out.lock().expect("no block panicked");
                let (values, scalars) = &mut *out;
                let members = block(b).flat_map(|c| self.clusters.row(c));
                for (&(m, _), row) in members.zip(rows.chunks_exact(width + 1)) {
                    let m = m as usize;
                    values[m * width..][..width].copy_from_slice(&row[..width]);
                    if let Some(s) = scalars.get_mut(m) {
                        *s = row[width];
                    }
                }
            },
        );
    }

    /// Appends the fit's sums of the kernel in `scratch`, Σ e_k · mean_k for each of its
    /// terms, `width` values each, then each term's sum of the scalars' means (0 where there
    /// are none).
    pub(super) fn fit_sums(
        &self,
        scratch: &vertices::Scratch,
        (means, scalar_means): (&[f32], &[f32]),
        width: usize,
        out: &mut Vec<f32>,
    ) {
        let terms = 3 + scratch.extra_terms;
        let start = out.len();
        out.resize(start + terms * (width + 1), 0.0);
        let (sums, scalar_sums) = out[start..].split_at_mut(terms * width);
        let entries = (scratch.kernel.iter().enumerate()).map(|(n, &(k, _))| {
            (
                entry_terms(scratch, n),
                &means[k as usize * width..][..width],
            )
        });
        lanes::weighted_sums(entries, (terms, width), sums);
        if scalar_means.is_empty() {
            return;
        }
        for (n, &(k, _)) in scratch.kernel.iter().enumerate() {
            let (e, s) = (entry_terms(scratch, n), scalar_means[k as usize]);
            for t in 0..terms {
                scalar_sums[t] += e[t] * s;
            }
        }
    }

    /// Appends each member of cluster c's answer, `width` values then its scalar, to `rows`,
    /// from c's kernel in `scratch` and each cluster's mean of the values and the scalars.
    /// A member's weight on neighbour k is e_k · p, p its terms (its place, and those past
    /// it: [`Filter::member_extra`]). Where c has at least as many members as its fit has
    /// terms, the fit's sums Σ e_k · mean_k are formed once, each term's, and every member
    /// dots them with its p: the neighbours' means are read once per term, not once per
    /// member. Where it has fewer (a texel alone, in contact or at a shadow's edge, whose fit
    /// has up to 8 terms), each member weighs the means with its own weights: on a terrain
    /// whose texels are mostly alone, 5 % of the filter's time.
    fn answer_members(
        &self,
        c: usize,
        scratch: &vertices::Scratch,
        (means, scalar_means): (&[f32], &[f32]),
        width: usize,
        sums: &mut Vec<f32>,
        rows: &mut Vec<f32>,
    ) {
        // The fit's terms: (1, u, v), and those past them where it has them.
        let terms = 3 + scratch.extra_terms;
        // Member m's terms.
        let member = |m: usize| self.member_terms(c, m, terms);
        let members = self.clusters.row(c);
        if members.len() < terms {
            for &(m, _) in members {
                let p = member(m as usize);
                let start = rows.len();
                rows.resize(start + width + 1, 0.0);
                let (row, scalar) = rows[start..].split_at_mut(width);
                for (n, &(k, _)) in scratch.kernel.iter().enumerate() {
                    let k = k as usize;
                    let w: f32 = entry_terms(scratch, n)
                        .iter()
                        .zip(&p)
                        .map(|(e, p)| e * p)
                        .sum();
                    clusters::add_scaled(row, w, &means[k * width..][..width]);
                    if let Some(s) = scalar_means.get(k) {
                        scalar[0] += w * s;
                    }
                }
            }
            return;
        }
        sums.clear();
        self.fit_sums(scratch, (means, scalar_means), width, sums);
        let (sums, scalar_sums) = sums.split_at(terms * width);
        // Each member's values, then its scalar.
        for &(m, _) in members {
            let p = member(m as usize);
            match terms {
                3 => {
                    let (s0, rest) = sums.split_at(width);
                    let (s1, s2) = rest.split_at(width);
                    let dot = |(a, (b, d)): (&f32, (&f32, &f32))| a * p[0] + b * p[1] + d * p[2];
                    rows.extend(s0.iter().zip(s1.iter().zip(s2)).map(dot));
                }
                _ => rows.extend(
                    (0..width).map(|j| (0..terms).map(|t| sums[t * width + j] * p[t]).sum::<f32>()),
                ),
            }
            let s = &scalar_sums[..terms];
            rows.push(s.iter().zip(p).map(|(s, p)| s * p).sum());
        }
    }
}

/// Kernel entry n's weights on its fit's terms: (1, u, v), then those past them, 0 past the
/// fit's own.
fn entry_terms(scratch: &vertices::Scratch, n: usize) -> [f32; TERMS] {
    let (e, extra) = (scratch.kernel[n].1, scratch.extra.get(n));
    std::array::from_fn(|t| match t {
        0..3 => e[t],
        _ => extra.map_or(0.0, |x| x[t - 3]),
    })
}
