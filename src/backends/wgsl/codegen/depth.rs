//! A pass that replaces the fragment's depth (the shadow mask's redraw on a
//! GeForce3, NV_texture_shader's `DOT_PRODUCT_DEPTH_REPLACE_NV`): the
//! fragment function returns its colour at `@location(0)` and the depth at
//! `@builtin(frag_depth)`, clamped to [0, 1] as the depth buffer holds it,
//! so the pipeline's depth test takes it in place of the interpolated one.

use super::interface::location;
use super::*;

impl Gen<'_> {
    /// Returns `colour` and the replaced depth `d` (already computed in `b`)
    /// from the fragment function.
    pub(super) fn depth_replaced_output(
        &mut self,
        mut b: Body,
        colour: NH,
        d: ir::Handle<Expr>,
    ) -> R<Function> {
        let v =
            b.vals.get(&d).copied().ok_or_else(|| {
                GenError::Internal(format!("the replaced depth %{} not computed", d.index()))
            })?;
        let (zero, one) = (b.lit(0.0), b.lit(1.0));
        let depth = b.emit(Expression::Math {
            fun: naga::MathFunction::Clamp,
            arg: v,
            arg1: Some(zero),
            arg2: Some(one),
            arg3: None,
        });
        b.name(depth, "replaced_depth");
        let vec4 = self.vec_ty(4);
        let f32_ty = self.vec_ty(1);
        let members = vec![
            StructMember { name: Some("colour".into()), ty: vec4, binding: Some(location(0)), offset: 0 },
            StructMember {
                name: Some("depth".into()),
                ty: f32_ty,
                binding: Some(Binding::BuiltIn(naga::BuiltIn::FragDepth)),
                offset: 16,
            },
        ];
        let ty = self.module.types.insert(
            Type { name: Some("DepthReplaced".into()), inner: TypeInner::Struct { members, span: 32 } },
            naga::Span::UNDEFINED,
        );
        let out = b.emit(Expression::Compose { ty, components: vec![colour, depth] });
        b.f.body.push(Statement::Return { value: Some(out) }, naga::Span::UNDEFINED);
        b.f.result = Some(FunctionResult { ty, binding: None });
        Ok(b.f)
    }
}
