//! Statements that render into a texture a later statement samples:
//! texture shading `T δu x ← …` (Pipeline Grammar, eq. (13): the mesh
//! unwrapped over its texture coordinates), a texture computed over its
//! own texels `T δu ← …`, and a frame rendered into a texture
//! (`T δπx ← …`, `T xs ← …`; render-to-texture).
//!
//! Each is evaluated into its own grid — a [`TEXEL_GRID`]²
//! grid over texels (docs/pass-plan.md, the planner's one decision of a
//! target's size), the frame's size otherwise — cleared to 0, every texel
//! stored as the declared format stores it (8 bits as k/255, clamped),
//! and later lookups sample it with this module's own GL §3.8 sampling:
//! the declared filter and wrap, and where the declaration says `mipmap`
//! a chain box-filtered from it (each level the mean of 2×2 texels of the
//! one above, docs/language.md "texture").
//!
//! Over texels, the triangles are drawn in order with no depth test and no
//! culling: where two overlap in texture space, the last one drawn keeps
//! the texel, as a pass in texture space without depth leaves it.

use std::collections::HashMap;

use super::geometry::{Coverage, View};
use super::program::{At, Evaluator, Tex};
use super::sampling::{mip_chain, Cube, Image, Level, Volume};
use super::Unsupported;
use crate::ir::{Expr, Frequency, Handle, Statement};
use crate::parser::ast::TextureKind;
use crate::textures::{TexelFormat, Wrap};

/// The side of the grid a texture rendered over its texels holds: 256,
/// docs/pass-plan.md's size for a target drawn in texture space (the
/// planner's `pipeline::RENDERED_TEXTURE_SIZE`, which this reference may
/// not import: `tests/three_way.rs` checks that the two are one).
pub const TEXEL_GRID: u32 = 256;

/// Runs `st` into texture `id`; `levels` holds each rendered texture's
/// base level between statements.
pub fn statement(
    ev: &mut Evaluator,
    st: &Statement,
    id: usize,
    levels: &mut HashMap<(usize, usize), Level>,
) -> Result<(), Unsupported> {
    let decl = &ev.m.textures[id];
    let volume = decl.kind == TextureKind::Tex3d;
    if volume && !over_texels(st) {
        return Err(Unsupported::new("a 3-D texture rendered other than over its texels"));
    }
    let cube = decl.kind == TextureKind::Cube;
    if cube && !over_texels(st) {
        return Err(Unsupported::new("a frame rendered into a cube map (its faces are square texel grids)"));
    }
    // A bundle (a fat texel, Pipeline Grammar eq. (5), (15)): each member
    // its own image; any other value: one.
    let members: Vec<Handle<Expr>> = match (&ev.m.exprs[st.value], ev.m.info(st.value).ty) {
        (Expr::Bundle(members), _) => members.clone(),
        (_, crate::ir::Ty::Bundle(_)) => {
            return Err(Unsupported::new("a fat texture written with a value other than a bundle"))
        }
        _ => vec![st.value],
    };
    let fat = matches!(ev.m.exprs[st.value], Expr::Bundle(_));
    if (volume || cube) && fat {
        return Err(Unsupported::new("a fat 3-D or cube texture"));
    }
    let format = super::textures::store_format(decl.format);
    let sampling = decl.sampling;
    let samples = raster(ev, st)?;
    let size = raster_size(ev, st);
    let mut writes = Vec::with_capacity(samples.len());
    for (i, at) in samples {
        let mut memo = HashMap::new();
        let mut texel = Vec::with_capacity(members.len());
        for &h in &members {
            let Some(v) = ev.value(h, at, 0, &mut memo)? else { break };
            let v = match ev.m.info(h).ty.width() {
                1 => [v[0], v[0], v[0], 1.0],
                2 => [v[0], v[1], 0.0, 1.0],
                3 => [v[0], v[1], v[2], 1.0],
                _ => v,
            };
            texel.push(v.map(|c| store(format, c)));
        }
        if texel.len() == members.len() {
            writes.push((i, texel));
        }
    }
    let mut images = Vec::with_capacity(members.len());
    for k in 0..members.len() {
        let level = levels.entry((id, k)).or_insert_with(|| Level {
            width: size.0,
            height: size.1,
            texels: vec![[0.0; 4]; (size.0 * size.1) as usize],
        });
        if (level.width, level.height) != size {
            return Err(Unsupported::new("statements rendering one texture at two sizes"));
        }
        for (i, texel) in &writes {
            level.texels[*i] = texel[k];
        }
        if volume {
            ev.textures[id] = Tex::Volume(volume_of(level, sampling.wrap, sampling.filter));
            return Ok(());
        }
        if cube {
            // Six faces, each the grid the statement rendered over its
            // texels at the face's (s, t) (GL 1.3 §3.8.6: a cube map is six
            // 2-D images), sampled at level 0, each face clamped.
            let face =
                Image { levels: vec![level.clone()], wrap: Wrap::ClampToEdge, filter: sampling.filter };
            ev.textures[id] = Tex::Cube(Cube { faces: vec![face; 6] });
            return Ok(());
        }
        let base = level.clone();
        let chain = if sampling.mipmap { mip_chain(base, format) } else { vec![base] };
        images.push(Image { levels: chain, wrap: sampling.wrap, filter: sampling.filter });
    }
    ev.textures[id] = match images.pop() {
        Some(image) if !fat => Tex::Flat(image),
        Some(last) => {
            images.push(last);
            Tex::Fat(images)
        }
        None => return Err(Unsupported::new("an empty bundle")),
    };
    Ok(())
}

/// The texels along each axis of a 3-D texture its statements render
/// (docs/solid-textures.md): 64 × 64 × 16.
pub const VOLUME: [u32; 3] = [64, 64, 16];

/// How many slices a row of the rendered grid holds: the 16 slices of a
/// volume lie 4 × 4 over the [`TEXEL_GRID`]² texels its statements render
/// (docs/solid-textures.md), slice z at column z mod 4 and row ⌊z/4⌋ of
/// slices, its texel (x, y) at (x, y) within.
pub const SLICES_PER_ROW: u32 = 4;

/// The volume the statements rendered into `grid` (GL 1.2's `TEXTURE_3D`
/// of [`VOLUME`] texels, one level).
fn volume_of(grid: &Level, wrap: Wrap, filter: crate::textures::Filter) -> Volume {
    let [w, h, d] = VOLUME;
    let mut texels = Vec::with_capacity((w * h * d) as usize);
    for z in 0..d {
        let (col, row) = (z % SLICES_PER_ROW, z / SLICES_PER_ROW);
        for y in 0..h {
            for x in 0..w {
                let (gx, gy) = (col * w + x, row * h + y);
                texels.push(grid.texels.get((gy * grid.width + gx) as usize).copied().unwrap_or([0.0; 4]));
            }
        }
    }
    Volume { width: w, height: h, depth: d, texels, wrap, filter }
}

/// Whether `st` draws over texels (its size the rendered-texture grid).
fn over_texels(st: &Statement) -> bool {
    st.freq == Frequency::Texel
}

fn raster_size(ev: &Evaluator, st: &Statement) -> (u32, u32) {
    if over_texels(st) {
        (TEXEL_GRID, TEXEL_GRID)
    } else {
        (ev.coverage.width, ev.coverage.height)
    }
}

/// The samples of the statement's index, by their place in the raster.
fn raster(ev: &Evaluator, st: &Statement) -> Result<Vec<(usize, At)>, Unsupported> {
    if !over_texels(st) {
        return super::samples(ev, st);
    }
    let n = TEXEL_GRID;
    let m = ev.m;
    let through_mesh = m.reachable(&[st.index]).iter().any(|h| m.info(*h).freq == Frequency::Vertex);
    if through_mesh {
        let c = Coverage::find_in(&ev.world, n, n, View::Texels);
        let samples = c.fragments.iter().enumerate().filter_map(|(i, f)| f.map(|f| (i, At::Fragment(f))));
        return Ok(samples.collect());
    }
    let centre = |k: u32| (f64::from(k) + 0.5) / f64::from(n);
    let samples =
        (0..n).flat_map(|y| (0..n).map(move |x| ((y * n + x) as usize, At::Texel([centre(x), centre(y)]))));
    Ok(samples.collect())
}

/// A texel as `format` stores it.
fn store(format: TexelFormat, v: f64) -> f64 {
    match format {
        TexelFormat::Rgba8 => (v.clamp(0.0, 1.0) * 255.0).round() / 255.0,
        TexelFormat::Signed8 => (v.clamp(-1.0, 1.0) * 127.0).round() / 127.0,
        TexelFormat::Rgba16 => (v.clamp(0.0, 1.0) * 65535.0).round() / 65535.0,
        TexelFormat::F32 => v,
    }
}
