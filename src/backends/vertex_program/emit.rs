//! The per-vertex part of a pass as a `!!VP1.0` program, for the GeForce3
//! (NV_vertex_program, NVIDIA 2001): the nodes the pass's interpolants and
//! clip position reach (`PassInterface`), evaluated per vertex, as
//! instructions on at most 12 temporaries, 96 parameters and 128
//! instructions, each reading at most one attribute and one parameter
//! register.
//!
//! The binding, which the host follows when it loads the program:
//! - `v[k]` is the pass's `vertex_leaves[k]` (as `PassInterface` widens it
//!   to four components);
//! - each `c[k]` is a [`Parameter`]: a constant, a leaf the host computes
//!   per object (a uniform, a per-object vector), or one row of a
//!   projection's model → clip matrix (four consecutive registers);
//! - `o[HPOS]` is the clip position, `o[TEX0+k]` interpolant `k` (lanes past
//!   its width zero, as the evaluator's canonical layout has them).
//!
//! Every value lives in a temporary in the evaluator's canonical layout
//! (a scalar replicated, a vector's lanes past its width unused); what the
//! instructions cannot compute exactly as `ir::eval` does (transcendental
//! functions, ⊕ modes per vertex, booleans) is refused with its reason, and
//! the host computes that pass's vertices.

use std::any::Any;
use std::cell::Cell;
use std::collections::HashMap;
use std::sync::Arc;

use crate::ir::{BinaryOp, Expr, Handle, MathFunction, Module, Projection, Ty, UnaryOp};
use crate::pipeline::{PassInterface, Planned};

use super::program::*;

/// Where the value of a parameter register comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum Parameter {
    Constant([f32; 4]),
    /// A node the host evaluates once per object (a uniform, a vector of
    /// uniform frequency), in the canonical layout.
    Leaf(Handle<Expr>),
    /// Row `row` of the projection's model → clip matrix.
    Row(Projection, u8),
}

/// A pass's vertex program and how the host binds it.
#[derive(Clone, Debug, PartialEq)]
pub struct Emitted {
    pub program: VertexProgram,
    /// `c[k]` is `parameters[k]`.
    pub parameters: Vec<Parameter>,
    /// `v[k]` is `attributes[k]` (the pass's vertex leaves).
    pub attributes: Vec<Handle<Expr>>,
    /// The interpolants (δ nodes), each written to `outputs[k]`.
    pub interpolants: Vec<Handle<Expr>>,
    pub outputs: Vec<Output>,
}

/// Why a pass's vertices stay on the host.
#[derive(Clone, Debug, PartialEq)]
pub struct EmitError {
    pub node: Option<Handle<Expr>>,
    pub reason: String,
}

impl std::fmt::Display for EmitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.reason)
    }
}

fn refuse<T>(node: Option<Handle<Expr>>, reason: impl Into<String>) -> Result<T, EmitError> {
    Err(EmitError { node, reason: reason.into() })
}

/// The vertex program of pass `index` of `planned`, each interpolant
/// written where the pass's combiners read it ([`outputs_for`]).
pub fn emit_pass(planned: &Planned, index: usize) -> Result<Emitted, EmitError> {
    EMITTED.with(|n| n.set(n.get() + 1));
    let pi = PassInterface::of(planned, index);
    let outputs = outputs_for(planned, index, &pi);
    let copies = shared_coordinates(planned, index, &pi, &outputs);
    emit_with_copies(&planned.module, &pi, &outputs, &copies)
}

/// The texture units of pass `index` by the coordinates they read, each
/// with the hardware unit whose `o[TEXu]` feeds it.
fn unit_coordinates(planned: &Planned, index: usize) -> Vec<(Handle<Expr>, u8)> {
    let pass = &planned.plan.passes[index];
    // A HILO map's dot-product stages take units of their own and read
    // their interpolated vectors as those units' coordinates (planner::hilo).
    let lookups: Vec<Handle<Expr>> = pass.textures.iter().map(|t| planned.handle(t.lookup)).collect();
    let hardware = |u: u32| crate::planner::hilo::hardware_unit(&planned.module, &lookups, u as usize);
    let mut units: Vec<(Handle<Expr>, u8)> =
        pass.textures.iter().map(|t| (planned.handle(t.coords), hardware(t.unit).min(7) as u8)).collect();
    units.extend(
        crate::planner::hilo::row_units(&planned.module, &lookups).into_iter().map(|(h, u)| (h, u as u8)),
    );
    units
}

/// Units that read the same interpolated coordinates as an earlier unit
/// (a decal and a gloss map both at `δu x`): each texture unit reads its
/// own `o[TEXu]` (NV_vertex_program, Section 2.14.1.3), so the program
/// writes the value there too. `(k, o)`: interpolant `k` also goes to `o`.
pub fn shared_coordinates(
    planned: &Planned,
    index: usize,
    pi: &PassInterface,
    outputs: &[Output],
) -> Vec<(usize, Output)> {
    let mut copies = Vec::new();
    for (h, u) in unit_coordinates(planned, index) {
        let Some(k) = pi.interpolants.iter().position(|&i| i == h) else { continue };
        let o = Output::tex(u);
        if outputs.get(k) != Some(&o) && !outputs.contains(&o) && !copies.iter().any(|&(_, c)| c == o) {
            copies.push((k, o));
        }
    }
    copies
}

/// Pass `index`'s vertex program as its setup keeps it: emitted by
/// [`emit_pass`] on first use, then read by `--emit combiners` and
/// `render` alike (the pass contract: one generation per pass).
pub fn of(planned: &Planned, index: usize) -> Result<Arc<Emitted>, EmitError> {
    let kept = planned
        .setup(index)
        .vertex_program
        .get_or_init(|| Arc::new(emit_pass(planned, index).map(Arc::new)) as Arc<dyn Any + Send + Sync>);
    match kept.downcast_ref::<Result<Arc<Emitted>, EmitError>>() {
        Some(result) => result.clone(),
        None => refuse(None, "the pass's vertex program was not made by this emitter"),
    }
}

thread_local! {
    static EMITTED: Cell<usize> = const { Cell::new(0) };
}

/// How many vertex programs this thread has emitted for passes (every
/// [`emit_pass`]): what the test that each pass's program is emitted once
/// counts.
pub fn emitted_programs() -> usize {
    EMITTED.with(Cell::get)
}

/// Where each interpolant of pass `index` goes: `o[COL0]` / `o[COL1]` for
/// the combiners' primary and secondary colours, `o[TEXu]` for the
/// coordinates of texture unit `u`, else the first texture coordinate set
/// no unit reads.
pub fn outputs_for(planned: &Planned, index: usize, pi: &PassInterface) -> Vec<Output> {
    let generated = crate::backends::combiners::setup::of(planned, index).ok();
    let (primary, secondary) = generated.map_or((None, None), |g| (g.primary, g.secondary));
    let units = unit_coordinates(planned, index);
    let mut taken: Vec<Output> = units.iter().map(|(_, u)| Output::tex(*u)).collect();
    let mut out = Vec::new();
    for &h in &pi.interpolants {
        let o = if Some(h) == primary {
            Output::COL0
        } else if Some(h) == secondary {
            Output::COL1
        } else if let Some((_, u)) = units.iter().find(|(c, _)| *c == h) {
            Output::tex(*u)
        } else {
            let free = (0..8).map(Output::tex).find(|o| !taken.contains(o)).unwrap_or(Output::tex(7));
            taken.push(free);
            free
        };
        out.push(o);
    }
    out
}

/// The vertex program computing `pi`'s interpolants (into `o[TEX0]`,
/// `o[TEX1]`, … in order) and clip position.
pub fn emit(m: &Module, pi: &PassInterface) -> Result<Emitted, EmitError> {
    let outputs: Vec<Output> = (0..pi.interpolants.len().min(8)).map(|k| Output::tex(k as u8)).collect();
    emit_to(m, pi, &outputs)
}

/// The vertex program computing `pi`'s interpolants into `outputs` and its
/// clip position into `o[HPOS]`.
pub fn emit_to(m: &Module, pi: &PassInterface, outputs: &[Output]) -> Result<Emitted, EmitError> {
    emit_with_copies(m, pi, outputs, &[])
}

/// [`emit_to`], with interpolant `k` of each `(k, o)` of `copies` also
/// written to `o` ([`shared_coordinates`]).
pub fn emit_with_copies(
    m: &Module,
    pi: &PassInterface,
    outputs: &[Output],
    copies: &[(usize, Output)],
) -> Result<Emitted, EmitError> {
    if pi.vertex_leaves.len() > ATTRIBUTES {
        return refuse(
            None,
            format!(
                "the pass reads {} per-vertex inputs; a vertex program has {ATTRIBUTES} attribute registers",
                pi.vertex_leaves.len()
            ),
        );
    }
    let distinct = outputs.iter().enumerate().all(|(k, o)| !outputs[..k].contains(o));
    if pi.interpolants.len() > outputs.len() || !distinct {
        return refuse(None, format!("the pass interpolates {} values; a vertex program writes 8 texture coordinate sets and 2 colours", pi.interpolants.len()));
    }
    let mut roots: Vec<(Handle<Expr>, Option<Output>)> = Vec::new();
    for (k, &h) in pi.interpolants.iter().enumerate() {
        let value = match m.exprs[h] {
            Expr::Interpolate { value, .. } => value,
            _ => h,
        };
        roots.push((value, outputs.get(k).copied()));
        roots.extend(copies.iter().filter(|c| c.0 == k).map(|c| (value, Some(c.1))));
    }
    let mut e = Emitter::new(m, pi);
    if let Some(p) = pi.position {
        roots.push((p, Some(Output::HPOS)));
    }
    let handles: Vec<Handle<Expr>> = roots.iter().map(|r| r.0).collect();
    let nodes = post_order(m, &handles);
    for &n in &nodes {
        m.exprs[n].visit_operands(|o| *e.uses.entry(o).or_default() += 1);
    }
    for &(h, _) in &roots {
        *e.uses.entry(h).or_default() += 1;
    }
    for &n in &nodes {
        let before = e.refs;
        let src = e.node(n)?;
        // A fresh temporary holds one reference from `alloc`; a value passed
        // through (a swizzle, a negation) shares its operand's and adds one.
        if let SrcReg::Temporary(t) = src.reg {
            if before[usize::from(t)] > 0 {
                e.refs[usize::from(t)] += 1;
            }
        }
        e.values.insert(n, src);
        let operands = m.exprs[n].operands();
        for o in operands {
            e.release(o);
        }
        for &(h, out) in roots.iter().filter(|r| r.0 == n) {
            e.output(h, out)?;
            e.release(h);
        }
    }
    if pi.position.is_none() {
        let one = e.constant([0.0, 0.0, 0.0, 1.0]);
        e.op(Opcode::Mov, DstReg::Output(Output::HPOS), 15, &[one])?;
    }
    Ok(Emitted {
        program: VertexProgram { version: Version::V10, position_invariant: false, instructions: e.code },
        parameters: e.params,
        attributes: pi.vertex_leaves.clone(),
        interpolants: pi.interpolants.clone(),
        outputs: outputs.to_vec(),
    })
}

/// The nodes the roots reach, each after its operands, depth first from
/// the roots in order: a subtree is finished before the next begins, which
/// keeps few values live at once (Sethi and Ullman 1970). Iterative, so a
/// deep DAG cannot overflow the stack.
fn post_order(m: &Module, roots: &[Handle<Expr>]) -> Vec<Handle<Expr>> {
    let mut done = std::collections::HashSet::new();
    let mut out = Vec::new();
    for &r in roots {
        let mut stack = vec![(r, false)];
        while let Some((n, expanded)) = stack.pop() {
            if done.contains(&n) {
                continue;
            }
            if expanded {
                done.insert(n);
                out.push(n);
                continue;
            }
            stack.push((n, true));
            let mut ops = m.exprs[n].operands();
            ops.reverse();
            stack.extend(ops.into_iter().filter(|o| !done.contains(o)).map(|o| (o, false)));
        }
    }
    out
}

struct Emitter<'m> {
    m: &'m Module,
    pi: &'m PassInterface,
    code: Vec<Instruction>,
    params: Vec<Parameter>,
    uses: HashMap<Handle<Expr>, u32>,
    values: HashMap<Handle<Expr>, Source>,
    refs: [u32; TEMPORARIES],
    /// The node being translated, for errors.
    at: Option<Handle<Expr>>,
}

const XYZW: u8 = 15;

fn lanes(width: usize) -> u8 {
    if width <= 1 {
        XYZW
    } else {
        (1u8 << width.min(4)) - 1
    }
}

fn neg(s: Source) -> Source {
    Source { negate: !s.negate, ..s }
}

fn lane(s: Source, i: usize) -> Source {
    Source { swizzle: [s.swizzle[i & 3]; 4], ..s }
}

fn temp(t: u8) -> Source {
    Source::new(SrcReg::Temporary(t))
}

impl<'m> Emitter<'m> {
    fn new(m: &'m Module, pi: &'m PassInterface) -> Emitter<'m> {
        Emitter {
            m,
            pi,
            code: Vec::new(),
            params: Vec::new(),
            uses: HashMap::new(),
            values: HashMap::new(),
            refs: [0; TEMPORARIES],
            at: None,
        }
    }

    fn width(&self, h: Handle<Expr>) -> usize {
        self.m.info(h).ty.width()
    }

    /// A free temporary, counted as used until released by the caller.
    fn alloc(&mut self) -> Result<u8, EmitError> {
        match self.refs.iter().position(|&r| r == 0) {
            Some(t) => {
                self.refs[t] = 1;
                Ok(t as u8)
            }
            None => refuse(self.at, format!("the per-vertex values need more than the {TEMPORARIES} temporaries of a vertex program at once")),
        }
    }

    fn free(&mut self, t: u8) {
        let r = &mut self.refs[usize::from(t)];
        *r = r.saturating_sub(1);
    }

    fn release(&mut self, h: Handle<Expr>) {
        let left = self.uses.entry(h).or_default();
        *left = left.saturating_sub(1);
        if *left == 0 {
            if let Some(Source { reg: SrcReg::Temporary(t), .. }) = self.values.get(&h).copied() {
                self.free(t);
            }
        }
    }

    fn parameter(&mut self, p: Parameter) -> Result<u8, EmitError> {
        if let Some(k) = self.params.iter().position(|q| *q == p) {
            return Ok(k as u8);
        }
        if self.params.len() >= PARAMETERS {
            return refuse(
                self.at,
                format!("the per-vertex values need more than the {PARAMETERS} parameter registers"),
            );
        }
        self.params.push(p);
        Ok((self.params.len() - 1) as u8)
    }

    fn constant(&mut self, v: [f32; 4]) -> Source {
        let k = self.parameter(Parameter::Constant(v)).unwrap_or(0);
        Source::new(SrcReg::Parameter(k))
    }

    fn splat(&mut self, x: f32) -> Source {
        self.constant([x; 4])
    }

    /// Emits `op`, first moving a second attribute or parameter register to
    /// a temporary (an instruction reads at most one of each).
    fn op(&mut self, op: Opcode, dst: DstReg, mask: u8, srcs: &[Source]) -> Result<(), EmitError> {
        let mut srcs = srcs.to_vec();
        let mut scratch = Vec::new();
        let mut attribute = None;
        let mut parameter = None;
        for s in &mut srcs {
            let class = match s.reg {
                SrcReg::Attribute(_) => &mut attribute,
                SrcReg::Parameter(_) | SrcReg::Relative(_) => &mut parameter,
                SrcReg::Temporary(_) => continue,
            };
            match class {
                None => *class = Some(s.reg),
                Some(r) if *r == s.reg => {}
                Some(_) => {
                    let t = self.alloc()?;
                    self.code.push(Instruction {
                        op: Opcode::Mov,
                        dst: Dest { reg: DstReg::Temporary(t), mask: XYZW },
                        src: vec![Source::new(s.reg)],
                    });
                    s.reg = SrcReg::Temporary(t);
                    scratch.push(t);
                }
            }
        }
        self.code.push(Instruction { op, dst: Dest { reg: dst, mask }, src: srcs });
        for t in scratch {
            self.free(t);
        }
        if self.code.len() > MAX_INSTRUCTIONS {
            return refuse(self.at, format!("the per-vertex values need more than the {MAX_INSTRUCTIONS} instructions of a vertex program"));
        }
        Ok(())
    }

    fn to(&mut self, op: Opcode, t: u8, mask: u8, srcs: &[Source]) -> Result<(), EmitError> {
        self.op(op, DstReg::Temporary(t), mask, srcs)
    }

    fn output(&mut self, h: Handle<Expr>, out: Option<Output>) -> Result<(), EmitError> {
        let Some(out) = out else { return Ok(()) };
        let src = self.values[&h];
        let ty = self.m.info(h).ty;
        if out == Output::HPOS && ty == Ty::Vec2 {
            // Into a texture by its coordinates (Pipeline Grammar (15)): (2u − 1, 1 − 2v, 0, 1).
            let t = self.alloc()?;
            self.to(Opcode::Add, t, 0b11, &[src, src])?;
            let bias = self.constant([-1.0, 1.0, 0.0, 0.0]);
            let sign = Source { swizzle: [0, 1, 2, 3], ..temp(t) };
            let flip = self.constant([1.0, -1.0, 0.0, 0.0]);
            self.to(Opcode::Mul, t, 0b11, &[sign, flip])?;
            self.op(Opcode::Add, DstReg::Output(out), 0b11, &[temp(t), bias])?;
            self.free(t);
            return Ok(());
        }
        let w = ty.width();
        self.op(Opcode::Mov, DstReg::Output(out), lanes(w), &[src])?;
        if (2..4).contains(&w) {
            // A texture unit divides its (s, t, r) by q (NV_texture_shader's
            // texture_2d reads (s/q, t/q), as conventional texturing does):
            // coordinates without a q of their own get q = 1. A colour's
            // fourth component is its alpha, 0 where the value has none.
            let q = if out.is_texture() { 1.0 } else { 0.0 };
            let q = self.splat(q);
            self.op(Opcode::Mov, DstReg::Output(out), 0b1000, &[q])?;
        }
        Ok(())
    }

    fn get(&self, h: Handle<Expr>) -> Source {
        self.values.get(&h).copied().unwrap_or(Source::new(SrcReg::Parameter(0)))
    }

    /// The value of node `n`: a register with a swizzle, written by new
    /// instructions when `n` computes.
    fn node(&mut self, n: Handle<Expr>) -> Result<Source, EmitError> {
        self.at = Some(n);
        let m = self.m;
        let e = &m.exprs[n];
        let w = self.width(n);
        match e {
            Expr::Constant(c) => Ok(self.constant(crate::ir::eval::value(c).map(|x| x as f32))),
            Expr::VertexPosition(_) | Expr::TexCoord { .. } | Expr::Vector { .. } | Expr::Uniform(_) => {
                if let Some(k) = self.pi.vertex_leaves.iter().position(|&l| l == n) {
                    return Ok(Source::new(SrcReg::Attribute(k as u8)));
                }
                let k = self.parameter(Parameter::Leaf(n))?;
                Ok(Source::new(SrcReg::Parameter(k)))
            }
            Expr::Project { projection, value } => self.project(projection, *value),
            Expr::Unary { op: UnaryOp::Neg, value } => Ok(neg(self.get(*value))),
            Expr::Binary { op, lhs, rhs } => self.binary(*op, *lhs, *rhs, w),
            Expr::Math { fun, args } => self.math(*fun, args, w),
            Expr::Swizzle { value, pattern, len, .. } => {
                let s = self.get(*value);
                let len = usize::from(*len).clamp(1, 4);
                let mut sw = [0u8; 4];
                for (k, x) in sw.iter_mut().enumerate() {
                    let from = usize::from(pattern[k.min(len - 1)] & 3);
                    *x = s.swizzle[from];
                }
                if len == 1 {
                    sw = [sw[0]; 4];
                }
                Ok(Source { swizzle: sw, ..s })
            }
            Expr::Compose { components, .. } => self.compose(components),
            Expr::Convert { value, to } => {
                let s = self.get(*value);
                if m.info(*value).ty == Ty::Rgb && *to == Ty::Rgba {
                    let t = self.alloc()?;
                    self.to(Opcode::Mov, t, 0b0111, &[s])?;
                    let one = self.splat(1.0);
                    self.to(Opcode::Mov, t, 0b1000, &[one])?;
                    return Ok(temp(t));
                }
                Ok(s)
            }
            Expr::Select { cond, accept, reject: Some(reject) } => self.select(*cond, *accept, *reject),
            other => refuse(Some(n), format!("{} per vertex has no vertex-program form", describe(other))),
        }
    }

    fn project(&mut self, projection: &Projection, value: Handle<Expr>) -> Result<Source, EmitError> {
        let v = self.get(value);
        let t = self.alloc()?;
        if self.m.info(value).ty == Ty::Vec3 {
            // The sphere map of a direction (Pipeline Grammar (7)):
            // (x/m + ½, y/m + ½, 0, 0), m = 2·√(x² + y² + (z + 1)²).
            let up = self.constant([0.0, 0.0, 1.0, 0.0]);
            self.to(Opcode::Add, t, 0b0111, &[v, up])?;
            self.to(Opcode::Dp3, t, 0b1000, &[temp(t), temp(t)])?;
            self.to(Opcode::Rsq, t, 0b1000, &[lane(temp(t), 3)])?;
            let half = self.splat(0.5);
            self.to(Opcode::Mul, t, 0b1000, &[lane(temp(t), 3), half])?;
            self.to(Opcode::Mad, t, 0b0011, &[v, lane(temp(t), 3), half])?;
            let zero = self.splat(0.0);
            self.to(Opcode::Mov, t, 0b1100, &[zero])?;
            return Ok(temp(t));
        }
        let mut point = v;
        let pos_leaf = matches!(self.m.exprs[value], Expr::VertexPosition(_));
        if self.m.info(value).ty == Ty::Position && !projection.inverse && !pos_leaf {
            // A point with w = 0 is taken with w = 1 (as `scene::bind::project_by`).
            let z = self.alloc()?;
            let zero = self.splat(0.0);
            self.to(Opcode::Sge, z, 0b0001, &[lane(v, 3), zero])?;
            self.to(Opcode::Sge, z, 0b0010, &[lane(neg(v), 3), zero])?;
            self.to(Opcode::Mul, z, 0b0001, &[lane(temp(z), 0), lane(temp(z), 1)])?;
            self.to(Opcode::Mov, z, 0b0111, &[v])?;
            self.to(Opcode::Add, z, 0b1000, &[lane(v, 3), lane(temp(z), 0)])?;
            point = temp(z);
        }
        let base = self.parameter(Parameter::Row(projection.clone(), 0))?;
        for row in 1..4u8 {
            let k = self.parameter(Parameter::Row(projection.clone(), row))?;
            if k != base + row {
                return refuse(self.at, "a projection's rows are not in consecutive parameter registers");
            }
        }
        for row in 0..4u8 {
            self.to(Opcode::Dp4, t, 1 << row, &[Source::new(SrcReg::Parameter(base + row)), point])?;
        }
        if let SrcReg::Temporary(z) = point.reg {
            self.free(z);
        }
        if projection.inverse {
            // π⁻¹: divided by w.
            let r = self.alloc()?;
            self.to(Opcode::Rcp, r, XYZW, &[lane(temp(t), 3)])?;
            self.to(Opcode::Mul, t, 0b0111, &[temp(t), temp(r)])?;
            let one = self.splat(1.0);
            self.to(Opcode::Mov, t, 0b1000, &[one])?;
            self.free(r);
        }
        Ok(temp(t))
    }

    fn binary(
        &mut self,
        op: BinaryOp,
        lhs: Handle<Expr>,
        rhs: Handle<Expr>,
        w: usize,
    ) -> Result<Source, EmitError> {
        let (a, b) = (self.get(lhs), self.get(rhs));
        let t = self.alloc()?;
        let mask = lanes(w);
        match op {
            BinaryOp::Add => self.to(Opcode::Add, t, mask, &[a, b])?,
            BinaryOp::Sub => self.to(Opcode::Add, t, mask, &[a, neg(b)])?,
            BinaryOp::Mul => self.to(Opcode::Mul, t, mask, &[a, b])?,
            BinaryOp::Div => {
                self.per_lane(Opcode::Rcp, t, b, w)?;
                self.to(Opcode::Mul, t, mask, &[a, temp(t)])?;
            }
            BinaryOp::Dot => self.dot(t, a, b, self.width(lhs))?,
            BinaryOp::Pow => self.pow(t, a, b, lhs, rhs, w)?,
            BinaryOp::Lt => self.to(Opcode::Slt, t, XYZW, &[lane(a, 0), lane(b, 0)])?,
            BinaryOp::Gt => self.to(Opcode::Slt, t, XYZW, &[lane(b, 0), lane(a, 0)])?,
            BinaryOp::Le => self.to(Opcode::Sge, t, XYZW, &[lane(b, 0), lane(a, 0)])?,
            BinaryOp::Ge => self.to(Opcode::Sge, t, XYZW, &[lane(a, 0), lane(b, 0)])?,
            _ => {
                return refuse(
                    self.at,
                    format!("the operator `{op:?}` per vertex has no vertex-program form here"),
                )
            }
        }
        Ok(temp(t))
    }

    /// A scalar instruction (RCP, RSQ) on each lane of `a` into `t`.
    fn per_lane(&mut self, op: Opcode, t: u8, a: Source, w: usize) -> Result<(), EmitError> {
        if w <= 1 {
            return self.to(op, t, XYZW, &[lane(a, 0)]);
        }
        for i in 0..w.min(4) {
            self.to(op, t, 1 << i, &[lane(a, i)])?;
        }
        Ok(())
    }

    /// The dot product of `width`-lane values, replicated.
    fn dot(&mut self, t: u8, a: Source, b: Source, width: usize) -> Result<(), EmitError> {
        match width {
            4 => self.to(Opcode::Dp4, t, XYZW, &[a, b]),
            3 => self.to(Opcode::Dp3, t, XYZW, &[a, b]),
            2 => {
                self.to(Opcode::Mul, t, 0b0001, &[lane(a, 0), lane(b, 0)])?;
                self.to(Opcode::Mad, t, XYZW, &[lane(a, 1), lane(b, 1), lane(temp(t), 0)])
            }
            _ => self.to(Opcode::Mul, t, XYZW, &[a, b]),
        }
    }

    /// `a ^ b` through LIT's power, for a base ≥ 0 and an exponent the spec
    /// does not clamp (|b| < 128 − 1/256).
    fn pow(
        &mut self,
        t: u8,
        a: Source,
        b: Source,
        lhs: Handle<Expr>,
        rhs: Handle<Expr>,
        w: usize,
    ) -> Result<(), EmitError> {
        let (base, exp) = (self.m.info(lhs).interval, self.m.info(rhs).interval);
        let limit = 128.0 - 1.0 / 256.0;
        if base.lo < 0.0 || exp.lo <= -limit || exp.hi >= limit {
            return refuse(self.at, "a power per vertex is LIT's, which needs a base ≥ 0 and an exponent within ±(128 − 1/256): this one's ranges are wider");
        }
        let s = self.alloc()?;
        let one = self.splat(1.0);
        self.to(Opcode::Mov, s, 0b0001, &[one])?;
        for i in 0..w.clamp(1, 4) {
            self.to(Opcode::Mov, s, 0b0010, &[lane(a, i)])?;
            self.to(Opcode::Mov, s, 0b1000, &[lane(b, i)])?;
            self.to(Opcode::Lit, s, 0b0100, &[temp(s)])?;
            self.to(Opcode::Mov, t, if w <= 1 { XYZW } else { 1 << i }, &[lane(temp(s), 2)])?;
        }
        self.free(s);
        Ok(())
    }

    fn math(&mut self, fun: MathFunction, args: &[Handle<Expr>], w: usize) -> Result<Source, EmitError> {
        use MathFunction::*;
        let a = args.first().map(|&h| self.get(h)).unwrap_or(Source::new(SrcReg::Parameter(0)));
        let b = args.get(1).map(|&h| self.get(h)).unwrap_or(a);
        let c = args.get(2).map(|&h| self.get(h)).unwrap_or(a);
        let aw = args.first().map_or(w, |&h| self.width(h));
        let mask = lanes(w);
        let t = self.alloc()?;
        match fun {
            Normalize => {
                self.dot(t, a, a, aw)?;
                self.to(Opcode::Rsq, t, XYZW, &[lane(temp(t), 0)])?;
                self.to(Opcode::Mul, t, mask, &[a, temp(t)])?;
            }
            Length => {
                self.dot(t, a, a, aw)?;
                self.to(Opcode::Rsq, t, XYZW, &[lane(temp(t), 0)])?;
                self.to(Opcode::Rcp, t, XYZW, &[lane(temp(t), 0)])?;
            }
            Cross => {
                let s = self.alloc()?;
                let sw =
                    |x: Source, p: [u8; 4]| Source { swizzle: p.map(|k| x.swizzle[usize::from(k)]), ..x };
                self.to(Opcode::Mul, s, 0b0111, &[sw(a, [2, 0, 1, 3]), sw(b, [1, 2, 0, 3])])?;
                self.to(Opcode::Mad, t, 0b0111, &[sw(a, [1, 2, 0, 3]), sw(b, [2, 0, 1, 3]), neg(temp(s))])?;
                self.free(s);
            }
            Reflect => {
                let s = self.alloc()?;
                self.to(Opcode::Dp3, s, XYZW, &[b, a])?;
                self.to(Opcode::Add, s, XYZW, &[temp(s), temp(s)])?;
                self.to(Opcode::Mad, t, mask, &[neg(temp(s)), b, a])?;
                self.free(s);
            }
            Max => self.to(Opcode::Max, t, mask, &[a, b])?,
            Min => self.to(Opcode::Min, t, mask, &[a, b])?,
            Clamp => {
                self.to(Opcode::Max, t, mask, &[a, b])?;
                self.to(Opcode::Min, t, mask, &[temp(t), c])?;
            }
            Saturate => {
                let (zero, one) = (self.splat(0.0), self.splat(1.0));
                self.to(Opcode::Max, t, mask, &[a, zero])?;
                self.to(Opcode::Min, t, mask, &[temp(t), one])?;
            }
            Abs => self.to(Opcode::Max, t, mask, &[a, neg(a)])?,
            Rsqrt => self.per_lane(Opcode::Rsq, t, a, w)?,
            Sqrt => {
                self.per_lane(Opcode::Rsq, t, a, w)?;
                self.per_lane(Opcode::Rcp, t, temp(t), w)?;
            }
            Floor | Fract => self.fract(t, a, w, fun == Floor)?,
            Expand | HalfBias | Compress | Mix => self.remap(fun, t, [a, b, c], mask)?,
            Step => self.to(Opcode::Sge, t, mask, &[b, a])?,
            _ => {
                return refuse(
                    self.at,
                    format!(
                        "`{}` per vertex has no exact vertex-program form (EXP and LOG are approximations)",
                        format!("{fun:?}").to_lowercase()
                    ),
                )
            }
        }
        Ok(temp(t))
    }

    /// The range mappings into temporary `t` (the combiners' `expand`,
    /// `half_bias`, their inverse `compress`, and `mix`): `[a, b, c]` are the
    /// operands.
    fn remap(&mut self, fun: MathFunction, t: u8, [a, b, c]: [Source; 3], mask: u8) -> Result<(), EmitError> {
        use MathFunction::*;
        match fun {
            Expand => {
                let one = self.splat(1.0);
                self.to(Opcode::Add, t, mask, &[a, a])?;
                self.to(Opcode::Add, t, mask, &[temp(t), neg(one)])?;
            }
            HalfBias => {
                let half = self.splat(0.5);
                self.to(Opcode::Add, t, mask, &[a, neg(half)])?;
            }
            Compress => {
                let (one, half) = (self.splat(1.0), self.splat(0.5));
                self.to(Opcode::Add, t, mask, &[a, one])?;
                self.to(Opcode::Mul, t, mask, &[temp(t), half])?;
            }
            Mix => {
                let s = self.alloc()?;
                let one = self.splat(1.0);
                self.to(Opcode::Add, s, mask, &[one, neg(c)])?;
                self.to(Opcode::Mul, s, mask, &[a, temp(s)])?;
                self.to(Opcode::Mad, t, mask, &[b, c, temp(s)])?;
                self.free(s);
            }
            _ => {}
        }
        Ok(())
    }

    /// x − ⌊x⌋ from EXP's y, lane by lane; ⌊x⌋ = x − that.
    fn fract(&mut self, t: u8, a: Source, w: usize, floor: bool) -> Result<(), EmitError> {
        let s = self.alloc()?;
        for i in 0..w.clamp(1, 4) {
            self.to(Opcode::Exp, s, 0b0010, &[lane(a, i)])?;
            let m = if w <= 1 { XYZW } else { 1 << i };
            if floor {
                self.to(Opcode::Add, t, m, &[lane(a, i), neg(lane(temp(s), 1))])?;
            } else {
                self.to(Opcode::Mov, t, m, &[lane(temp(s), 1)])?;
            }
        }
        self.free(s);
        Ok(())
    }

    fn compose(&mut self, components: &[Handle<Expr>]) -> Result<Source, EmitError> {
        let t = self.alloc()?;
        let mut k = 0usize;
        for &h in components {
            let s = self.get(h);
            let cw = self.width(h);
            let mut sw = [0u8; 4];
            let mut mask = 0u8;
            for j in 0..cw {
                if k + j < 4 {
                    sw[k + j] = s.swizzle[if cw == 1 { 0 } else { j }];
                    mask |= 1 << (k + j);
                }
            }
            if mask != 0 {
                self.to(Opcode::Mov, t, mask, &[Source { swizzle: sw, ..s }])?;
            }
            k += cw;
        }
        Ok(temp(t))
    }

    /// `c ? a : b` with c's lane 0 read as true where it is not 0, as
    /// `ir::eval`: m = 0 < |c| (0 or 1), then a·m + b·(1 − m), exact.
    fn select(
        &mut self,
        cond: Handle<Expr>,
        accept: Handle<Expr>,
        reject: Handle<Expr>,
    ) -> Result<Source, EmitError> {
        let (c, a, b) = (self.get(cond), self.get(accept), self.get(reject));
        let (t, s) = (self.alloc()?, self.alloc()?);
        let zero = self.splat(0.0);
        let one = self.splat(1.0);
        self.to(Opcode::Max, s, XYZW, &[lane(c, 0), lane(neg(c), 0)])?;
        self.to(Opcode::Slt, s, XYZW, &[zero, temp(s)])?;
        self.to(Opcode::Mul, t, XYZW, &[a, temp(s)])?;
        self.to(Opcode::Add, s, XYZW, &[one, neg(temp(s))])?;
        self.to(Opcode::Mad, t, XYZW, &[b, temp(s), temp(t)])?;
        self.free(s);
        Ok(temp(t))
    }
}

fn describe(e: &Expr) -> &'static str {
    match e {
        Expr::Interpolate { .. } => "an interpolation",
        Expr::Lookup { .. } => "a texture lookup",
        Expr::Combine { .. } => "a ⊕ texture-environment combination",
        Expr::FramebufferRead { .. } => "a framebuffer read",
        Expr::Select { .. } => "a conditional without an else value",
        Expr::Unary { .. } => "a logical not",
        _ => "this value",
    }
}

/// The parameter registers' values for one object: `leaf` evaluates a
/// per-object node (canonical layout), `matrix` gives a projection's model
/// → clip matrix as rows.
pub fn parameter_values(
    emitted: &Emitted,
    mut leaf: impl FnMut(Handle<Expr>) -> [f32; 4],
    mut matrix: impl FnMut(&Projection) -> [[f32; 4]; 4],
) -> [[f32; 4]; PARAMETERS] {
    let mut c = [[0.0; 4]; PARAMETERS];
    for (k, p) in emitted.parameters.iter().enumerate().take(PARAMETERS) {
        c[k] = match p {
            Parameter::Constant(v) => *v,
            Parameter::Leaf(h) => leaf(*h),
            Parameter::Row(proj, row) => matrix(proj)[usize::from(*row) & 3],
        };
    }
    c
}

/// A leaf in the program's own words: `x`, `u x`, `N`, a uniform's name.
pub fn leaf_name(m: &Module, h: Handle<Expr>) -> String {
    let name = |v: Option<&String>| v.cloned().unwrap_or_else(|| "?".into());
    match &m.exprs[h] {
        Expr::VertexPosition(v) => name(m.vertices.get(*v as usize)),
        Expr::TexCoord { set, vertex } => format!(
            "{} {}",
            m.texcoord_sets.get(*set as usize).map_or("?", |s| s.name.as_str()),
            name(m.vertices.get(*vertex as usize))
        ),
        Expr::Vector { vector, .. } => m.vectors.get(*vector as usize).map_or("?".into(), |v| v.name.clone()),
        Expr::Uniform(u) => m.uniforms.get(*u as usize).map_or("?".into(), |u| u.name.clone()),
        _ => "a per-object value".into(),
    }
}

fn projection_name(p: &Projection) -> String {
    format!(
        "π{}{}{}",
        p.subscript.as_deref().unwrap_or(""),
        if p.star { "*" } else { "" },
        if p.inverse { "⁻¹" } else { "" }
    )
}

/// The `#` lines naming what the host loads into each register.
pub fn binding_comment(m: &Module, e: &Emitted) -> String {
    let mut out = String::new();
    let attrs: Vec<String> =
        e.attributes.iter().enumerate().map(|(k, &h)| format!("v[{k}] = {}", leaf_name(m, h))).collect();
    if !attrs.is_empty() {
        out.push_str(&format!("# {}\n", attrs.join(", ")));
    }
    let mut params = Vec::new();
    for (k, p) in e.parameters.iter().enumerate() {
        match p {
            Parameter::Constant(v) => {
                params.push(format!("c[{k}] = ({}, {}, {}, {})", v[0], v[1], v[2], v[3]))
            }
            Parameter::Leaf(h) => params.push(format!("c[{k}] = {}", leaf_name(m, *h))),
            Parameter::Row(p, 0) => {
                params.push(format!("c[{k}]..c[{}] = the rows of {}", k + 3, projection_name(p)))
            }
            Parameter::Row(..) => {}
        }
    }
    for chunk in params.chunks(4) {
        out.push_str(&format!("# {}\n", chunk.join(", ")));
    }
    let outs: Vec<String> =
        e.outputs.iter().enumerate().map(|(k, o)| format!("o[{}] = interpolant {k}", o.name())).collect();
    if !outs.is_empty() {
        out.push_str(&format!("# o[HPOS] = the clip position, {}\n", outs.join(", ")));
    }
    out
}

/// What the host computes per vertex for pass `index` where the target
/// runs no vertex program: the clip position and each interpolated value,
/// quoted from `source` where the node has a span there.
pub fn host_work(planned: &Planned, index: usize, source: Option<&str>) -> Vec<String> {
    let m = &planned.module;
    let pi = PassInterface::of(planned, index);
    let quote = |h: Handle<Expr>| -> String {
        let span = m.span(h);
        let text = source.and_then(|s| s.get(span.start as usize..span.end as usize)).unwrap_or("");
        let text: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
        if text.is_empty() {
            format!("a {} value", m.info(h).ty.name())
        } else if text.chars().count() > 60 {
            format!("`{}…`", text.chars().take(60).collect::<String>())
        } else {
            format!("`{text}`")
        }
    };
    let mut out = Vec::new();
    if let Some(p) = pi.position {
        out.push(format!("the clip position {}", quote(p)));
    }
    for &h in &pi.interpolants {
        let value = match m.exprs[h] {
            Expr::Interpolate { value, .. } => value,
            _ => h,
        };
        out.push(format!("the interpolated {}", quote(value)));
    }
    out
}

/// The per-vertex part of pass `index` as text for `compile --emit
/// combiners`: a `!!VP1.0` program where the target has vertex programs
/// and the pass's vertex values have a form, else `#` lines saying what the
/// host computes and why.
pub fn pass_text(planned: &Planned, index: usize, source: Option<&str>, title: &str) -> String {
    let target = planned.plan.target.as_str();
    // The profile says (`vertex_programs`): NV_vertex_program came with the
    // GeForce3 (NV20); the GeForce 256 and GeForce2 transformed and lit
    // vertices in fixed function, so there the host computes per vertex.
    if !planned.vertex_programs {
        let work = host_work(planned, index, source);
        if work.is_empty() {
            return String::new();
        }
        let mut out = format!("# {target} has no vertex programs (fixed-function transform and lighting): the host computes per vertex\n");
        for w in work {
            out.push_str(&format!("#   {w}\n"));
        }
        return out + "\n";
    }
    match of(planned, index) {
        Ok(e) => {
            let text = super::print(&e.program);
            let (header, rest) = text.split_once('\n').unwrap_or((&text, ""));
            format!("{header}\n{title}{}{rest}\n", binding_comment(&planned.module, &e))
        }
        Err(why) => {
            let mut out = format!("# the host computes this pass's vertices: {why}\n");
            for w in host_work(planned, index, source) {
                out.push_str(&format!("#   {w}\n"));
            }
            out + "\n"
        }
    }
}
