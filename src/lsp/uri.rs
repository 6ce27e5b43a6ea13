//! `file://` URIs, percent-encoded (RFC 3986 §2.1, §3.3): strict clients
//! reject a path with a raw space or `ä`, which `check --format json`
//! used to write.

use std::path::{Path, PathBuf};

/// Bytes a path segment may hold unencoded: RFC 3986's unreserved set, plus
/// `/` between segments and the sub-delimiters and `:`/`@` a segment allows.
fn is_plain(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b"-._~/!$&'()*+,;=:@".contains(&b)
}

/// Percent-encodes every byte of `text` outside the plain set.
pub fn encode_path(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for &b in text.as_bytes() {
        if is_plain(b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// Decodes `%XX` escapes; `None` when an escape is malformed or the bytes
/// are not UTF-8.
pub fn decode(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = text.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The `file://` URI of a path (made absolute), percent-encoded.
pub fn from_path(path: &Path) -> String {
    let abs = std::fs::canonicalize(path).unwrap_or_else(|_| match std::env::current_dir() {
        Ok(dir) if path.is_relative() => dir.join(path),
        _ => path.to_path_buf(),
    });
    format!("file://{}", encode_path(&abs.to_string_lossy()))
}

/// The path of a `file://` URI, decoded; `None` for other schemes.
pub fn to_path(uri: &str) -> Option<PathBuf> {
    let rest = uri.strip_prefix("file://")?;
    let path = rest.find('/').map(|i| &rest[i..])?;
    decode(path).map(PathBuf::from)
}

/// A short name for messages: the file name of a `file://` URI, else the URI.
pub fn display_name(uri: &str) -> String {
    to_path(uri)
        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_else(|| uri.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn spaces_and_umlauts_are_encoded() {
        assert_eq!(encode_path("/tmp/a b/ä.shd"), "/tmp/a%20b/%C3%A4.shd");
        assert_eq!(to_path("file:///tmp/a%20b/%C3%A4.shd"), Some(PathBuf::from("/tmp/a b/ä.shd")));
        assert!(from_path(Path::new("/tmp/a b/ä#1.shd")).parse::<lsp_types::Uri>().is_ok());
    }

    proptest! {
        #[test]
        fn encoding_round_trips_and_parses_as_a_uri(path in "(/[a-zA-Z0-9 äöü#%?\\[\\]δ←-]{1,8}){1,4}") {
            let uri = format!("file://{}", encode_path(&path));
            prop_assert!(uri.parse::<lsp_types::Uri>().is_ok(), "{uri}");
            prop_assert_eq!(to_path(&uri), Some(PathBuf::from(&path)));
        }
    }
}
