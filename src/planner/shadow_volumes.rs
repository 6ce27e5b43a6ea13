//! The shadow volume statements of Pipeline Grammar (Section 3.5) in a
//! plan: which passes rasterize `x′`, the volumes that
//! `scene::shadow_volume` builds from the scene, and how the stencil update
//! `σ C δπx ← (σ C δπx) OR ((z δπx′) > (z C δπx′))` counts them by facing
//! (Heidmann 1991; z-fail, Everitt and Kilgard 2002).

use crate::diag::Diagnostic;
use crate::ir::{Expr, Module, Table};
use crate::pipeline::setup::streams_of;
pub use crate::pipeline::setup::{volume_streams, VolumeStreams};
use crate::pipeline::{CullMode, Pass, Planned, StencilOp};
use crate::scene::shadow_volume::volumes;
use crate::scene::{Mesh, Scene, SceneAssets};

/// The stencil update over a shadow volume as the hardware counted it
/// (Heidmann 1991; z-fail, Everitt and Kilgard 2002): +1 on the volume's
/// back faces and −1 on its front faces where the depth test
/// `z δπx′ > z C δπx′` passes (wrapping, as `GL_INCR_WRAP`/`GL_DECR_WRAP`).
/// With `two_sided` stencil (a state per face) one pass draws both faces;
/// without (GeForce 256, GeForce3: one state for both) the pass becomes
/// two, the back faces (front ones culled) then the front faces. Returns,
/// for each pass now, the index of the pass it was made from.
pub fn count_by_facing(m: &Module, passes: &mut Vec<Pass>, two_sided: bool) -> Vec<usize> {
    let mut out = Vec::with_capacity(passes.len() + 1);
    let mut origins = Vec::with_capacity(passes.len() + 1);
    let volumes = VolumeStreams::of(m);
    for (index, pass) in passes.drain(..).enumerate() {
        if !(pass.state.stencil.enabled && volumes.drawn_by(m, &pass)) {
            out.push(pass);
            origins.push(index);
            continue;
        }
        let why = "where the volume lies behind the surface (z-fail)";
        if two_sided {
            let mut p = pass.clone();
            p.state.cull = CullMode::None;
            p.state.stencil.pass = StencilOp::DecrWrap;
            p.state.stencil.back_pass = Some(StencilOp::IncrWrap);
            p.reason = format!("{}: the shadow volume's faces counted by facing in one pass (two-sided stencil: back +1, front −1) {why}", pass.reason);
            out.push(p);
            origins.push(index);
            continue;
        }
        for (cull, op, faces) in [
            (CullMode::Front, StencilOp::IncrWrap, "back faces, +1"),
            (CullMode::Back, StencilOp::DecrWrap, "front faces, −1"),
        ] {
            let mut p = pass.clone();
            p.state.cull = cull;
            p.state.stencil.pass = op;
            p.reason = format!("{}: the shadow volume's {faces} {why}", pass.reason);
            out.push(p);
            origins.push(index);
        }
    }
    *passes = out;
    origins
}

/// Uses of a volume stream other than the depth a stencil update compares
/// (a colour statement interpolating `x′` over `x`): the scene gives `x′`
/// no vertices there, so the program is refused at the use.
pub fn unbound_uses(m: &Module) -> Vec<Diagnostic> {
    let volume = volume_streams(m);
    if volume.is_empty() {
        return Vec::new();
    }
    let mut out = Vec::new();
    for st in &m.statements {
        if matches!(st.table, Table::Framebuffer { channel: crate::ir::FbChannel::Stencil, .. }) {
            continue;
        }
        let used = m.reachable(&[st.value]).into_iter().find_map(|h| match m.exprs[h] {
            Expr::VertexPosition(v) if volume.contains(&v) => Some((h, &m.vertices[v as usize])),
            _ => None,
        });
        if let Some((h, name)) = used {
            out.push(Diagnostic::error("no-geometry", format!("`{name}` has no geometry here: no statement draws it, and only a stencil update's compared depth (`z δπ{name} > z C δπ{name}`, Pipeline Grammar, Section 3.5) rasterizes the shadow volumes built for it"), m.span(h), "no vertices for this stream").with_help(format!("index a statement by `{name}` (`C δπ{name} ← …`) or read `{name}` only in a stencil update's depth comparison")));
        }
    }
    out
}

/// The volume pass `index` of `planned` draws (where its setup says it
/// draws the volumes), or why it has none: no light, or no closed mesh in
/// the scene (located at the pass's statement).
pub fn for_pass(
    scene: &Scene,
    assets: &SceneAssets,
    planned: &Planned,
    index: usize,
) -> Result<Option<Mesh>, String> {
    if !planned.setup(index).draws_volumes {
        return Ok(None);
    }
    let (m, pass) = (&planned.module, &planned.plan.passes[index]);
    let light = pass.light.unwrap_or(0) as usize;
    let stream = streams_of(m, &[crate::ir::Handle::new(pass.vertex.position.unwrap_or(0) as usize)]);
    let name = stream.first().map_or("x′", |v| m.vertices[*v as usize].as_str());
    match volumes(scene, assets, light) {
        Some(mesh) if !mesh.triangles.is_empty() => Ok(Some(mesh)),
        Some(_) => Err(format!("{}: the shadow volume `{name}` has no geometry: no object of the scene is a closed mesh (each edge shared by two triangles) to cast a shadow from light {light}; help: add a closed mesh (sphere, cube, torus, closed OBJ) between the light and a receiver", pass.at)),
        None => Err(format!("{}: the shadow volume `{name}` has no geometry: the scene has no light {light} to extrude it from; help: add a light to the scene", pass.at)),
    }
}
