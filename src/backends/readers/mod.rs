//! What the three NVIDIA program readers share: nvparse read `!!RC1.0`
//! (register combiners, Kilgard 2000), `!!TS1.0` (texture shaders) and
//! `!!VP1.0` (NV_vertex_program, NVIDIA 2001) with one flex scanner shape
//! — names, numbers, a little punctuation, `#`/`//`/`/* */` comments — and
//! so does shadec.
//!
//! It sits beside `combiners` and `vertex_program` rather than inside
//! either, because both use it: [`lex`] splits a text into [`lex::Token`]s
//! with byte spans (shown as `file:line:col` by the diagnostics) under a
//! per-format [`lex::Dialect`], and [`cursor::Cursor`] is the look-ahead
//! each recursive-descent parser walks, with the located `expected …`
//! errors they all report the same way.

pub mod cursor;
pub mod lex;

/// The help for a text whose header is not its first characters because a
/// comment comes first (as some loaders, e.g. the Xbox's fp20 compiler,
/// tolerate): nvparse and `LoadProgramNV` compare the text's first
/// characters with the header, so the comment must move below it. `None`
/// when `rest` (the text from its first non-blank) does not start with a
/// comment or holds none of `headers`.
pub fn comment_before_header(rest: &str, headers: &[&str]) -> Option<String> {
    if !["#", "//", "/*"].iter().any(|c| rest.starts_with(c)) {
        return None;
    }
    let found = headers.iter().filter_map(|h| rest.find(h).map(|at| (at, *h))).min()?;
    Some(format!(
        "the header must be the text's first characters (nvparse and the driver compare them): move the comment below `{}`",
        found.1
    ))
}
