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

use super::visibility::{EMPTY, PLAIN};
use super::write::BandOut;
use super::{AdaptiveStats, Ctx, ADAPTIVE, DISCARD_BIT, EDGE, INTERPOLATED, NONE, REGULAR, UNKNOWN};
use crate::renderer::raster::PassSetup;
use crate::renderer::tile::{fragment_at, interpolate};
use crate::renderer::{Fragment, FragmentResult, BATCH};

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

/// Refinement waves of fewer pixels are grown and shaded on the calling thread.
const SERIAL_WAVE: usize = 4096;

thread_local! {
    /// A band's colours where the frame has no buffer for them ([`Ctx::columns`]),
    /// kept for the next band on this thread.
    static BAND: std::cell::Cell<Vec<[f32; 4]>> = const { std::cell::Cell::new(Vec::new()) };
}

/// A frame's colours by pixel: the draw's buffer, or the target's texels
/// where the bands wrote through ([`super::write::TileColors`]).
pub(super) trait Colors: Sync {
    fn get(&self, i: usize) -> [f32; 4];
    fn set(&mut self, i: usize, c: [f32; 4]);
}

impl Colors for [[f32; 4]] {
    #[inline(always)]
    fn get(&self, i: usize) -> [f32; 4] {
        self[i]
    }
    #[inline(always)]
    fn set(&mut self, i: usize, c: [f32; 4]) {
        self[i] = c;
    }
}

/// The largest per-channel difference between two colours (`f32::max`
/// passes over a NaN channel).
#[cfg(test)]
fn difference(a: [f32; 4], b: [f32; 4]) -> f32 {
    (0..4).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max)
}

/// Whether two colours differ by more than `t` in some channel:
/// `difference(a, b) > t`, without the maximum's chain (a NaN channel
/// counts in neither: `f32::max` passes over it, `NaN > t` is false).
#[inline(always)]
pub(super) fn differs(a: [f32; 4], b: [f32; 4], t: f32) -> bool {
    ((a[0] - b[0]).abs() > t)
        | ((a[1] - b[1]).abs() > t)
        | ((a[2] - b[2]).abs() > t)
        | ((a[3] - b[3]).abs() > t)
}

impl Ctx<'_> {
    /// Shades the visible primitive at each of `pixels` (frame indices),
    /// in batches of at most [`BATCH`] fragments of one pass; in a fused
    /// draw each batch is then shaded by every follower and added
    /// ([`Ctx::add_followers`]).
    pub(super) fn shade_many(&self, pixels: &[usize], out: &mut [[f32; 4]], results: &mut [FragmentResult]) {
        let mut fragments = Vec::with_capacity(BATCH);
        let mut varyings = Vec::new();
        let mut start = 0;
        while start < pixels.len() {
            let p = self.pass_of(self.ids[pixels[start]]);
            let (lo, hi) = (self.offsets[p] as u32, self.offsets[p + 1] as u32);
            let mut end = start + 1;
            while end < pixels.len() && end - start < BATCH && (lo..hi).contains(&self.ids[pixels[end]]) {
                end += 1;
            }
            let batch = &pixels[start..end];
            self.gather(&self.setups[p], p, batch, &mut fragments, &mut varyings);
            let (out, results) = (&mut out[start..end], &mut results[start..end]);
            self.passes[p].fragment.shade_batch(&fragments, &varyings, out, results);
            if !self.followers.is_empty() {
                self.add_followers(p, batch, out, &mut fragments, &mut varyings);
            }
            start = end;
        }
    }

    /// The fragments and interpolated varyings of pass `p` (set up as
    /// `setup`) at `pixels`, all of which show a triangle of that pass.
    pub(super) fn gather<'s>(
        &self,
        setup: &'s PassSetup,
        p: usize,
        pixels: &[usize],
        fragments: &mut Vec<Fragment<'s>>,
        varyings: &mut Vec<f32>,
    ) {
        let (w, n) = (self.w, setup.n_varyings);
        fragments.clear();
        varyings.clear();
        for &i in pixels {
            let tri = &setup.tris[self.ids[i] as usize - self.offsets[p]];
            let (vary, gradients) = setup.inputs(tri);
            let (fragment, _, weights) = fragment_at(tri, (i % w) as i32, (i / w) as i32, gradients);
            let at = varyings.len();
            varyings.resize(at + n, 0.0);
            interpolate(vary, n, weights, &mut varyings[at..]);
            fragments.push(fragment);
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
                if differs(va, vb, t) && s.depth < max_depth {
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

    /// Step 3: the columns between consecutive regular rows, in place in
    /// the frame's `color`/`state`, whose regular rows are known (only
    /// read here). Band k is rows k·n ..= min((k + 1)·n, h − 1) (n the
    /// spacing): bands k and k + 1 share a row, so the even bands run in
    /// parallel, then the odd ones, each in its own chunk of 2n rows.
    /// Where `outs` has a band's rows of the target ([`Ctx::band_outputs`]),
    /// the band is written there as soon as it is done (`depth`: the
    /// frame's); without the frame's `color`, each band's colours are then
    /// found in a buffer of the band's own, from its two regular rows in
    /// `reg_color` (packed), and are only written to the target.
    pub(super) fn columns(
        &self,
        regular_rows: &[usize],
        (mut color, reg_color): (Option<&mut [[f32; 4]]>, &[[f32; 4]]),
        state: &mut [u8],
        mut outs: Vec<Option<BandOut>>,
        depth: &[f32],
    ) -> (AdaptiveStats, Option<Vec<usize>>) {
        let n = self.settings.spacing as usize;
        let bands = regular_rows.len().saturating_sub(1);
        let chunk = 2 * n * self.w;
        let mut stats = AdaptiveStats::default();
        let mut wave = Vec::new();
        let join = |mut a: (AdaptiveStats, Vec<usize>), mut b: (AdaptiveStats, Vec<usize>)| {
            a.1.append(&mut b.1);
            (a.0 + b.0, a.1)
        };
        outs.resize_with(bands, || None);
        let w = self.w;
        for parity in 0..2 {
            let skip = (parity * n * w).min(state.len());
            // Band 2j + parity's rows of the target, if written here.
            let mine: Vec<Option<BandOut>> =
                outs.iter_mut().skip(parity).step_by(2).map(Option::take).collect();
            let frame: Vec<Option<&mut [[f32; 4]]>> = match color.as_deref_mut() {
                Some(c) => c[skip..].chunks_mut(chunk).map(Some).collect(),
                None => mine.iter().map(|_| None).collect(),
            };
            let (s, mut found) = state[skip..]
                .par_chunks_mut(chunk)
                .zip(frame)
                .zip(mine)
                .enumerate()
                .map(|(j, ((s, c), out))| {
                    let k = 2 * j + parity;
                    let rows = (regular_rows[k], regular_rows[k + 1]);
                    debug_assert_eq!(rows.0, k * n, "regular rows are every n-th");
                    let mut own = Vec::new();
                    let c = match c {
                        Some(c) => c,
                        None => {
                            // The band's two regular rows, the rest found below.
                            let len = (rows.1 - rows.0 + 1) * w;
                            own = BAND.with(|b| b.take());
                            if own.len() < len {
                                own.resize(len, [0.0; 4]);
                            }
                            own[..w].copy_from_slice(&reg_color[k * w..(k + 1) * w]);
                            own[len - w..len].copy_from_slice(&reg_color[(k + 1) * w..(k + 2) * w]);
                            &mut own[..len]
                        }
                    };
                    let stats = self.band(k, rows, c, s);
                    let mut found = Vec::new();
                    if self.settings.threshold > 0.0 {
                        self.band_wave(rows, c, s, &mut found);
                    }
                    if let Some(mut out) = out {
                        self.write_band(&mut out, rows.0, c, s, depth);
                    }
                    if !own.is_empty() {
                        BAND.with(|b| b.set(own));
                    }
                    (stats, found)
                })
                .reduce(|| (AdaptiveStats::default(), Vec::new()), join);
            stats = stats + s;
            wave.append(&mut found);
        }
        // Without bands (one row) the regular rows are the whole frame.
        (stats, (bands > 0).then_some(wave))
    }

    /// The refinement's first wave ([`Ctx::first_wave`]) among the pairs
    /// of band `top..=bottom` (`c`/`s` start at row `top`, its columns
    /// done) whose upper or left pixel lies in rows `top..bottom`, and in
    /// row `bottom` too where it is the frame's last: every pair of the
    /// frame is then seen by one band, while the band is in the cache.
    fn band_wave(&self, (top, bottom): (usize, usize), c: &[[f32; 4]], s: &[u8], found: &mut Vec<usize>) {
        let (w, t, keys) = (self.w, self.settings.threshold, self.keys);
        let last = if bottom == self.h - 1 { bottom } else { bottom - 1 };
        let mut hits = Vec::new();
        for y in top..=last {
            let row =
                WaveRow { w, span: self.spans[y], local: (y - top) * w, frame: y * w, below: y < bottom };
            wave_pairs(row, (c, s, keys), t, &mut hits, found);
        }
    }

    /// Band k, rows `top..=bottom` (`c`/`s` start at row `top`): a plain
    /// column ([`PLAIN`]) whose ends differ by at most the threshold is one
    /// segment the subdivision would interpolate whole — it is, row after
    /// row over all such columns at once, with the subdivision's formula —
    /// and every other column that shows something goes through
    /// [`Ctx::fill_lines`].
    fn band(
        &self,
        k: usize,
        (top, bottom): (usize, usize),
        c: &mut [[f32; 4]],
        s: &mut [u8],
    ) -> AdaptiveStats {
        let (w, t) = (self.w, self.settings.threshold);
        let len = bottom - top + 1;
        let kinds = &self.columns[k * w..(k + 1) * w];
        let bottom_row = (len - 1) * w;
        // A plain column is interpolated when the subdivision would not split it.
        let split = |x: usize| differs(c[x], c[bottom_row + x], t) && self.settings.max_depth > 0;
        let direct: Vec<bool> = (0..w).map(|x| t > 0.0 && kinds[x] == PLAIN && !split(x)).collect();
        let lines: Vec<Line> = (0..w)
            .filter(|&x| kinds[x] != EMPTY && !direct[x])
            .map(|x| Line { base: x, stride: w, len, pixel0: top * w + x, pixel_stride: w })
            .collect();
        let mut stats = self.fill_lines(&lines, c, s, |line, i| i == 0 || i == line.len - 1);
        let runs = runs_of(&direct);
        let n_direct: usize = runs.iter().map(|&(a, b)| b - a).sum();
        stats.interpolated += (n_direct * len.saturating_sub(2)) as u64;
        let span = (len - 1) as f32;
        let (head, rest) = c.split_at_mut(w);
        let (rows, tail) = rest.split_at_mut(bottom_row - w);
        let (first, last) = (&*head, &tail[..w]);
        for (r, row) in rows.chunks_mut(w).enumerate() {
            let f = (r + 1) as f32 / span;
            for &(a, b) in &runs {
                for ((v, va), vb) in row[a..b].iter_mut().zip(&first[a..b]).zip(&last[a..b]) {
                    *v = [0, 1, 2, 3].map(|ch| va[ch] + (vb[ch] - va[ch]) * f);
                }
                s[(r + 1) * w + a..(r + 1) * w + b].fill(INTERPOLATED);
            }
        }
        stats
    }
}

/// Whether two lists hold the same pixels (in any order, any number of times).
fn same_pixels(a: &[usize], b: &[usize]) -> bool {
    let set = |v: &[usize]| v.iter().copied().collect::<std::collections::BTreeSet<usize>>();
    set(a) == set(b)
}

/// The runs `a..b` of consecutive `true`s.
fn runs_of(flags: &[bool]) -> Vec<(usize, usize)> {
    let mut runs = Vec::new();
    let mut x = 0;
    while x < flags.len() {
        if flags[x] {
            let a = x;
            while x < flags.len() && flags[x] {
                x += 1;
            }
            runs.push((a, x));
        } else {
            x += 1;
        }
    }
    runs
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
    /// `first` is the first wave where the columns found it ([`Ctx::columns`]).
    pub(super) fn refine<C: Colors + ?Sized>(
        &self,
        color: &mut C,
        state: &mut [u8],
        stats: &mut AdaptiveStats,
        first: Option<Vec<usize>>,
    ) {
        let (w, h, t) = (self.w, self.h, self.settings.threshold);
        let keys = self.keys;
        let mut wave = match first {
            Some(wave) => {
                // The bands' pairs are the whole frame's, every draw of the tests.
                debug_assert!(
                    same_pixels(&wave, &self.first_wave(color, state)),
                    "the bands' first wave is not the frame's"
                );
                wave
            }
            None => self.first_wave(color, state),
        };
        while !wave.is_empty() {
            // A small wave runs on this thread: handing it to the pool and
            // back costs more than it does (the feature's tip grows by a
            // few pixels a wave).
            let parallel = wave.len() >= SERIAL_WAVE;
            if parallel {
                wave.par_sort_unstable();
            } else {
                wave.sort_unstable();
            }
            wave.dedup();
            self.reshade(&wave, color, state, stats);
            let (color, state) = (&*color, &*state);
            let next = |&i: &usize| {
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
                    state[j] == INTERPOLATED && keys[j] == keys[i] && differs(color.get(i), color.get(j), t)
                })
            };
            wave = if parallel {
                wave.par_iter().flat_map_iter(next).collect()
            } else {
                wave.iter().flat_map(next).collect()
            };
        }
    }

    /// The refinement's first wave: the interpolated pixels of every pair
    /// of horizontal or vertical neighbours on one surface whose colours
    /// differ by more than the threshold, rows in parallel, each over its
    /// covered span only.
    fn first_wave<C: Colors + ?Sized>(&self, color: &C, state: &[u8]) -> Vec<usize> {
        let (w, h, t, keys) = (self.w, self.h, self.settings.threshold, self.keys);
        (0..h)
            .into_par_iter()
            .with_min_len(8)
            .flat_map_iter(|y| {
                let mut found = Vec::new();
                let (x0, x1) = self.spans[y];
                for i in y * w + x0..y * w + x1 {
                    let x = i - y * w;
                    let right = (x + 1 < w).then(|| i + 1);
                    let below = (y + 1 < h).then(|| i + w);
                    for j in [right, below].into_iter().flatten() {
                        if (state[i] == INTERPOLATED || state[j] == INTERPOLATED)
                            && keys[i] != NONE
                            && keys[j] == keys[i]
                            && differs(color.get(i), color.get(j), t)
                        {
                            found.extend([i, j].into_iter().filter(|&k| state[k] == INTERPOLATED));
                        }
                    }
                }
                found
            })
            .collect()
    }

    /// Shades the interpolated pixels `wave` exactly, in parallel batches.
    fn reshade<C: Colors + ?Sized>(
        &self,
        wave: &[usize],
        color: &mut C,
        state: &mut [u8],
        stats: &mut AdaptiveStats,
    ) {
        const CHUNK: usize = 8 * BATCH;
        let mut out = vec![[0.0f32; 4]; wave.len()];
        let mut results = vec![FragmentResult::Keep; wave.len()];
        if wave.len() < SERIAL_WAVE {
            self.shade_many(wave, &mut out, &mut results);
        } else {
            wave.par_chunks(CHUNK)
                .zip(out.par_chunks_mut(CHUNK))
                .zip(results.par_chunks_mut(CHUNK))
                .for_each(|((pixels, out), results)| self.shade_many(pixels, out, results));
        }
        for ((&i, colour), result) in wave.iter().zip(out).zip(results) {
            stats.interpolated -= 1;
            stats.adaptive += 1;
            if result == FragmentResult::Discard {
                stats.discarded += 1;
                color.set(i, [0.0; 4]);
                state[i] = ADAPTIVE | DISCARD_BIT;
            } else {
                color.set(i, colour);
                state[i] = ADAPTIVE;
            }
        }
    }
}

/// One row of a band for [`Ctx::band_wave`]: the frame's width, the row's
/// covered span, where the row starts in the band's buffers (`local`) and
/// in the frame (`frame`), and whether the band has the row below.
#[derive(Clone, Copy, Debug)]
struct WaveRow {
    w: usize,
    span: (usize, usize),
    local: usize,
    frame: usize,
    below: bool,
}

/// Whether pixels a and b are a pair of the refinement's first wave: one
/// of them interpolated, both on one surface, colours beyond the
/// threshold. Without branches, so that a row's pairs are tested in one
/// straight loop.
#[inline(always)]
fn pair_hit(a: ([f32; 4], u8, u32), b: ([f32; 4], u8, u32), t: f32) -> u8 {
    u8::from(
        ((a.1 == INTERPOLATED) | (b.1 == INTERPOLATED)) & (a.2 != NONE) & (a.2 == b.2) & differs(a.0, b.0, t),
    )
}

/// Sets `bit` in `hits[x]` where pixel x of the `a` slices and of the `b`
/// slices are a first-wave pair ([`pair_hit`]): with AVX2 where the CPU
/// has it ([`mark_pairs_avx2`]), else as built.
fn mark_pairs(
    hits: &mut [u8],
    bit: u8,
    a: (&[[f32; 4]], &[u8], &[u32]),
    b: (&[[f32; 4]], &[u8], &[u32]),
    t: f32,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has the feature the function is compiled for.
        return unsafe { mark_pairs_avx2(hits, bit, a, b, t) };
    }
    mark_pairs_body(hits, bit, a, b, t)
}

/// [`mark_pairs`] eight pixels at a time: two pixels' colour differences
/// in each 8-lane subtraction, their absolute values (the sign bit
/// cleared, as `f32::abs`) compared with `t` by an ordered comparison (a
/// NaN channel counts in neither, as in [`differs`]); the four channels'
/// results of each pixel packed into one 32-bit lane (a pixel differs
/// where that lane is not zero), the surface conditions of [`pair_hit`]
/// on the eight pixels' keys and states as lanes; the few hits are then
/// set one by one. The same flags as [`mark_pairs_body`] (the lanes past
/// a multiple of eight through it). The compiler's own vector code for
/// that loop transposed four pixels' colours into channel vectors first,
/// shuffles that cost more than the arithmetic.
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn mark_pairs_avx2(
    hits: &mut [u8],
    bit: u8,
    a: (&[[f32; 4]], &[u8], &[u32]),
    b: (&[[f32; 4]], &[u8], &[u32]),
    t: f32,
) {
    use std::arch::x86_64::*;
    let n = hits.len();
    let (ca, sa, ka, cb, sb, kb) = (&a.0[..n], &a.1[..n], &a.2[..n], &b.0[..n], &b.1[..n], &b.2[..n]);
    let magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
    let tv = _mm256_set1_ps(t);
    let zero = _mm256_setzero_si256();
    // The packed lanes hold pixels 0, 2, 4, 6, 1, 3, 5, 7: back in order.
    let order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
    let none = _mm256_set1_epi32(NONE as i32);
    let interpolated = _mm256_set1_epi32(INTERPOLATED as i32);
    let mut x = 0;
    while x + 8 <= n {
        // SAFETY (every load): pixels x..x + 8 are within the n of each slice.
        let (pa, pb) = (ca.as_ptr().add(x) as *const f32, cb.as_ptr().add(x) as *const f32);
        let mut beyond = [zero; 4];
        for (j, c) in beyond.iter_mut().enumerate() {
            let d = _mm256_sub_ps(_mm256_loadu_ps(pa.add(8 * j)), _mm256_loadu_ps(pb.add(8 * j)));
            *c = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_and_ps(d, magnitude), tv));
        }
        // Each channel's −1 or 0 saturated to a byte: a pixel's four in one lane.
        let packed = _mm256_packs_epi16(
            _mm256_packs_epi32(beyond[0], beyond[1]),
            _mm256_packs_epi32(beyond[2], beyond[3]),
        );
        let alike = _mm256_permutevar8x32_epi32(_mm256_cmpeq_epi32(packed, zero), order);
        let (kav, kbv) = (
            _mm256_loadu_si256(ka.as_ptr().add(x) as *const __m256i),
            _mm256_loadu_si256(kb.as_ptr().add(x) as *const __m256i),
        );
        let (sav, sbv) = (
            _mm256_cvtepu8_epi32(_mm_loadl_epi64(sa.as_ptr().add(x) as *const __m128i)),
            _mm256_cvtepu8_epi32(_mm_loadl_epi64(sb.as_ptr().add(x) as *const __m128i)),
        );
        let either =
            _mm256_or_si256(_mm256_cmpeq_epi32(sav, interpolated), _mm256_cmpeq_epi32(sbv, interpolated));
        let surface = _mm256_and_si256(either, _mm256_cmpeq_epi32(kav, kbv));
        let miss = _mm256_or_si256(_mm256_cmpeq_epi32(kav, none), alike);
        let mut m = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_andnot_si256(miss, surface))) as u32;
        while m != 0 {
            hits[x + m.trailing_zeros() as usize] |= bit;
            m &= m - 1;
        }
        x += 8;
    }
    mark_pairs_body(&mut hits[x..], bit, (&ca[x..], &sa[x..], &ka[x..]), (&cb[x..], &sb[x..], &kb[x..]), t);
}

#[inline(always)]
fn mark_pairs_body(
    hits: &mut [u8],
    bit: u8,
    a: (&[[f32; 4]], &[u8], &[u32]),
    b: (&[[f32; 4]], &[u8], &[u32]),
    t: f32,
) {
    let n = hits.len();
    let (ca, sa, ka, cb, sb, kb) = (&a.0[..n], &a.1[..n], &a.2[..n], &b.0[..n], &b.1[..n], &b.2[..n]);
    for x in 0..n {
        hits[x] |= bit * pair_hit((ca[x], sa[x], ka[x]), (cb[x], sb[x], kb[x]), t);
    }
}

/// The first wave's pixels of one row's pairs (pixel and right
/// neighbour, pixel and the one below where the band has it), in the
/// order of the per-pixel loop it replaces (`tests::wave_pairs_reference`):
/// every pair is first tested in straight loops over the row, and only the
/// few pairs that differ are then looked at one by one.
fn wave_pairs(
    row: WaveRow,
    (c, s, keys): (&[[f32; 4]], &[u8], &[u32]),
    t: f32,
    hits: &mut Vec<u8>,
    found: &mut Vec<usize>,
) {
    let WaveRow { w, span: (x0, x1), local: l0, frame: i0, below } = row;
    if x0 >= x1 {
        return;
    }
    hits.clear();
    hits.resize(x1 - x0, 0);
    let (l, i) = (l0 + x0, i0 + x0);
    let here = (&c[l..], &s[l..], &keys[i..]);
    // Pixels x0..xr have a right neighbour.
    let xr = x1.min(w - 1);
    if x0 < xr {
        mark_pairs(&mut hits[..xr - x0], 1, here, (&c[l + 1..], &s[l + 1..], &keys[i + 1..]), t);
    }
    if below {
        mark_pairs(hits, 2, here, (&c[l + w..], &s[l + w..], &keys[i + w..]), t);
    }
    for (x, &h) in (x0..x1).zip(hits.iter()) {
        if h == 0 {
            continue;
        }
        let (l, i) = (l0 + x, i0 + x);
        for (bit, lj, j) in [(1, l + 1, i + 1), (2, l + w, i + w)] {
            if h & bit != 0 {
                found.extend(
                    [(l, i), (lj, j)].into_iter().filter(|&(lk, _)| s[lk] == INTERPOLATED).map(|(_, k)| k),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{difference, differs, wave_pairs, WaveRow, INTERPOLATED, NONE};

    /// The per-pixel loop of the first wave over one row of a band, as it
    /// was before [`wave_pairs`] (kept as the reference it must equal).
    fn wave_pairs_reference(row: WaveRow, c: &[[f32; 4]], s: &[u8], keys: &[u32], t: f32) -> Vec<usize> {
        let WaveRow { w, span: (x0, x1), local, frame, below } = row;
        let mut found = Vec::new();
        for x in x0..x1 {
            let (l, i) = (local + x, frame + x);
            let key = keys[i];
            if key == NONE {
                continue;
            }
            let right = (x + 1 < w).then_some((l + 1, i + 1));
            for (lj, j) in [right, below.then_some((l + w, i + w))].into_iter().flatten() {
                if (s[l] == INTERPOLATED || s[lj] == INTERPOLATED)
                    && keys[j] == key
                    && differs(c[l], c[lj], t)
                {
                    found.extend(
                        [(l, i), (lj, j)]
                            .into_iter()
                            .filter(|&(lk, _)| s[lk] == INTERPOLATED)
                            .map(|(_, k)| k),
                    );
                }
            }
        }
        found
    }

    /// The branch-free row loop finds the same pixels, in the same order,
    /// as the per-pixel loop, on generated bands: widths 1 to 40, every
    /// span, surfaces with and without gaps, interpolated and exact
    /// pixels, colours near the threshold and NaN.
    #[test]
    fn wave_pairs_equal_the_per_pixel_loop_bit_for_bit() {
        let mut seed = 0x2545_f491_u64;
        let mut next = move |n: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % n) as usize
        };
        let colours = [0.0, 0.05, 0.085, 0.1, 0.2, 1.0, f32::NAN];
        let (mut hits, mut found, mut rows, mut nonempty) = (Vec::new(), Vec::new(), 0, 0);
        for round in 0..400 {
            let w = 1 + round % 40;
            let h = 2 + next(3);
            let (top, frame_rows) = (next(3), h + 3);
            let c: Vec<[f32; 4]> =
                (0..h * w).map(|_| [0; 4].map(|_: i32| colours[next(colours.len() as u64)])).collect();
            let s: Vec<u8> = (0..h * w).map(|_| if next(3) == 0 { 1 } else { INTERPOLATED }).collect();
            let keys: Vec<u32> = (0..frame_rows * w).map(|_| [NONE, 0, 1, 1, 1][next(5)]).collect();
            let t = [0.0, 0.085, 0.5][next(3)];
            for y in 0..h {
                let x0 = next(w as u64 + 1);
                let x1 = x0 + next((w - x0) as u64 + 1);
                let row = WaveRow { w, span: (x0, x1), local: y * w, frame: (top + y) * w, below: y + 1 < h };
                found.clear();
                wave_pairs(row, (&c, &s, &keys), t, &mut hits, &mut found);
                assert_eq!(found, wave_pairs_reference(row, &c, &s, &keys, t), "round {round} row {y}");
                rows += 1;
                nonempty += usize::from(!found.is_empty());
            }
        }
        assert!(rows > 1000 && nonempty > 200, "{rows} rows, {nonempty} with pairs");
    }

    /// `differs` is `difference(a, b) > t` for every threshold the draw
    /// compares against (t ≥ 0), with NaN, infinite and signed-zero channels.
    #[test]
    fn differs_is_the_largest_channel_difference_above_the_threshold() {
        let values =
            [0.0, -0.0, 0.085, 0.1, 0.5, -0.3, 1.0, 1e-9, f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
        let mut n = 0;
        for (i, &a) in values.iter().enumerate() {
            for &b in &values {
                for t in [0.0, 0.085, 0.5, 2.0] {
                    let x = [a, 0.2, b, 0.0];
                    let y = [b, 0.2 + t, a, f32::NAN];
                    let z = [values[(i + 3) % values.len()], a, b, 0.1];
                    for (p, q) in [(x, y), (y, x), (x, z), (z, y)] {
                        assert_eq!(differs(p, q, t), difference(p, q) > t, "{p:?} {q:?} {t}");
                        n += 1;
                    }
                }
            }
        }
        assert!(n > 1000);
    }
}
