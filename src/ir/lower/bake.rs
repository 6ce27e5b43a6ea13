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

impl Lowerer<'_> {
    /// The texel coordinate `s.xyz` a texture-shading statement's shader
    /// reads (`T δu ← f s δu`, Pipeline Grammar, eq. (13)): the texel's
    /// centre in [0, 1]ⁿ of the texture it renders. A 2-D (or 1-D) table
    /// is rendered over its own texels, so that is `δu` itself. A 3-D
    /// texture is rendered as [`crate::textures::solid`]'s tiled grid
    /// (`TILES`² slices of `SIDE`², slice `z` at tile column `z mod TILES`,
    /// row `z div TILES`): its texel `(x, y, z)` is read back from the grid
    /// coordinate `g` as `xy = fract(TILES·g)` and
    /// `z = (TILES·⌊TILES·g⌋.y + ⌊TILES·g⌋.x + ½) / SLICES`, the same map
    /// solid mapping bakes by (`lowering::solid`), so that `bake(f)` of a
    /// volume sees its own three coordinates.
    pub(super) fn texel_coordinate(&mut self, span: Span) -> Res<Handle<Expr>> {
        let grid = self.append(Expr::TexelCoord, span)?;
        if !self.texel_volume {
            return Ok(grid);
        }
        use crate::textures::solid::{SLICES, TILES};
        let tiles = self.constant(Constant::scalar(f64::from(TILES)), span);
        let scaled = self.append(Expr::Binary { op: BinaryOp::Mul, lhs: grid, rhs: tiles }, span)?;
        let xy = self.append(Expr::Math { fun: MathFunction::Fract, args: vec![scaled] }, span)?;
        let cell = self.append(Expr::Math { fun: MathFunction::Floor, args: vec![scaled] }, span)?;
        let column = self.swizzle(cell, "x", span)?;
        let row = self.swizzle(cell, "y", span)?;
        let rows = self.append(Expr::Binary { op: BinaryOp::Mul, lhs: row, rhs: tiles }, span)?;
        let slice = self.append(Expr::Binary { op: BinaryOp::Add, lhs: rows, rhs: column }, span)?;
        let half = self.constant(Constant::scalar(0.5), span);
        let centre = self.append(Expr::Binary { op: BinaryOp::Add, lhs: slice, rhs: half }, span)?;
        let slices = self.constant(Constant::scalar(f64::from(SLICES)), span);
        let z = self.append(Expr::Binary { op: BinaryOp::Div, lhs: centre, rhs: slices }, span)?;
        self.append(Expr::Compose { ty: Ty::Vec3, components: vec![xy, z] }, span)
    }
}
