//! Steps 2-4 of [`super::draw_adaptive`] breadth first: the samples of many
//! lines (regular rows, or the columns of a band between two regular rows)
//! are gathered level by level of the binary subdivision (Adaptive Sample
//! Shading, Section 2.1.2) and shaded together through the fragment stage's
//! batches ([`FragmentStage::shade_batch`](crate::renderer::FragmentStage)),
//! the lane code that full shading runs, instead of one fragment at a time.
//!
//! The samples and the interpolated pixels are those of the depth-first
//! subdivision: a segment between two samples depends only on its two ends,
//! and the segments of one line do not overlap, so visiting them level by
//! level changes the order of the shading, not what is shaded.

use rayon::prelude::*;

use super::{AdaptiveStats, Ctx, ADAPTIVE, DISCARD_BIT, EDGE, INTERPOLATED, NONE, REGULAR, UNKNOWN};
use crate::renderer::tile::{fragment_at, interpolate};
use crate::renderer::{FragmentResult, BATCH};

/// One line of samples inside a buffer: position `i` is the buffer's entry
/// `base + i * stride` and the frame's pixel `pixel0 + i * pixel_stride`.
#[derive(Clone, Copy)]
pub(super) struct Line {
    pub base: usize,
    pub stride: usize,
    pub len: usize,
    pub pixel0: usize,
    pub pixel_stride: usize,
}

impl Line {
    fn at(&self, i: usize) -> usize {
        self.base + i * self.stride
    }
    fn pixel(&self, i: usize) -> usize {
        self.pixel0 + i * self.pixel_stride
    }
}

/// A stretch of one line between two samples, `lo` and `hi` (positions),
/// at subdivision `depth`.
#[derive(Clone, Copy)]
struct Segment {
    line: usize,
    lo: usize,
    hi: usize,
    depth: u32,
}

/// Samples waiting to be shaded: the buffer entry, the frame's pixel, and
/// the kind to record.
#[derive(Default)]
pub(super) struct Pending {
    entries: Vec<usize>,
    pixels: Vec<usize>,
    kinds: Vec<u8>,
}

impl Pending {
    fn push(&mut self, entry: usize, pixel: usize, kind: u8) {
        self.entries.push(entry);
        self.pixels.push(pixel);
        self.kinds.push(kind);
    }
}

/// The largest per-channel difference between two colours.
fn difference(a: [f32; 4], b: [f32; 4]) -> f32 {
    (0..4).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max)
}

impl Ctx<'_> {
    /// Shades the visible primitive at each of `pixels` (frame indices),
    /// in batches of at most [`BATCH`] fragments of one pass.
    pub(super) fn shade_many(&self, pixels: &[usize], out: &mut [[f32; 4]], results: &mut [FragmentResult]) {
        let w = self.w;
        let mut fragments = Vec::with_capacity(BATCH);
        let mut varyings = Vec::new();
        let mut start = 0;
        while start < pixels.len() {
            let p = self.pass_of(self.ids[pixels[start]]);
            let setup = &self.setups[p];
            let n = setup.n_varyings;
            fragments.clear();
            varyings.clear();
            let mut end = start;
            while end < pixels.len() && end - start < BATCH {
                let i = pixels[end];
                let id = self.ids[i];
                if id < self.offsets[p] as u32 || id >= self.offsets[p + 1] as u32 {
                    break;
                }
                let tri = &setup.tris[id as usize - self.offsets[p]];
                let (vary, gradients) = setup.inputs(tri);
                let (fragment, _, weights) = fragment_at(tri, (i % w) as i32, (i / w) as i32, gradients);
                let at = varyings.len();
                varyings.resize(at + n, 0.0);
                interpolate(vary, n, weights, &mut varyings[at..]);
                fragments.push(fragment);
                end += 1;
            }
            self.passes[p].fragment.shade_batch(
                &fragments,
                &varyings,
                &mut out[start..end],
                &mut results[start..end],
            );
            start = end;
        }
    }

    /// Shades every pending sample into `vals`/`st`, counting it in `stats`.
    pub(super) fn shade_pending(
        &self,
        pending: &mut Pending,
        vals: &mut [[f32; 4]],
        st: &mut [u8],
        stats: &mut AdaptiveStats,
    ) {
        let n = pending.pixels.len();
        if n == 0 {
            return;
        }
        let mut out = vec![[0.0f32; 4]; n];
        let mut results = vec![FragmentResult::Keep; n];
        self.shade_many(&pending.pixels, &mut out, &mut results);
        for k in 0..n {
            let (entry, kind) = (pending.entries[k], pending.kinds[k]);
            match kind {
                REGULAR => stats.regular += 1,
                EDGE => stats.edge += 1,
                _ => stats.adaptive += 1,
            }
            if results[k] == FragmentResult::Discard {
                stats.discarded += 1;
                vals[entry] = [0.0; 4];
                st[entry] = kind | DISCARD_BIT;
            } else {
                vals[entry] = out[k];
                st[entry] = kind;
            }
        }
        pending.entries.clear();
        pending.pixels.clear();
        pending.kinds.clear();
    }

    /// Processes `lines` of `vals`/`st`: known entries (state ≠ UNKNOWN)
    /// are samples as they are; each run of one surface is sampled at its
    /// ends, at `regular(i)` positions and at edge pixels, then subdivided
    /// level by level; what is left between close samples is interpolated.
    pub(super) fn fill_lines(
        &self,
        lines: &[Line],
        vals: &mut [[f32; 4]],
        st: &mut [u8],
        regular: impl Fn(&Line, usize) -> bool,
    ) -> AdaptiveStats {
        let mut stats = AdaptiveStats::default();
        let mut pending = Pending::default();
        let mut segments = Vec::new();
        for (l, line) in lines.iter().enumerate() {
            self.first_samples(l, line, st, &regular, &mut pending, &mut segments);
        }
        self.shade_pending(&mut pending, vals, st, &mut stats);
        let (t, max_depth) = (self.settings.threshold, self.settings.max_depth);
        while !segments.is_empty() {
            let mut next = Vec::with_capacity(segments.len());
            for s in segments.drain(..) {
                if s.hi - s.lo <= 1 {
                    continue;
                }
                let line = &lines[s.line];
                let (va, vb) = (vals[line.at(s.lo)], vals[line.at(s.hi)]);
                if difference(va, vb) > t && s.depth < max_depth {
                    let mid = (s.lo + s.hi) / 2;
                    if st[line.at(mid)] == UNKNOWN {
                        pending.push(line.at(mid), line.pixel(mid), ADAPTIVE);
                    }
                    next.push(Segment { hi: mid, depth: s.depth + 1, ..s });
                    next.push(Segment { lo: mid, depth: s.depth + 1, ..s });
                } else {
                    let span = (s.hi - s.lo) as f32;
                    for i in s.lo + 1..s.hi {
                        let e = line.at(i);
                        if st[e] == UNKNOWN {
                            let f = (i - s.lo) as f32 / span;
                            vals[e] = [0, 1, 2, 3].map(|c| va[c] + (vb[c] - va[c]) * f);
                            st[e] = INTERPOLATED;
                            stats.interpolated += 1;
                        }
                    }
                }
            }
            self.shade_pending(&mut pending, vals, st, &mut stats);
            segments = next;
        }
        stats
    }

    /// The first samples of line `l` (pending) and the segments between
    /// consecutive samples of each run.
    fn first_samples(
        &self,
        l: usize,
        line: &Line,
        st: &[u8],
        regular: &impl Fn(&Line, usize) -> bool,
        pending: &mut Pending,
        segments: &mut Vec<Segment>,
    ) {
        let all = self.settings.threshold <= 0.0;
        let mut a = 0;
        while a < line.len {
            let key = self.keys[line.pixel(a)];
            if key == NONE {
                a += 1;
                continue;
            }
            let mut b = a;
            while b + 1 < line.len && self.keys[line.pixel(b + 1)] == key {
                b += 1;
            }
            let mut prev = None;
            for i in a..=b {
                let (e, px) = (line.at(i), line.pixel(i));
                let edge = self.edges[px];
                if !(st[e] != UNKNOWN || all || i == a || i == b || regular(line, i) || edge) {
                    continue;
                }
                if st[e] == UNKNOWN {
                    pending.push(e, px, if edge { EDGE } else { REGULAR });
                }
                if let Some(lo) = prev {
                    segments.push(Segment { line: l, lo, hi: i, depth: 0 });
                }
                prev = Some(i);
            }
            a = b + 1;
        }
    }

    /// Step 2: the regular rows (every `spacing`-th and the last), packed
    /// one after another in `reg_color`/`reg_state`, in parallel chunks.
    pub(super) fn scanlines(
        &self,
        regular_rows: &[usize],
        reg_color: &mut [[f32; 4]],
        reg_state: &mut [u8],
    ) -> AdaptiveStats {
        let (w, n) = (self.w, self.settings.spacing as usize);
        let per = regular_rows.len().div_ceil(4 * rayon::current_num_threads()).max(1);
        reg_color
            .par_chunks_mut(per * w)
            .zip(reg_state.par_chunks_mut(per * w))
            .enumerate()
            .map(|(chunk, (vals, st))| {
                let lines: Vec<Line> = (0..vals.len() / w)
                    .map(|r| Line {
                        base: r * w,
                        stride: 1,
                        len: w,
                        pixel0: regular_rows[chunk * per + r] * w,
                        pixel_stride: 1,
                    })
                    .collect();
                self.fill_lines(&lines, vals, st, |_, i| i % n == 0)
            })
            .reduce(AdaptiveStats::default, std::ops::Add::add)
    }

    /// Step 3: the columns between consecutive regular rows, from the
    /// regular rows' pixels at their ends, band by band in parallel.
    pub(super) fn columns(
        &self,
        regular_rows: &[usize],
        (reg_color, reg_state): (&[[f32; 4]], &[u8]),
        color: &mut [[f32; 4]],
        state: &mut [u8],
    ) -> AdaptiveStats {
        let w = self.w;
        super::between_rows(color, state, w, regular_rows)
            .into_par_iter()
            .map(|(k, c_band, s_band)| {
                let (top, bottom) = (regular_rows[k], regular_rows[k + 1]);
                let len = bottom - top + 1;
                let mut vals = vec![[0.0f32; 4]; len * w];
                let mut st = vec![UNKNOWN; len * w];
                vals[..w].copy_from_slice(&reg_color[k * w..(k + 1) * w]);
                st[..w].copy_from_slice(&reg_state[k * w..(k + 1) * w]);
                vals[(len - 1) * w..].copy_from_slice(&reg_color[(k + 1) * w..(k + 2) * w]);
                st[(len - 1) * w..].copy_from_slice(&reg_state[(k + 1) * w..(k + 2) * w]);
                let lines: Vec<Line> = (0..w)
                    .filter(|&x| (top..=bottom).any(|y| self.keys[y * w + x] != NONE))
                    .map(|x| Line { base: x, stride: w, len, pixel0: top * w + x, pixel_stride: w })
                    .collect();
                let stats =
                    self.fill_lines(&lines, &mut vals, &mut st, |line, i| i == 0 || i == line.len - 1);
                c_band.copy_from_slice(&vals[w..(len - 1) * w]);
                s_band.copy_from_slice(&st[w..(len - 1) * w]);
                stats
            })
            .reduce(AdaptiveStats::default, std::ops::Add::add)
    }
}

impl Ctx<'_> {
    /// Step 4, refinement (ours, beyond the paper): a feature that lies
    /// wholly between two regular rows and two samples of a column — the tip
    /// of a spot cone, a small highlight — is missed by both 1D passes but
    /// shows as a jump of more than the threshold between an interpolated
    /// pixel and its horizontal or vertical neighbour. Such pixels are
    /// shaded exactly, and the search continues from them (a flood fill
    /// that follows the feature, one wave of pixels at a time, each wave
    /// shaded in batches) until no interpolated pixel next to an exact one
    /// differs by more than the threshold.
    pub(super) fn refine(&self, color: &mut [[f32; 4]], state: &mut [u8], stats: &mut AdaptiveStats) {
        let (w, h, t) = (self.w, self.h, self.settings.threshold);
        let keys = self.keys;
        let mut wave: Vec<usize> = {
            let (color, state) = (&*color, &*state);
            (0..h)
                .into_par_iter()
                .flat_map_iter(|y| {
                    let mut found = Vec::new();
                    for x in 0..w {
                        let i = y * w + x;
                        if keys[i] == NONE {
                            continue;
                        }
                        let right = (x + 1 < w).then(|| i + 1);
                        let below = (y + 1 < h).then(|| i + w);
                        for j in [right, below].into_iter().flatten() {
                            if keys[j] == keys[i] && difference(color[i], color[j]) > t {
                                found.extend([i, j].into_iter().filter(|&k| state[k] == INTERPOLATED));
                            }
                        }
                    }
                    found
                })
                .collect()
        };
        while !wave.is_empty() {
            wave.par_sort_unstable();
            wave.dedup();
            self.reshade(&wave, color, state, stats);
            let (color, state) = (&*color, &*state);
            wave = wave
                .par_iter()
                .flat_map_iter(|&i| {
                    let (x, y) = (i % w, i / w);
                    [
                        (x > 0).then(|| i - 1),
                        (x + 1 < w).then(|| i + 1),
                        (y > 0).then(|| i - w),
                        (y + 1 < h).then(|| i + w),
                    ]
                    .into_iter()
                    .flatten()
                    .filter(move |&j| {
                        state[j] == INTERPOLATED && keys[j] == keys[i] && difference(color[i], color[j]) > t
                    })
                })
                .collect();
        }
    }

    /// Shades the interpolated pixels `wave` exactly, in parallel batches.
    fn reshade(&self, wave: &[usize], color: &mut [[f32; 4]], state: &mut [u8], stats: &mut AdaptiveStats) {
        const CHUNK: usize = 8 * BATCH;
        let mut out = vec![[0.0f32; 4]; wave.len()];
        let mut results = vec![FragmentResult::Keep; wave.len()];
        wave.par_chunks(CHUNK)
            .zip(out.par_chunks_mut(CHUNK))
            .zip(results.par_chunks_mut(CHUNK))
            .for_each(|((pixels, out), results)| self.shade_many(pixels, out, results));
        for ((&i, colour), result) in wave.iter().zip(out).zip(results) {
            stats.interpolated -= 1;
            stats.adaptive += 1;
            if result == FragmentResult::Discard {
                stats.discarded += 1;
                color[i] = [0.0; 4];
                state[i] = ADAPTIVE | DISCARD_BIT;
            } else {
                color[i] = colour;
                state[i] = ADAPTIVE;
            }
        }
    }
}
