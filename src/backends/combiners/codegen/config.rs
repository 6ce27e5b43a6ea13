//! The last step: the scheduled, allocated operations written out as a
//! `CombinerConfig` (general stages, final combiner, constants and the
//! texture-shader program for dependent lookups), the data the validator,
//! the emulator and the `!!RC1.0` printer read.

use super::*;

impl Gen<'_> {
    /// The register a source reads in general stage `stage` (`None`: the
    /// final combiner, which reads the global constants).
    pub(super) fn register(&self, s: &Src, stage: Option<usize>) -> Register {
        match s.base {
            Base::Reg(r) => r,
            Base::V(v) => self.vregs[v].reg.expect("allocated"),
            Base::K(k) => {
                let a = &self.assigned;
                let slot = |j: usize| match stage.and_then(|st| a.local.get(st).and_then(|l| l[j])) {
                    Some(local) => local == k,
                    None => a.global[j] == Some(k),
                };
                [Register::Constant0, Register::Constant1][(0..2).find(|j| slot(*j)).expect("assigned")]
            }
        }
    }

    pub(super) fn general_input(&self, s: &Src, lane: Lane, stage: usize) -> GeneralInput {
        let usage = match (lane, s.comp) {
            (Lane::Rgb, Comp::Rgb | Comp::Bcast) => ComponentUsage::Rgb,
            (_, Comp::Alpha) => ComponentUsage::Alpha,
            (Lane::Alpha, _) => ComponentUsage::Blue,
            (Lane::Rgb, Comp::Blue) => unreachable!("fixed up by emit"),
        };
        GeneralInput::new(self.register(s, Some(stage)), s.map, usage)
    }

    pub(super) fn final_input(&self, v: FinalVal) -> FinalInput {
        match v {
            FinalVal::Ef => FinalInput::new(FinalSource::EfProduct, UnsignedIdentity, ComponentUsage::Rgb),
            FinalVal::Src(s) => {
                let usage = if s.comp == Comp::Alpha { ComponentUsage::Alpha } else { ComponentUsage::Rgb };
                FinalInput::new(FinalSource::Register(self.register(&s, None)), s.map, usage)
            }
        }
    }

    pub(super) fn build(&self, fin: &FinalSpec) -> CombinerConfig {
        let color = |k: Option<usize>| k.map(|k| &self.konsts[k]).filter(|k| k.known).map(|k| k.color);
        let mut general: Vec<GeneralStage> = (0..self.stage_used.len())
            .map(|st| {
                let local = self.assigned.local.get(st).copied().unwrap_or([None, None]);
                GeneralStage {
                    rgb: GeneralPortion::discard_all(),
                    alpha: GeneralPortion::discard_all(),
                    constant0: color(local[0]),
                    constant1: color(local[1]),
                }
            })
            .collect();
        for op in &self.ops {
            let zero = GeneralInput::new(Register::Zero, UnsignedIdentity, ComponentUsage::Alpha);
            let out = self.vregs[op.out].reg;
            if op.in_cd {
                let portion = match op.lane {
                    Lane::Rgb => &mut general[op.stage].rgb,
                    Lane::Alpha => &mut general[op.stage].alpha,
                };
                portion.c = self.general_input(&op.ab.a, op.lane, op.stage);
                portion.d = self.general_input(&op.ab.b, op.lane, op.stage);
                portion.cd_dot = op.ab.dot;
                portion.cd_output = out;
                continue;
            }
            let (c, d, cd_dot) = match op.cd {
                Some(t) => (
                    self.general_input(&t.a, op.lane, op.stage),
                    self.general_input(&t.b, op.lane, op.stage),
                    t.dot,
                ),
                None => (zero, zero, false),
            };
            let combined = op.cd.is_some() || op.mux.is_some();
            let portion = GeneralPortion {
                a: self.general_input(&op.ab.a, op.lane, op.stage),
                b: self.general_input(&op.ab.b, op.lane, op.stage),
                c,
                d,
                ab_output: if combined { None } else { out },
                cd_output: None,
                sum_output: if combined { out } else { None },
                ab_dot: op.ab.dot,
                cd_dot,
                mux_sum: op.mux.is_some(),
                scale: op.scale,
                bias: op.bias,
            };
            let stage = &mut general[op.stage];
            match op.lane {
                Lane::Rgb => stage.rgb = portion,
                Lane::Alpha => stage.alpha = portion,
            }
        }
        let g = self.final_input(FinalVal::Src(fin.g));
        let final_combiner = FinalCombiner {
            a: self.final_input(fin.a),
            b: self.final_input(fin.b),
            c: self.final_input(fin.c),
            d: self.final_input(fin.d),
            e: self.final_input(FinalVal::Src(fin.e)),
            f: self.final_input(FinalVal::Src(fin.f)),
            g: FinalInput { usage: ComponentUsage::Alpha, ..g },
            color_sum_clamp: true,
        };
        CombinerConfig {
            constant0: color(self.assigned.global[0]),
            constant1: color(self.assigned.global[1]),
            general,
            final_combiner,
            // Dependent lookups (EMBM's offset) as a `!!TS1.0` program.
            texture_shader: super::super::ts1::lower::program(self.m, self.units),
        }
    }
}
