//! One flat JSON object, for `--json` output, written by `serde_json`.

use serde::Serialize;
use serde_json::{Map, Value};

/// Fields in insertion order.
#[derive(Default)]
pub(crate) struct JsonObject {
    fields: Map<String, Value>,
}

impl JsonObject {
    /// Adds field `k`: a number (non-finite floats become `null`, as JSON
    /// has no infinity), a boolean or a string.
    pub(crate) fn with(mut self, k: &str, v: impl Serialize) -> Self {
        self.fields.insert(
            k.to_string(),
            serde_json::to_value(v).unwrap_or(Value::Null),
        );
        self
    }

    /// The object as one line.
    pub(crate) fn finish(self) -> String {
        Value::Object(self.fields).to_string()
    }
}
