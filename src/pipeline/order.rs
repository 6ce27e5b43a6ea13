//! The order a plan's passes are drawn in: pass by pass over every object,
//! except the groups drawn object by object (`Pass::object_major`). Every
//! executor draws in this order.

use super::plan::{Geometry, PassPlan};

/// One draw of a plan: pass `pass` over `objects` (indices into the
/// scene's objects; `None`: every object, or the pass's rectangle).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Draw {
    pub pass: usize,
    pub objects: Option<Vec<usize>>,
    /// The pass's first draw (an object-major pass is drawn once per object).
    pub first: bool,
}

impl PassPlan {
    /// The plan's draws on a scene of `n_objects` objects, in order: a pass
    /// over the objects it draws (`Pass::objects`), then the next; a run of
    /// adjacent mesh passes with the same `Pass::object_major` group drawn
    /// one object at a time — all of the run's passes for object 0, then
    /// for object 1, … — each pass only for the objects it draws.
    pub fn draws(&self, n_objects: usize) -> Vec<Draw> {
        let passes = &self.passes;
        let mut out = Vec::with_capacity(passes.len());
        let mut i = 0;
        while i < passes.len() {
            let group =
                passes[i].object_major.filter(|_| matches!(passes[i].geometry, Geometry::Mesh { .. }));
            let Some(group) = group else {
                out.push(Draw { pass: i, objects: passes[i].objects.clone(), first: true });
                i += 1;
                continue;
            };
            let end = (i..passes.len())
                .find(|&k| {
                    passes[k].object_major != Some(group)
                        || !matches!(passes[k].geometry, Geometry::Mesh { .. })
                })
                .unwrap_or(passes.len());
            let mut first = vec![true; end - i];
            for object in 0..n_objects {
                for k in i..end {
                    if passes[k].objects.as_ref().is_some_and(|keep| !keep.contains(&object)) {
                        continue;
                    }
                    out.push(Draw { pass: k, objects: Some(vec![object]), first: first[k - i] });
                    first[k - i] = false;
                }
            }
            // A pass that drew no object still runs once (its target is made).
            for k in i..end {
                if first[k - i] {
                    out.push(Draw { pass: k, objects: Some(Vec::new()), first: true });
                }
            }
            i = end;
        }
        out
    }
}
