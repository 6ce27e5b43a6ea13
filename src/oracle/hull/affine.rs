//! Affine arithmetic (Comba and Stolfi 1993; Stolfi and de Figueiredo
//! 1997): a quantity is an affine form `x₀ + Σ xᵢ·εᵢ`, each noise symbol
//! `εᵢ` an unknown in [−1, 1] that every form naming it shares. Where an
//! interval forgets that two values move together — a value read twice
//! (`x − x`), the four channels of one lookup, which move with one λ — a
//! form keeps it: sums and scalings are exact, and a product keeps its
//! operands' linear parts and adds one fresh symbol for the rest. A form's
//! range (its centre plus or minus the sum of its coefficients' sizes)
//! holds every value the quantity takes for any εᵢ in [−1, 1].

use super::interval::I;

/// An affine form: the centre and each symbol's coefficient, by symbol,
/// ascending.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Affine {
    pub center: f64,
    pub terms: Vec<(u32, f64)>,
}

/// A node's four lanes, each an affine form.
pub type Form = [Affine; 4];

/// Hands out fresh noise symbols.
#[derive(Debug, Default)]
pub struct Symbols {
    next: u32,
}

impl Symbols {
    pub fn fresh(&mut self) -> u32 {
        self.next += 1;
        self.next - 1
    }
}

impl Affine {
    pub fn constant(x: f64) -> Self {
        Affine { center: x, terms: Vec::new() }
    }

    /// A quantity known only to lie in `i`: its own symbol `sym` spanning
    /// it (the whole line where `i` is not finite).
    pub fn interval(i: I, sym: u32) -> Self {
        let (lo, hi) = i;
        if lo.to_bits() == hi.to_bits() || lo == hi {
            return Affine::constant(lo);
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return Affine { center: 0.0, terms: vec![(sym, f64::INFINITY)] };
        }
        let center = 0.5 * (lo + hi);
        let radius = (hi - center).max(center - lo);
        Affine { center, terms: vec![(sym, radius)] }
    }

    pub fn is_constant(&self) -> bool {
        self.terms.is_empty()
    }

    /// The sum of the coefficients' sizes: how far the form reaches from
    /// its centre.
    pub fn radius(&self) -> f64 {
        self.terms.iter().map(|t| t.1.abs()).sum()
    }

    /// The least and greatest value the form takes, widened by a relative
    /// 10⁻¹² for the rounding of the f64 arithmetic that built it (no form
    /// here is more than a few dozen operations deep).
    pub fn range(&self) -> I {
        if self.is_constant() {
            return (self.center, self.center);
        }
        let r = self.radius();
        if !(r.is_finite() && self.center.is_finite()) {
            return (f64::NEG_INFINITY, f64::INFINITY);
        }
        let slack = 1e-12 * (self.center.abs() + r);
        (self.center - r - slack, self.center + r + slack)
    }

    /// `a·self + b·other + shift`, exact up to rounding.
    pub fn linear(&self, a: f64, other: &Affine, b: f64, shift: f64) -> Affine {
        let (x, y) = (&self.terms, &other.terms);
        let mut terms = Vec::with_capacity(x.len() + y.len());
        let (mut i, mut j) = (0, 0);
        while i < x.len() || j < y.len() {
            let (sym, c) = match (x.get(i), y.get(j)) {
                (Some(p), Some(q)) if p.0 == q.0 => {
                    (i, j) = (i + 1, j + 1);
                    (p.0, a * p.1 + b * q.1)
                }
                (Some(p), Some(q)) if p.0 > q.0 => {
                    j += 1;
                    (q.0, b * q.1)
                }
                (None, Some(q)) => {
                    j += 1;
                    (q.0, b * q.1)
                }
                (Some(p), _) => {
                    i += 1;
                    (p.0, a * p.1)
                }
                (None, None) => unreachable!("the loop ends first"),
            };
            if c != 0.0 {
                terms.push((sym, c));
            }
        }
        Affine { center: a * self.center + b * other.center + shift, terms }
    }

    pub fn add(&self, other: &Affine) -> Affine {
        self.linear(1.0, other, 1.0, 0.0)
    }

    pub fn sub(&self, other: &Affine) -> Affine {
        self.linear(1.0, other, -1.0, 0.0)
    }

    /// `k·self + shift`.
    pub fn scale(&self, k: f64, shift: f64) -> Affine {
        self.linear(k, &Affine::default(), 0.0, shift)
    }

    /// The product as Stolfi and de Figueiredo 1997 take it: the
    /// centres' product, each operand's linear part scaled by the other's
    /// centre, and the quadratic rest bounded — `xᵢyᵢεᵢ²` of a shared
    /// symbol lies between 0 and `xᵢyᵢ`, the cross terms within the
    /// product of the radii less those — its middle added to the centre
    /// and its half-width the coefficient of the fresh symbol `sym`.
    pub fn mul(&self, other: &Affine, sym: u32) -> Affine {
        if self.is_constant() {
            return other.scale(self.center, 0.0);
        }
        if other.is_constant() {
            return self.scale(other.center, 0.0);
        }
        let mut out = self.linear(other.center, other, self.center, 0.0);
        out.center = self.center * other.center;
        let (mut low, mut high, mut diagonal) = (0.0, 0.0, 0.0);
        for &(s, x) in &self.terms {
            if let Ok(k) = other.terms.binary_search_by_key(&s, |t| t.0) {
                let p = x * other.terms[k].1;
                (low, high, diagonal) = (low + p.min(0.0), high + p.max(0.0), diagonal + p.abs());
            }
        }
        let cross = (self.radius() * other.radius() - diagonal).max(0.0);
        out.center += 0.5 * (low + high);
        let error = 0.5 * (high - low) + cross;
        if error != 0.0 {
            out.terms.push((sym, error));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn form(center: f64, terms: &[(u32, f64)]) -> Affine {
        Affine { center, terms: terms.to_vec() }
    }

    /// `x − x` is 0, where intervals give twice x's width; a sum keeps
    /// each symbol once.
    #[test]
    fn a_value_read_twice_cancels() {
        let x = form(0.5, &[(0, 0.25)]);
        assert_eq!(x.sub(&x), Affine::constant(0.0));
        let y = form(1.0, &[(1, 0.5)]);
        assert_eq!(x.add(&y), form(1.5, &[(0, 0.25), (1, 0.5)]));
    }

    /// `x·(1 − x)` for x in [0.25, 0.75] lies in [0.1875, 0.25]: the
    /// product's range holds it and is narrower than the intervals'
    /// [0.0625, 0.5625].
    #[test]
    fn a_product_holds_every_value_and_keeps_the_shared_symbol() {
        let x = form(0.5, &[(0, 0.25)]);
        let p = x.mul(&x.scale(-1.0, 1.0), 1);
        let (lo, hi) = p.range();
        for k in 0..=100 {
            let e = -1.0 + 0.02 * f64::from(k);
            let v = (0.5 + 0.25 * e) * (0.5 - 0.25 * e);
            assert!(lo <= v && v <= hi, "{v} outside {lo}..{hi}");
        }
        assert!(hi - lo < 0.5 * (0.5625 - 0.0625), "{lo}..{hi}");
    }

    /// Products of independent forms hold every corner.
    #[test]
    fn a_product_of_independent_forms_holds_its_corners() {
        let (x, y) = (form(0.3, &[(0, 0.2)]), form(-0.1, &[(1, 0.4)]));
        let (lo, hi) = x.mul(&y, 2).range();
        for (a, b) in [(0.1, -0.5), (0.1, 0.3), (0.5, -0.5), (0.5, 0.3)] {
            assert!(lo <= a * b && a * b <= hi, "{} outside {lo}..{hi}", a * b);
        }
    }
}
