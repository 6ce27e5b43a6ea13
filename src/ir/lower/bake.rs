//! `texture T … = bake(f)` and the tabulating generators: which texture
//! sources are computed by the pipeline itself (texture shading, Pipeline
//! Grammar, eq. (13)), added to the program as statements before lowering.
//!
//! Apart because it rewrites the AST, before the `Lowerer` exists.

use super::*;

/// The function a texture source's generator tabulates (an exponent
/// given as a number; a named constant is not looked up).
pub(super) fn tabulated(src: &ast::Expr) -> Option<super::super::Tabulated> {
    let ExprKind::Apply { func, arg } = &src.kind else { return None };
    let FuncKind::Name(f) = &func.kind else { return None };
    let first = match &arg.kind {
        ExprKind::Tuple(items) => items.first()?,
        _ => arg,
    };
    match f.key().as_str() {
        "normalize_cube" => Some(super::super::Tabulated::Normalize),
        "exponent_table" => match first.kind {
            ExprKind::Number(n) if n >= 1.0 => Some(super::super::Tabulated::Power(n)),
            _ => None,
        },
        _ => None,
    }
}

/// Whether a texture source is `bake(f)`.
pub(super) fn is_bake(src: &ast::Expr) -> bool {
    matches!(&src.kind, ExprKind::Apply { func, arg } if matches!((&func.kind, &arg.kind), (FuncKind::Name(f), ExprKind::Name(_)) if f.key() == "bake"))
}

/// `texture T … = bake(f)` is texture shading (Pipeline Grammar, eq. (13)) of the
/// function `f` over T's texels: the program with the statement
/// `T δu ← f s δu` added for every such texture (its spans those of the
/// `bake(…)` source, so it sorts, plans and reports where it was written),
/// or `None` when no texture is baked. Renderers treat a baked texture as
/// one that statements render into.
pub(super) fn with_bakes(program: &ast::Program) -> Option<ast::Program> {
    let mut added = Vec::new();
    for item in &program.items {
        let ItemKind::Texture(t) = &item.kind else { continue };
        let Some(src) = t.source.as_ref().filter(|s| is_bake(s)) else { continue };
        let ExprKind::Apply { arg, .. } = &src.kind else { continue };
        let ExprKind::Name(shader) = &arg.kind else { continue };
        for name in &t.names {
            let (parsed, diagnostics) =
                crate::parser::parse(&format!("{} delta u <- {} s delta u;", name.key(), shader.key()));
            let Some(mut statement) = parsed.items.into_iter().next().filter(|_| diagnostics.is_empty())
            else {
                continue;
            };
            statement.erase_spans();
            statement.span = src.span;
            if let ItemKind::Statement(st) = &mut statement.kind {
                st.target.span = src.span;
                st.target.table.span = name.span;
                st.value.span = src.span;
            }
            added.push(statement);
        }
    }
    if added.is_empty() {
        return None;
    }
    let mut p = program.clone();
    p.items.extend(added);
    Some(p)
}
