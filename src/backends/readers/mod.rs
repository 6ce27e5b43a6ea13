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
