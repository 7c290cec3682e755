//! One flat JSON object, for `--json` output (no dependency needed).

use std::fmt::Write;

/// Fields in insertion order.
#[derive(Default)]
pub(crate) struct JsonObject {
    body: String,
}

impl JsonObject {
    fn key(&mut self, k: &str) {
        if !self.body.is_empty() {
            self.body.push_str(", ");
        }
        let _ = write!(self.body, "\"{k}\": ");
    }

    /// A number; non-finite values become `null` (JSON has no infinity).
    pub(crate) fn num(mut self, k: &str, v: f64) -> Self {
        self.key(k);
        if v.is_finite() {
            let _ = write!(self.body, "{v}");
        } else {
            self.body.push_str("null");
        }
        self
    }

    /// A boolean.
    pub(crate) fn bool(mut self, k: &str, v: bool) -> Self {
        self.key(k);
        self.body.push_str(if v { "true" } else { "false" });
        self
    }

    /// A string, escaped.
    pub(crate) fn str(mut self, k: &str, v: &str) -> Self {
        self.key(k);
        self.body.push('"');
        for c in v.chars() {
            match c {
                '"' => self.body.push_str("\\\""),
                '\\' => self.body.push_str("\\\\"),
                c if (c as u32) < 0x20 => {
                    let _ = write!(self.body, "\\u{:04x}", c as u32);
                }
                c => self.body.push(c),
            }
        }
        self.body.push('"');
        self
    }

    /// The object as one line.
    pub(crate) fn finish(self) -> String {
        format!("{{{}}}", self.body)
    }
}
