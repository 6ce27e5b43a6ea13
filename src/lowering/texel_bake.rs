//! Rule `compiler_baked`: a texture-shading statement `T δu ← f s δu`
//! (Pipeline Grammar, eq. (13)) whose value depends on the texel coordinate and
//! constants only is computed by the compiler on the CPU, as `bake(f)` is
//!, instead of by a pass of the target — whose combiners may
//! lack `f`'s operations (`examples/henyey_greenstein_skin.shd`'s power
//! 1.5). The texture keeps its declared format, so the result differs from
//! the target's own rendering only where the target could not compute it:
//! the rule's error bound is the format's rounding, ½ of an 8-bit step.

use super::Rewriter;
use crate::ir::{Expr, Frequency, Table};
use crate::pipeline::ApproximationCost;

/// Marks every such statement's texture baked.
pub fn apply(r: &mut Rewriter) {
    for i in 0..r.m.statements.len() {
        let st = &r.m.statements[i];
        let Table::Texture(id) = st.table else { continue };
        let t = &r.m.textures[id as usize];
        if st.freq != Frequency::Texel || t.baked || t.format.is_wide() {
            continue;
        }
        let pure = r.m.reachable(&[st.value]).iter().all(|h| {
            let e = &r.m.exprs[*h];
            matches!(e, Expr::TexelCoord) || crate::ir::eval::is_pure_arithmetic(e)
        });
        if !pure {
            continue;
        }
        let (span, name) = (st.span, t.name.clone());
        let texels = (crate::pipeline::RENDERED_TEXTURE_SIZE as u64).pow(2);
        r.m.textures[id as usize].baked = true;
        r.record(
            "compiler_baked",
            span,
            None,
            format!("the texture `{name}`, a function of its texel coordinate, is computed by the compiler, not by a pass of the target"),
            ApproximationCost { texture_units: 0, passes: 0, general_combiners: 0, texels },
            Some(0.5 / 255.0),
        );
    }
}
