//! Bounds on JSON input applied while it is parsed, so that no collection,
//! string or number is allocated at the size the input asks for:
//!
//! - [`vec`] and [`map`] (for `#[serde(deserialize_with)]`) refuse an
//!   array or object past its element limit as the elements come, with an
//!   error serde_json places at the element (the path names it);
//! - [`JsonLimits`] wraps the reader of a JSON stream and refuses a text
//!   longer than its declared size, a string or a number token longer than
//!   a limit, before serde_json buffers it (serde_json reads a whole string,
//!   and with `float_roundtrip` a whole number, into one buffer).

use std::collections::BTreeMap;
use std::fmt;
use std::io::Read;
use std::marker::PhantomData;

use serde::de::{Deserialize, Deserializer, Error, MapAccess, SeqAccess, Visitor};

/// Elements reserved up front at most, whatever the size hint.
const MAX_PREALLOCATED: usize = 4096;

/// An array of at most `max` elements, refused at element `max` (before
/// the vector grows past `max`).
pub fn vec<'de, D, T>(d: D, max: usize) -> Result<Vec<T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct V<T> {
        max: usize,
        t: PhantomData<T>,
    }
    impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
        type Value = Vec<T>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            write!(f, "an array of at most {} elements", self.max)
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
            let hint = seq.size_hint().unwrap_or(0);
            let mut out = Vec::with_capacity(hint.min(self.max).min(MAX_PREALLOCATED));
            while let Some(v) = seq.next_element()? {
                if out.len() == self.max {
                    return Err(A::Error::custom(format_args!(
                        "more than {} elements, over the limit",
                        self.max
                    )));
                }
                out.push(v);
            }
            Ok(out)
        }
    }
    d.deserialize_seq(V {
        max,
        t: PhantomData,
    })
}

/// An object of at most `max` members (keys unique), refused at member
/// `max`.
pub fn map<'de, D, V>(d: D, max: usize) -> Result<BTreeMap<String, V>, D::Error>
where
    D: Deserializer<'de>,
    V: Deserialize<'de>,
{
    struct M<V> {
        max: usize,
        v: PhantomData<V>,
    }
    impl<'de, V: Deserialize<'de>> Visitor<'de> for M<V> {
        type Value = BTreeMap<String, V>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            write!(f, "an object of at most {} members", self.max)
        }
        fn visit_map<A: MapAccess<'de>>(self, mut m: A) -> Result<Self::Value, A::Error> {
            let mut out = BTreeMap::new();
            while let Some((k, v)) = m.next_entry::<String, V>()? {
                if out.len() == self.max {
                    return Err(A::Error::custom(format_args!(
                        "more than {} members, over the limit",
                        self.max
                    )));
                }
                out.insert(k, v);
            }
            Ok(out)
        }
    }
    d.deserialize_map(M {
        max,
        v: PhantomData,
    })
}

/// Where the text broke a [`JsonLimits`] bound.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Violation {
    /// Offset of the byte at fault in the text (0-based).
    pub offset: u64,
    /// What was too long, with the limit.
    pub msg: String,
}

/// Lexical state of [`JsonLimits`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Lex {
    Outside,
    String { escaped: bool },
}

/// A reader of JSON text that passes the bytes of `inner` on and fails (an
/// I/O error; [`JsonLimits::violation`] says where and why) as soon as the
/// text passes `max_total` bytes, a string `max_string` bytes (escapes
/// counted as written) or a number token `max_number` bytes. Put a
/// `BufReader` over it: it checks each chunk it reads in one pass.
pub struct JsonLimits<R> {
    inner: R,
    max_total: u64,
    max_string: usize,
    max_number: usize,
    n: u64,
    lex: Lex,
    run: usize,
    violation: Option<Violation>,
}

impl<R: Read> JsonLimits<R> {
    pub fn new(inner: R, max_total: u64, max_string: usize, max_number: usize) -> Self {
        JsonLimits {
            inner,
            max_total,
            max_string,
            max_number,
            n: 0,
            lex: Lex::Outside,
            run: 0,
            violation: None,
        }
    }

    /// Bytes passed on so far.
    pub fn bytes_read(&self) -> u64 {
        self.n
    }

    /// The bound the text broke, if it did.
    pub fn violation(&self) -> Option<&Violation> {
        self.violation.as_ref()
    }

    /// The first byte of `buf` (read at offset `self.n`) that breaks a
    /// bound; updates the lexical state over the bytes before it.
    fn scan(&mut self, buf: &[u8]) -> Option<Violation> {
        for (k, &b) in buf.iter().enumerate() {
            let at = |msg: String| {
                Some(Violation {
                    offset: self.n + k as u64,
                    msg,
                })
            };
            match &mut self.lex {
                Lex::Outside => match b {
                    b'"' => {
                        self.lex = Lex::String { escaped: false };
                        self.run = 0;
                    }
                    b'0'..=b'9' | b'-' | b'+' | b'.' | b'e' | b'E' => {
                        self.run += 1;
                        if self.run > self.max_number {
                            return at(format!(
                                "a number over {} characters, over the limit",
                                self.max_number
                            ));
                        }
                    }
                    _ => self.run = 0,
                },
                Lex::String { escaped } => {
                    if *escaped {
                        *escaped = false;
                    } else if b == b'\\' {
                        *escaped = true;
                    } else if b == b'"' {
                        self.lex = Lex::Outside;
                        self.run = 0;
                        continue;
                    }
                    self.run += 1;
                    if self.run > self.max_string {
                        return at(format!(
                            "a string over {} bytes, over the limit",
                            self.max_string
                        ));
                    }
                }
            }
        }
        None
    }
}

impl<R: Read> Read for JsonLimits<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if let Some(v) = &self.violation {
            return Err(std::io::Error::other(v.msg.clone()));
        }
        // never read past the first byte over max_total
        let room = self.max_total.saturating_sub(self.n).saturating_add(1);
        let want = buf.len().min(usize::try_from(room).unwrap_or(usize::MAX));
        let k = self.inner.read(&mut buf[..want])?;
        let over_total = self.n + k as u64 > self.max_total;
        let v = self.scan(&buf[..k]).or_else(|| {
            over_total.then(|| Violation {
                offset: self.max_total,
                msg: format!("the text is longer than {} bytes", self.max_total),
            })
        });
        if let Some(v) = v {
            let e = std::io::Error::other(v.msg.clone());
            self.violation = Some(v);
            return Err(e);
        }
        self.n += k as u64;
        Ok(k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read_all(text: &[u8], total: u64) -> Result<u64, Violation> {
        let mut r = JsonLimits::new(text, total, 8, 5);
        let mut sink = Vec::new();
        match std::io::copy(&mut r, &mut sink) {
            Ok(n) => Ok(n),
            Err(_) => Err(r.violation().cloned().expect("a violation")),
        }
    }

    #[test]
    fn limits_strings_numbers_and_length_where_they_break() {
        assert_eq!(read_all(br#"{"abc": [12345, "12345678"]}"#, 100), Ok(28));
        // escapes count as written; an escaped quote does not end the string
        assert_eq!(read_all(br#"["a\"b\\"]"#, 100), Ok(10));
        let v = read_all(br#"{"k": "123456789"}"#, 100).unwrap_err();
        assert_eq!(v.offset, 15);
        assert!(v.msg.contains("string over 8 bytes"), "{}", v.msg);
        let v = read_all(br#"[1, 123456]"#, 100).unwrap_err();
        assert_eq!(v.offset, 9);
        assert!(v.msg.contains("number over 5"), "{}", v.msg);
        let v = read_all(br#"[1, 2, 3]"#, 5).unwrap_err();
        assert_eq!(v.offset, 5);
        assert!(v.msg.contains("longer than 5 bytes"), "{}", v.msg);
        assert_eq!(read_all(br#"[1, 2, 3]"#, 9), Ok(9));
    }

    #[derive(Debug, serde::Deserialize)]
    struct Capped {
        #[serde(deserialize_with = "three")]
        v: Vec<u8>,
        #[serde(default, deserialize_with = "two")]
        m: BTreeMap<String, u8>,
    }
    fn three<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
        vec(d, 3)
    }
    fn two<'de, D: Deserializer<'de>>(d: D) -> Result<BTreeMap<String, u8>, D::Error> {
        map(d, 2)
    }

    #[test]
    fn collections_are_refused_at_the_element_past_the_limit() {
        let ok: Capped = serde_json::from_str(r#"{"v": [1, 2, 3], "m": {"a": 1}}"#).unwrap();
        assert_eq!(ok.v, [1, 2, 3]);
        assert_eq!(ok.m.len(), 1);
        let e = serde_json::from_str::<Capped>(r#"{"v": [1, 2, 3, 4, 5]}"#).unwrap_err();
        assert!(e.to_string().contains("more than 3 elements"), "{e}");
        // serde_json places the error after the fourth element and the
        // separator that follows it (a path scan names element [4])
        assert_eq!(e.column(), 19);
        let e = serde_json::from_str::<Capped>(r#"{"v": [], "m": {"a": 1, "b": 2, "c": 3}}"#)
            .unwrap_err();
        assert!(e.to_string().contains("more than 2 members"), "{e}");
    }
}
