//! What NV_texture_shader allows (its "texture shader consistency" rules,
//! as nvparse's `InstList::Validate` checks them): at most four stages; a
//! dot-product stage `KofN` follows stages `1ofN` … `(K−1)ofN` of its own
//! family; a dependent stage reads a stage before it (before the first
//! stage of its dot-product group), never stage 0 itself reading back; and
//! the stage it reads writes an RGBA result.

use std::fmt;

use crate::diag::Diagnostic;
use crate::span::Span;

use super::parser::StageSpans;
use super::program::{Operation, TextureShader, MAX_STAGES};

/// Which span of a stage an error points at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum At {
    Instruction,
    Previous,
}

/// One broken rule, at stage `stage`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TsError {
    pub code: &'static str,
    pub stage: usize,
    pub at: At,
    pub message: String,
    pub label: String,
    pub help: String,
}

impl fmt::Display for TsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "texture shader stage {}: {}", self.stage, self.message)
    }
}

impl TsError {
    /// The error as a located diagnostic: at the stage's instruction or its previous-stage
    /// argument in `spans`, else at `fallback`.
    pub fn to_diagnostic(&self, spans: &[StageSpans], fallback: Span) -> Diagnostic {
        let span = spans.get(self.stage).map_or(fallback, |s| match self.at {
            At::Previous => s.previous.unwrap_or(s.name),
            At::Instruction => s.name,
        });
        Diagnostic::error(self.code, self.message.clone(), span, self.label.clone())
            .with_help(self.help.clone())
    }
}

/// Every rule `program` breaks (empty when it is consistent).
pub fn validate(program: &TextureShader) -> Vec<TsError> {
    let mut errors = Vec::new();
    for (i, op) in program.stages.iter().enumerate() {
        if i >= MAX_STAGES {
            errors.push(TsError {
                code: "too-many-stages",
                stage: i,
                at: At::Instruction,
                message: format!(
                    "{} texture-shader stages, but the geforce3 has {MAX_STAGES} texture units",
                    program.stages.len()
                ),
                label: format!("stage {i} does not exist"),
                help: "a !!TS1.0 program has one instruction per texture unit: remove the extra ones".into(),
            });
            continue;
        }
        let group_start = group(program, i, op, &mut errors);
        if let Some(previous) = op.previous() {
            reads(program, i, op, previous as usize, group_start, &mut errors);
        }
    }
    errors
}

/// Checks that a dot-product stage `KofN` follows its family's earlier
/// stages; returns the unit its group starts at (`i` for other stages).
fn group(program: &TextureShader, i: usize, op: &Operation, errors: &mut Vec<TsError>) -> usize {
    let Operation::DotProduct { family, step, .. } = *op else { return i };
    let step = step as usize;
    if step == 0 {
        return i;
    }
    let first = format!("dot_product_{}_1of{}", family.stem(), family.stages());
    if step > i {
        errors.push(TsError {
            code: "ts-group-incomplete",
            stage: i,
            at: At::Instruction,
            message: format!("`{}` at unit {i} needs {step} earlier stage(s) of its family", op.name()),
            label: "prior stage missing".into(),
            help: format!(
                "a {}-stage dot product starts with `{first}` {step} unit(s) before this one",
                family.stages()
            ),
        });
        return i;
    }
    for k in 0..step {
        let unit = i - step + k;
        let expected = format!("dot_product_{}_{}of{}", family.stem(), k + 1, family.stages());
        let ok = matches!(program.stages[unit], Operation::DotProduct { family: f, step: s, .. } if f == family && s as usize == k);
        if !ok {
            errors.push(TsError {
                code: "ts-group-incomplete",
                stage: i,
                at: At::Instruction,
                message: format!(
                    "`{}` at unit {i} needs `{expected}` at unit {unit}, found `{}`",
                    op.name(),
                    program.stages[unit].name()
                ),
                label: "stage mismatch".into(),
                help: format!(
                    "put `{expected}` at unit {unit}: the stages of one dot product are consecutive units"
                ),
            });
            return i;
        }
    }
    i - step
}

fn reads(
    program: &TextureShader,
    i: usize,
    op: &Operation,
    previous: usize,
    group_start: usize,
    errors: &mut Vec<TsError>,
) {
    if i == 0 {
        errors.push(TsError {
            code: "ts-dependent-stage-0",
            stage: i,
            at: At::Instruction,
            message: format!("`{}` reads a previous stage, but stage 0 has none", op.name()),
            label: "stage 0 cannot be dependent".into(),
            help: "start the program with a stage that reads its own coordinates, such as `texture_2d();`"
                .into(),
        });
        return;
    }
    if previous >= group_start {
        let why = if group_start < i {
            format!("before unit {group_start}, where its dot product begins")
        } else {
            format!("before unit {i}")
        };
        errors.push(TsError {
            code: "ts-reads-later-stage",
            stage: i,
            at: At::Previous,
            message: format!(
                "`{}` at unit {i} reads `tex{previous}`, which is not an earlier stage",
                op.name()
            ),
            label: format!("must be a stage {why}"),
            help: format!(
                "a dependent stage reads the result of a stage {why}: use `tex0`..`tex{}`",
                group_start.saturating_sub(1)
            ),
        });
        return;
    }
    let read = program.stages[previous];
    if !read.has_output() {
        errors.push(TsError {
            code: "ts-reads-no-output",
            stage: i,
            at: At::Previous,
            message: format!("`{}` reads `tex{previous}`, but stage {previous} (`{}`) writes no RGBA result", op.name(), read.name()),
            label: "this stage has no output".into(),
            help: "read a stage that looks up a texture or passes its coordinates through (not `nop`, `cull_fragment` or a first dot-product stage)".into(),
        });
    }
}
