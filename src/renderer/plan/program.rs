//! A pass's fragment program as steps: the reachable IR nodes in
//! topological order, each with its slot, operands, leaf (what it reads),
//! its arithmetic decided once ([`Kernel`]) and, in `fixed9`, how its
//! register write is rounded ([`RegisterOp`]); built by [`StepBuilder`].

use std::collections::HashMap;

use crate::ir::{self, eval::Value, Expr, FbChannel, Frequency, Handle, Module, TextureId, Ty};
use crate::renderer::RenderError;
use crate::scene::bind::BoundObject;

use crate::numerics::{fixed9_with, Precision};

use super::shade::{lod_varying, Source};
use super::targets::Rendered;
use super::PlanRenderer;

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Leaf {
    Uniform(Value),
    /// Interpolant k (varyings 4k..4k+4).
    Varying {
        k: usize,
    },
    Lookup {
        texture: TextureId,
        coords_ty: Ty,
        lod_from: Option<usize>,
    },
    /// Member `member` of a fat texel of `texture` (Pipeline Grammar, eq. (6), (14),
    /// (16)): layer `member` sampled at the lookup's coordinates.
    FatMember {
        texture: TextureId,
        member: u8,
        coords_ty: Ty,
        lod_from: Option<usize>,
    },
    Framebuffer {
        framebuffer: u32,
        channel: FbChannel,
    },
    Pixel(Frequency),
    TexelCoord,
    Depth,
    /// `π p` of a per-pixel point (`πl π⁻¹ xs`, Pipeline Grammar, Section 3.5):
    /// by the projection's model → clip matrix of the scene's first object
    /// (in `πl π⁻¹` the model matrix cancels), as the WGSL target does.
    Project {
        matrix: glam::Mat4,
        inverse: bool,
        ty: Ty,
    },
    /// A value the fragment stage cannot know (NaN).
    Unknown,
}

#[derive(Clone, Debug)]
pub(super) struct Step<'m> {
    pub(super) expr: &'m Expr,
    pub(super) ty: Ty,
    pub(super) slot: u32,
    pub(super) ops: [u32; 4],
    pub(super) n_ops: u8,
    pub(super) leaf: Option<Leaf>,
    /// fixed9: a per-fragment result, clamped and rounded ([`fixed9`]).
    pub(super) quantize: bool,
    /// fixed9: a constant or uniform result, which the compiler folds into
    /// a constant register and an output scale: rounded, not clamped.
    pub(super) folded: bool,
    /// A colour texel loaded into a combiner register: kept as the texture
    /// unit delivers it (all four channels: the register has the texture's
    /// alpha even where the program reads only rgb), not narrowed to the
    /// node's type. A scalar texel is an intensity (v, v, v, v), as the
    /// program's type says.
    pub(super) raw: bool,
    /// fixed9: how a register write of a power or a quotient is rounded.
    pub(super) register: RegisterOp,
    /// The step's arithmetic, decided once.
    pub(super) kernel: Kernel,
}

/// A step's arithmetic when it is one of the common operations, decided
/// when the program is built, so that a fragment does not walk the IR's
/// expression kinds again for it; each computes exactly what
/// [`ir::eval::apply`] computes, which [`Kernel::General`] calls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Kernel {
    Add,
    Sub,
    Mul,
    Neg,
    /// A dot product of vectors of this width.
    Dot(usize),
    Swizzle([u8; 4], u8),
    /// rgb widened to rgba: alpha 1.
    RgbToRgba,
    /// A conversion that keeps the value.
    Same,
    Max,
    Min,
    Clamp,
    Saturate,
    Expand,
    Compress,
    Mix,
    /// `normalize` of a vector of this width.
    Normalize(usize),
    General,
}

impl Kernel {
    pub(super) fn of(m: &Module, expr: &Expr, ty: Ty) -> Kernel {
        use ir::{BinaryOp, UnaryOp};
        match expr {
            Expr::Binary { op: BinaryOp::Add, .. } => Kernel::Add,
            Expr::Binary { op: BinaryOp::Sub, .. } => Kernel::Sub,
            Expr::Binary { op: BinaryOp::Mul, .. } => Kernel::Mul,
            Expr::Unary { op: UnaryOp::Neg, .. } => Kernel::Neg,
            Expr::Binary { op: BinaryOp::Dot, lhs, .. } => Kernel::Dot(m.info(*lhs).ty.width()),
            Expr::Swizzle { pattern, len, .. } => Kernel::Swizzle(*pattern, *len),
            Expr::Convert { value, to } if m.info(*value).ty == Ty::Rgb && *to == Ty::Rgba => {
                Kernel::RgbToRgba
            }
            Expr::Convert { .. } => Kernel::Same,
            Expr::Math { fun, .. } => match fun {
                ir::MathFunction::Max => Kernel::Max,
                ir::MathFunction::Min => Kernel::Min,
                ir::MathFunction::Clamp => Kernel::Clamp,
                ir::MathFunction::Saturate => Kernel::Saturate,
                ir::MathFunction::Expand => Kernel::Expand,
                ir::MathFunction::Compress => Kernel::Compress,
                ir::MathFunction::Mix => Kernel::Mix,
                ir::MathFunction::Normalize => Kernel::Normalize(ty.width()),
                _ => Kernel::General,
            },
            _ => Kernel::General,
        }
    }

    #[inline]
    pub(super) fn apply(self, m: &Module, expr: &Expr, ty: Ty, o: &[Value]) -> Value {
        match self {
            Kernel::Add => [0, 1, 2, 3].map(|i| o[0][i] + o[1][i]),
            Kernel::Sub => [0, 1, 2, 3].map(|i| o[0][i] - o[1][i]),
            Kernel::Mul => [0, 1, 2, 3].map(|i| o[0][i] * o[1][i]),
            Kernel::Neg => [0, 1, 2, 3].map(|i| -o[0][i]),
            Kernel::Dot(width) => [(0..width.min(4)).map(|i| o[0][i] * o[1][i]).sum(); 4],
            Kernel::Swizzle(pattern, len) => {
                let mut v = [0.0; 4];
                for (k, &i) in pattern[..len as usize].iter().enumerate() {
                    v[k] = o[0][i as usize & 3];
                }
                v
            }
            Kernel::RgbToRgba => [o[0][0], o[0][1], o[0][2], 1.0],
            Kernel::Same => o[0],
            Kernel::Max => [0, 1, 2, 3].map(|i| o[0][i].max(o[1][i])),
            Kernel::Min => [0, 1, 2, 3].map(|i| o[0][i].min(o[1][i])),
            Kernel::Clamp => [0, 1, 2, 3].map(|i| o[0][i].max(o[1][i]).min(o[2][i])),
            Kernel::Saturate => o[0].map(|x| x.clamp(0.0, 1.0)),
            Kernel::Expand => o[0].map(|x| 2.0 * x - 1.0),
            Kernel::Compress => o[0].map(|x| (x + 1.0) / 2.0),
            Kernel::Mix => [0, 1, 2, 3].map(|i| o[0][i] * (1.0 - o[2][i]) + o[1][i] * o[2][i]),
            Kernel::Normalize(width) => {
                let a = o[0];
                let n = (0..width.min(4)).map(|i| a[i] * a[i]).sum::<f64>().sqrt();
                if n == 0.0 {
                    [0.0; 4]
                } else {
                    a.map(|x| x / n)
                }
            }
            Kernel::General => ir::eval::apply(m, expr, ty, o),
        }
    }
}

/// A fixed9 register write the WGSL's hardware fidelity computes its own
/// way, so the CPU computes it that way too.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum RegisterOp {
    /// Any other: the operation in float, rounded once.
    Rounded,
    /// `x^k` by `k`'s squarings, each product rounded ([`ir::squaring_exponent`]).
    Squarings(u32),
    /// A quotient rounded from the registers' integers ([`fixed9_quotient`]).
    Quotient,
}

/// What turning a pass's reachable nodes into [`Step`]s reads: the
/// renderer, the mode, the analyses of the fragment reach and the pass's
/// texture sources.
pub(super) struct StepBuilder<'c, 'a> {
    pub(super) r: &'a PlanRenderer<'a>,
    pub(super) mode: Precision,
    /// fixed9 with a generated combiner setup: the IR only loads registers.
    pub(super) combiners: bool,
    pub(super) address: Vec<bool>,
    pub(super) register_reads: Vec<bool>,
    pub(super) varying_of: HashMap<Handle<Expr>, usize>,
    pub(super) sources: &'c [Source<'a>],
    pub(super) fat: &'c [Vec<&'a Rendered>],
    pub(super) first_object: Option<&'c BoundObject<'c>>,
}

impl<'a> StepBuilder<'_, 'a> {
    /// The value of constant node `i`: in fixed9 a register value in the
    /// combiners' precision (as WGSL's hardware fidelity writes it; scale
    /// factors beyond ±1 and addresses stay exact), in f32 an f32.
    pub(super) fn constant(&self, i: usize, c: &ir::Constant) -> Value {
        let v = ir::eval::value(c);
        let register = self.mode == Precision::Fixed9
            && !self.combiners
            && !self.address[i]
            && c.values().iter().all(|x| x.abs() <= 1.0);
        if register {
            v.map(|x| fixed9_with(x, self.r.rounding_bias.register_steps))
        } else if self.mode == Precision::F32 {
            // f32: every node in f32, constants too (as WGSL holds them).
            v.map(|x| x as f32 as f64)
        } else {
            v
        }
    }

    /// The leaf a node reads at the fragment (`None` for an operation the
    /// IR's semantics computes), and the slots of its operands.
    pub(super) fn leaf_and_operands(
        &self,
        h: Handle<Expr>,
        expr: &Expr,
        slot_of: &[u32],
    ) -> Result<(Option<Leaf>, [u32; 4], u8), RenderError> {
        let m = &self.r.planned.module;
        let mut ops = [u32::MAX; 4];
        let mut n_ops = 0u8;
        let leaf = match expr {
            Expr::Uniform(id) => Some(Leaf::Uniform(self.uniform(*id))),
            Expr::Interpolate { .. } => match self.varying_of.get(&h) {
                Some(&k) => Some(Leaf::Varying { k }),
                None => Some(Leaf::Unknown),
            },
            Expr::Lookup { texture, coords } => {
                ops[0] = slot_of[coords.index()];
                n_ops = 1;
                Some(self.lookup_leaf(*texture, *coords)?)
            }
            Expr::FramebufferRead { framebuffer, channel, position } => {
                ops[0] = slot_of[position.index()];
                n_ops = 1;
                Some(Leaf::Framebuffer { framebuffer: *framebuffer, channel: *channel })
            }
            Expr::Depth(p) => {
                ops[0] = slot_of[p.index()];
                n_ops = 1;
                Some(Leaf::Depth)
            }
            Expr::Pixel { freq } => Some(Leaf::Pixel(*freq)),
            Expr::TexelCoord => Some(Leaf::TexelCoord),
            Expr::FatMember { texel, member } => {
                let (leaf, coords) = self.fat_member_leaf(*texel, *member)?;
                ops[0] = slot_of[coords.index()];
                n_ops = 1;
                Some(leaf)
            }
            Expr::Project { projection, value } if m.info(*value).freq.is_sample() => match self.first_object
            {
                Some(object) => {
                    ops[0] = slot_of[value.index()];
                    n_ops = 1;
                    Some(Leaf::Project {
                        matrix: object.clip_matrix(projection),
                        inverse: projection.inverse,
                        ty: m.info(*value).ty,
                    })
                }
                None => Some(Leaf::Unknown),
            },
            Expr::VertexPosition(_)
            | Expr::TexCoord { .. }
            | Expr::Vector { .. }
            | Expr::Project { .. }
            | Expr::Bundle(_) => Some(Leaf::Unknown),
            e => {
                let operands = e.operands();
                if operands.len() > 4 {
                    return Err(RenderError::Unsupported("an operation with more than four operands".into()));
                }
                for (k, o) in operands.iter().enumerate() {
                    ops[k] = slot_of[o.index()];
                }
                n_ops = operands.len() as u8;
                None
            }
        };
        Ok((leaf, ops, n_ops))
    }

    /// Uniform `id`'s value: the scene's, else the declared default, else
    /// NaN (the renderer's notes say so).
    fn uniform(&self, id: u32) -> Value {
        let m = &self.r.planned.module;
        self.r
            .uniforms
            .get(id as usize)
            .copied()
            .flatten()
            .or_else(|| m.uniforms[id as usize].default.as_ref().map(ir::eval::value))
            .unwrap_or(ir::eval::NAN)
    }

    /// A lookup of `texture` at `coords`, its mipmap level from the
    /// derivatives of the coordinate varying where there is one; an error
    /// where no pass has rendered the texture yet.
    fn lookup_leaf(&self, texture: TextureId, coords: Handle<Expr>) -> Result<Leaf, RenderError> {
        let m = &self.r.planned.module;
        let lod_from = lod_varying(m, coords).and_then(|c| self.varying_of.get(&c).copied());
        if matches!(self.sources[texture as usize], Source::Missing) {
            return Err(RenderError::Unsupported(format!(
                "texture `{}` is read before any pass renders it",
                m.textures[texture as usize].name
            )));
        }
        Ok(Leaf::Lookup { texture, coords_ty: m.info(coords).ty, lod_from })
    }

    /// Member `member` of the fat texel `texel` reads, and the coordinates
    /// of its lookup; an error where no pass rendered that layer.
    fn fat_member_leaf(&self, texel: Handle<Expr>, member: u8) -> Result<(Leaf, Handle<Expr>), RenderError> {
        let m = &self.r.planned.module;
        let Expr::Lookup { texture, coords } = m.exprs[texel] else {
            return Err(RenderError::Unsupported("a fat member of something not a lookup".into()));
        };
        if self.fat[texture as usize].len() <= member as usize {
            return Err(RenderError::Unsupported(format!(
                "member {} of the fat texels of `{}`, which no pass renders (a fat texture from an image has no layout yet)",
                member + 1,
                m.textures[texture as usize].name
            )));
        }
        let lod_from = lod_varying(m, coords).and_then(|c| self.varying_of.get(&c).copied());
        Ok((Leaf::FatMember { texture, member, coords_ty: m.info(coords).ty, lod_from }, coords))
    }

    /// Node `h`'s step, with how fixed9 rounds its result.
    pub(super) fn step(
        &self,
        h: Handle<Expr>,
        expr: &'a Expr,
        slot: u32,
        ops: [u32; 4],
        n_ops: u8,
        leaf: Option<Leaf>,
    ) -> Step<'a> {
        let m = &self.r.planned.module;
        let i = h.index();
        let ty = m.info(h).ty;
        let per_sample = m.info(h).freq.is_sample();
        let per_operation =
            self.mode == Precision::Fixed9 && !self.combiners && !self.address[i] && leaf.is_none();
        // A register write clamps where the hardware's would: a value a
        // product or function reads from a register, and the powers and
        // quotients the generator cannot fold (`ir::register_reads`).
        let own_register = self.register_reads[i]
            || ir::squaring_exponent(m, h).is_some()
            || matches!(expr, Expr::Binary { op: ir::BinaryOp::Div, .. });
        let quantize = per_operation && per_sample && own_register;
        let folded = per_operation && !quantize;
        let raw = self.combiners
            && ty.width() >= 3
            && matches!(leaf, Some(Leaf::Lookup { .. } | Leaf::Framebuffer { .. }));
        let register = match (quantize, ir::squaring_exponent(m, h)) {
            (false, _) => RegisterOp::Rounded,
            (true, Some(k)) => RegisterOp::Squarings(k),
            (true, None) if matches!(expr, Expr::Binary { op: ir::BinaryOp::Div, .. }) => {
                RegisterOp::Quotient
            }
            (true, None) => RegisterOp::Rounded,
        };
        let kernel = Kernel::of(m, expr, ty);
        Step { expr, ty, slot, ops, n_ops, leaf, quantize, folded, raw, register, kernel }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every node of every example whose step gets a specialized
    /// [`Kernel`] computes, on operand values spanning signs, zero and
    /// magnitudes, bit for bit what `ir::eval::apply` computes (after the
    /// canonical form both pass through).
    #[test]
    fn kernels_compute_what_eval_computes() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
        let values = [-2.5, -1.0, -0.25, 0.0, 0.125, 0.5, 1.0, 3.0];
        let mut checked = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "shd") {
                continue;
            }
            let (program, _) = crate::parser::check(&std::fs::read_to_string(&path).unwrap());
            let (m, _) = ir::lower(&program);
            for (h, expr) in m.exprs.arena().iter() {
                let ty = m.info(h).ty;
                let kernel = Kernel::of(&m, expr, ty);
                if kernel == Kernel::General {
                    continue;
                }
                let n = expr.operands().len();
                for k in 0..values.len() {
                    let o: Vec<Value> = (0..n)
                        .map(|j| [0, 1, 2, 3].map(|c| values[(k + 3 * j + c) % values.len()]))
                        .collect();
                    let fast = ir::eval::canonical(ty, kernel.apply(&m, expr, ty, &o));
                    let slow = ir::eval::apply(&m, expr, ty, &o);
                    assert_eq!(
                        fast.map(f64::to_bits),
                        slow.map(f64::to_bits),
                        "{kernel:?} {expr:?} on {o:?}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 500, "{checked}");
    }
}
