//! How far an error at one value can move the program's output: a rule
//! states its bound at the value it replaces (an 8-bit normal is within
//! 1/255 per component), but `max(0, N·H)¹⁶` multiplies an error of `H`
//! by up to 16·3 at the pixel. The output bound of an approximation is its
//! site bound times the output's sensitivity to the site, `L`, found here
//! by first-order interval arithmetic over the lowered IR: `L` of a sum is
//! the sum of `L`s, of a product `L_a·max|b| + max|a|·L_b`, of `xⁿ`
//! `n·max|x|ⁿ⁻¹·L_x`, of `expand` `2L`, of a clamp `L` (the ranges are the
//! IR's intervals, Kilgard 2000, Section 4.2's register ranges where known).
//! Errors stored by one statement (a texture, a framebuffer) are read by
//! the next through their lookups (filtering is a convex combination).
//!
//! What has no such bound — a site inside a texture coordinate (the slope
//! of the texture is unknown), a condition, a division, `normalize` —
//! gives `None`: only a scene can measure it (`--max-error` on a scene).

use std::collections::HashMap;

use crate::ir::{BinaryOp, Expr, FbChannel, Handle, MathFunction, Module, Table, UnaryOp};
use crate::parser::ast::CombineMode;

/// Where an error is held between statements.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Store {
    Texture(u32),
    Framebuffer(u32, FbChannel),
}

/// The largest change of any framebuffer's value, per component, per unit
/// of change at `site` (`None`: unbounded or unknown).
pub fn output_sensitivity(m: &Module, site: Handle<Expr>) -> Option<f64> {
    Reach::new(m, &[site]).output_sensitivity(m, site)
}

/// Which statements each site and each store reaches, found once for all
/// of a lowering's sites, and what an error held in one store goes on to
/// do. A site's bound walks only the statements its error can move (its
/// own, and those reading a store it moved); once the site is behind it
/// and one store holds the error, the rest depends only on where and on
/// which store — every rule is linear in `L` — so it is remembered as a
/// gain and shared by the sites that reach the same state. Without it an
/// accumulation `C ← C ⊕ gᵢ` of N statements, one approximation each,
/// walked N² statements.
pub struct Reach {
    /// The statements whose value or index reaches each site.
    holding: HashMap<Handle<Expr>, Vec<usize>>,
    /// The statements reading each store.
    readers: HashMap<Store, Vec<usize>>,
    /// After statement `i`, with only `Store` holding an error: the
    /// output's change per unit of it (`None`: unbounded).
    gains: std::cell::RefCell<HashMap<(usize, Store), Option<f64>>>,
    /// Each site's bound, once found (a site shared by many statements'
    /// approximations is asked for many times).
    found: std::cell::RefCell<HashMap<Handle<Expr>, Option<f64>>>,
}

/// A state whose future is a gain: after statement `at`, `store` alone
/// holding `held`; `seen` framebuffer writes had been made before it.
struct Waypoint {
    at: usize,
    store: Store,
    held: f64,
    seen: usize,
}

/// Sorted lists of statements merged in program order, each from a cursor.
struct Pending<'a> {
    lists: Vec<&'a [usize]>,
    at: Vec<usize>,
}

impl<'a> Pending<'a> {
    fn add(&mut self, list: &'a [usize], from: usize) {
        self.lists.push(list);
        self.at.push(from);
    }

    /// The earliest statement left in any list, taken from all of them.
    fn next(&mut self) -> Option<usize> {
        let i = (0..self.lists.len()).filter_map(|k| self.lists[k].get(self.at[k]).copied()).min()?;
        for k in 0..self.lists.len() {
            if self.lists[k].get(self.at[k]) == Some(&i) {
                self.at[k] += 1;
            }
        }
        Some(i)
    }
}

impl Reach {
    pub fn new(m: &Module, sites: &[Handle<Expr>]) -> Reach {
        let sites: std::collections::HashSet<_> = sites.iter().copied().collect();
        let (mut holding, mut readers) = (HashMap::<_, Vec<usize>>::new(), HashMap::<_, Vec<usize>>::new());
        for (i, st) in m.statements.iter().enumerate() {
            for h in m.reachable(&[st.index, st.value]) {
                if sites.contains(&h) {
                    holding.entry(h).or_default().push(i);
                }
                let read = match m.exprs[h] {
                    Expr::Lookup { texture, .. } => Store::Texture(texture),
                    Expr::FramebufferRead { framebuffer, channel, .. } => {
                        Store::Framebuffer(framebuffer, channel)
                    }
                    _ => continue,
                };
                let list = readers.entry(read).or_default();
                if list.last() != Some(&i) {
                    list.push(i);
                }
            }
        }
        Reach { holding, readers, gains: Default::default(), found: Default::default() }
    }

    /// [`output_sensitivity`] of `site`, one of the sites `self` was built for.
    pub fn output_sensitivity(&self, m: &Module, site: Handle<Expr>) -> Option<f64> {
        if let Some(&l) = self.found.borrow().get(&site) {
            return l;
        }
        let l = self.walk_from(m, site);
        self.found.borrow_mut().insert(site, l);
        l
    }

    fn walk_from(&self, m: &Module, site: Handle<Expr>) -> Option<f64> {
        let holding = self.holding.get(&site).map_or(&[][..], |v| &v[..]);
        let last_holding = holding.last().copied();
        let mut stored: HashMap<Store, f64> = HashMap::new();
        // The framebuffer writes' `L`, in order (the output is their max).
        let mut writes: Vec<f64> = Vec::new();
        let mut trail: Vec<Waypoint> = Vec::new();
        // Statements in program order; one neither holding the site nor
        // reading a moved store has L = 0 and is never walked.
        let mut pending = Pending { lists: vec![holding], at: vec![0] };
        let mut woken: Vec<Store> = Vec::new();
        let mut tail: Option<Option<f64>> = None; // a remembered gain's contribution
        while let Some(i) = pending.next() {
            let step = self.step(m, site, i, &mut stored);
            let Some(write) = step else {
                tail = Some(None);
                break;
            };
            if let Some((store, l)) = write {
                if matches!(store, Store::Framebuffer(..)) {
                    writes.push(l);
                }
                if !woken.contains(&store) {
                    woken.push(store);
                    let readers = self.readers.get(&store).map_or(&[][..], |v| &v[..]);
                    pending.add(readers, readers.partition_point(|&r| r <= i));
                }
            }
            if last_holding.is_none_or(|last| i >= last) && stored.len() == 1 {
                let Some((&store, &held)) = stored.iter().next() else { break };
                if let Some(&gain) = self.gains.borrow().get(&(i, store)) {
                    tail = Some(gain.map(|g| held * g));
                    break;
                }
                trail.push(Waypoint { at: i, store, held, seen: writes.len() });
            }
        }
        self.remember(&trail, &writes, tail);
        let out = writes.iter().copied().fold(0.0f64, f64::max);
        let out = match tail {
            Some(t) => out.max(t?),
            None => out,
        };
        out.is_finite().then_some(out)
    }

    /// Walks statement `i` with the errors `stored` holds: `None` when
    /// unbounded, else the store it moved and by how much, which `stored`
    /// now holds.
    fn step(
        &self,
        m: &Module,
        site: Handle<Expr>,
        i: usize,
        stored: &mut HashMap<Store, f64>,
    ) -> Option<Option<(Store, f64)>> {
        let st = &m.statements[i];
        let mut walk = Walk { m, site, stored: &*stored, memo: HashMap::new() };
        if walk.of(st.index)? != 0.0 {
            return None; // the site moves where the statement writes
        }
        let l = walk.of(st.value)?;
        drop(walk);
        if l == 0.0 {
            return Some(None);
        }
        let store = match st.table {
            Table::Framebuffer { id, channel } => Store::Framebuffer(id, channel),
            Table::Texture(id) => Store::Texture(id),
            Table::TexCoords(_) => return None, // a coordinate: unknown slope
        };
        let held = stored.entry(store).or_insert(0.0);
        *held = held.max(l);
        Some(Some((store, l)))
    }

    /// The gains of the waypoints a walk passed: the largest later write
    /// (or the remembered `tail` it ended on) per unit held.
    fn remember(&self, trail: &[Waypoint], writes: &[f64], tail: Option<Option<f64>>) {
        let mut gains = self.gains.borrow_mut();
        let mut after = tail.unwrap_or(Some(0.0));
        let mut k = writes.len();
        for w in trail.iter().rev() {
            while k > w.seen {
                k -= 1;
                after = after.map(|a| a.max(writes[k]));
            }
            gains.entry((w.at, w.store)).or_insert(after.map(|a| a / w.held));
        }
    }
}

struct Walk<'a> {
    m: &'a Module,
    site: Handle<Expr>,
    stored: &'a HashMap<Store, f64>,
    memo: HashMap<Handle<Expr>, Option<f64>>,
}

impl Walk<'_> {
    /// `L` of `h` with respect to the site.
    fn of(&mut self, h: Handle<Expr>) -> Option<f64> {
        if h == self.site {
            return Some(1.0);
        }
        if let Some(&l) = self.memo.get(&h) {
            return l;
        }
        let l = self.node(h).filter(|l| l.is_finite());
        self.memo.insert(h, l);
        l
    }

    /// max |x| over `h`'s interval.
    fn mag(&self, h: Handle<Expr>) -> f64 {
        let iv = self.m.info(h).interval;
        iv.lo.abs().max(iv.hi.abs())
    }

    fn width(&self, h: Handle<Expr>) -> f64 {
        self.m.info(h).ty.width() as f64
    }

    fn product(&mut self, a: Handle<Expr>, b: Handle<Expr>) -> Option<f64> {
        let (la, lb) = (self.of(a)?, self.of(b)?);
        Some(nonzero(la, self.mag(b)) + nonzero(lb, self.mag(a)))
    }

    fn max_of(&mut self, hs: &[Handle<Expr>]) -> Option<f64> {
        hs.iter().try_fold(0.0f64, |acc, &h| Some(acc.max(self.of(h)?)))
    }

    fn node(&mut self, h: Handle<Expr>) -> Option<f64> {
        let e = self.m.exprs[h].clone();
        // A leaf other than the site (a constant, a vector, the pixel) is exact.
        if e.operands().is_empty() {
            return Some(0.0);
        }
        match e {
            Expr::Lookup { texture, coords } => {
                (self.of(coords)? == 0.0).then(|| self.stored_at(Store::Texture(texture)))
            }
            Expr::FramebufferRead { framebuffer, channel, position } => {
                (self.of(position)? == 0.0).then(|| self.stored_at(Store::Framebuffer(framebuffer, channel)))
            }
            Expr::Interpolate { value, .. } | Expr::Swizzle { value, .. } | Expr::Convert { value, .. } => {
                self.of(value)
            }
            Expr::Unary { op: UnaryOp::Neg, value } => self.of(value),
            Expr::FatMember { texel, .. } => self.of(texel),
            Expr::Compose { components: v, .. } | Expr::Bundle(v) => self.max_of(&v),
            Expr::Binary { op, lhs, rhs } => self.binary(op, lhs, rhs),
            Expr::Combine { mode, lhs, rhs } => match mode {
                CombineMode::Modulate => self.product(lhs, rhs),
                CombineMode::Add | CombineMode::AddSigned | CombineMode::Subtract => {
                    Some(self.of(lhs)? + self.of(rhs)?)
                }
                CombineMode::Replace => self.of(lhs),
                _ => self.unless_depends(h),
            },
            Expr::Math { fun, args } => self.math(fun, &args, h),
            Expr::Select { cond, accept, reject } => {
                if self.of(cond)? != 0.0 {
                    return None; // a step: no first-order bound
                }
                let mut ops = vec![accept];
                ops.extend(reject);
                self.max_of(&ops)
            }
            _ => self.unless_depends(h),
        }
    }

    fn binary(&mut self, op: BinaryOp, a: Handle<Expr>, b: Handle<Expr>) -> Option<f64> {
        match op {
            BinaryOp::Add | BinaryOp::Sub => Some(self.of(a)? + self.of(b)?),
            BinaryOp::Mul => self.product(a, b),
            BinaryOp::Dot => Some(self.width(a).max(self.width(b)) * self.product(a, b)?),
            BinaryOp::Pow => {
                let n = match &self.m.exprs[b] {
                    Expr::Constant(c) if c.components[0] >= 1.0 => c.components[0],
                    _ => return self.unless_depends_on(&[a, b]),
                };
                Some(nonzero(self.of(a)?, n * self.mag(a).powf(n - 1.0)))
            }
            _ => self.unless_depends_on(&[a, b]),
        }
    }

    fn math(&mut self, fun: MathFunction, args: &[Handle<Expr>], h: Handle<Expr>) -> Option<f64> {
        use MathFunction::*;
        match fun {
            // 1-Lipschitz in each argument.
            Max | Min | Clamp | Saturate | Abs => self.max_of(args),
            Expand => Some(2.0 * self.of(args[0])?),
            Compress => Some(0.5 * self.of(args[0])?),
            HalfBias => self.of(args[0]),
            Length => Some(self.width(args[0]).sqrt() * self.of(args[0])?),
            Exp => Some(nonzero(self.of(args[0])?, self.m.info(args[0]).interval.hi.exp())),
            Mix => {
                // a + (b − a)·t
                let (la, lb, lt) = (self.of(args[0])?, self.of(args[1])?, self.of(args[2])?);
                let t = self.mag(args[2]);
                let spread = self.mag(args[0]) + self.mag(args[1]);
                Some(nonzero(la, 1.0 + t) + nonzero(lb, t) + nonzero(lt, spread))
            }
            _ => self.unless_depends(h),
        }
    }

    /// 0 when `h` neither reaches the site nor reads a stored error, else
    /// unknown.
    fn unless_depends(&mut self, h: Handle<Expr>) -> Option<f64> {
        let ops = self.m.operands(h);
        self.unless_depends_on(&ops)
    }

    fn unless_depends_on(&mut self, ops: &[Handle<Expr>]) -> Option<f64> {
        for &o in ops {
            if self.of(o)? != 0.0 {
                return None;
            }
        }
        Some(0.0)
    }

    fn stored_at(&self, s: Store) -> f64 {
        self.stored.get(&s).copied().unwrap_or(0.0)
    }
}

/// `l · k`, with 0 · ∞ = 0 (an exact operand of an unbounded factor).
fn nonzero(l: f64, k: f64) -> f64 {
    if l == 0.0 {
        0.0
    } else {
        l * k
    }
}

#[cfg(test)]
mod tests {
    use super::{output_sensitivity, Reach};
    use crate::ir::{Expr, Handle, Module};

    fn module(source: &str) -> Module {
        let (program, diags) = crate::parser::check(source);
        assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
        let (m, diags) = crate::ir::lower(&program);
        assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
        m
    }

    /// The node of `m` written `text` in `source` (outer parentheses aside).
    fn at(m: &Module, source: &str, text: &str) -> Handle<Expr> {
        (0..m.exprs.len())
            .map(Handle::new)
            .find(|&h| {
                let span = m.span(h);
                let written = source.get(span.start as usize..span.end as usize).unwrap_or("");
                written == text || written.strip_prefix('(').and_then(|w| w.strip_suffix(')')) == Some(text)
            })
            .unwrap_or_else(|| panic!("no node at `{text}`"))
    }

    #[test]
    fn a_power_multiplies_an_error_of_its_base() {
        let source = "vector N : normal;\nvector H : half(0);\ntexture A : 2d rgb8 = image(\"a.png\");\n\
            C δπx ← (A δu x) * saturate((δ N s x)·(δ H s x))^16;\n";
        let m = module(source);
        // saturate(N·H) ∈ [0, 1]: d(x¹⁶)/dx ≤ 16, times the texel's ≤ 1.
        let l = output_sensitivity(&m, at(&m, source, "saturate((δ N s x)·(δ H s x))")).unwrap();
        assert!((l - 16.0).abs() < 1e-9, "{l}");
        // The texel scales a power ≤ 1.
        assert_eq!(output_sensitivity(&m, at(&m, source, "(A δu x)")), Some(1.0));
    }

    #[test]
    fn an_error_in_a_coordinate_or_a_condition_has_no_bound() {
        let source = "vector N : normal;\nvector L : light(0);\ntexture T : 1d r8 = image(\"t.png\");\n\
            C δπx ← rgb(T ((δ N s x)·(δ L s x)));\n";
        let m = module(source);
        assert_eq!(output_sensitivity(&m, at(&m, source, "(δ N s x)·(δ L s x)")), None);
        let source =
            "vector N : normal;\nvector L : light(0);\nC δπx ← rgb(((δ N s x)·(δ L s x)) > 0 ? 1 : 0);\n";
        let m = module(source);
        assert_eq!(output_sensitivity(&m, at(&m, source, "(δ N s x)·(δ L s x)")), None);
    }

    #[test]
    fn an_error_stored_in_a_texture_reaches_the_statement_reading_it() {
        let source = "texture A : 2d rgb8 = image(\"a.png\");\ntexture T : 2d rgba8;\n\
            T δu x ← rgba(0.5 * (A δu x), 1);\nC δπx ← expand((T δu x).rgb);\n";
        let m = module(source);
        // ½ stored, doubled by expand.
        assert_eq!(output_sensitivity(&m, at(&m, source, "(A δu x)")), Some(1.0));
    }

    /// Errors carried through an accumulation into `C`: each site's bound
    /// is the largest write it moves, whether found alone or through the
    /// gains other sites left behind.
    #[test]
    fn an_accumulated_error_keeps_its_bound_whichever_site_is_asked_first() {
        let source = "texture A : 2d rgb8 = image(\"a.png\");\ntexture B : 2d rgb8 = image(\"b.png\");\n\
            C δπx ← 0.5 * (A δu x);\nC δπx ← (C δπx) + 0.25 * (B δu x);\nC δπx ← 0.5 * (C δπx);\n\
            C δπx ← (C δπx) + 0.1 * (B δu x);\n";
        let m = module(source);
        let (a, b) = (at(&m, source, "(A δu x)"), at(&m, source, "(B δu x)"));
        assert_eq!(output_sensitivity(&m, a), Some(0.5));
        // B is read twice; C holds the larger of what it was given (0.25, then 0.125).
        assert_eq!(output_sensitivity(&m, b), Some(0.35));
        for order in [[a, b], [b, a]] {
            let reach = Reach::new(&m, &order);
            for site in order {
                assert_eq!(reach.output_sensitivity(&m, site), output_sensitivity(&m, site), "{order:?}");
            }
        }
    }
}
