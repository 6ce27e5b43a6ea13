//! JSON-RPC 2.0 over `Content-Length` frames, read so that no byte sequence
//! ends the session. `lsp-server`'s reader stops at the first
//! bad frame and cannot resynchronize, so the framing is ours (it is small);
//! the messages are still `lsp-types`'.
//!
//! What the reader does with what a careless client sends:
//!
//! - bytes before a `Content-Length:` header that are not headers (the rest
//!   of a frame whose length was short, noise) are skipped, and the reader
//!   goes on at the next `Content-Length:`; a header block without one is
//!   reported and skipped the same way;
//! - a body that is not JSON, or ends before its JSON does (a length a few
//!   bytes short), or nests deeper than `serde_json`'s 128 levels, is a
//!   parse error (-32700, id null); a JSON array (a batch, which LSP does not
//!   have) or an object that is not a request, notification or response is
//!   an invalid request (-32600) — the server answers and goes on;
//! - a body holding a whole message followed by more bytes (a length a few
//!   bytes long swallows the start of the next header) is that message, and
//!   the rest goes back to be read as the next frame; a length that promises
//!   bytes that never come is found the same way once the input pauses;
//! - bytes that are not UTF-8 and `\ud800`-style escapes of lone surrogates
//!   (valid JSON that JavaScript clients produce, which `serde_json` refuses)
//!   become U+FFFD, which the analysis reports where it stands;
//! - a frame longer than [`MAX_FRAME`] is refused and skipped without being
//!   held in memory.

use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::Duration;

use serde_json::Value;

/// The largest frame the server reads: 64 MiB, room for a source at the
/// compiler's own limit (`io::MAX_SOURCE_BYTES`) with JSON escapes.
pub const MAX_FRAME: usize = 64 << 20;

/// Header blocks longer than this are noise, not headers.
const MAX_HEADER: usize = 8 << 10;

/// How long the input may pause inside a body before the reader looks for a
/// whole message in what came (a `Content-Length` that was too long).
const PAUSE: Duration = Duration::from_millis(150);

/// JSON-RPC 2.0's codes for what could not be read.
pub const PARSE_ERROR: i32 = -32700;
/// JSON-RPC 2.0's code for a message that is JSON but no request.
pub const INVALID_REQUEST: i32 = -32600;

/// One thing read from the client.
#[derive(Clone, Debug, PartialEq)]
pub enum Incoming {
    Request {
        id: Value,
        method: String,
        params: Value,
    },
    Notification {
        method: String,
        params: Value,
    },
    /// A response to a request of ours (the server sends none): ignored.
    Response,
    /// What could not be read as a message: answered with this error (id
    /// null unless the message had a valid one) and the session goes on.
    Invalid {
        id: Value,
        code: i32,
        message: String,
    },
}

/// Where the reader's bytes come from.
pub trait Source {
    /// More bytes; `None` at the end of input. With `pause`, `Some(empty)`
    /// when nothing came in that time.
    fn more(&mut self, pause: Option<Duration>) -> Option<Vec<u8>>;
}

/// Chunks from a thread that reads standard input.
impl Source for Receiver<Vec<u8>> {
    fn more(&mut self, pause: Option<Duration>) -> Option<Vec<u8>> {
        match pause {
            None => self.recv().ok(),
            Some(t) => match self.recv_timeout(t) {
                Ok(v) => Some(v),
                Err(RecvTimeoutError::Timeout) => Some(Vec::new()),
                Err(RecvTimeoutError::Disconnected) => None,
            },
        }
    }
}

/// All the bytes at once (tests): never pauses.
impl Source for std::vec::IntoIter<Vec<u8>> {
    fn more(&mut self, _: Option<Duration>) -> Option<Vec<u8>> {
        self.next()
    }
}

/// Reads messages from a [`Source`].
pub struct Reader<S> {
    source: S,
    buf: Vec<u8>,
    pos: usize,
    eof: bool,
    /// The last frame failed: the bytes up to the next header are its rest
    /// and need no second error.
    after_error: bool,
}

const CONTENT_LENGTH: &[u8] = b"content-length:";

impl<S: Source> Reader<S> {
    /// A reader of `source`, nothing read yet.
    pub fn new(source: S) -> Reader<S> {
        Reader { source, buf: Vec::new(), pos: 0, eof: false, after_error: false }
    }

    /// Reads more bytes; false at the end of input (or, with a pause, when
    /// nothing came).
    fn fill(&mut self, pause: Option<Duration>) -> bool {
        if self.eof {
            return false;
        }
        match self.source.more(pause) {
            // Nothing in the pause; without one, an empty chunk is no news.
            Some(chunk) if chunk.is_empty() => pause.is_none() && self.fill(None),
            Some(chunk) => {
                self.buf.extend_from_slice(&chunk);
                true
            }
            None => {
                self.eof = true;
                false
            }
        }
    }

    /// The next message, or `None` at the end of input.
    pub fn next_message(&mut self) -> Option<Incoming> {
        loop {
            if let Some(incoming) = self.next_frame()? {
                return Some(incoming);
            }
        }
    }

    /// One step: `Some(None)` when bytes were consumed with nothing to say.
    fn next_frame(&mut self) -> Option<Option<Incoming>> {
        // Drop what was read (here only: below, offsets into `buf` are held).
        if self.pos > (1 << 16) && self.pos * 2 > self.buf.len() {
            self.buf.drain(..self.pos);
            self.pos = 0;
        }
        // Find the next `Content-Length:`, reading as needed.
        let at = loop {
            if let Some(i) = find_ci(&self.buf[self.pos..], CONTENT_LENGTH) {
                break self.pos + i;
            }
            // Keep what might be the start of the header; the rest is noise.
            let keep = self.buf.len().saturating_sub(CONTENT_LENGTH.len()).max(self.pos);
            if keep - self.pos > MAX_HEADER {
                let skipped = self.skip_to(keep);
                if let Some(e) = skipped {
                    return Some(Some(e));
                }
            }
            if !self.fill(None) {
                let rest = self.skip_to(self.buf.len());
                return rest.map(Some);
            }
        };
        if let Some(e) = self.skip_to(at) {
            return Some(Some(e));
        }
        // The header block ends at a blank line.
        let (end, body_start) = loop {
            if let Some(found) = header_end(&self.buf[at..]) {
                break (at + found.0, at + found.1);
            }
            if self.buf.len() - at > MAX_HEADER || !self.fill(None) {
                self.pos = at + CONTENT_LENGTH.len();
                self.after_error = true;
                return Some(Some(parse_error(
                    "a header that never ends (no blank line after `Content-Length`)",
                )));
            }
        };
        let line_end = self.buf[at..end].iter().position(|&b| b == b'\n').map_or(end, |i| at + i);
        let value =
            String::from_utf8_lossy(&self.buf[at + CONTENT_LENGTH.len()..line_end]).trim().to_string();
        self.pos = body_start;
        let Ok(length) = value.parse::<usize>() else {
            self.after_error = true;
            return Some(Some(parse_error(&format!(
                "`Content-Length: {}` is not a length in bytes",
                escape_for_message(&value)
            ))));
        };
        if length > MAX_FRAME {
            self.discard(length);
            self.after_error = true;
            return Some(Some(parse_error(&format!(
                "a frame of {length} bytes is over the server's limit of {MAX_FRAME} bytes; it was skipped"
            ))));
        }
        // The body: wait for it, unless the input pauses with a whole
        // message already there (the length was too long).
        while self.buf.len() < body_start + length {
            let paused = !self.fill(Some(PAUSE));
            if paused {
                if let Some(Decoded::Value(v, used)) =
                    decode(&self.buf[body_start..]).filter(|d| d.is_value())
                {
                    self.pos = body_start + used;
                    self.after_error = false;
                    return Some(Some(classify(v)));
                }
                if self.eof {
                    self.pos = self.buf.len();
                    return Some(Some(parse_error("the input ended inside a frame's body")));
                }
                if !self.fill(None) && self.eof {
                    continue;
                }
            }
        }
        Some(Some(self.body(body_start, length)))
    }

    /// The message of a whole body of `length` bytes at `body_start`, and
    /// where the next frame starts.
    fn body(&mut self, body_start: usize, length: usize) -> Incoming {
        let body = &self.buf[body_start..body_start + length];
        match decode(body) {
            Some(Decoded::Value(v, used)) => {
                // Trailing bytes that are not blank: the length was long and
                // they belong to the next frame.
                let rest_blank = body[used..].iter().all(u8::is_ascii_whitespace);
                self.pos = if rest_blank { body_start + length } else { body_start + used };
                self.after_error = false;
                classify(v)
            }
            Some(Decoded::Error(message)) => {
                self.pos = body_start + length;
                self.after_error = true;
                parse_error(&message)
            }
            None => {
                self.pos = body_start + length;
                self.after_error = true;
                parse_error("the message ends before its JSON does (is its Content-Length short?)")
            }
        }
    }

    /// Moves to `to`, reporting what was skipped if it was more than blank
    /// lines or header lines.
    fn skip_to(&mut self, to: usize) -> Option<Incoming> {
        let skipped = &self.buf[self.pos..to];
        self.pos = to;
        if skipped.iter().all(u8::is_ascii_whitespace) || is_header_lines(skipped) {
            return None;
        }
        if std::mem::take(&mut self.after_error) {
            return None;
        }
        let what = if header_end(skipped).is_some() && is_header_lines(&skipped[..header_end(skipped)?.0]) {
            "a frame's header has no `Content-Length`; the frame was skipped".to_string()
        } else {
            format!("{} bytes that are not a framed message were skipped", skipped.len())
        };
        Some(parse_error(&what))
    }

    /// Skips `n` bytes after `pos` without holding them.
    fn discard(&mut self, mut n: usize) {
        loop {
            let here = (self.buf.len() - self.pos).min(n);
            self.pos += here;
            n -= here;
            if n == 0 {
                return;
            }
            self.buf.clear();
            self.pos = 0;
            if !self.fill(None) {
                return;
            }
        }
    }
}

fn parse_error(message: &str) -> Incoming {
    Incoming::Invalid { id: Value::Null, code: PARSE_ERROR, message: format!("parse error: {message}") }
}

fn invalid(id: Value, message: &str) -> Incoming {
    Incoming::Invalid { id, code: INVALID_REQUEST, message: format!("invalid request: {message}") }
}

/// A message's JSON as JSON-RPC 2.0 reads it.
pub fn classify(v: Value) -> Incoming {
    let Value::Object(mut o) = v else {
        return invalid(
            Value::Null,
            if v.is_array() {
                "a JSON array (a batch) is not part of the language server protocol: send each message in its own frame"
            } else {
                "a message is a JSON object"
            },
        );
    };
    let id = match o.remove("id") {
        None => None,
        Some(id @ (Value::Number(_) | Value::String(_))) => Some(id),
        Some(_) => return invalid(Value::Null, "`id` must be a number or a string"),
    };
    if o.get("jsonrpc").and_then(Value::as_str) != Some("2.0") {
        return invalid(id.unwrap_or(Value::Null), "`jsonrpc` must be \"2.0\"");
    }
    let params = o.remove("params").unwrap_or(Value::Null);
    match (o.remove("method"), id) {
        (Some(Value::String(method)), Some(id)) => Incoming::Request { id, method, params },
        (Some(Value::String(method)), None) => Incoming::Notification { method, params },
        (Some(_), id) => invalid(id.unwrap_or(Value::Null), "`method` must be a string"),
        (None, Some(_)) if o.contains_key("result") || o.contains_key("error") => Incoming::Response,
        (None, id) => {
            invalid(id.unwrap_or(Value::Null), "an object with neither `method` nor `result`/`error`")
        }
    }
}

enum Decoded {
    /// A value, and the bytes it took.
    Value(Value, usize),
    /// Not JSON (beyond a missing end).
    Error(String),
}

impl Decoded {
    fn is_value(&self) -> bool {
        matches!(self, Decoded::Value(..))
    }
}

/// The first JSON value in `body`, after mending lone surrogate escapes and
/// bytes that are not UTF-8 into U+FFFD; `None` when the JSON is cut short.
fn decode(body: &[u8]) -> Option<Decoded> {
    // Find where the value ends on a copy of the same length: bad bytes as
    // `?`, lone surrogates as `\ufffd` (six bytes for six).
    let mut same_length = body.to_vec();
    let utf8_ok = mend_utf8_in_place(&mut same_length);
    mend_surrogates(&mut same_length);
    let mut stream = serde_json::Deserializer::from_slice(&same_length).into_iter::<Value>();
    let value = match stream.next()? {
        Ok(v) => v,
        Err(e) if e.is_eof() => return None,
        Err(e) => return Some(Decoded::Error(format!("the body is not JSON: {e}"))),
    };
    let used = stream.byte_offset();
    if utf8_ok {
        return Some(Decoded::Value(value, used));
    }
    // Decode again with the bad bytes as U+FFFD rather than `?`.
    let mut text = String::from_utf8_lossy(&body[..used]).into_owned().into_bytes();
    mend_surrogates(&mut text);
    match serde_json::from_slice(&text) {
        Ok(v) => Some(Decoded::Value(v, used)),
        Err(e) => Some(Decoded::Error(format!("the body is not JSON: {e}"))),
    }
}

/// Replaces each byte of an invalid UTF-8 sequence by `?`; whether there
/// was none.
fn mend_utf8_in_place(bytes: &mut [u8]) -> bool {
    let mut ok = true;
    let mut at = 0;
    while at < bytes.len() {
        match std::str::from_utf8(&bytes[at..]) {
            Ok(_) => break,
            Err(e) => {
                ok = false;
                let bad_start = at + e.valid_up_to();
                let bad_len = e.error_len().unwrap_or(bytes.len() - bad_start);
                bytes[bad_start..bad_start + bad_len].fill(b'?');
                at = bad_start + bad_len;
            }
        }
    }
    ok
}

/// Rewrites `\uD800`–`\uDFFF` escapes that are not a high surrogate
/// followed by a low one as `\uFFFD`, in place (same length). Escaped
/// backslashes (`\\ud800`, a backslash and text) are left alone.
pub fn mend_surrogates(json: &mut [u8]) {
    let hex = |b: &[u8]| -> Option<u16> { u16::from_str_radix(std::str::from_utf8(b).ok()?, 16).ok() };
    let escape_at = |json: &[u8], i: usize| -> Option<u16> {
        (json.get(i..i + 2)? == b"\\u").then_some(())?;
        hex(json.get(i + 2..i + 6)?)
    };
    let mut i = 0;
    while i < json.len() {
        if json[i] != b'\\' {
            i += 1;
            continue;
        }
        match escape_at(json, i) {
            Some(high @ 0xD800..=0xDBFF) => {
                let _ = high;
                if matches!(escape_at(json, i + 6), Some(0xDC00..=0xDFFF)) {
                    i += 12;
                } else {
                    json[i + 2..i + 6].copy_from_slice(b"fffd");
                    i += 6;
                }
            }
            Some(0xDC00..=0xDFFF) => {
                json[i + 2..i + 6].copy_from_slice(b"fffd");
                i += 6;
            }
            Some(_) => i += 6,
            // `\\`, `\"`, …: two bytes.
            None => i += 2,
        }
    }
}

/// The end of the header block (its blank line) and the start of the body.
fn header_end(bytes: &[u8]) -> Option<(usize, usize)> {
    let crlf = find_ci(bytes, b"\r\n\r\n").map(|i| (i, i + 4));
    let lf = find_ci(bytes, b"\n\n").map(|i| (i, i + 2));
    match (crlf, lf) {
        (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
        (a, b) => a.or(b),
    }
}

/// Whether `bytes` are `Name: value` lines (headers before
/// `Content-Length`, such as `Content-Type`).
fn is_header_lines(bytes: &[u8]) -> bool {
    let text = String::from_utf8_lossy(bytes);
    let lines: Vec<&str> =
        text.split('\n').map(|l| l.trim_end_matches('\r')).filter(|l| !l.is_empty()).collect();
    !lines.is_empty()
        && lines.iter().all(|l| {
            l.split_once(':').is_some_and(|(name, _)| {
                !name.is_empty() && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-')
            })
        })
        && !bytes.windows(2).any(|w| w == b"\n\n")
        && !bytes.windows(4).any(|w| w == b"\r\n\r\n")
}

/// The first occurrence of `needle` (ASCII, lowercase) in `hay`, ignoring
/// ASCII case.
fn find_ci(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w.eq_ignore_ascii_case(needle))
}

/// Text from the client made safe to quote: control characters escaped,
/// at most 80 characters.
fn escape_for_message(s: &str) -> String {
    let mut out: String = s.chars().take(80).flat_map(char::escape_debug).collect();
    if s.chars().count() > 80 {
        out.push('…');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(body: &str) -> Vec<u8> {
        format!("Content-Length: {}\r\n\r\n{body}", body.len()).into_bytes()
    }

    fn read_all(chunks: Vec<Vec<u8>>) -> Vec<Incoming> {
        let mut r = Reader::new(chunks.into_iter());
        std::iter::from_fn(|| r.next_message()).collect()
    }

    const HOVER: &str = r#"{"jsonrpc":"2.0","id":7,"method":"textDocument/hover","params":{}}"#;

    fn is_hover(i: &Incoming) -> bool {
        matches!(i, Incoming::Request { id, method, .. } if *id == 7 && method == "textDocument/hover")
    }

    fn code(i: &Incoming) -> Option<i32> {
        match i {
            Incoming::Invalid { code, .. } => Some(*code),
            _ => None,
        }
    }

    #[test]
    fn bad_frames_are_errors_and_the_next_frame_is_read() {
        let cases: Vec<(&str, Vec<u8>, i32)> = vec![
            ("not JSON", frame("{nope"), PARSE_ERROR),
            ("a batch", frame(&format!("[{HOVER}]")), INVALID_REQUEST),
            ("a number", frame("5"), INVALID_REQUEST),
            ("no jsonrpc", frame(r#"{"id":1,"method":"x"}"#), INVALID_REQUEST),
            ("an object id", frame(r#"{"jsonrpc":"2.0","id":{},"method":"x"}"#), INVALID_REQUEST),
            ("too deep", frame(&format!("{}{}", "[".repeat(200), "]".repeat(200))), PARSE_ERROR),
            (
                "short length",
                {
                    let mut f = format!("Content-Length: {}\r\n\r\n", HOVER.len() - 3).into_bytes();
                    f.extend_from_slice(HOVER.as_bytes());
                    f
                },
                PARSE_ERROR,
            ),
            ("no Content-Length", format!("Content-Type: x\r\n\r\n{HOVER}").into_bytes(), PARSE_ERROR),
            ("noise", b"garbage\x00\xff".to_vec(), PARSE_ERROR),
            ("bad length", b"Content-Length: lots\r\n\r\n{}".to_vec(), PARSE_ERROR),
        ];
        for (what, bad, expected) in cases {
            let got = read_all(vec![bad, frame(HOVER)]);
            assert_eq!(code(&got[0]), Some(expected), "{what}: {got:?}");
            assert!(is_hover(got.last().unwrap()), "{what}: {got:?}");
            assert_eq!(got.len(), 2, "{what}: {got:?}");
        }
    }

    #[test]
    fn a_long_length_gives_the_message_and_the_next_one() {
        let mut f = format!("Content-Length: {}\r\n\r\n{HOVER}", HOVER.len() + 5).into_bytes();
        f.extend(frame(HOVER));
        let got = read_all(vec![f]);
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(got.iter().all(is_hover), "{got:?}");
    }

    #[test]
    fn frames_split_anywhere_read_the_same() {
        let mut all = frame(HOVER);
        all.extend(b"Content-Type: application/vscode-jsonrpc; charset=utf-8\r\n");
        all.extend(frame(HOVER));
        for cut in 0..all.len() {
            let got = read_all(vec![all[..cut].to_vec(), all[cut..].to_vec()]);
            assert_eq!(got.len(), 2, "cut at {cut}: {got:?}");
            assert!(got.iter().all(is_hover), "cut at {cut}: {got:?}");
        }
    }

    #[test]
    fn lone_surrogates_and_bad_bytes_become_replacement_characters() {
        let body = br#"{"jsonrpc":"2.0","method":"m","params":{"a":"x\ud800y","b":"\ud83d\ude00","c":"\\ud800","d":"p?q"}}"#;
        let mut body = body.to_vec();
        let q = body.iter().position(|&b| b == b'?').unwrap();
        body[q] = 0xff;
        let mut f = format!("Content-Length: {}\r\n\r\n", body.len()).into_bytes();
        f.extend(body);
        let got = read_all(vec![f]);
        let Incoming::Notification { params, .. } = &got[0] else { panic!("{got:?}") };
        assert_eq!(params["a"], "x\u{fffd}y");
        assert_eq!(params["b"], "😀");
        assert_eq!(params["c"], "\\ud800");
        assert_eq!(params["d"], "p\u{fffd}q");
    }

    /// Frames of many chunks, after enough bytes that the buffer is
    /// compacted while a body is read (a bug the burst test found).
    #[test]
    fn large_frames_in_small_chunks_read_whole() {
        let big = format!(r#"{{"jsonrpc":"2.0","method":"m","params":{{"t":"{}"}}}}"#, "x".repeat(100_000));
        let mut all = Vec::new();
        for _ in 0..5 {
            all.extend(frame(&big));
        }
        let chunks: Vec<Vec<u8>> = all.chunks(4096).map(<[u8]>::to_vec).collect();
        let got = read_all(chunks);
        assert_eq!(got.len(), 5);
        assert!(got.iter().all(|g| matches!(g, Incoming::Notification { params, .. } if params["t"].as_str().unwrap().len() == 100_000)));
    }

    #[test]
    fn an_oversized_frame_is_skipped() {
        let mut f = format!("Content-Length: {}\r\n\r\n", MAX_FRAME + 1).into_bytes();
        f.extend(vec![b' '; MAX_FRAME + 1]);
        let got = read_all(vec![f, frame(HOVER)]);
        assert_eq!(code(&got[0]), Some(PARSE_ERROR), "{got:?}");
        assert!(is_hover(&got[1]));
    }
}
