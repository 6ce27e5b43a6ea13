//! `textDocument/formatting` and the ASCII ↔ Unicode conversions: the
//! canonical printer `shadec fmt` uses (`parser::print`). The printer keeps
//! comments (`ast::Comments`); as a guard, a document whose comments would
//! not all survive — checked by comparing them before and after — is refused
//! with a message, never rewritten with comments lost.

use crate::parser::{self, print};

/// The document printed in `style`, or why it cannot be.
pub fn print_document(text: &str, style: print::Style) -> Result<String, String> {
    let (program, diagnostics) = parser::parse(text);
    if let Some(d) = diagnostics.iter().find(|d| d.is_error()) {
        return Err(format!(
            "the document has syntax errors (the first: {}); fix them before formatting",
            d.message
        ));
    }
    let out = print::program(&program, style);
    let (before, after) = (comments(text), comments(&out));
    if before != after {
        return Err(format!(
            "formatting would lose or move comments ({} before, {} after); the document was left as it is",
            before.len(),
            after.len()
        ));
    }
    Ok(out)
}

/// The comments of a text (`//`, `#`, `/* */`, outside strings), trimmed, in order.
pub fn comments(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find(['"', '/', '#']) {
        let tail = &rest[i..];
        if let Some(string) = tail.strip_prefix('"') {
            let end = string.find('"').map_or(tail.len(), |j| j + 2);
            rest = &tail[end..];
        } else if tail.starts_with("//") || tail.starts_with('#') {
            let end = tail.find('\n').unwrap_or(tail.len());
            out.push(tail[..end].trim().to_string());
            rest = &tail[end..];
        } else if tail.starts_with("/*") {
            let end = tail.find("*/").map_or(tail.len(), |j| j + 2);
            out.push(tail[..end].trim().to_string());
            rest = &tail[end..];
        } else {
            rest = &tail[1..];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_printer_keeps_comments() {
        let text =
            "// lead\ntexture T : 2d = image(\"a#b.png\"); # trailing\n/* block */\nC δπx ← T δu x; // end\n";
        let out = print_document(text, print::Style::Ascii).unwrap();
        assert_eq!(comments(&out), comments(text), "{out}");
        assert_eq!(comments(text), ["// lead", "# trailing", "/* block */", "// end"]);
    }
}
