//! The lowering: what a target cannot compute, rewritten into
//! what it has — the GeForce-era techniques of GeForce3 Phong and Kilgard 2000 as
//! named rules, each recording an [`Approximation`] with its cost and its
//! error bound.
//!
//! It sits between the IR and the planner: the planner calls [`lower`]
//! only when the program as written does not plan (so programs that plan,
//! and every WGSL plan, are unchanged), once per [`Choice`], most accurate
//! first ([`choices`]). The rules, one file each (docs/lowering.md):
//!
//! - [`cube_map`]: `normalize(δ v)` → an 8-bit normalization cube map
//!   (GeForce3 Phong, Section 4.2.2, Formula 4; Kilgard 2000, Section 5.2);
//! - [`taylor`]: `normalize(δ v)` → `v + ½ v (1 − v·v)` in the combiners
//!   (GeForce3 Phong, Formula 6), no texture unit;
//! - [`per_vertex`]: a per-fragment function of interpolated values
//!   computed per vertex and interpolated instead (Pipeline Grammar, eq. (1) against
//!   (4)): what makes the other rules' coordinates;
//! - [`table`]: a per-fragment function of one bounded interpolated
//!   scalar (`sqrt`, division, `floor`, `fract`, `exp`, a fractional power)
//!   → a 1-D table baked by the compiler on the CPU (the `bake` path) and
//!   indexed by texgen (Heidrich & Seidel 1999, Section 3: functions as textures); on
//!   geforce3 a function of a dot product that reads a texel, looked up at
//!   the dot product by a texture-shader stage (`dependent_table`);
//! - [`power`]: `x^n` not a power of two → squarings multiplied in one
//!   pass; beyond the stages of one pass → a product of
//!   powers that do fit, multiplied in the framebuffer across passes;
//! - [`range_compress`]: a signed vector interpolated into the combiners
//!   → `expand(δ (v + 1)/2)` (Kilgard 2000, Section 5.2, Tables 2-3);
//! - [`texel_bake`]: a texture-shading statement that is a function of the
//!   texel coordinate and uniforms only → computed by the compiler, as
//!   `bake(f)` is;
//! - [`signed_texture`]: a signed cube or 3-D texture on a target without
//!   signed formats → the same source stored range-compressed in RGB8 and
//!   expanded after each lookup (Kilgard 2000, Section 5.2);
//! - [`fat_texture`]: a fat texture (a bundle of shading parameters per
//!   texel, Pipeline Grammar, eq. (5), (14)) on the combiners → one 8-bit texture per
//!   member, range-compressed where signed;
//! - [`float_texture`]: a float texture written only with values in
//!   [0, 1] → the same texture in RGBA8;
//! - [`solid`]: solid mapping planned for a scene, on a target with 3-D
//!   textures → the shader baked into a 3-D texture over the scene's
//!   object bounds, read at the box-mapped position (Pipeline Grammar,
//!   eq. (15)-(16));
//! - [`table2d`]: a per-fragment function of two per-vertex arguments
//!   (dot products) → a 2-D table baked by the compiler (Heidrich & Seidel 1999, §3);
//! - [`dependent`]: on a target without dependent lookups (GeForce 256),
//!   a lookup whose coordinate reads a texel → the function the table
//!   holds computed in the combiners (`exponent_table(n)` → xⁿ), or the
//!   coordinate computed per vertex and interpolated;
//! - [`alpha_ramp`]: on a target without depth textures (GeForce 256),
//!   Williams's shadow-map test with both depths from the light encoded in
//!   an 8-bit alpha ramp and compared in the combiners (Kilgard's shadow
//!   mapping on the GeForce 1 and 2, GDC 2000), measured, not bounded;
//! - [`per_vertex::gouraud`]: the last resort when no choice above plans —
//!   every maximal per-fragment part that reads only interpolants computed
//!   per vertex (Gouraud), reported without a bound.
//!
//! What no rule rewrites (a texture indexed by another texture's result on
//! geforce256, float textures) keeps the planner's located refusal.

pub mod alpha_ramp;
pub mod cube_map;
pub mod dependent;
pub mod fat_texture;
pub mod float_texture;
pub mod per_vertex;
pub mod periodic;
pub mod power;
pub mod range_compress;
pub mod sensitivity;
pub mod signed_texture;
pub mod solid;
pub mod table;
pub mod table2d;
pub mod taylor;
pub mod texel_bake;
pub mod texel_cube;

use std::collections::HashMap;

use crate::ir::{BinaryOp, Constant, Expr, Frequency, Handle, MathFunction, Module, Statement, Table, Ty};
use crate::pipeline::{Approximation, ApproximationCost};
use crate::profile::Profile;
use crate::span::Span;

/// What the user allows (`compile --no-approx`, `--max-error E`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowerOptions {
    /// `false`: refuse what the target cannot compute, as without the lowering.
    pub approximate: bool,
    /// Accept only approximations whose stated bound is at most this
    /// (an approximation with no bound is then refused); `None`: any.
    pub max_error: Option<f64>,
    /// Plan only this choice of rules, whatever its bounds (the
    /// scene-measured choice, `accuracy::choose`, tries each in turn).
    pub only: Option<Choice>,
}

impl Default for LowerOptions {
    fn default() -> LowerOptions {
        LowerOptions { approximate: true, max_error: None, only: None }
    }
}

/// How a per-fragment `normalize` is replaced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Normalization {
    /// A normalization cube map: one texture unit, error one 8-bit step.
    CubeMap,
    /// Taylor renormalization in the combiners: no unit, error growing
    /// with the angle the interpolated vectors span.
    Taylor,
}

/// One way to lower a program.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Choice {
    pub normalization: Normalization,
    /// Every maximal per-fragment part that reads only interpolated values
    /// computed per vertex first ([`per_vertex::gouraud`]): the last resort,
    /// Gouraud shading of what the target cannot shade per fragment.
    pub gouraud: bool,
    /// With `gouraud`: a sum of colours whose range passes [0, 1], which
    /// GL would clamp as one vertex colour, falls back term by term, each
    /// term its own per-vertex part ([`per_vertex::gouraud_by_term`]).
    pub by_term: bool,
    /// Every largest per-fragment function of two per-vertex arguments a
    /// 2-D table first ([`table2d`]).
    pub tables_2d: bool,
}

/// The choices for `profile`, most accurate first (the planner takes the
/// first that plans within the options).
pub fn choices(profile: &Profile) -> Vec<Choice> {
    let mut out = Vec::new();
    if profile.cube_maps {
        out.push(Choice {
            normalization: Normalization::CubeMap,
            gouraud: false,
            tables_2d: false,
            by_term: false,
        });
    }
    out.push(Choice {
        normalization: Normalization::Taylor,
        gouraud: false,
        tables_2d: false,
        by_term: false,
    });
    let best = out[0];
    out.push(Choice { tables_2d: true, ..best });
    // A sum split across δ before the whole sum: each term its own vertex
    // colour, clamped on its own (planned only where it splits a sum).
    out.push(Choice { gouraud: true, by_term: true, ..best });
    out.push(Choice { gouraud: true, ..best });
    out
}

/// A lowered program and what was approximated in it.
#[derive(Clone, Debug)]
pub struct Lowered {
    pub module: Module,
    pub approximations: Vec<Approximation>,
    /// The sums [`per_vertex::gouraud_by_term`] split across δ (a
    /// `by_term` choice that split none is the whole-sum one).
    pub split_sums: usize,
}

impl Lowered {
    /// Whether the approximations together stay within `options.max_error`
    /// at the output (the sum of their output bounds, [`sensitivity`]).
    pub fn within(&self, options: &LowerOptions) -> bool {
        options.max_error.is_none_or(|e| self.output_bound().is_some_and(|b| b <= e))
    }

    /// The sum of the approximations' output bounds (`None` when one has
    /// none): first order, as the bounds are.
    pub fn output_bound(&self) -> Option<f64> {
        self.approximations.iter().map(|a| a.output_bound).sum()
    }
}

/// Rewrites what `profile` lacks in `module`'s statements. `at` gives the
/// `line:col` of a span for the record.
pub fn lower(module: &Module, profile: &Profile, choice: Choice, at: &dyn Fn(Span) -> String) -> Lowered {
    lower_for(module, profile, choice, at, None)
}

/// [`lower`] for a scene whose meshes fill `bounds` in object space
/// ([`solid`]: positions mapped into a 3-D texture's [0, 1]³).
pub fn lower_for(
    module: &Module,
    profile: &Profile,
    choice: Choice,
    at: &dyn Fn(Span) -> String,
    bounds: Option<solid::Bounds>,
) -> Lowered {
    let mut r = Rewriter {
        m: module.clone(),
        profile,
        choice,
        at,
        approximations: Vec::new(),
        pending: Vec::new(),
        results: Vec::new(),
        result_at: HashMap::new(),
        bounds,
        split_sums: 0,
    };
    texel_bake::apply(&mut r);
    solid::apply(&mut r);
    signed_texture::apply(&mut r);
    fat_texture::apply(&mut r);
    float_texture::apply(&mut r);
    alpha_ramp::apply(&mut r);
    for st in std::mem::take(&mut r.m.statements) {
        if matches!(st.table, Table::TexCoords(_)) || r.m.is_baked(&st) {
            r.m.statements.push(st);
            continue;
        }
        let value = if choice.tables_2d { table2d::apply(&mut r, st.value) } else { st.value };
        let value = match (choice.gouraud, choice.by_term) {
            (true, false) => per_vertex::gouraud(&mut r, value),
            (true, true) => per_vertex::gouraud_by_term(&mut r, value),
            (false, _) => value,
        };
        let value = r.rewrite(value);
        // A table's texel statement runs before the statement sampling it.
        let tables = std::mem::take(&mut r.pending);
        r.m.statements.extend(tables);
        r.m.statements.push(Statement { value, ..st });
    }
    r.drop_unread_tables(module.textures.len());
    r.finish()
}

/// A top-down rule: what stands for a node, or `None` to try its operands
/// ([`Rewriter::top_down`]).
pub type Replace<'a> = dyn FnMut(&mut Rewriter<'a>, Handle<Expr>) -> Option<Handle<Expr>>;

/// The state the rules share.
pub struct Rewriter<'a> {
    pub m: Module,
    pub profile: &'a Profile,
    pub choice: Choice,
    at: &'a dyn Fn(Span) -> String,
    pub approximations: Vec<Approximation>,
    /// Texel statements of tables made for the statement being rewritten.
    pub pending: Vec<Statement>,
    /// The value each approximation produced, in the same order.
    results: Vec<Option<Handle<Expr>>>,
    /// Where each value of `results` stands in it.
    result_at: HashMap<Handle<Expr>, Vec<usize>>,
    /// The scene's object bounds, when planning for one ([`solid`]).
    pub bounds: Option<solid::Bounds>,
    /// Sums split across δ ([`Lowered::split_sums`]).
    pub split_sums: usize,
}

impl<'a> Rewriter<'a> {
    /// `value` with every per-sample node the target cannot compute
    /// rewritten; its operands first (arena order is topological).
    fn rewrite(&mut self, value: Handle<Expr>) -> Handle<Expr> {
        let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::new();
        for h in self.m.reachable(&[value]) {
            if !self.m.info(h).freq.is_sample() {
                continue;
            }
            let e = self.m.exprs[h].map_operands(|o| map.get(&o).copied().unwrap_or(o));
            let span = self.m.span(h);
            let nh = self.m.intern(e, span).unwrap_or(h);
            let lowered = self.rule(h, nh, span);
            map.insert(h, lowered);
        }
        let lowered = map.get(&value).copied().unwrap_or(value);
        if self.combiners() {
            self.compress_interpolants(lowered)
        } else {
            lowered
        }
    }

    /// After the other rules (whose cube maps and tables take interpolated
    /// coordinates): every signed vector the combiners still read as an
    /// interpolated colour, range-compressed ([`range_compress`]).
    fn compress_interpolants(&mut self, value: Handle<Expr>) -> Handle<Expr> {
        let read_by_combiners = crate::ir::usage::value_read_from(&self.m, &[value]);
        let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::new();
        for h in self.m.reachable(&[value]) {
            // A texture's coordinates stay as they were, even where the
            // combiners also read their interpolant compressed (`δ L`
            // indexing a cube map and giving `L.z`): the texture unit
            // iterates coordinates in float.
            let address = crate::ir::usage::address_operand(&self.m.exprs[h]);
            let e = self.m.exprs[h].map_operands(|o| {
                if Some(o) == address {
                    o
                } else {
                    map.get(&o).copied().unwrap_or(o)
                }
            });
            let span = self.m.span(h);
            let nh = self.m.intern(e, span).unwrap_or(h);
            let out = match &self.m.exprs[nh] {
                Expr::Interpolate { .. } if read_by_combiners.contains(&h) => {
                    range_compress::apply(self, nh, span).unwrap_or(nh)
                }
                // A compressed interpolant stored compressed (a fat texel,
                // [`fat_texture`]): `compress(expand(δ y)) = δ y`.
                Expr::Math { fun: MathFunction::Compress, args } => match &self.m.exprs[args[0]] {
                    Expr::Math { fun: MathFunction::Expand, args: inner }
                        if matches!(self.m.exprs[inner[0]], Expr::Interpolate { .. }) =>
                    {
                        inner[0]
                    }
                    _ => nh,
                },
                _ => nh,
            };
            map.insert(h, out);
        }
        // An approximation's value rebuilt around a compressed interpolant
        // is still that approximation's (`finish` keeps the live ones).
        // Each moved once, as `map` says (an index, not a scan of every
        // statement's approximations: linear in the program).
        let moved: Vec<(Handle<Expr>, Vec<usize>)> = (map.iter())
            .filter(|(h, to)| h != to)
            .filter_map(|(&h, &to)| Some((to, self.result_at.remove(&h)?)))
            .collect();
        for (to, at) in moved {
            for &i in &at {
                self.results[i] = Some(to);
            }
            self.result_at.entry(to).or_default().extend(at);
        }
        map.get(&value).copied().unwrap_or(value)
    }

    /// The first rule that rewrites `h` (`original` before its operands
    /// were rewritten: what a per-vertex rule computes at the vertices),
    /// or `h`.
    fn rule(&mut self, original: Handle<Expr>, h: Handle<Expr>, span: Span) -> Handle<Expr> {
        match &self.m.exprs[h] {
            Expr::Math { fun: MathFunction::Normalize, args } => {
                let (x, x_written) = (args[0], self.m.operands(original)[0]);
                let normalized = match self.choice.normalization {
                    // A filtered normal-map texel: by the texture shader's dot products.
                    _ if texel_cube::expanded_texel(&self.m, x).is_some() => {
                        texel_cube::normalize_texel(self, x, span)
                    }
                    Normalization::CubeMap if self.profile.cube_maps => {
                        cube_map::apply(self, x, x_written, span)
                    }
                    _ => taylor::apply(self, x_written, span),
                };
                normalized.unwrap_or(h)
            }
            Expr::Binary { op: BinaryOp::Pow, .. } if !needs_table(&self.m, h) => {
                power::apply(self, h, span).unwrap_or(h)
            }
            // A cube map at an expanded texel: the texture shader's dot products.
            Expr::Lookup { coords, .. }
                if texel_cube::available(self) && texel_cube::expanded_texel(&self.m, *coords).is_some() =>
            {
                texel_cube::lookup_at_texel(self, h, span).unwrap_or(h)
            }
            // A coordinate that reads a texel, on a target without
            // dependent lookups (issue 18: "on geforce256 a per-vertex
            // approximation"), or one no texture-shader operation computes
            // (geforce3: `Texp(N·Hn)`, Hn a cube map's texel).
            Expr::Lookup { coords, .. }
                if self.combiners()
                    && reads_texel(&self.m, *coords)
                    && (!self.profile.has_dependent_lookups()
                        || !dependent::texture_shader_form(&self.m, *coords)) =>
            {
                dependent::apply(self, h, original, span).unwrap_or(h)
            }
            // A `step` the mux computes is tabulated in the choice of
            // tables too, for a target whose stages the mux does not fit.
            _ if needs_table(&self.m, h) || self.choice.tables_2d && is_step(&self.m, h) => {
                periodic::apply(self, h, span)
                    .or_else(|| table::apply(self, h, original, span))
                    .or_else(|| per_vertex::apply(self, original, "this value", span))
                    .unwrap_or(h)
            }
            // An rgb division (`kd·(N·L)/((N·L) + (N·V))`): no table of one
            // scalar holds it; per vertex is what is left.
            _ if no_combiner_op(&self.m, h) => {
                per_vertex::apply(self, original, "this value", span).unwrap_or(h)
            }
            _ => h,
        }
    }

    /// Records an approximation made at `span` whose value is `result`
    /// (`None`: a whole statement's).
    pub fn record(
        &mut self,
        rule: &str,
        span: Span,
        result: Option<Handle<Expr>>,
        why: String,
        cost: ApproximationCost,
        error_bound: Option<f64>,
    ) {
        let at = (self.at)(span);
        let output_bound = None; // set by `finish`, once the program is whole
        self.approximations.push(Approximation {
            rule: rule.into(),
            at,
            span,
            why,
            cost,
            error_bound,
            output_bound,
        });
        if let Some(h) = result {
            self.result_at.entry(h).or_default().push(self.results.len());
        }
        self.results.push(result);
    }

    /// The approximations whose value was `from` now stand at `to`, a
    /// rule's result that reads `from` (or what it was computed from)
    /// and replaces it: `finish` keeps those `to` reaches.
    pub fn carry_results(&mut self, from: Handle<Expr>, to: Handle<Expr>) {
        if from == to {
            return;
        }
        let Some(at) = self.result_at.remove(&from) else { return };
        for &i in &at {
            self.results[i] = Some(to);
        }
        self.result_at.entry(to).or_default().extend(at);
    }

    /// The lowered module with the approximations some statement still
    /// uses (a rule applied inside a value a later rule computed per vertex
    /// is gone).
    fn finish(self) -> Lowered {
        let roots: Vec<Handle<Expr>> = self.m.statements.iter().map(|st| st.value).collect();
        let live: std::collections::HashSet<Handle<Expr>> = self.m.reachable(&roots).into_iter().collect();
        let sites: Vec<Handle<Expr>> = self.results.iter().flatten().copied().collect();
        let reach = sensitivity::Reach::new(&self.m, &sites);
        let approximations = self
            .approximations
            .into_iter()
            .zip(self.results)
            .filter(|(_, r)| r.is_none_or(|h| live.contains(&h)))
            .map(|(mut a, r)| {
                let sensitivity = match r {
                    Some(h) => reach.output_sensitivity(&self.m, h),
                    None => Some(1.0), // a whole statement's value
                };
                a.output_bound = a.error_bound.zip(sensitivity).map(|(b, l)| b * l);
                a
            })
            .collect();
        Lowered { module: self.m, approximations, split_sums: self.split_sums }
    }

    /// Drops the texel statements of tables this lowering made (textures
    /// from `first` on) that no other statement reads: a rule that
    /// tabulated part of a value a later rule tabulated whole leaves one
    /// (`floor(3d)` inside `floor(3d)/3`), which would cost a pass.
    fn drop_unread_tables(&mut self, first: usize) {
        loop {
            let reads = |st: &Statement| -> Vec<u32> {
                self.m
                    .reachable(&[st.value, st.index])
                    .into_iter()
                    .filter_map(|h| match self.m.exprs[h] {
                        Expr::Lookup { texture, .. } => Some(texture),
                        _ => None,
                    })
                    .collect()
            };
            let read: std::collections::HashSet<u32> = self.m.statements.iter().flat_map(reads).collect();
            let unread = |st: &Statement| matches!(st.table, Table::Texture(t) if t as usize >= first && !read.contains(&t));
            let before = self.m.statements.len();
            let kept: Vec<Statement> = self.m.statements.iter().filter(|st| !unread(st)).cloned().collect();
            if kept.len() == before {
                return;
            }
            self.m.statements = kept.into();
        }
    }

    /// Whether the target's fragment stage is the register combiners.
    pub fn combiners(&self) -> bool {
        matches!(self.profile.fragment, crate::profile::FragmentStage::Combiners(_))
    }

    /// Every statement's value and index rebuilt bottom-up: `replace` gets
    /// each node with its operands already rebuilt and returns what stands
    /// for it, or `None` for the node itself.
    pub fn rebuild_statements(
        &mut self,
        mut replace: impl FnMut(&mut Self, &Expr, Span) -> Option<Handle<Expr>>,
    ) {
        let roots: Vec<Handle<Expr>> = self.m.statements.iter().flat_map(|st| [st.value, st.index]).collect();
        let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::new();
        for h in self.m.reachable(&roots) {
            let e = self.m.exprs[h].map_operands(|o| map.get(&o).copied().unwrap_or(o));
            let span = self.m.span(h);
            let out = replace(self, &e, span).or_else(|| self.node(e, span)).unwrap_or(h);
            map.insert(h, out);
        }
        for st in &mut self.m.statements {
            st.value = map.get(&st.value).copied().unwrap_or(st.value);
            st.index = map.get(&st.index).copied().unwrap_or(st.index);
        }
    }

    /// `value` with each largest per-sample part (not an interpolant) that
    /// `replace` rewrites replaced, top-down: where it declines, the node's
    /// operands are tried.
    pub fn top_down(&mut self, value: Handle<Expr>, replace: &mut Replace<'a>) -> Handle<Expr> {
        fn visit<'a>(
            r: &mut Rewriter<'a>,
            h: Handle<Expr>,
            replace: &mut Replace<'a>,
            done: &mut HashMap<Handle<Expr>, Handle<Expr>>,
        ) -> Handle<Expr> {
            if let Some(&to) = done.get(&h) {
                return to;
            }
            let to = if !r.m.info(h).freq.is_sample() || is_interpolant(&r.m, h) {
                h
            } else if let Some(v) = replace(r, h) {
                v
            } else {
                let e = r.m.exprs[h].clone();
                let ops: Vec<Handle<Expr>> =
                    e.operands().into_iter().map(|o| visit(r, o, replace, done)).collect();
                let mut it = ops.into_iter();
                // One rewritten operand per operand, in order (`operands`).
                let e = e.map_operands(|o| it.next().unwrap_or(o));
                r.m.intern(e, r.m.span(h)).unwrap_or(h)
            };
            done.insert(h, to);
            to
        }
        visit(self, value, replace, &mut HashMap::new())
    }

    /// A node built by a rule (`None` when it would be ill-typed).
    pub fn node(&mut self, e: Expr, span: Span) -> Option<Handle<Expr>> {
        self.m.intern(e, span).ok()
    }
}

/// A per-sample scalar operation the register combiners have no way to
/// compute and a table can: `sqrt`, division, `floor`, …
pub fn needs_table(m: &Module, h: Handle<Expr>) -> bool {
    m.info(h).ty == crate::ir::Ty::Scalar && no_combiner_op(m, h)
}

/// A per-sample operation the register combiners have no way to compute
/// (Kilgard 2000, Section 4.2: products, sums, dots, muxes and the input
/// mappings only).
pub fn no_combiner_op(m: &Module, h: Handle<Expr>) -> bool {
    if !m.info(h).freq.is_sample() {
        return false;
    }
    match &m.exprs[h] {
        Expr::Binary { op: BinaryOp::Div, .. } => reciprocal_of_divisor(m, h).is_none(),
        Expr::Binary { op: BinaryOp::Pow, rhs, .. } => match &m.exprs[*rhs] {
            Expr::Constant(c) => !(c.components[0] >= 1.0 && c.components[0].fract() == 0.0),
            _ => true,
        },
        Expr::Math { fun: MathFunction::Step, args } => !step_by_mux(m, args[0], args[1]),
        Expr::Math { fun, .. } => matches!(
            fun,
            MathFunction::Sqrt
                | MathFunction::Rsqrt
                | MathFunction::Exp
                | MathFunction::Log
                | MathFunction::Sin
                | MathFunction::Cos
                | MathFunction::Floor
                | MathFunction::Fract
                | MathFunction::Smoothstep
                | MathFunction::Sign
        ),
        _ => false,
    }
}

/// Whether `h` is a `step` per sample.
fn is_step(m: &Module, h: Handle<Expr>) -> bool {
    m.info(h).freq.is_sample() && matches!(m.exprs[h], Expr::Math { fun: MathFunction::Step, .. })
}

/// `1/k` for `x / k` with `k` a non-zero scalar constant: a product by a
/// constant, which the combiners compute (`(N·L + ½)/1.5`, wrap lighting).
pub fn reciprocal_of_divisor(m: &Module, h: Handle<Expr>) -> Option<f64> {
    let Expr::Binary { op: BinaryOp::Div, rhs, .. } = &m.exprs[h] else { return None };
    match &m.exprs[*rhs] {
        Expr::Constant(c) if c.ty == crate::ir::Ty::Scalar && c.components[0] != 0.0 => {
            Some(1.0 / c.components[0])
        }
        _ => None,
    }
}

/// Whether `step(edge, x)` is the combiners' mux: `x ≥ edge` tested as
/// `x + (½ − edge) ≥ ½` (Kilgard 2000, Section 4.2.2) — a scalar `x`
/// against a constant edge the offset reaches, or a computed edge that
/// stays at or above 0 (its HALF_BIAS_NEGATE mapping clamps below 0).
fn step_by_mux(m: &Module, edge: Handle<Expr>, x: Handle<Expr>) -> bool {
    let scalar = |h| m.info(h).ty == crate::ir::Ty::Scalar;
    match &m.exprs[edge] {
        Expr::Constant(c) => scalar(x) && (-0.5..=1.5).contains(&c.components[0]),
        _ => scalar(x) && scalar(edge) && m.info(edge).interval.lo >= 0.0,
    }
}

/// `value` as `texture`'s texel type: an rgb colour of a vector, alpha 1
/// added for rgba; `None` when it cannot be (the rule then declines).
pub fn as_texel(m: &mut Module, texture: u32, value: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let t = &m.textures[texture as usize];
    let (ty, _) = crate::ir::valid::texel_type(t.kind, t.format);
    let components = match ty {
        _ if m.info(value).ty == ty => return Some(value),
        Ty::Rgba => vec![value, m.intern(Expr::Constant(Constant::new(Ty::Scalar, &[1.0])), span).ok()?],
        _ => vec![value],
    };
    m.intern(Expr::Compose { ty, components }, span).ok()
}

/// Whether `h` reads a texture per sample (a coordinate made of it makes
/// a dependent lookup).
pub fn reads_texel(m: &Module, h: Handle<Expr>) -> bool {
    m.reachable(&[h])
        .into_iter()
        .any(|x| m.info(x).freq.is_sample() && matches!(m.exprs[x], Expr::Lookup { .. }))
}

/// Whether `h` is `δ v`: a per-vertex value interpolated to a sample.
pub fn is_interpolant(m: &Module, h: Handle<Expr>) -> bool {
    matches!(m.exprs[h], Expr::Interpolate { .. }) && m.info(h).freq == Frequency::Fragment
}
