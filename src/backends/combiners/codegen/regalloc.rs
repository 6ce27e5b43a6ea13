//! Step 4 of the generator: virtual registers get `spare0`, `spare1`, or a
//! texture/colour register whose own value is no longer read, by live
//! interval; the mux's select value is pinned to `spare0.a`.

use super::*;

impl Gen<'_> {
    pub(super) fn allocate(&mut self, fin: &FinalSpec) -> R<()> {
        let n = self.stage_used.len();
        let lane_of = |s: &Src| match s.comp {
            Comp::Alpha => Lane::Alpha,
            _ => Lane::Rgb,
        };
        // Last read of every virtual register and of every input register lane.
        let mut last = vec![0usize; self.vregs.len()];
        let mut phys: HashMap<(Register, Lane), usize> = HashMap::new();
        let mut read = |s: &Src, stage: usize, last: &mut Vec<usize>| match s.base {
            Base::V(v) => last[v] = last[v].max(stage),
            // Constant registers are read-only: nothing to allocate.
            Base::K(_) => {}
            Base::Reg(r) => {
                let e = phys.entry((r, lane_of(s))).or_insert(stage);
                *e = (*e).max(stage);
            }
        };
        for op in &self.ops {
            let mut srcs = vec![op.ab.a, op.ab.b];
            if let Some(cd) = op.cd {
                srcs.extend([cd.a, cd.b]);
            }
            srcs.extend(op.mux);
            for s in &srcs {
                read(s, op.stage, &mut last);
            }
        }
        for v in [fin.a, fin.b, fin.c, fin.d] {
            if let FinalVal::Src(s) = v {
                read(&s, n, &mut last);
            }
        }
        for s in [fin.e, fin.f, fin.g] {
            read(&s, n, &mut last);
        }
        let def: Vec<usize> = self.vregs.iter().map(|v| self.ops[v.op].stage).collect();
        for (i, l) in last.iter_mut().enumerate() {
            *l = (*l).max(def[i] + 1);
        }
        let mut candidates = vec![Register::Spare0, Register::Spare1];
        for u in 0..self.limits.texture_units.min(4) {
            candidates.push(Register::texture(u).expect("unit < 4"));
        }
        candidates.extend([Register::Primary, Register::Secondary]);
        let mut order: Vec<usize> = (0..self.vregs.len()).collect();
        order.sort_by_key(|&v| (self.vregs[v].pin.is_none(), def[v], v));
        let mut taken: Vec<(Register, Lane, usize, usize)> = Vec::new();
        for v in order {
            let lane = self.vregs[v].lane;
            let (d, l) = (def[v], last[v]);
            let free = |r: Register| {
                let phys_ok = match r {
                    Register::Spare0 | Register::Spare1 => true,
                    _ => phys.get(&(r, lane)).is_none_or(|&u| u <= d),
                };
                phys_ok && taken.iter().all(|&(tr, tl, td, tu)| tr != r || tl != lane || tu <= d || l <= td)
            };
            let reg = match self.vregs[v].pin {
                Some(p) if free(p) => p,
                Some(_) => {
                    return Err(CodegenError::OutOfRegisters { span: self.ops[self.vregs[v].op].span })
                }
                None => *candidates
                    .iter()
                    .find(|r| free(**r))
                    .ok_or(CodegenError::OutOfRegisters { span: self.ops[self.vregs[v].op].span })?,
            };
            taken.push((reg, lane, d, l));
            self.vregs[v].reg = Some(reg);
        }
        Ok(())
    }
}
