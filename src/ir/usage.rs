//! What one statement needs from a target: texture units, interpolants,
//! constant registers, dependent lookups, texture kinds. The profile check
//! (`crate::profile::fit`) compares this with a profile; the pass planner
//! will use it to decide where to split.

use super::{BinaryOp, Expr, Frequency, Handle, MathFunction, Module, Statement, Table, Ty};
use crate::parser::ast::{TextureFormat, TextureKind};

/// Resources of one statement, each a list of the nodes that need them (so a
/// diagnostic can point at every one). Lists are in arena order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Usage {
    /// Distinct per-sample lookups: one texture unit each (hash-consing makes
    /// a lookup used twice one node, hence one unit).
    pub lookups: Vec<Handle<Expr>>,
    /// Lookups at per-vertex frequency (vertex texture fetch).
    pub vertex_lookups: Vec<Handle<Expr>>,
    /// Per-sample lookups whose coordinates depend on another lookup
    /// (texture shaders: offset, dot-product and dependent reads).
    pub dependent_lookups: Vec<Handle<Expr>>,
    pub cube_lookups: Vec<Handle<Expr>>,
    pub lookups_3d: Vec<Handle<Expr>>,
    /// Lookups of signed (`signed8`, `signed16`) textures.
    pub signed_lookups: Vec<Handle<Expr>>,
    /// Lookups of float (`rgba16f`, `rgba32f`) textures.
    pub float_lookups: Vec<Handle<Expr>>,
    /// Interpolated values other than the fragment position.
    pub interpolants: Vec<Handle<Expr>>,
    /// Colour or vector constants and uniforms used by per-sample
    /// arithmetic: each needs a constant register (scalars are left out: the
    /// planner turns many into scales and input mappings).
    pub constants: Vec<Handle<Expr>>,
    /// Per-sample arithmetic beyond the texture environment (dot products,
    /// powers, divisions, built-in functions).
    pub arithmetic: Vec<Handle<Expr>>,
    pub framebuffer_reads: Vec<Handle<Expr>>,
}

/// Whether node `h` is a lookup a pass makes through a texture unit: one
/// per sample, or one at coordinates the same for the whole draw
/// (`T vec2(0.3, 0.6)`: a texel read as a colour, a constant texture
/// coordinate on every vertex in GL), which is no less a texture read.
/// Lookups per vertex are the vertex stage's.
pub fn takes_unit(module: &Module, h: Handle<Expr>) -> bool {
    matches!(module.exprs[h], Expr::Lookup { .. }) && module.info(h).freq != Frequency::Vertex
}

impl Usage {
    /// Texture units the statement needs: one per entry of `lookups`.
    pub fn texture_units(&self) -> usize {
        self.lookups.len()
    }

    /// The resources of statement `st`.
    pub fn of(module: &Module, st: &Statement) -> Usage {
        Usage::of_value(module, st.value)
    }

    /// `Usage::of_value(module, value).texture_units()`, without the rest
    /// of the usage (the splitter asks it of every candidate piece).
    pub fn texture_units_of(module: &Module, value: Handle<Expr>) -> usize {
        module.reachable(&[value]).into_iter().filter(|&h| takes_unit(module, h)).count()
    }

    /// The resources a pass needs to compute `value` per sample.
    pub fn of_value(module: &Module, value: Handle<Expr>) -> Usage {
        Usage::of_reached(module, &module.reachable(&[value]))
    }

    /// Only the texture units of [`Usage::of_reached`]: its `lookups` and
    /// `framebuffer_reads`, the rest left empty (the fit check tries these
    /// first, and most values the planner measures fail on them).
    pub fn units_of_reached(module: &Module, nodes: &[Handle<Expr>]) -> Usage {
        let mut u = Usage::default();
        for &h in nodes {
            match &module.exprs[h] {
                Expr::Lookup { .. } if takes_unit(module, h) => u.lookups.push(h),
                Expr::FramebufferRead { .. } => u.framebuffer_reads.push(h),
                _ => {}
            }
        }
        u
    }

    /// [`Usage::of_value`] of the value whose reachable nodes
    /// ([`Module::reachable`]) are `nodes`.
    pub fn of_reached(module: &Module, nodes: &[Handle<Expr>]) -> Usage {
        // Whether a node depends on a per-sample lookup, bottom-up (operands
        // precede users in the arena, and `reachable` is in arena order, so
        // an operand's entry is found by binary search among `nodes`).
        #[allow(clippy::expect_used)] // `reachable` includes every operand of a node it reaches
        let at = |o: Handle<Expr>| nodes.binary_search(&o).expect("an operand of a reached node is reached");
        let mut on_lookup: Vec<bool> = Vec::with_capacity(nodes.len());
        for &h in nodes {
            let mut any = takes_unit(module, h);
            module.exprs[h].visit_operands(|o| any |= on_lookup[at(o)]);
            on_lookup.push(any);
        }
        let mut u = Usage::default();
        for &h in nodes {
            let info = module.info(h);
            let sample = info.freq.is_sample();
            match &module.exprs[h] {
                Expr::Lookup { texture, coords } => {
                    if !takes_unit(module, h) {
                        if info.freq == Frequency::Vertex {
                            u.vertex_lookups.push(h);
                        }
                        continue;
                    }
                    u.lookups.push(h);
                    if on_lookup[at(*coords)] {
                        u.dependent_lookups.push(h);
                    }
                    let t = &module.textures[*texture as usize];
                    match t.kind {
                        TextureKind::Cube => u.cube_lookups.push(h),
                        TextureKind::Tex3d => u.lookups_3d.push(h),
                        _ => {}
                    }
                    match t.format {
                        TextureFormat::Signed8 | TextureFormat::Signed16 => u.signed_lookups.push(h),
                        TextureFormat::Rgba16f | TextureFormat::Rgba32f => u.float_lookups.push(h),
                        _ => {}
                    }
                }
                Expr::Interpolate { .. } if info.ty != Ty::Position => u.interpolants.push(h),
                Expr::FramebufferRead { .. } => u.framebuffer_reads.push(h),
                Expr::Binary { op: BinaryOp::Dot | BinaryOp::Pow | BinaryOp::Div, .. }
                | Expr::Math { .. }
                    if sample =>
                {
                    u.arithmetic.push(h)
                }
                _ => {}
            }
            if sample {
                let pow_exponent = match &module.exprs[h] {
                    Expr::Binary { op: BinaryOp::Pow, rhs, .. } => Some(*rhs),
                    _ => None,
                };
                module.exprs[h].visit_operands(|o| {
                    let oi = module.info(o);
                    let register = matches!(module.exprs[o], Expr::Constant(_) | Expr::Uniform(_))
                        && oi.ty != Ty::Scalar;
                    let uniform_scalar = matches!(module.exprs[o], Expr::Uniform(_));
                    if (register || uniform_scalar)
                        && Some(o) != pow_exponent
                        && !u.constants.contains(&o)
                        && !is_trivial(module, o)
                    {
                        u.constants.push(o);
                    }
                });
            }
        }
        u.constants.sort();
        u
    }
}

/// 0 and 1 vectors come free (the zero register, input mappings).
fn is_trivial(module: &Module, h: Handle<Expr>) -> bool {
    match &module.exprs[h] {
        Expr::Constant(c) => c.values().iter().all(|v| *v == 0.0) || c.values().iter().all(|v| *v == 1.0),
        _ => false,
    }
}

/// Per texture of `m` (by id): how many members its fat texels hold — the
/// array layers it is stored in — or 0 for an ordinary texture. A texture
/// is fat when a statement writes a shading-parameter bundle into it
/// (Pipeline Grammar, eq. (5), (15)) or a shader reads members of its texels ((6), (14), (16)).
pub fn fat_layers(m: &Module) -> Vec<u8> {
    let mut layers = vec![0u8; m.textures.len()];
    for st in &m.statements {
        if let (Table::Texture(t), Ty::Bundle(n)) = (&st.table, m.info(st.value).ty) {
            layers[*t as usize] = layers[*t as usize].max(n);
        }
    }
    for (_, e) in m.exprs.arena().iter() {
        if let Expr::FatMember { texel, member } = e {
            if let Expr::Lookup { texture, .. } = m.exprs[*texel] {
                layers[texture as usize] = layers[texture as usize].max(member + 1);
            }
        }
    }
    layers
}

/// The nodes the fragment stage of a pass evaluates for `roots`: reachable
/// from them without crossing a `δ` (an `Interpolate` is reached, its
/// per-vertex operand is not). Indexed by arena index.
pub fn fragment_reach(m: &Module, roots: &[Handle<Expr>]) -> Vec<bool> {
    let n = m.exprs.len();
    let mut reach = vec![false; n];
    for h in roots {
        reach[h.index()] = true;
    }
    for i in (0..n).rev() {
        if !reach[i] || matches!(m.exprs[Handle::new(i)], Expr::Interpolate { .. }) {
            continue;
        }
        for o in m.exprs[Handle::new(i)].operands() {
            reach[o.index()] = true;
        }
    }
    reach
}

/// Of the `reach`ed nodes ([`fragment_reach`]), those that only address a
/// texture or a framebuffer: lookup coordinates, read positions, and what
/// only they use. The texture units iterate them in float, so the register
/// combiners' precision model (the CPU's `fixed9`, WGSL's hardware
/// fidelity) does not round them (Kilgard 2000, Section 4.2: the combiners see
/// texels, not coordinates).
pub fn address_only(m: &Module, reach: &[bool]) -> Vec<bool> {
    let n = m.exprs.len();
    let mut address = vec![false; n];
    for i in (0..n).rev() {
        if !reach[i] {
            continue;
        }
        match &m.exprs[Handle::new(i)] {
            Expr::Lookup { coords, .. } => address[coords.index()] = true,
            Expr::FramebufferRead { position, .. } => address[position.index()] = true,
            Expr::Depth(p) => address[p.index()] = true,
            e if address[i] && !matches!(e, Expr::Interpolate { .. }) => {
                for o in e.operands() {
                    address[o.index()] = true;
                }
            }
            _ => {}
        }
    }
    address
}

/// The nodes reachable from `roots` whose *value* reaches a root, through
/// operand positions other than an address (lookup coordinates, read
/// positions; [`address_only`]): what the register combiners read. A node
/// may be both an address and a value (`δ L` indexing a normalization cube
/// map and giving `L.z` for Kilgard's self-shadowing term, Kilgard 2000,
/// Section 2.4.1); it is in this set.
pub fn value_read_from(m: &Module, roots: &[Handle<Expr>]) -> rustc_hash::FxHashSet<Handle<Expr>> {
    let mut value: rustc_hash::FxHashSet<Handle<Expr>> = roots.iter().copied().collect();
    for h in m.reachable(roots).into_iter().rev() {
        let e = &m.exprs[h];
        if !value.contains(&h) || matches!(e, Expr::Interpolate { .. }) {
            continue;
        }
        let address = address_operand(e);
        e.visit_operands(|o| {
            if Some(o) != address {
                value.insert(o);
            }
        });
    }
    value
}

/// The operand of `e` that addresses a texture or framebuffer, if any.
pub fn address_operand(e: &Expr) -> Option<Handle<Expr>> {
    match e {
        Expr::Lookup { coords, .. } => Some(*coords),
        Expr::FramebufferRead { position, .. } => Some(*position),
        Expr::Depth(p) => Some(*p),
        _ => None,
    }
}

/// The per-operation fixed9 model (a pass the combiner generator cannot
/// build): which per-sample nodes are *register reads* — an operand that a
/// product, dot product, power or function of another per-sample value
/// takes, so the combiners hold it in a register, clamped to [−1, 1]
/// (Kilgard 2000, Section 4.2.2). Affine work — sums, constant scales and
/// biases, negation, the range mappings — rides on input mappings, output
/// scales and the AB + CD sum of the consumer's portion, where the
/// hardware does not clamp in between; such a node is rounded to 1/255 but
/// keeps its magnitude (`2 * Detail`, `2*s.x − 1` on the
/// way to a product). Both the CPU's `fixed9` and WGSL's hardware fidelity
/// clamp exactly these. `reach`: the pass's nodes ([`fragment_reach`]).
pub fn register_reads(m: &Module, reach: &[bool]) -> Vec<bool> {
    let mut reads = vec![false; m.exprs.len()];
    let sample = |h: Handle<Expr>| m.info(h).freq.is_sample();
    for (i, &reached) in reach.iter().enumerate() {
        if !reached || !sample(Handle::new(i)) {
            continue;
        }
        let e = &m.exprs[Handle::new(i)];
        let ops = e.operands();
        let product = match e {
            Expr::Binary { op: BinaryOp::Mul | BinaryOp::Dot | BinaryOp::Div, lhs, rhs } => {
                sample(*lhs) && sample(*rhs)
            }
            Expr::Binary { op: BinaryOp::Pow, .. } => true,
            Expr::Math { fun, .. } => !matches!(
                fun,
                MathFunction::Expand
                    | MathFunction::HalfBias
                    | MathFunction::Compress
                    | MathFunction::Saturate
            ),
            Expr::Combine { .. } => true,
            _ => false,
        };
        if product {
            for o in ops {
                mark_register_read(m, o, &mut reads);
            }
        }
    }
    reads
}

/// Marks `o` a register read, looking through what the consumer's portion
/// applies to a register on the way in or out: a constant or per-object
/// scale (its output scale or constant colour), a negation or a range
/// mapping (an input mapping) — `2 * Detail` in `Base * (2 * Detail)` is
/// `Base · Detail` with `scale_by_two()`, so only `Detail` is held.
fn mark_register_read(m: &Module, o: Handle<Expr>, reads: &mut [bool]) {
    let sample = |h: Handle<Expr>| m.info(h).freq.is_sample();
    match m.exprs[o] {
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } if sample(lhs) != sample(rhs) => {
            mark_register_read(m, if sample(lhs) { lhs } else { rhs }, reads)
        }
        Expr::Unary { op: super::UnaryOp::Neg, value } => mark_register_read(m, value, reads),
        Expr::Math { fun: MathFunction::Expand | MathFunction::HalfBias, ref args } => {
            mark_register_read(m, args[0], reads)
        }
        _ => reads[o.index()] = true,
    }
}

/// In the register combiners' precision model, the exponent `k` of `x^k`
/// when the power is taken by repeated squaring, each product a register
/// write rounded to 8 bits + sign (GeForce3 Phong, Section 4.4: "exponentiation
/// by squaring" in the combiners; Kilgard 2000, Section 4.2: every general
/// combiner output is a register). That is a power to a constant whole
/// exponent in 1..=256; other powers are one operation. The CPU's `fixed9`
/// and WGSL's hardware fidelity both round where this says, so they agree.
pub fn squaring_exponent(m: &Module, pow: Handle<Expr>) -> Option<u32> {
    let Expr::Binary { op: BinaryOp::Pow, rhs, .. } = &m.exprs[pow] else { return None };
    let Expr::Constant(c) = &m.exprs[*rhs] else { return None };
    let k = c.components[0];
    ((1.0..=256.0).contains(&k) && k.fract() == 0.0).then_some(k as u32)
}

/// `x^k` by repeated squaring ([`squaring_exponent`]), `round` applied to
/// every product — the order both executors follow: squarings of the base
/// from the lowest bit up, the running product multiplied in at each set
/// bit (the first set bit takes the base itself, unrounded).
pub fn power_by_squaring<T: Copy>(x: T, k: u32, mut mul: impl FnMut(T, T) -> T) -> T {
    let (mut e, mut base, mut acc) = (k, x, None);
    while e > 0 {
        if e & 1 == 1 {
            acc = Some(match acc {
                None => base,
                Some(a) => mul(a, base),
            });
        }
        e >>= 1;
        if e > 0 {
            base = mul(base, base);
        }
    }
    acc.unwrap_or(x)
}

#[cfg(test)]
mod tests {
    use super::power_by_squaring;

    /// `x^k` with the products
    /// the WGSL writes: ⌊log2 k⌋ squarings and one product per further set bit.
    #[test]
    fn power_by_squaring_takes_the_squarings_and_products_of_k() {
        for k in 1..=80u32 {
            let mut products = 0;
            let p = power_by_squaring(3u128, k, |a, b| {
                products += 1;
                a * b
            });
            assert_eq!(p, 3u128.pow(k), "k = {k}");
            assert_eq!(products, (31 - k.leading_zeros()) + k.count_ones() - 1, "k = {k}");
        }
    }

    /// Rounding each product (here to a coarse grid) is what makes the order matter.
    #[test]
    fn power_by_squaring_rounds_every_product() {
        let round = |v: f64| (v * 16.0 + 0.5).floor() / 16.0;
        // 0.9² = 0.81 → 0.8125, → 0.66015625 → 0.6875, → 0.47265625 → 0.5; 0.9⁸ = 0.4305 → 0.4375.
        assert_eq!(power_by_squaring(0.9, 8, |a, b| round(a * b)), 0.5);
        assert_eq!(round(0.9f64.powi(8)), 0.4375);
    }
}
