//! A record's seal: the SHA-256 of its own content, written into it, so an
//! edit made after crossaudit wrote it (run.json's `data`, `exploratory`,
//! `lock` or `notes`, all of which a report quotes) is found when it is
//! read back instead of being reported as the run's.
//!
//! The seal is the field `seal` of a JSON object: the SHA-256 (lowercase
//! hex) of the object's other fields written as canonical JSON, that is
//! compact, object keys sorted by their bytes, strings and numbers as
//! `serde_json` writes them. Anyone can recompute it (Python's
//! `json.dumps(v, sort_keys=True, separators=(",", ":"),
//! ensure_ascii=False)` writes the same text, numbers aside such as
//! `1e-07`, which `serde_json` writes `1e-7`), so it finds edits, not
//! forgeries. A record without a seal (one written before seals were) is
//! read as it is.

use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::Value;

/// The field a sealed record keeps its seal in.
pub const FIELD: &str = "seal";

/// `value` as pretty JSON (a final newline) with its seal as the last field.
pub fn sealed_json<T: Serialize>(value: &T) -> String {
    #[derive(Serialize)]
    struct Sealed<'a, T> {
        #[serde(flatten)]
        value: &'a T,
        seal: String,
    }
    let mut content = serde_json::to_value(value).unwrap_or_default();
    if let Some(fields) = content.as_object_mut() {
        fields.remove(FIELD);
    }
    super::pretty_json(&Sealed { value, seal: seal_of(&content) })
}

/// Why a sealed record cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SealError {
    /// Not the record's JSON (or its seal not a string).
    #[error("{0}")]
    Json(String),
    /// The content no longer matches its seal.
    #[error("it was edited after crossaudit wrote it: its content hashes to {now}, but its seal records {recorded}")]
    Edited {
        /// The SHA-256 of the content as it is.
        now: String,
        /// The seal.
        recorded: String,
    },
}

/// The record in `bytes`, its seal (where it has one) verified.
pub fn open<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, SealError> {
    let json = |e: serde_json::Error| SealError::Json(e.to_string());
    let mut content: Value = serde_json::from_slice(bytes).map_err(json)?;
    match content.as_object_mut().and_then(|fields| fields.remove(FIELD)) {
        None => {}
        Some(Value::String(recorded)) => {
            let now = seal_of(&content);
            if now != recorded {
                return Err(SealError::Edited { now, recorded });
            }
        }
        Some(other) => return Err(SealError::Json(format!("its seal is {other}, not a SHA-256 in hex"))),
    }
    serde_json::from_value(content).map_err(json)
}

/// The SHA-256 of `content` written as canonical JSON.
fn seal_of(content: &Value) -> String {
    let mut text = String::new();
    canonical(content, &mut text);
    super::sha256_hex(text.as_bytes())
}

/// `value` as compact JSON with every object's keys sorted, appended to `out`.
fn canonical(value: &Value, out: &mut String) {
    // Writing a string or a number to JSON text cannot fail.
    let scalar = |v: &Value| serde_json::to_string(v).unwrap_or_default();
    match value {
        Value::Object(fields) => {
            let mut keys: Vec<&String> = fields.keys().collect();
            keys.sort();
            out.push('{');
            for (i, key) in keys.into_iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                out.push_str(&scalar(&Value::String(key.clone())));
                out.push(':');
                canonical(&fields[key], out);
            }
            out.push('}');
        }
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                canonical(item, out);
            }
            out.push(']');
        }
        v => out.push_str(&scalar(v)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, serde::Deserialize)]
    struct Record {
        study: String,
        exploratory: bool,
        notes: Vec<String>,
    }

    fn record() -> Record {
        Record { study: "s".into(), exploratory: true, notes: vec!["é \"q\"".into()] }
    }

    #[test]
    fn the_seal_is_the_sha256_of_the_canonical_content() {
        // Canonical text written out by hand (keys sorted, compact), hashed
        // with sha2 independently of `canonical`.
        let text = sealed_json(&record());
        let v: Value = serde_json::from_str(&text).unwrap();
        let by_hand = r#"{"exploratory":true,"notes":["é \"q\""],"study":"s"}"#;
        assert_eq!(v[FIELD], super::super::sha256_hex(by_hand.as_bytes()));
        assert!(text.trim_end().ends_with('}') && text.ends_with('\n'));
        assert_eq!(open::<Record>(text.as_bytes()).unwrap(), record());
    }

    #[test]
    fn an_edit_is_found_and_reformatting_is_not_an_edit() {
        let text = sealed_json(&record());
        let edited = text.replace("\"exploratory\": true", "\"exploratory\": false");
        assert_ne!(edited, text);
        let err = open::<Record>(edited.as_bytes()).unwrap_err();
        assert!(matches!(&err, SealError::Edited { recorded, .. } if text.contains(recorded.as_str())), "{err}");
        // The same content, compact and with its keys in another order.
        let v: Value = serde_json::from_str(&text).unwrap();
        let reordered = format!(
            r#"{{"seal":{},"study":"s","notes":["é \"q\""],"exploratory":true}}"#,
            serde_json::to_string(&v[FIELD]).unwrap()
        );
        assert_eq!(open::<Record>(reordered.as_bytes()).unwrap(), record());
        // Unsealed (written before seals): read as it is.
        let unsealed = serde_json::to_string(&record()).unwrap();
        assert_eq!(open::<Record>(unsealed.as_bytes()).unwrap(), record());
        let bad = text.replace(&format!("\"{}\"", v[FIELD].as_str().unwrap()), "7");
        assert!(open::<Record>(bad.as_bytes()).unwrap_err().to_string().contains("not a SHA-256"));
    }
}
