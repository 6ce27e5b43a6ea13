//! Go to definition, find references, rename (with prepareRename), over
//! the name index (`index.rs`). Only declared names are renamed: the
//! paper's families (`x`, `C`, `u`…) and built-ins keep their names.

use std::collections::HashMap;

use lsp_types::{Location, PrepareRenameResponse, TextEdit, Uri, WorkspaceEdit};

use super::documents::Document;
use super::index::{self, Occurrence};

/// The declaration of the name under the cursor.
pub fn definition(doc: &Document, uri: &Uri, offset: usize) -> Option<Location> {
    let occ = index::occurrences(&doc.analysis.program);
    let decl = index::at(&occ, offset)?.decl?;
    Some(Location { uri: uri.clone(), range: doc.range(decl) })
}

/// Every occurrence of the entity under the cursor.
pub fn references(doc: &Document, uri: &Uri, offset: usize, include_decl: bool) -> Vec<Location> {
    let occ = index::occurrences(&doc.analysis.program);
    let Some(decl) = index::at(&occ, offset).and_then(|o| o.decl) else { return Vec::new() };
    index::references(&occ, decl)
        .into_iter()
        .filter(|o| include_decl || !o.is_decl())
        .map(|o| Location { uri: uri.clone(), range: doc.range(o.span) })
        .collect()
}

/// The name that would be renamed, or why not.
pub fn prepare_rename(doc: &Document, offset: usize) -> Result<PrepareRenameResponse, String> {
    let occ = index::occurrences(&doc.analysis.program);
    let o = renamable(&occ, offset)?;
    Ok(PrepareRenameResponse::RangeWithPlaceholder { range: doc.range(o.span), placeholder: o.key.clone() })
}

fn renamable(occ: &[Occurrence], offset: usize) -> Result<&Occurrence, String> {
    let o = index::at(occ, offset).ok_or("there is no name here to rename")?;
    if o.decl.is_none() {
        return Err(match o.entity {
            Some(e) => format!(
                "`{}` is a {} of the language, not a declared name: it cannot be renamed",
                o.key,
                e.describe()
            ),
            None => format!("`{}` is not declared: declare it before renaming it", o.key),
        });
    }
    Ok(o)
}

/// Whether `name` can stand for a declared name: a word (letters, digits,
/// `_`, not starting with a digit), optionally with primes `'`, not a
/// keyword and not one of the paper's families.
pub fn valid_new_name(name: &str) -> Result<(), String> {
    let base = name.trim_end_matches(['\'', '′']);
    let mut chars = base.chars();
    let ok_start = chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_');
    if !ok_start || !chars.all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!(
            "`{name}` is not a name: use letters, digits and `_`, then primes `'` if you like"
        ));
    }
    if KEYWORDS.contains(&base) {
        return Err(format!("`{base}` is a keyword of the language"));
    }
    if ["x", "xs", "u", "s", "C"].contains(&base) {
        return Err(format!("`{base}` names one of the paper's families (Pipeline Grammar, Figure 2)"));
    }
    Ok(())
}

/// The grammar's reserved words (`grammar/shade.pest`, `keyword`).
pub use crate::parser::resolve::KEYWORDS;

/// Every occurrence of the entity under the cursor, renamed.
pub fn rename(doc: &Document, uri: &Uri, offset: usize, new_name: &str) -> Result<WorkspaceEdit, String> {
    valid_new_name(new_name)?;
    let occ = index::occurrences(&doc.analysis.program);
    let o = renamable(&occ, offset)?;
    let Some(decl) = o.decl else { return Err(format!("`{}` has no declaration to rename", o.key)) };
    if occ.iter().any(|x| x.key == new_name && x.decl.is_some() && x.decl != Some(decl)) {
        return Err(format!("`{new_name}` is already declared"));
    }
    let edits = index::references(&occ, decl)
        .into_iter()
        .map(|o| TextEdit { range: doc.range(o.span), new_text: new_name.to_string() })
        .collect();
    Ok(WorkspaceEdit { changes: Some(HashMap::from([(uri.clone(), edits)])), ..Default::default() })
}
